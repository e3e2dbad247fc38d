"""Unsigned distances between contact primitives, with closed-form gradients and Hessians.

Conventions (shared by every primitive, so 3D point-triangle and edge-edge can follow with the
same interface):
  * A primitive pair is a stacked coordinate vector y: point-point y = (p, q) in R^(2d),
    point-edge y = (p, e0, e1) in R^(3d) (d = 2 now; 3D would add point-triangle
    y = (p, t0, t1, t2) and edge-edge y = (a0, a1, b0, b1)).
  * A pair first gets a *distance type*: which pair of closest features realises the distance.
    Point-edge types follow the IPC toolkit's numbering: PE_P_E0 = 0 (closest to e0),
    PE_P_E1 = 1 (closest to e1), PE_P_E = 2 (closest to the edge's interior). Classification:
    t = (p - e0).e / |e|^2 (e = e1 - e0); t < 0 -> P_E0, t > 1 -> P_E1, else P_E.
    A degenerate edge (|e| = 0) is P_E0.
  * `*_distance` returns the unsigned Euclidean distance d (not squared); `*_distance2` the
    squared distance d^2 (the quantity the IPC toolkit / `ipctk` calls "distance").
  * `*_hessian(y, g, H[, dtype])` fills the gradient g (len(y)) and Hessian H (len(y)^2) and
    returns the value; `*_gradient(y, g[, dtype])` fills only g. dtype = -1 classifies
    automatically; a fixed dtype evaluates that branch's formula (used by the finite-difference
    tests and to match ipctk's `dtype` argument).

Point-line (P_E) in 2D uses the *signed* distance s = c / sqrt(L), c = e x r = e_x r_y - e_y r_x,
r = p - e0, L = |e|^2, so that d = |s| and grad d = sign(s) grad s, hess d = sign(s) hess s; s is
smooth (no square root of d^2) and its derivatives are exact rational expressions:
  c = e0 x e1 + e1 x p + p x e0 is bilinear, its Hessian is constant (blocks J = [[0, 1], [-1, 0]]
  between u and v for every term u x v);
  grad s = grad c / sqrt(L) - c grad L / (2 L^1.5)
  hess s = hess c / sqrt(L) - (grad c grad L^T + grad L grad c^T) / (2 L^1.5)
           - c hess L / (2 L^1.5) + 3 c grad L grad L^T / (4 L^2.5).
Point-point: d = |p - q|, grad d = (n, -n), hess d = (I - n n^T)/d (x) [[1, -1], [-1, 1]].
The distance is C^1 across the type boundaries (t = 0, 1), not C^2; the barrier's Hessian is
taken per type, as in IPC (Li et al. 2020, doi:10.1145/3386569.3392425, Sec. 4).
At d = 0 the gradient is undefined: the functions return d = 0 with g = H = 0 (the barrier is
infinite there anyway).
"""

from __future__ import annotations

import numpy as np
from numba import njit

PE_P_E0 = 0  # point closest to endpoint e0 (point-point)
PE_P_E1 = 1  # point closest to endpoint e1 (point-point)
PE_P_E = 2  # point closest to the edge's interior (point-line)


# --------------------------------------------------------------------------------------------
# classification, closest point, tangents
# --------------------------------------------------------------------------------------------

@njit(cache=True, inline="always")
def _edge_param(y):
    """Unclamped closest-point parameter t = (p - e0).e / |e|^2 and L = |e|^2 of y = (p, e0, e1)."""
    ex = y[4] - y[2]
    ey = y[5] - y[3]
    L = ex * ex + ey * ey
    if L == 0.0:
        return 0.0, 0.0
    return ((y[0] - y[2]) * ex + (y[1] - y[3]) * ey) / L, L


@njit(cache=True)
def point_edge_distance_type(y):
    """Distance type of the point-edge pair y = (p, e0, e1): PE_P_E0 (t < 0 or |e| = 0),
    PE_P_E1 (t > 1) or PE_P_E (0 <= t <= 1), with t = (p - e0).e/|e|^2."""
    t, L = _edge_param(y)
    if L == 0.0 or t < 0.0:
        return PE_P_E0
    if t > 1.0:
        return PE_P_E1
    return PE_P_E


@njit(cache=True)
def point_edge_closest_param(y):
    """Closest-point parameter r in [0, 1] on the edge (closest point (1 - r) e0 + r e1): the
    lagged r_k of the friction slip u_k (notes, "Lagged friction")."""
    t, L = _edge_param(y)
    if L == 0.0 or t < 0.0:
        return 0.0
    if t > 1.0:
        return 1.0
    return t


@njit(cache=True)
def point_edge_tangent(y, tau):
    """Unit tangent of the edge, tau = (e1 - e0)/|e1 - e0|, written into tau (2,); returns |e|.
    A degenerate edge gives tau = (1, 0)."""
    ex = y[4] - y[2]
    ey = y[5] - y[3]
    le = np.sqrt(ex * ex + ey * ey)
    if le == 0.0:
        tau[0] = 1.0
        tau[1] = 0.0
        return 0.0
    tau[0] = ex / le
    tau[1] = ey / le
    return le


@njit(cache=True)
def point_edge_friction_frame(y, tau):
    """Lagged friction frame of a point-edge pair: returns the closest-point parameter r in [0, 1]
    and writes the sliding direction tau (2,). In the interior (P_E) tau is the edge tangent;
    in the endpoint regions the contact is point-point and tau is perpendicular to p - e_r
    (as IPC's vertex-vertex tangent basis), signed so that tau.e >= 0. The two coincide at the
    region boundary (there p - e_r is normal to the edge), so the frame is continuous."""
    dtype = point_edge_distance_type(y)
    if dtype == PE_P_E:
        point_edge_tangent(y, tau)
        return point_edge_closest_param(y)
    j = 2 if dtype == PE_P_E0 else 4
    rx = y[0] - y[j]
    ry = y[1] - y[j + 1]
    lr = np.sqrt(rx * rx + ry * ry)
    if lr == 0.0:
        point_edge_tangent(y, tau)
    else:
        tau[0] = ry / lr  # rotate (p - e_r)/|p - e_r| by -90 degrees
        tau[1] = -rx / lr
        if tau[0] * (y[4] - y[2]) + tau[1] * (y[5] - y[3]) < 0.0:
            tau[0] = -tau[0]
            tau[1] = -tau[1]
    return 0.0 if dtype == PE_P_E0 else 1.0


# --------------------------------------------------------------------------------------------
# point-point (blocks i, j of a stacked vector)
# --------------------------------------------------------------------------------------------

@njit(cache=True, inline="always")
def _pp_blocks(y, i, j, g, H, want_h, squared):
    """Point-point distance between the 2-blocks starting at i and j of y; adds its gradient
    (and Hessian) into the zeroed g, H at those blocks. Returns d (or d^2 if squared)."""
    rx = y[i] - y[j]
    ry = y[i + 1] - y[j + 1]
    d2 = rx * rx + ry * ry
    if squared:
        g[i] = 2.0 * rx
        g[i + 1] = 2.0 * ry
        g[j] = -2.0 * rx
        g[j + 1] = -2.0 * ry
        if want_h:
            for a in range(2):
                H[i + a, i + a] = 2.0
                H[j + a, j + a] = 2.0
                H[i + a, j + a] = -2.0
                H[j + a, i + a] = -2.0
        return d2
    d = np.sqrt(d2)
    if d == 0.0:
        return 0.0
    n0 = rx / d
    n1 = ry / d
    g[i] = n0
    g[i + 1] = n1
    g[j] = -n0
    g[j + 1] = -n1
    if want_h:
        inv = 1.0 / d
        P00 = (1.0 - n0 * n0) * inv
        P01 = -n0 * n1 * inv
        P11 = (1.0 - n1 * n1) * inv
        H[i, i] = P00
        H[i, i + 1] = P01
        H[i + 1, i] = P01
        H[i + 1, i + 1] = P11
        H[j, j] = P00
        H[j, j + 1] = P01
        H[j + 1, j] = P01
        H[j + 1, j + 1] = P11
        H[i, j] = -P00
        H[i, j + 1] = -P01
        H[i + 1, j] = -P01
        H[i + 1, j + 1] = -P11
        H[j, i] = -P00
        H[j, i + 1] = -P01
        H[j + 1, i] = -P01
        H[j + 1, i + 1] = -P11
    return d


@njit(cache=True)
def point_point_distance(y):
    """Distance |p - q| for y = (p, q) in R^4."""
    return np.sqrt((y[0] - y[2]) ** 2 + (y[1] - y[3]) ** 2)


@njit(cache=True)
def point_point_distance_gradient(y, g):
    """d = |p - q| for y = (p, q); fills g (4,) = (n, -n), n = (p - q)/d."""
    g[:] = 0.0
    return _pp_blocks(y, 0, 2, g, np.empty((0, 0)), False, False)


@njit(cache=True)
def point_point_distance_hessian(y, g, H):
    """d = |p - q| for y = (p, q); fills g (4,) and H (4, 4) = (I - n n^T)/d (x) [[1,-1],[-1,1]]."""
    g[:] = 0.0
    H[:, :] = 0.0
    return _pp_blocks(y, 0, 2, g, H, True, False)


@njit(cache=True)
def point_point_distance2_hessian(y, g, H):
    """Squared distance |p - q|^2 for y = (p, q); fills g (4,) and H (4, 4)."""
    g[:] = 0.0
    H[:, :] = 0.0
    return _pp_blocks(y, 0, 2, g, H, True, True)


# --------------------------------------------------------------------------------------------
# point-line (signed) in 2D
# --------------------------------------------------------------------------------------------

@njit(cache=True, inline="always")
def _add_cross_hessian(H, u, v, scale):
    """H += scale * hess(u x v) for 2-blocks starting at u and v (u x v = u_x v_y - u_y v_x)."""
    H[u, v + 1] += scale
    H[u + 1, v] -= scale
    H[v + 1, u] += scale
    H[v, u + 1] -= scale


@njit(cache=True, inline="always")
def _point_line_signed(y, g, H, want_h):
    """Signed point-line distance s = (e x r)/|e| of y = (p, e0, e1), positive when p is to the
    left of e0 -> e1. Fills grad s into g (6,) and hess s into H (6, 6) (both overwritten).
    Requires |e| > 0."""
    px, py, ax, ay, bx, by = y[0], y[1], y[2], y[3], y[4], y[5]
    ex = bx - ax
    ey = by - ay
    rx = px - ax
    ry = py - ay
    L = ex * ex + ey * ey
    c = ex * ry - ey * rx
    sL = np.sqrt(L)
    iL12 = 1.0 / sL
    iL32 = iL12 / L
    s = c * iL12
    # grad c and grad L (p, e0, e1 blocks)
    gc0 = -ey
    gc1 = ex
    gc2 = ey - ry
    gc3 = rx - ex
    gc4 = ry
    gc5 = -rx
    gL0 = 0.0
    gL1 = 0.0
    gL2 = -2.0 * ex
    gL3 = -2.0 * ey
    gL4 = 2.0 * ex
    gL5 = 2.0 * ey
    gcv = (gc0, gc1, gc2, gc3, gc4, gc5)
    gLv = (gL0, gL1, gL2, gL3, gL4, gL5)
    half_c_iL32 = 0.5 * c * iL32
    for a in range(6):
        g[a] = gcv[a] * iL12 - half_c_iL32 * gLv[a]
    if want_h:
        iL52 = iL32 / L
        k3 = 0.75 * c * iL52
        for a in range(6):
            for b in range(6):
                H[a, b] = -0.5 * iL32 * (gcv[a] * gLv[b] + gLv[a] * gcv[b]) + k3 * gLv[a] * gLv[b]
        # hess c: c = e0 x e1 + e1 x p + p x e0
        _add_cross_hessian(H, 2, 4, iL12)
        _add_cross_hessian(H, 4, 0, iL12)
        _add_cross_hessian(H, 0, 2, iL12)
        # hess L = 2 [[I, -I], [-I, I]] on (e0, e1)
        kL = -half_c_iL32 * 2.0
        for a in range(2):
            H[2 + a, 2 + a] += kL
            H[4 + a, 4 + a] += kL
            H[2 + a, 4 + a] -= kL
            H[4 + a, 2 + a] -= kL
    return s


@njit(cache=True)
def point_line_signed_distance_hessian(y, g, H):
    """Signed distance s = ((e1 - e0) x (p - e0))/|e1 - e0| from p to the line through e0, e1
    (positive to the left of e0 -> e1), with gradient g (6,) and Hessian H (6, 6)."""
    return _point_line_signed(y, g, H, True)


# --------------------------------------------------------------------------------------------
# point-edge
# --------------------------------------------------------------------------------------------

@njit(cache=True, inline="always")
def _pe_dispatch(y, g, H, dtype, want_h, squared):
    if dtype < 0:
        dtype = point_edge_distance_type(y)
    for a in range(6):
        g[a] = 0.0
    if want_h:
        for a in range(6):
            for b in range(6):
                H[a, b] = 0.0
    if dtype == PE_P_E0:
        return _pp_blocks(y, 0, 2, g, H, want_h, squared)
    if dtype == PE_P_E1:
        return _pp_blocks(y, 0, 4, g, H, want_h, squared)
    s = _point_line_signed(y, g, H, want_h)
    if squared:
        # d^2 = s^2: grad = 2 s grad s, hess = 2 grad s grad s^T + 2 s hess s
        if want_h:
            for a in range(6):
                for b in range(6):
                    H[a, b] = 2.0 * (g[a] * g[b] + s * H[a, b])
        for a in range(6):
            g[a] *= 2.0 * s
        return s * s
    if s < 0.0:
        for a in range(6):
            g[a] = -g[a]
        if want_h:
            for a in range(6):
                for b in range(6):
                    H[a, b] = -H[a, b]
        return -s
    return s


@njit(cache=True)
def point_edge_distance(y, dtype=-1):
    """Unsigned distance from p to the segment [e0, e1] for y = (p, e0, e1) in R^6."""
    if dtype < 0:
        dtype = point_edge_distance_type(y)
    if dtype == PE_P_E0:
        return np.sqrt((y[0] - y[2]) ** 2 + (y[1] - y[3]) ** 2)
    if dtype == PE_P_E1:
        return np.sqrt((y[0] - y[4]) ** 2 + (y[1] - y[5]) ** 2)
    ex = y[4] - y[2]
    ey = y[5] - y[3]
    c = ex * (y[1] - y[3]) - ey * (y[0] - y[2])
    return abs(c) / np.sqrt(ex * ex + ey * ey)


@njit(cache=True)
def point_edge_distance2(y, dtype=-1):
    """Squared distance from p to the segment [e0, e1] (ipctk's `point_edge_distance`)."""
    if dtype < 0:
        dtype = point_edge_distance_type(y)
    if dtype == PE_P_E0:
        return (y[0] - y[2]) ** 2 + (y[1] - y[3]) ** 2
    if dtype == PE_P_E1:
        return (y[0] - y[4]) ** 2 + (y[1] - y[5]) ** 2
    ex = y[4] - y[2]
    ey = y[5] - y[3]
    c = ex * (y[1] - y[3]) - ey * (y[0] - y[2])
    return c * c / (ex * ex + ey * ey)


@njit(cache=True)
def point_edge_distance_gradient(y, g, dtype=-1, squared=False):
    """Unsigned point-edge distance d (d^2 with squared); fills its gradient g (6,) w.r.t.
    y = (p, e0, e1)."""
    return _pe_dispatch(y, g, np.empty((0, 0)), dtype, False, squared)


@njit(cache=True)
def point_edge_distance_hessian(y, g, H, dtype=-1, squared=False):
    """Unsigned point-edge distance d (d^2 with squared); fills gradient g (6,) and Hessian
    H (6, 6)."""
    return _pe_dispatch(y, g, H, dtype, True, squared)
