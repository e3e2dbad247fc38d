"""IPC's edge-edge mollifier (mpmsim/contact/barrier/potential.py) against the IPC toolkit: the
threshold eps_x at rest, the squared cross norm x, the mollifier m(x) with its gradient and Hessian,
and the mollified barrier m b(d) with its gradient and Hessian, on 10,000 random edge pairs and
10,000 nearly parallel ones (angles from 1e-8 to 3e-2 rad, log-uniform: the mollifier's range is
sin^2 < 1e-3) and exactly parallel ones; rest positions differ from the current ones."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.contact.barrier.closest import edge_edge_distance_type
from mpmsim.contact.barrier.potential import (edge_edge_cross2_hessian, edge_edge_mollifier_threshold,
                                              mollified_edge_edge_barrier)

pytestmark = pytest.mark.implicit
N = 10_000


def split(y):
    return [np.ascontiguousarray(y[3 * i: 3 * i + 3]) for i in range(4)]


def random_pairs(rng, n):
    return [rng.normal(size=12) for _ in range(n)]


def near_parallel_pairs(rng, n, exact=False):
    """Edge b a copy of a's direction turned by an angle 10^U(-8, -1.5) (0 if exact) about an
    axis normal to it, offset sideways and along."""
    out = []
    for _ in range(n):
        a0, u = rng.normal(size=3), rng.normal(size=3)
        off = np.cross(u, rng.normal(size=3))
        off *= rng.uniform(0.05, 1.0) / np.linalg.norm(off)
        w = np.cross(u, off)
        w /= np.linalg.norm(w)
        th = 0.0 if exact else 10.0 ** rng.uniform(-8.0, -1.5)
        v = rng.uniform(0.3, 2.0) * np.linalg.norm(u) * (np.cos(th) * u / np.linalg.norm(u) + np.sin(th) * w)
        b0 = a0 + off + rng.uniform(-0.8, 0.8) * u
        out.append(np.r_[a0, a0 + u, b0, b0 + v])
    return out


def unsquared(s, gs, Hs):
    d = np.sqrt(s)
    return d, gs / (2 * d), Hs / (2 * d) - np.outer(gs, gs) / (4 * d ** 3)


def ipctk_mollified(ipctk, y, rest, dhat, kappa, dtype):
    """m b(d), gradient and Hessian composed from ipctk's pieces: its mollifier and derivatives,
    its squared distance and derivatives (type dtype) and its barrier (kappa/dhat) ipctk.barrier(d)."""
    v, r = split(y), split(rest)
    eps = ipctk.edge_edge_mollifier_threshold(*r)
    m = ipctk.edge_edge_mollifier(*v, eps)
    gm = np.asarray(ipctk.edge_edge_mollifier_gradient(*v, eps)).ravel()
    Hm = np.asarray(ipctk.edge_edge_mollifier_hessian(*v, eps))
    t = ipctk.EdgeEdgeDistanceType(dtype)
    d, gd, Hd = unsquared(ipctk.edge_edge_distance(*v, t), np.asarray(ipctk.edge_edge_distance_gradient(*v, t)).ravel(),
                          np.asarray(ipctk.edge_edge_distance_hessian(*v, t)))
    s = kappa / dhat
    b0, b1, b2 = (s * ipctk.barrier(d, dhat), s * ipctk.barrier_first_derivative(d, dhat),
                  s * ipctk.barrier_second_derivative(d, dhat))
    e = m * b0
    g = b0 * gm + m * b1 * gd
    H = b0 * Hm + b1 * (np.outer(gm, gd) + np.outer(gd, gm)) + m * (b2 * np.outer(gd, gd) + b1 * Hd)
    return e, g, H, m, eps


def errors(ipctk, pairs, rng):
    """Per pair: (angle between the edges, mollifier m, relative errors of the value, gradient and
    Hessian of m b(d) against ipctk's, whether the two types agree). The errors are taken
    relative to the larger of the mollified quantity and the unmollified barrier's scale (b,
    |b'|, b''): m b(d) -> 0 for parallel edges, where a relative error of a rounding-level m
    means nothing."""
    from mpmsim.contact.barrier.potential import barrier, barrier_first_derivative, barrier_second_derivative

    out = []
    g, H = np.zeros(12), np.zeros((12, 12))
    for y in pairs:
        rest = y + 0.05 * rng.normal(size=12)
        t = int(ipctk.edge_edge_distance_type(*split(y)).value)
        d = np.sqrt(ipctk.edge_edge_distance(*split(y)))
        dhat, kappa = d * rng.uniform(1.1, 3.0), rng.uniform(0.5, 2.0)
        e_ref, g_ref, H_ref, m, eps = ipctk_mollified(ipctk, y, rest, dhat, kappa, t)
        assert edge_edge_mollifier_threshold(rest) == pytest.approx(eps, rel=1e-14)
        e = mollified_edge_edge_barrier(y, edge_edge_mollifier_threshold(rest), dhat, kappa, g, H, False, t)
        u, v = y[3:6] - y[0:3], y[9:12] - y[6:9]
        angle = np.arcsin(min(1.0, np.linalg.norm(np.cross(u, v)) / np.linalg.norm(u) / np.linalg.norm(v)))
        out.append((angle, m, abs(e - e_ref) / max(abs(e_ref), barrier(d, dhat, kappa)),
                    np.abs(g - g_ref).max() / max(np.abs(g_ref).max(), -barrier_first_derivative(d, dhat, kappa)),
                    np.abs(H - H_ref).max() / max(np.abs(H_ref).max(), barrier_second_derivative(d, dhat, kappa)),
                    edge_edge_distance_type(y) == t))
    return np.array(out)


def test_squared_cross_norm_and_mollifier_threshold_match_ipctk():
    """x = |ea x eb|^2 with gradient and Hessian within 1e-13 of ipctk's, value and gradient
    relative to the mollifier's scale eps = 1e-3 |ea|^2 |eb|^2 (eps |ea + eb| / |ea| |eb| for the
    gradient): for nearly parallel edges x itself is the difference of nearly equal products and
    both codes round it to ~1e-16 / angle relative (measured 8e-9 apart at 1e-8 rad)."""
    ipctk = pytest.importorskip("ipctk")
    rng = np.random.default_rng(31)
    g, H = np.zeros(12), np.zeros((12, 12))
    worst = 0.0
    for y in random_pairs(rng, 2000) + near_parallel_pairs(rng, 2000):
        v = split(y)
        x = edge_edge_cross2_hessian(y, g, H)
        x_ref = ipctk.edge_edge_cross_squarednorm(*v)
        g_ref = np.asarray(ipctk.edge_edge_cross_squarednorm_gradient(*v)).ravel()
        H_ref = np.asarray(ipctk.edge_edge_cross_squarednorm_hessian(*v))
        la, lb = np.linalg.norm(v[1] - v[0]), np.linalg.norm(v[3] - v[2])
        eps = 1e-3 * la * la * lb * lb
        worst = max(worst, abs(x - x_ref) / max(abs(x_ref), eps),
                    np.abs(g - g_ref).max() / max(np.abs(g_ref).max(), eps * (la + lb) / (la * lb)),
                    np.abs(H - H_ref).max() / np.abs(H_ref).max())
    assert worst < 1e-13, worst


@pytest.mark.parametrize("kind", ["random", "nearly parallel", "parallel"])
def test_mollified_edge_edge_barrier_matches_ipctk(kind):
    """Value, gradient and Hessian of m b(d) within 1e-10 of ipctk's (`errors`), d's type taken
    from ipctk. Random pairs: the same type every time. Nearly parallel (1e-8..3e-2 rad; over
    90% mollified): value and gradient within 1e-10 at every angle, the Hessian within 1e-10
    from 1e-5 rad (measured 5.2e-11); below, m b' hess d carries hess d's conditioning (hess d ~
    1/angle^2, m ~ angle^2 / 1e-3: two exact formulas round apart by up to 2.2e-15 / angle
    relative, measured 1.8e-9 at 1.2e-6 rad and 2.7e-8 at 1e-8 rad; unmollified, the same
    derivatives differ by 2e-4 at 1e-6 rad, test_closest.py), so there the bound is 1e-14 /
    angle. Exactly parallel: m = 0 up to rounding and everything within 1e-10."""
    ipctk = pytest.importorskip("ipctk")
    rng = np.random.default_rng({"random": 32, "nearly parallel": 33, "parallel": 34}[kind])
    pairs = {"random": lambda: random_pairs(rng, N), "nearly parallel": lambda: near_parallel_pairs(rng, N),
             "parallel": lambda: near_parallel_pairs(rng, 1000, exact=True)}[kind]()
    r = errors(ipctk, pairs, rng)
    angle, m, value, grad, hess, same = r.T
    assert value.max() < 1e-10 and grad.max() < 1e-10, (value.max(), grad.max())
    if kind == "random":
        assert same.all()
        assert hess.max() < 1e-10, hess.max()
    elif kind == "nearly parallel":
        assert (m < 1.0).mean() > 0.9
        wide = angle >= 1e-5
        assert hess[wide].max() < 1e-10, hess[wide].max()
        assert (hess * angle).max() < 1e-14, (hess * angle).max()
    else:
        assert (m < 1e-12).all()
        assert hess.max() < 1e-10, hess.max()
