"""3D distances between contact primitives (point-triangle, and the point-edge and point-point
pieces it is made of) as closest-point problems, with exact gradients and Hessians; the 3D
companion of distance.py, same conventions (stacked coordinates y, the IPC toolkit's distance
types, `*_distance2` the squared distance that ipctk calls "distance").

One formula serves every type. On a type, the closest points are affine in a few parameters s
(none for point-point, the edge parameter for point-edge, two barycentric coordinates for the
face): the vector between them is

    r(y, s) = sum_j c_j(s) x_j,   c_j(s) = c0_j + sum_m s_m dc_mj,

over the pair's vertices x_j (y = (x_0, x_1, ...)), and the squared distance is the minimum over
s of f = |r|^2, s* = -(W^T W)^-1 W^T r0 (W's columns w_m = sum_j dc_mj x_j). At s* (df/ds = 0),

    grad d^2 = df/dy:          block j = 2 c_j r,
    hess d^2 = d2f/dy2 - M S^-1 M^T   (the implicit function theorem),
        d2f/dy2: block (j, k) = 2 c_j c_k I,  S = 2 W^T W,
        M column m, block j = 2 (dc_mj r + c_j w_m).

The types of a point-triangle pair (ipctk's numbering): P_T0, P_T1, P_T2 (a vertex), P_E0 (edge
t0-t1), P_E1 (t1-t2), P_E2 (t2-t0), P_T (the face). The type is the one whose closest point is
the true one: the face when the point projects inside the triangle, else the nearest of the
edges (clamped parameter inside) and vertices. Edge-edge pairs y = (a0, a1, b0, b1): EA0_EB0,
EA0_EB1, EA1_EB0, EA1_EB1 (two vertices), EA_EB0, EA_EB1 (a vertex of b against edge a), EA0_EB,
EA1_EB (a vertex of a against edge b), EA_EB (the two edges' interiors), chosen the same way;
nearly parallel edges need IPC's mollifier on top (not here). The distance is C^1 across types, not C^2; the
barrier's Hessian is taken per type, as in IPC (Li et al. 2020, doi:10.1145/3386569.3392425).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ...linalg import dot

PT_P_T0, PT_P_T1, PT_P_T2, PT_P_E0, PT_P_E1, PT_P_E2, PT_P_T = 0, 1, 2, 3, 4, 5, 6
EE_EA0_EB0, EE_EA0_EB1, EE_EA1_EB0, EE_EA1_EB1, EE_EA_EB0, EE_EA_EB1, EE_EA0_EB, EE_EA1_EB, EE_EA_EB = range(9)
# the edges (local vertex pairs of the triangle) of P_E0..P_E2
_EDGES = np.array([[0, 1], [1, 2], [2, 0]], dtype=np.int64)


@njit(cache=True, inline="always")
def _closest(y, c0, dc, ns, g, H, want):
    """Squared distance min_s |sum_j c_j(s) x_j|^2 over the vertices x_j = y[3j:3j+3] (k = len(c0)),
    c = c0 + s dc (dc (ns, k), ns <= 2); fills the gradient g (3k) and, with want, the Hessian H
    (3k, 3k) of the squared distance (the module's formula)."""
    k = c0.shape[0]
    r0 = np.zeros(3)
    w = np.zeros((2, 3))
    for j in range(k):
        for a in range(3):
            r0[a] += c0[j] * y[3 * j + a]
            for m in range(ns):
                w[m, a] += dc[m, j] * y[3 * j + a]
    S = np.zeros((2, 2))
    b = np.zeros(2)
    for m in range(ns):
        for a in range(3):
            b[m] -= w[m, a] * r0[a]
        for n in range(ns):
            for a in range(3):
                S[m, n] += w[m, a] * w[n, a]
    s = np.zeros(2)
    det = 0.0
    if ns == 1:
        s[0] = b[0] / S[0, 0]
    elif ns == 2:
        # with n = w0 x w1 (det S = |n|^2, Lagrange's identity, without the cancellation of
        # S00 S11 - S01^2 for nearly parallel w): -r0 = s0 w0 + s1 w1 + c n, so
        # s0 = -(w1 x n).r0 / |n|^2, s1 = -(n x w0).r0 / |n|^2
        n = np.cross(w[0], w[1])
        det = dot(n, n)
        s[0] = -dot(np.cross(w[1], n), r0) / det
        s[1] = -dot(np.cross(n, w[0]), r0) / det
    c = c0.copy()
    for m in range(ns):
        for j in range(k):
            c[j] += s[m] * dc[m, j]
    r = r0.copy()
    for m in range(ns):
        for a in range(3):
            r[a] += s[m] * w[m, a]
    d2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    for j in range(k):
        for a in range(3):
            g[3 * j + a] = 2.0 * c[j] * r[a]
    if not want:
        return d2
    for j in range(k):
        for l in range(k):
            for a in range(3):
                for e in range(3):
                    H[3 * j + a, 3 * l + e] = 2.0 * c[j] * c[l] if a == e else 0.0
    if ns == 0:
        return d2
    # S^-1 of the 2 W^T W block, and M's columns
    Si = np.zeros((2, 2))
    if ns == 1:
        Si[0, 0] = 1.0 / (2.0 * S[0, 0])
    else:  # (2 S)^-1 = adj(S) / (2 det S)
        Si[0, 0] = S[1, 1] / (2.0 * det)
        Si[1, 1] = S[0, 0] / (2.0 * det)
        Si[0, 1] = -S[0, 1] / (2.0 * det)
        Si[1, 0] = -S[1, 0] / (2.0 * det)
    M = np.zeros((3 * k, 2))
    for m in range(ns):
        for j in range(k):
            for a in range(3):
                M[3 * j + a, m] = 2.0 * (dc[m, j] * r[a] + c[j] * w[m, a])
    for p in range(3 * k):
        for q in range(3 * k):
            acc = 0.0
            for m in range(ns):
                for n in range(ns):
                    acc += M[p, m] * Si[m, n] * M[q, n]
            H[p, q] -= acc
    return d2


@njit(cache=True, inline="always")
def _pt_coefficients(dtype, c0, dc):
    """c0 (4,), dc (2, 4) of a point-triangle type over (p, t0, t1, t2); returns ns."""
    c0[:] = 0.0
    dc[:, :] = 0.0
    c0[0] = 1.0
    if dtype <= PT_P_T2:  # p - t_i
        c0[1 + dtype] = -1.0
        return 0
    if dtype <= PT_P_E2:  # p - (t_i + s (t_j - t_i))
        i, j = _EDGES[dtype - PT_P_E0, 0], _EDGES[dtype - PT_P_E0, 1]
        c0[1 + i] = -1.0
        dc[0, 1 + i] = 1.0
        dc[0, 1 + j] = -1.0
        return 1
    c0[1] = -1.0  # p - (t0 + a (t1 - t0) + b (t2 - t0))
    dc[0, 1] = 1.0
    dc[0, 2] = -1.0
    dc[1, 1] = 1.0
    dc[1, 3] = -1.0
    return 2


@njit(cache=True, inline="always")
def _nearer(q, x0, x1, edge, best, kind, code):
    """(best, kind) updated with the candidate of type `code`: point q against the edge x0-x1
    (edge: only where its closest point is inside the edge) or against the vertex x0."""
    if edge:
        d = x1 - x0
        L = dot(d, d)
        t = dot(q - x0, d) / L if L > 0.0 else -1.0
        if not 0.0 < t < 1.0:
            return best, kind
        r = q - x0 - t * d
    else:
        r = q - x0
    dist = dot(r, r)
    return (dist, code) if dist < best else (best, kind)


@njit(cache=True)
def point_triangle_distance_type(y):
    """The type (PT_*) of the pair y = (p, t0, t1, t2) (12,)."""
    p = y[0:3]
    t0, t1, t2 = y[3:6], y[6:9], y[9:12]
    u = t1 - t0
    v = t2 - t0
    q = p - t0
    uu, uv, vv = dot(u, u), dot(u, v), dot(v, v)
    qu, qv = dot(q, u), dot(q, v)
    det = uu * vv - uv * uv
    if det > 0.0:
        a = (vv * qu - uv * qv) / det
        b = (uu * qv - uv * qu) / det
        if a >= 0.0 and b >= 0.0 and a + b <= 1.0:
            return PT_P_T
    best, kind = np.inf, PT_P_T0
    for e in range(3):
        i, j = _EDGES[e, 0], _EDGES[e, 1]
        best, kind = _nearer(p, y[3 + 3 * i: 6 + 3 * i], y[3 + 3 * j: 6 + 3 * j], True, best, kind, PT_P_E0 + e)
    for i in range(3):
        best, kind = _nearer(p, y[3 + 3 * i: 6 + 3 * i], p, False, best, kind, PT_P_T0 + i)
    return kind


@njit(cache=True, inline="always")
def _pair_distance2(triangle, y, g, H, dtype, want_h):
    """Squared distance of a point-triangle (triangle) or edge-edge pair y (12,) of type dtype
    (-1: classified), with its gradient and (want_h) Hessian."""
    if dtype < 0:
        dtype = point_triangle_distance_type(y) if triangle else edge_edge_distance_type(y)
    c0 = np.zeros(4)
    dc = np.zeros((2, 4))
    ns = _pt_coefficients(dtype, c0, dc) if triangle else _ee_coefficients(dtype, c0, dc)
    return _closest(y, c0, dc, ns, g, H, want_h)


@njit(cache=True)
def point_triangle_distance2_hessian(y, g, H, dtype=-1, want_h=True):
    """Squared point-triangle distance of y = (p, t0, t1, t2) (12,); fills its gradient g (12,)
    and (want_h) Hessian H (12, 12). dtype -1: classified (point_triangle_distance_type)."""
    return _pair_distance2(True, y, g, H, dtype, want_h)


@njit(cache=True)
def point_triangle_distance2(y, dtype=-1):
    """Squared point-triangle distance (ipctk's point_triangle_distance)."""
    return point_triangle_distance2_hessian(y, np.zeros(12), np.zeros((12, 12)), dtype, False)


@njit(cache=True)
def point_triangle_distance(y, dtype=-1):
    """Unsigned point-triangle distance."""
    return np.sqrt(point_triangle_distance2(y, dtype))


@njit(cache=True, inline="always")
def _unsquared(s, g, H):
    """d = sqrt(s) with its gradient and Hessian from those of s in g, H (in place):
    g = g_s / 2d, H = H_s / 2d - g_s g_s^T / 4d^3 (zero at d = 0)."""
    d = np.sqrt(s)
    if not d > 0.0:
        g[:] = 0.0
        H[:, :] = 0.0
        return 0.0
    n = g.shape[0]
    for p in range(n):
        for q in range(n):
            H[p, q] = H[p, q] / (2.0 * d) - g[p] * g[q] / (4.0 * d * d * d)
    for p in range(n):
        g[p] /= 2.0 * d
    return d


@njit(cache=True)
def point_triangle_distance_hessian(y, g, H, dtype=-1):
    """Unsigned point-triangle distance d with its gradient g (12,) and Hessian H (12, 12)."""
    return _unsquared(point_triangle_distance2_hessian(y, g, H, dtype, True), g, H)


@njit(cache=True, inline="always")
def _ee_coefficients(dtype, c0, dc):
    """c0 (4,), dc (2, 4) of an edge-edge type over (a0, a1, b0, b1): r = a(s) - b(t),
    a(s) = a0 + s (a1 - a0), b(t) = b0 + t (b1 - b0); returns ns."""
    c0[:] = 0.0
    dc[:, :] = 0.0
    if dtype <= EE_EA1_EB1:  # a vertex of each
        c0[dtype // 2] = 1.0
        c0[2 + dtype % 2] = -1.0
        return 0
    if dtype <= EE_EA_EB1:  # vertex b_i against edge a
        c0[0] = 1.0
        dc[0, 0] = -1.0
        dc[0, 1] = 1.0
        c0[2 + dtype - EE_EA_EB0] = -1.0
        return 1
    if dtype <= EE_EA1_EB:  # vertex a_i against edge b
        c0[dtype - EE_EA0_EB] = 1.0
        c0[2] = -1.0
        dc[0, 2] = 1.0
        dc[0, 3] = -1.0
        return 1
    c0[0] = 1.0
    c0[2] = -1.0
    dc[0, 0] = -1.0
    dc[0, 1] = 1.0
    dc[1, 2] = 1.0
    dc[1, 3] = -1.0
    return 2


@njit(cache=True)
def edge_edge_distance_type(y):
    """The type (EE_*) of the pair y = (a0, a1, b0, b1) (12,): the interiors when the lines'
    closest points fall inside both edges, else the nearest of the vertex-edge pairs (parameter
    inside) and vertex pairs."""
    a0, a1, b0, b1 = y[0:3], y[3:6], y[6:9], y[9:12]
    u = a1 - a0
    v = b1 - b0
    w = a0 - b0
    uu, uv, vv, uw, vw = dot(u, u), dot(u, v), dot(v, v), dot(u, w), dot(v, w)
    det = uu * vv - uv * uv
    if det > 1e-14 * uu * vv:
        s = (uv * vw - vv * uw) / det
        t = (uu * vw - uv * uw) / det
        if 0.0 < s < 1.0 and 0.0 < t < 1.0:
            return EE_EA_EB
    best, kind = np.inf, EE_EA0_EB0
    for i in range(2):  # vertex b_i against edge a, vertex a_i against edge b
        best, kind = _nearer(y[6 + 3 * i: 9 + 3 * i], a0, a1, True, best, kind, EE_EA_EB0 + i)
        best, kind = _nearer(y[3 * i: 3 * i + 3], b0, b1, True, best, kind, EE_EA0_EB + i)
    for i in range(2):
        for j in range(2):
            best, kind = _nearer(y[3 * i: 3 * i + 3], y[6 + 3 * j: 9 + 3 * j], a0, False, best, kind, 2 * i + j)
    return kind


@njit(cache=True)
def edge_edge_distance2_hessian(y, g, H, dtype=-1, want_h=True):
    """Squared edge-edge distance of y = (a0, a1, b0, b1) (12,); fills its gradient g (12,) and
    (want_h) Hessian H (12, 12). dtype -1: classified (edge_edge_distance_type)."""
    return _pair_distance2(False, y, g, H, dtype, want_h)


@njit(cache=True)
def edge_edge_distance2(y, dtype=-1):
    """Squared edge-edge distance (ipctk's edge_edge_distance)."""
    return edge_edge_distance2_hessian(y, np.zeros(12), np.zeros((12, 12)), dtype, False)


@njit(cache=True)
def edge_edge_distance_hessian(y, g, H, dtype=-1):
    """Unsigned edge-edge distance d with its gradient g (12,) and Hessian H (12, 12)."""
    return _unsquared(edge_edge_distance2_hessian(y, g, H, dtype, True), g, H)
