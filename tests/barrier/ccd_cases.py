"""Random point-edge trajectories for the CCD tests, and an exact (rational-arithmetic) checker.

Cases: generic random motion, head-on / near-touching approach, grazing past an endpoint,
motion parallel to the edge (including exactly collinear motion along the x axis), a rotating
edge sweeping over a point, and near-touching starts. Each case is y = (p, e0, e1), dy (their
displacements over the step), and a label.

Exact checker. With y(t) = y + t dy, the point lies on the edge's line when
    q(t) = (e1 - e0)(t) x (p - e0)(t) = q0 + q1 t + q2 t^2 = 0
and on the segment when moreover 0 <= sigma(t) <= L(t), sigma = (p - e0).(e1 - e0),
L = |e1 - e0|^2. Coefficients are computed exactly with Fractions from the float inputs. Each
real root of q in [0, 1] is located in floating point, then bracketed by rationals on which q
changes sign exactly (tightened by exact bisection), and the segment condition is decided by
exact evaluation at both bracket ends (ambiguous if the ends disagree). If q vanishes
identically (collinear motion) contact first happens when the point meets an endpoint, found
exactly from the linear equations p(t) = e_i(t).
"""

from __future__ import annotations

import math
from fractions import Fraction
from itertools import pairwise

import numpy as np


def _unit(v):
    return v / np.linalg.norm(v)


def make_cases(n, seed=0):
    """About n cases as (y (n, 6), dy (n, 6), labels list)."""
    rng = np.random.default_rng(seed)
    ys, dys, labels = [], [], []

    def add(y, dy, label):
        ys.append(np.asarray(y, float))
        dys.append(np.asarray(dy, float))
        labels.append(label)

    def edge():
        a = rng.uniform(-1, 1, 2)
        L = rng.uniform(0.2, 2.0)
        th = rng.uniform(0, 2 * np.pi)
        t = np.array([np.cos(th), np.sin(th)])
        return a, a + L * t, t, np.array([-t[1], t[0]]), L

    share = {"random": 0.25, "head-on": 0.15, "grazing": 0.15, "parallel": 0.15, "collinear": 0.05,
             "rotating": 0.15, "near-touching": 0.10}
    for label, frac in share.items():
        for _ in range(round(frac * n)):
            if label == "random":
                y = rng.uniform(-1, 1, 6)
                dy = rng.normal(0, 0.7, 6)
            elif label == "head-on":
                a, b, t, nrm, L = edge()
                h = 10 ** rng.uniform(-8, -1) * rng.choice([-1, 1])
                p = a + rng.uniform(0.05, 0.95) * (b - a) + h * nrm
                dp = -h * rng.uniform(0.3, 3.0) * nrm + rng.normal(0, abs(h) + 0.05) * t
                y = np.r_[p, a, b]
                dy = np.r_[dp, rng.normal(0, 0.01, 4) * rng.uniform(0, 1)]
            elif label == "grazing":
                a, b, t, nrm, L = edge()
                delta = 10 ** rng.uniform(-9, -2) * rng.choice([-1, 1, 1])  # mostly just outside
                end, out = (a, -t) if rng.random() < 0.5 else (b, t)
                cross = end + delta * out  # where the point crosses the edge's line
                v = -rng.uniform(0.2, 2.0) * nrm * rng.choice([-1, 1]) + rng.normal(0, 0.3) * t
                tc = rng.uniform(0.1, 1.3)
                p = cross - tc * v
                moving = rng.random() < 0.3
                de = rng.normal(0, 1e-3, 4) if moving else np.zeros(4)
                y = np.r_[p, a, b]
                dy = np.r_[v, de]
            elif label == "parallel":
                a, b, t, nrm, L = edge()
                h = 10 ** rng.uniform(-8, -1) * rng.choice([-1, 1])
                p = a + rng.uniform(-1.0, 2.0) * (b - a) + h * nrm
                dp = rng.uniform(-2, 2) * L * t
                kind = rng.integers(3)
                if kind == 0:
                    de = np.zeros(4)
                elif kind == 1:
                    s = rng.normal(0, 0.5, 2)
                    de = np.r_[s, s] + rng.normal(0, 1e-3, 4) * (rng.random() < 0.5)
                else:  # edge moves toward the point's line slowly
                    de = np.tile(h * rng.uniform(0, 2) * nrm, 2)
                y = np.r_[p, a, b]
                dy = np.r_[dp, de]
            elif label == "collinear":  # exactly collinear along the x axis
                a0, b0 = np.sort(rng.uniform(-1, 1, 2))
                px = rng.choice([a0 - rng.uniform(1e-8, 1.0), b0 + rng.uniform(1e-8, 1.0)])
                y = np.array([px, 0.0, a0, 0.0, b0, 0.0])
                dy = np.array([rng.normal(0, 1.0), 0.0, rng.normal(0, 0.1), 0.0, rng.normal(0, 0.1), 0.0])
            elif label == "rotating":
                a, b, t, nrm, L = edge()
                m = 0.5 * (a + b)
                ang = rng.uniform(0.1, 3.0) * rng.choice([-1, 1])
                R = np.array([[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]])
                a1 = m + R @ (a - m)
                b1 = m + R @ (b - m)
                h = 10 ** rng.uniform(-4, -1) * rng.choice([-1, 1])
                p = a + rng.uniform(0.55, 1.0) * (b - a) + h * nrm
                dp = rng.normal(0, 0.05, 2) * (rng.random() < 0.5)
                y = np.r_[p, a, b]
                dy = np.r_[dp, a1 - a, b1 - b]
            else:  # near-touching start
                a, b, t, nrm, L = edge()
                h = 10 ** rng.uniform(-10, -6) * rng.choice([-1, 1])
                s = rng.uniform(-0.2, 1.2)
                p = a + s * (b - a)
                p = p + h * (nrm if 0 <= s <= 1 else _unit(p - (a if s < 0 else b)))
                y = np.r_[p, a, b]
                dy = np.r_[rng.normal(0, 0.5, 2), rng.normal(0, 0.05, 4)]
            add(y, dy, label)
    return np.array(ys), np.array(dys), labels


# ------------------------------------------------------------------------------------------
# exact checker
# ------------------------------------------------------------------------------------------

def _cross(u, v):
    return u[0] * v[1] - u[1] * v[0]


def _dot(u, v):
    return u[0] * v[0] + u[1] * v[1]


class Trajectory:
    """Exact rational description of y(t) = y + t dy."""

    def __init__(self, y, dy):
        F = [Fraction(float(v)) for v in y]
        D = [Fraction(float(v)) for v in dy]
        self.p, self.a, self.b = F[0:2], F[2:4], F[4:6]
        self.dp, self.da, self.db = D[0:2], D[2:4], D[4:6]
        E0 = [self.b[i] - self.a[i] for i in range(2)]
        dE = [self.db[i] - self.da[i] for i in range(2)]
        R0 = [self.p[i] - self.a[i] for i in range(2)]
        dR = [self.dp[i] - self.da[i] for i in range(2)]
        self.E0, self.dE, self.R0, self.dR = E0, dE, R0, dR
        self.q = (_cross(E0, R0), _cross(E0, dR) + _cross(dE, R0), _cross(dE, dR))

    def qval(self, t):
        q0, q1, q2 = self.q
        return q0 + t * (q1 + t * q2)

    def on_segment_side(self, t):
        """(sigma(t), L(t) - sigma(t)) at rational t: both >= 0 iff the line point is on the
        segment."""
        E = [self.E0[i] + t * self.dE[i] for i in range(2)]
        R = [self.R0[i] + t * self.dR[i] for i in range(2)]
        s = _dot(R, E)
        return s, _dot(E, E) - s

    def endpoint_hits(self):
        """Times in [0, 1] at which p(t) = e0(t) or e1(t) (exact; for collinear motion)."""
        out = []
        for x0, dx in ((self.a, self.da), (self.b, self.db)):
            r = [self.p[i] - x0[i] for i in range(2)]
            v = [self.dp[i] - dx[i] for i in range(2)]
            ts = set()
            ok = True
            for i in range(2):
                if v[i] == 0:
                    if r[i] != 0:
                        ok = False
                else:
                    ts.add(-r[i] / v[i])
            if ok and len(ts) == 1:
                t = ts.pop()
                if 0 <= t <= 1:
                    out.append(t)
        return out


def _float_roots(q0, q1, q2):
    q0, q1, q2 = float(q0), float(q1), float(q2)
    if q2 == 0.0:
        return [] if q1 == 0.0 else [-q0 / q1]
    disc = q1 * q1 - 4 * q2 * q0
    if disc < 0:
        # possibly a double root lost to rounding: keep the vertex as a candidate
        return [-q1 / (2 * q2)]
    sq = math.sqrt(disc)
    qq = -0.5 * (q1 + math.copysign(sq, q1))
    roots = [qq / q2]
    if qq != 0.0:
        roots.append(q0 / qq)
    return roots


def _sign(x):
    return (x > 0) - (x < 0)


def _isolate(traj, l, r, guesses):
    """Rational bracket [lo, hi] of the single root of q in the monotone interval [l, r]
    (q(l) q(r) <= 0), seeded by floating-point guesses, else by exact bisection."""
    ql = _sign(traj.qval(l))
    if ql == 0:
        return l, l
    if _sign(traj.qval(r)) == 0:
        return r, r
    lo, hi = l, r
    for g in guesses:
        if not (float(l) <= g <= float(r)):
            continue
        gg = Fraction(g)
        w = Fraction(1, 10 ** 12) * max(1, abs(gg))
        for _ in range(6):
            a, b = max(l, gg - w), min(r, gg + w)
            if _sign(traj.qval(a)) == ql and _sign(traj.qval(b)) != ql:
                lo, hi = a, b
                break
            w *= 1000
        break
    for _ in range(200):  # exact bisection (only when the guess failed) down to 1e-11
        if hi - lo <= Fraction(1, 10 ** 11) * max(1, abs(hi)):
            break
        mid = (lo + hi) / 2
        sm = _sign(traj.qval(mid))
        if sm == 0:
            return mid, mid
        if sm == ql:
            lo = mid
        else:
            hi = mid
    return lo, hi


def contacts(traj):
    """Contact events in [0, 1] as a sorted list of (t_lo, t_hi, status) with rational
    brackets of the time; status 'hit' (the point is on the segment at both bracket ends) or
    'ambiguous' (on it at one end only). Complete: q is split exactly at its vertex into
    monotone pieces, so every root of q in [0, 1] is bracketed. Collinear motion gives exact
    (t, t, 'hit')."""
    q0, q1, q2 = traj.q
    if q0 == 0 and q1 == 0 and q2 == 0:
        return sorted((t, t, "hit") for t in traj.endpoint_hits())
    cuts = [Fraction(0)]
    if q2 != 0:
        tv = -q1 / (2 * q2)
        if 0 < tv < 1:
            cuts.append(tv)
    cuts.append(Fraction(1))
    guesses = _float_roots(q0, q1, q2)
    events = []
    for l, r in pairwise(cuts):
        if _sign(traj.qval(l)) * _sign(traj.qval(r)) > 0:
            continue
        lo, hi = _isolate(traj, l, r, guesses)
        s_lo, o_lo = traj.on_segment_side(lo)
        s_hi, o_hi = traj.on_segment_side(hi)
        inside_lo = s_lo >= 0 and o_lo >= 0
        inside_hi = s_hi >= 0 and o_hi >= 0
        if inside_lo and inside_hi:
            events.append((lo, hi, "hit"))
        elif inside_lo or inside_hi:
            events.append((lo, hi, "ambiguous"))
    return sorted(events)


def _np_distance(y):
    p, a, b = y[0:2], y[2:4], y[4:6]
    e = b - a
    L = e @ e
    t = 0.0 if L == 0 else min(max((p - a) @ e / L, 0.0), 1.0)
    return float(np.linalg.norm(p - (a + t * e)))


def first_time_below(y, dy, g):
    """First t in [0, 1] with d(t) <= g (floating point), or None. The first crossing of d = g
    is a root of the active branch's polynomial: |p - e_i|^2 - g^2 (quadratic) or
    q^2 - g^2 |e|^2 (quartic); every real root in [0, 1] is a candidate, confirmed by the
    distance itself (roots of inactive branches fail the confirmation)."""
    y = np.asarray(y, float)
    dy = np.asarray(dy, float)
    if _np_distance(y) <= g:
        return 0.0
    P = np.polynomial.polynomial
    cands = []
    p, a, b = (y[0:2], dy[0:2]), (y[2:4], dy[2:4]), (y[4:6], dy[4:6])
    for e in (a, b):
        r0, r1 = p[0] - e[0], p[1] - e[1]
        cands.append(P.polyadd(P.polyadd([r0 @ r0 - g * g], [0, 2 * r0 @ r1]), [0, 0, r1 @ r1]))
    E0, dE = b[0] - a[0], b[1] - a[1]
    R0, dR = p[0] - a[0], p[1] - a[1]
    q = np.array([_cross(E0, R0), _cross(E0, dR) + _cross(dE, R0), _cross(dE, dR)])
    L = np.array([E0 @ E0, 2 * E0 @ dE, dE @ dE])
    cands.append(P.polysub(P.polymul(q, q), g * g * L))
    roots = []
    for c in cands:
        c = np.trim_zeros(np.asarray(c, float), "b")
        if len(c) < 2:
            continue
        for r in P.polyroots(c):
            if abs(r.imag) <= 1e-7 * max(1.0, abs(r.real)) and -1e-9 <= r.real <= 1 + 1e-9:
                roots.append(min(max(r.real, 0.0), 1.0))
    for r in sorted(roots):
        for t in (r, np.nextafter(r, 2.0)):
            if _np_distance(y + t * dy) <= g * (1 + 1e-7):
                return t
    return None
