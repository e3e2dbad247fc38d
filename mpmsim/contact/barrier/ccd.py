"""Additive continuous collision detection (ACCD) for linearly moving primitives.

Additive CCD (Li, Kaufman & Jiang 2021, "Codimensional Incremental Potential Contact",
doi:10.1145/3450626.3459767, Sec. 5 / Alg. 1): the distance d(t) between two primitives whose
points move linearly, x(t) = x + t dx, is Lipschitz in t with a constant M computed from the
displacements, so from a time t_k with distance d_k no contact can happen before
t_k + d_k / M. The algorithm advances by the fraction (1 - eta) of that bound,
    t_{k+1} = t_k + (1 - eta) d_k / M,
which keeps d >= eta d_k during the advance, and stops before the first advance that would leave
a distance below eta d_0; the returned time therefore never lets the primitives touch and leaves
at least eta (10%) of the current distance. The paper's line-search filter uses eta = 0.1
(BFEMP Sec. 5: "never below 10% of the current distance").

Lipschitz constant. For point-edge, d(t) = min_s |p(t) - e(s, t)| with e(s, t) = (1 - s) e0(t)
+ s e1(t); each |p(t) - e(s, t)| has rate at most |dp - ((1 - s) de0 + s de1)|, convex in s,
so M = max(|dp - de0|, |dp - de1|) bounds every s (and d as their minimum). This is at most the
paper's |dp'| + max(|de0'|, |de1'|) (displacements minus their mean), and equal for a head-on
approach. Point-point: M = |dp - dq|.

Two refinements, both rigorous lower bounds on d(t), so the result stays conservative:
  * Directional step. For ANY fixed unit axis n, d(t) >= min_i n.(p - e_i)(t) (projection is
    1-Lipschitz and the edge projects inside the hull of its endpoints' projections), and the
    right side is a minimum of two linear functions of t. With n the current closest-point
    axis (edge normal in the interior region, p - e_i at an endpoint), each iteration advances
    by the longer of the additive step and the step to where this bound reaches
    max(eta d_k, 1.01 eta d_0). This is exact for a translating edge and removes the additive
    method's slow crawl when a point slides along an edge at a small distance while the two
    slowly close in (there M is the sliding speed, far above the closing speed).
  * Separating axes. Over [t_a, t_b] the edge stays inside the convex hull of its four end
    positions (bilinear in s, t) and the point on its segment, so if their projections onto a
    unit axis are separated by g, d(t) >= g on the whole interval. Tried at the start and every
    16 iterations on [t_k, t_max]; if g >= eta d_0, t_max is returned (axes: the edge's tangent
    and normal at both ends of the interval, the normal of the point's relative motion, x, y).
    This settles sliding/grazing motion that never closes in.

Stopping rule vs time of impact: the CCD stops where the distance would first drop below
eta d_0, which can be long before the impact (a point sliding along an edge at 1% of its start
distance before being pinched): then the returned step is far below the time of impact, as for
any method that keeps 10% of the distance (the IPC toolkit's AdditiveCCD behaves the same).

Robustness. Positions are recomputed from the start, x + t dx, at every iterate (no accumulated
drift). d_0 <= 0 or non-finite input returns 0 (no feasible motion). After `max_iter` advances
the current time is returned (conservative, possibly small); with the refinements above this
has not been seen on the test trajectories (worst case ~4 ms).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .closest import edge_edge_distance2, point_triangle_distance2
from .distance import point_edge_distance

CCD_ETA = 0.1
CCD_MAX_ITER = 1_000_000
_SEPARATION_EVERY = 16
_DIR_MARGIN = 1.01  # directional steps stop at 1.01 eta d0, clear of rounding in d


@njit(cache=True, inline="always")
def _proj_gap(ax, ay, q):
    """Separation along the unit axis (ax, ay) between the point segment q[0:2]-q[2:4] and the
    edge hull q[4:12] (four points); negative if the projections overlap."""
    p0 = ax * q[0] + ay * q[1]
    p1 = ax * q[2] + ay * q[3]
    plo = min(p0, p1)
    phi = max(p0, p1)
    elo = np.inf
    ehi = -np.inf
    for k in range(4):
        v = ax * q[4 + 2 * k] + ay * q[5 + 2 * k]
        elo = min(elo, v)
        ehi = max(ehi, v)
    return max(elo - phi, plo - ehi)


@njit(cache=True)
def point_edge_separation_bound(y, dy, ta, tb):
    """Lower bound on the point-edge distance over t in [ta, tb] for y(t) = y + t dy, from
    separating axes (<= 0 when no axis separates). See the module docstring."""
    q = np.empty(12)
    q[0] = y[0] + ta * dy[0]
    q[1] = y[1] + ta * dy[1]
    q[2] = y[0] + tb * dy[0]
    q[3] = y[1] + tb * dy[1]
    for c in range(2):
        q[4 + c] = y[2 + c] + ta * dy[2 + c]
        q[6 + c] = y[4 + c] + ta * dy[4 + c]
        q[8 + c] = y[2 + c] + tb * dy[2 + c]
        q[10 + c] = y[4 + c] + tb * dy[4 + c]
    best = max(_proj_gap(1.0, 0.0, q), _proj_gap(0.0, 1.0, q))
    for k in range(2):
        ex = q[6 + 4 * k] - q[4 + 4 * k]
        ey = q[7 + 4 * k] - q[5 + 4 * k]
        le = np.sqrt(ex * ex + ey * ey)
        if le > 0.0:
            best = max(best, _proj_gap(ex / le, ey / le, q))
            best = max(best, _proj_gap(-ey / le, ex / le, q))
    # normal of the point's motion relative to the edge's mean motion
    mx = dy[0] - 0.5 * (dy[2] + dy[4])
    my = dy[1] - 0.5 * (dy[3] + dy[5])
    lm = np.sqrt(mx * mx + my * my)
    if lm > 0.0:
        best = max(best, _proj_gap(-my / lm, mx / lm, q))
    return best


@njit(cache=True, inline="always")
def _directional_step(yt, dy, target):
    """Largest h >= 0 with min_i n.(p - e_i)(t + h) >= target, for a fixed unit axis n pointing
    from the edge to p at the current iterate yt (distance d > 0); inf if that projected gap
    does not shrink, 0 if it is already below the target. Projection on a fixed unit axis is
    1-Lipschitz and the edge projects inside the hull of its endpoints' projections, so
    d(t) >= min_i n.(p - e_i)(t), a minimum of linear functions of t, for ANY unit n. The axis
    is the edge normal (sign of the cross product) when p projects inside the edge, else the
    direction from the closest endpoint: computed from the edge or from p - e_i directly, so it
    stays accurate when d is tiny compared with the coordinates."""
    ex = yt[4] - yt[2]
    ey = yt[5] - yt[3]
    L = ex * ex + ey * ey
    t = -1.0
    if L > 0.0:
        t = ((yt[0] - yt[2]) * ex + (yt[1] - yt[3]) * ey) / L
    if 0.0 <= t <= 1.0:
        le = np.sqrt(L)
        c = ex * (yt[1] - yt[3]) - ey * (yt[0] - yt[2])
        sg = 1.0 if c >= 0.0 else -1.0
        nx = -sg * ey / le
        ny = sg * ex / le
    else:
        j = 2 if t < 0.0 else 4
        nx = yt[0] - yt[j]
        ny = yt[1] - yt[j + 1]
        ln = np.sqrt(nx * nx + ny * ny)
        if not ln > 0.0:
            return 0.0
        nx /= ln
        ny /= ln
    h = np.inf
    for i in (2, 4):
        g0 = nx * (yt[0] - yt[i]) + ny * (yt[1] - yt[i + 1])
        if not g0 >= target:
            return 0.0
        rate = nx * (dy[0] - dy[i]) + ny * (dy[1] - dy[i + 1])
        if rate < 0.0:
            h = min(h, (g0 - target) / -rate)
    return h


@njit(cache=True, inline="always")
def _advance_verdict(d_next, gap, toc, t_next, t_max, it, max_iter):
    """After an advance from toc to t_next reaching distance d_next: the step to return, or -1
    to go on. The first advance is safe by the bounds alone (d >= eta d0 in exact arithmetic);
    later ones stop once the distance would fall below eta d0 (gap); a capped advance ends the
    search (safe even where round-off puts d_next at gap on the first), and so does the
    iteration limit (at the advance just taken, which is safe)."""
    if d_next < gap and toc > 0.0:
        return toc
    if t_next >= t_max:
        return t_max
    if it + 1 >= max_iter:
        return t_next
    return -1.0


@njit(cache=True)
def point_edge_ccd(y, dy, eta=CCD_ETA, t_max=1.0, max_iter=CCD_MAX_ITER):
    """Additive CCD of a point against an edge, both moving linearly: y = (p, e0, e1) at the
    start, dy their displacements over the full step. Returns t in [0, t_max] such that for
    every s in [0, t] the point does not touch the edge and d(t) >= eta d(0) (t_max if no
    contact can happen before t_max).

    Each advance is the longer of two safe steps from the current iterate (distance d): the
    additive step (1 - eta) d / M, and the directional step along the current closest-point
    axis (`_directional_step`), which is exact for a rigidly translating edge and keeps
    tangential sliding from shrinking the steps. Both keep d >= eta d over the advance."""
    d0 = point_edge_distance(y)
    if not d0 > 0.0:
        return 0.0
    rx0 = dy[0] - dy[2]
    ry0 = dy[1] - dy[3]
    rx1 = dy[0] - dy[4]
    ry1 = dy[1] - dy[5]
    M = np.sqrt(max(rx0 * rx0 + ry0 * ry0, rx1 * rx1 + ry1 * ry1))
    if not np.isfinite(M):
        return 0.0
    if M == 0.0 or (1.0 - eta) * d0 >= M * t_max:
        return t_max
    gap = eta * d0
    if point_edge_separation_bound(y, dy, 0.0, t_max) >= gap:
        return t_max
    yt = y.copy()
    toc = 0.0
    d = d0
    it = 0
    while True:
        # the directional step aims just above the stopping distance eta d0 (not at eta d, which
        # could jump below it and forfeit the whole step)
        step = max((1.0 - eta) * d / M, _directional_step(yt, dy, max(eta * d, _DIR_MARGIN * gap)))
        t_next = min(toc + step, t_max)
        for a in range(6):
            yt[a] = y[a] + t_next * dy[a]
        d_next = point_edge_distance(yt)
        done = _advance_verdict(d_next, gap, toc, t_next, t_max, it, max_iter)
        if done >= 0.0:
            return done
        toc = t_next
        d = d_next
        it += 1
        if it % _SEPARATION_EVERY == 0 and point_edge_separation_bound(y, dy, toc, t_max) >= gap:
            return t_max


@njit(cache=True)
def point_point_ccd(y, dy, eta=CCD_ETA, t_max=1.0, max_iter=CCD_MAX_ITER):
    """Additive CCD of two linearly moving points y = (p, q), displacements dy (4,); same
    contract as `point_edge_ccd` with M = |dp - dq|."""
    return _pair_ccd(PP, y, dy, eta, t_max, max_iter)


@njit(cache=True)
def point_edge_ccd_pairs(points, dpoints, verts, dverts, edges, pairs, eta=CCD_ETA, t_max=1.0):
    """Largest common step in [0, t_max] for all point-edge pairs (k, 2) = (point, edge): the
    minimum of `point_edge_ccd` over the pairs (each call capped by the running minimum)."""
    y = np.empty(6)
    dy = np.empty(6)
    t = t_max
    for k in range(pairs.shape[0]):
        i = pairs[k, 0]
        a = edges[pairs[k, 1], 0]
        b = edges[pairs[k, 1], 1]
        for c in range(2):
            y[c] = points[i, c]
            y[2 + c] = verts[a, c]
            y[4 + c] = verts[b, c]
            dy[c] = dpoints[i, c]
            dy[2 + c] = dverts[a, c]
            dy[4 + c] = dverts[b, c]
        t = min(t, point_edge_ccd(y, dy, eta, t))
        if t == 0.0:
            break
    return t


# ---------------------------------------------------------------------------------------------- 3D
# pair kinds of the plain additive CCD: 3D point-triangle (p, t0, t1, t2), 3D edge-edge
# (a0, a1, b0, b1), 2D point-point (p, q)
PT, EE, PP = 0, 1, 2


@njit(cache=True, inline="always")
def _pair_distance(kind, y):
    if kind == PP:
        return np.sqrt((y[0] - y[2]) ** 2 + (y[1] - y[3]) ** 2)
    return np.sqrt(point_triangle_distance2(y) if kind == PT else edge_edge_distance2(y))


@njit(cache=True, inline="always")
def _pair_rate(kind, dy):
    """The Lipschitz constant of the pair's distance along dy: the largest relative speed of a
    vertex of one side against a vertex of the other (the distance is a minimum over convex
    combinations, each moving at a convex combination of those speeds). Point-triangle: side
    {p} against {t0, t1, t2}; edge-edge: {a0, a1} against {b0, b1}; point-point: p against q."""
    dim = 2 if kind == PP else 3
    first = 2 if kind == EE else 1
    M = 0.0
    for i in range(first):
        for j in range(first, dy.shape[0] // dim):
            r = 0.0
            for a in range(dim):
                r += (dy[dim * i + a] - dy[dim * j + a]) ** 2
            M = max(M, np.sqrt(r))
    return M


@njit(cache=True, inline="always")
def _pair_ccd(kind, y, dy, eta, t_max, max_iter):
    """Plain additive CCD of a pair (the module's algorithm without the point-edge refinements):
    t in [0, t_max] such that the pair does not touch over [0, t] and d(t) >= eta d(0)."""
    d0 = _pair_distance(kind, y)
    if not d0 > 0.0:
        return 0.0
    M = _pair_rate(kind, dy)
    if not np.isfinite(M):
        return 0.0
    if M == 0.0 or (1.0 - eta) * d0 >= M * t_max:
        return t_max
    gap = eta * d0
    yt = y.copy()
    toc = 0.0
    d = d0
    for it in range(max_iter):
        t_next = min(toc + (1.0 - eta) * d / M, t_max)
        for a in range(y.shape[0]):
            yt[a] = y[a] + t_next * dy[a]
        d = _pair_distance(kind, yt)
        done = _advance_verdict(d, gap, toc, t_next, t_max, it, max_iter)
        if done >= 0.0:
            return done
        toc = t_next
    return toc


@njit(cache=True)
def point_triangle_ccd(y, dy, eta=CCD_ETA, t_max=1.0, max_iter=CCD_MAX_ITER):
    """Additive CCD of a point against a triangle, y = (p, t0, t1, t2) (12,) at the start, dy
    their displacements; same contract as `point_edge_ccd`, M = max_i |dp - dt_i|."""
    return _pair_ccd(PT, y, dy, eta, t_max, max_iter)


@njit(cache=True)
def edge_edge_ccd(y, dy, eta=CCD_ETA, t_max=1.0, max_iter=CCD_MAX_ITER):
    """Additive CCD of two edges, y = (a0, a1, b0, b1) (12,); M = max_ij |da_i - db_j|."""
    return _pair_ccd(EE, y, dy, eta, t_max, max_iter)
