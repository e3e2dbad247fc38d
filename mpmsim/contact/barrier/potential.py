"""Smoothly clamped log barrier on unsigned distances, and the per-pair barrier energies.

Distance form of the IPC barrier (Li et al. 2020, "Incremental Potential Contact",
doi:10.1145/3386569.3392425, Eq. 6; BFEMP Eq. 27; implementation notes, "BFEMP"):
    b(d) = -kappa dhat (u - 1)^2 ln u,  u = d/dhat,  for 0 < d < dhat;  0 for d >= dhat
    b'(d)  = kappa [-2 (u - 1) ln u - (u - 1)^2 / u]
    b''(d) = (kappa/dhat) [-2 ln u - 4 (u - 1)/u + (u - 1)^2 / u^2]
d is the unsigned distance (not squared) in length units; kappa is in stress units (energy per
length^2 in 2D, i.e. the energy b has units kappa * length: multiply by the particle weight
w_p, a length in 2D, to get energy per unit thickness), so b' is a force per unit weight. The
relation to the IPC toolkit's unit-stiffness barrier (ipctk.barrier(d, dhat) =
-(d - dhat)^2 ln(d/dhat), same d) is b = (kappa/dhat) * ipctk.barrier(d, dhat), and likewise for
both derivatives. b is C^2 at d = dhat (b = b' = b'' = 0 there) and b -> +inf as d -> 0+;
for d <= 0 the functions return +inf (energy), -inf (b') and +inf (b'').

Per-pair energies follow by the chain rule on the stacked vector y:
    E = b(d(y)),  grad E = b'(d) grad d,  hess E = b''(d) grad d grad d^T + b'(d) hess d,
with the distance derivatives of `distance.py`; the Hessian can be projected to PSD per stencil
(projected Newton). The caller scales kappa by the quadrature weight (w_p for a particle-edge
pair; -(deg - 1) w_p for the boundary-node correction of the notes / BFEMP Eq. 31).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ...linalg import dot
from .closest import edge_edge_distance_hessian, point_triangle_distance_hessian
from .distance import _pe_dispatch, _pp_blocks
from ...fem.elements import project_psd


@njit(cache=True, inline="always")
def _barrier(d, dhat, kappa, order):
    """The barrier (order 0) or its first or second derivative in d: 0 for d >= dhat, +-inf for
    d <= 0 (the sign of the function's limit)."""
    if d >= dhat:
        return 0.0
    if d <= 0.0:
        return -np.inf if order == 1 else np.inf
    u = d / dhat
    if order == 0:
        return -kappa * dhat * (u - 1.0) ** 2 * np.log(u)
    if order == 1:
        return kappa * (-2.0 * (u - 1.0) * np.log(u) - (u - 1.0) ** 2 / u)
    return kappa / dhat * (-2.0 * np.log(u) - 4.0 * (u - 1.0) / u + (u - 1.0) ** 2 / (u * u))


@njit(cache=True)
def barrier(d, dhat, kappa):
    """b(d) = -kappa dhat (u - 1)^2 ln u, u = d/dhat, for 0 < d < dhat; 0 beyond; +inf for d <= 0."""
    return _barrier(d, dhat, kappa, 0)


@njit(cache=True)
def barrier_first_derivative(d, dhat, kappa):
    """b'(d) = kappa [-2 (u - 1) ln u - (u - 1)^2 / u] (<= 0): minus the normal force per unit
    weight."""
    return _barrier(d, dhat, kappa, 1)


@njit(cache=True)
def barrier_second_derivative(d, dhat, kappa):
    """b''(d) = (kappa/dhat) [-2 ln u - 4 (u - 1)/u + (u - 1)^2/u^2] (>= 0)."""
    return _barrier(d, dhat, kappa, 2)


@njit(cache=True)
def barrier_normal_force(d, dhat, kappa):
    """Contact force magnitude -b'(d) >= 0 per unit weight: the lagged lambda_k of friction is
    w_p times this (notes, "Lagged friction")."""
    return -barrier_first_derivative(d, dhat, kappa)


@njit(cache=True, inline="always")
def _chain(d, g, H, dhat, kappa, project):
    """Turn (d, grad d, hess d) in g, H into the barrier's energy, gradient and Hessian."""
    n = g.shape[0]
    if d >= dhat:
        g[:] = 0.0
        H[:, :] = 0.0
        return 0.0
    if d <= 0.0:
        g[:] = 0.0
        H[:, :] = 0.0
        return np.inf
    b1 = barrier_first_derivative(d, dhat, kappa)
    b2 = barrier_second_derivative(d, dhat, kappa)
    for a in range(n):
        for c in range(n):
            H[a, c] = b2 * g[a] * g[c] + b1 * H[a, c]
    for a in range(n):
        g[a] *= b1
    if project:
        project_psd(H)
    return barrier(d, dhat, kappa)


@njit(cache=True)
def point_edge_barrier(y, dhat, kappa, g, H, project=False, dtype=-1):
    """Barrier energy b(d) of the point-edge pair y = (p, e0, e1) (unsigned distance d);
    fills its gradient g (6,) and Hessian H (6, 6) (PSD-projected if `project`)."""
    d = _pe_dispatch(y, g, H, dtype, True, False)
    return _chain(d, g, H, dhat, kappa, project)


@njit(cache=True)
def point_triangle_barrier(y, dhat, kappa, g, H, project=False, dtype=-1):
    """Barrier energy b(d) of the 3D point-triangle pair y = (p, t0, t1, t2) (12,); fills its
    gradient g (12,) and Hessian H (12, 12) (PSD-projected if `project`)."""
    d = point_triangle_distance_hessian(y, g, H, dtype)
    return _chain(d, g, H, dhat, kappa, project)


@njit(cache=True)
def edge_edge_barrier(y, dhat, kappa, g, H, project=False, dtype=-1):
    """Barrier energy b(d) of the 3D edge-edge pair y = (a0, a1, b0, b1) (12,), without IPC's
    mollifier for near-parallel edges (mollified_edge_edge_barrier); fills g (12,) and H (12, 12)."""
    d = edge_edge_distance_hessian(y, g, H, dtype)
    return _chain(d, g, H, dhat, kappa, project)


# ---------------------------------------------------------------- edge-edge mollifier (3D)
MOLLIFIER_SCALE = 1e-3  # IPC's eps_x = 1e-3 |ea|^2 |eb|^2 at rest


@njit(cache=True)
def edge_edge_mollifier_threshold(rest):
    """eps_x = 1e-3 |a0 - a1|^2 |b0 - b1|^2 of the edges' rest positions rest = (a0, a1, b0, b1)
    (12,) (IPC, Li et al. 2020, doi:10.1145/3386569.3392425, Sec. 4.3)."""
    la = 0.0
    lb = 0.0
    for a in range(3):
        la += (rest[3 + a] - rest[a]) ** 2
        lb += (rest[9 + a] - rest[6 + a]) ** 2
    return MOLLIFIER_SCALE * la * lb


@njit(cache=True)
def edge_edge_cross2_hessian(y, g, H):
    """x = |(a1 - a0) x (b1 - b0)|^2 of y = (a0, a1, b0, b1) (12,) with its gradient g (12,) and
    Hessian H (12, 12). With u = a1 - a0, v = b1 - b0, c = u x v: dx/du = 2 v x c, dx/dv =
    2 c x u (from the cross product: no cancellation for nearly parallel edges), and from
    x = |u|^2 |v|^2 - (u.v)^2: d2x/du2 = 2 |v|^2 I - 2 v v^T, d2x/dv2 = 2 |u|^2 I - 2 u u^T,
    d2x/du dv = 4 u v^T - 2 v u^T - 2 (u.v) I."""
    u = y[3:6] - y[0:3]
    v = y[9:12] - y[6:9]
    c = np.cross(u, v)
    gu = 2.0 * np.cross(v, c)
    gv = 2.0 * np.cross(c, u)
    uu, vv, uv = dot(u, u), dot(v, v), dot(u, v)
    sign = (-1.0, 1.0)
    for i in range(2):
        for a in range(3):
            g[3 * i + a] = sign[i] * gu[a]
            g[6 + 3 * i + a] = sign[i] * gv[a]
    for a in range(3):
        for e in range(3):
            eye = 1.0 if a == e else 0.0
            huu = 2.0 * vv * eye - 2.0 * v[a] * v[e]
            hvv = 2.0 * uu * eye - 2.0 * u[a] * u[e]
            huv = 4.0 * u[a] * v[e] - 2.0 * v[a] * u[e] - 2.0 * uv * eye
            for i in range(2):
                for j in range(2):
                    s = sign[i] * sign[j]
                    H[3 * i + a, 3 * j + e] = s * huu
                    H[6 + 3 * i + a, 6 + 3 * j + e] = s * hvv
                    H[3 * i + a, 6 + 3 * j + e] = s * huv
                    H[6 + 3 * j + e, 3 * i + a] = s * huv
    return dot(c, c)


@njit(cache=True)
def edge_edge_mollifier(x, eps_x, order=0):
    """IPC's m(x) = -x^2/eps_x^2 + 2 x/eps_x for x < eps_x, else 1 (order 0), or its first or
    second derivative in x (order 1, 2)."""
    if x >= eps_x:
        return 1.0 if order == 0 else 0.0
    if order == 0:
        r = x / eps_x
        return (2.0 - r) * r
    if order == 1:
        return 2.0 / eps_x * (1.0 - x / eps_x)
    return -2.0 / (eps_x * eps_x)


@njit(cache=True, inline="always")
def _mollified_chain(y, d, g, H, eps_x, dhat, kappa, gx, Hx):
    """Turn (d, grad d, hess d) in g, H of an edge pair y (12,) into m(x) b(d), x the pair's
    squared cross norm, with its gradient and Hessian (product rule; gx, Hx scratch):
    grad = b grad m + m b' grad d, hess = b hess m + b' (grad m grad d^T + grad d grad m^T)
    + m (b'' grad d grad d^T + b' hess d), grad m = m' grad x, hess m = m' hess x + m'' grad x grad x^T."""
    if d >= dhat or d <= 0.0:
        return _chain(d, g, H, dhat, kappa, False)
    x = edge_edge_cross2_hessian(y, gx, Hx)
    if x >= eps_x:
        return _chain(d, g, H, dhat, kappa, False)
    b0 = barrier(d, dhat, kappa)
    b1 = barrier_first_derivative(d, dhat, kappa)
    b2 = barrier_second_derivative(d, dhat, kappa)
    m = edge_edge_mollifier(x, eps_x, 0)
    m1 = edge_edge_mollifier(x, eps_x, 1)
    m2 = edge_edge_mollifier(x, eps_x, 2)
    n = g.shape[0]
    for a in range(n):
        for c in range(n):
            H[a, c] = (b0 * (m1 * Hx[a, c] + m2 * gx[a] * gx[c]) + b1 * m1 * (gx[a] * g[c] + g[a] * gx[c])
                       + m * (b2 * g[a] * g[c] + b1 * H[a, c]))
    for a in range(n):
        g[a] = b0 * m1 * gx[a] + m * b1 * g[a]
    return m * b0


@njit(cache=True)
def mollified_edge_edge_barrier(y, eps_x, dhat, kappa, g, H, project=False, dtype=-1):
    """IPC's mollified edge-edge barrier m(x) b(d) of y = (a0, a1, b0, b1) (12,): x = |(a1 - a0) x
    (b1 - b0)|^2, m the mollifier with threshold eps_x (edge_edge_mollifier_threshold of the
    rest positions), d the edge-edge distance (type dtype, -1: classified). m = 1 unless the
    edges are nearly parallel (sin^2 of their angle below 1e-3 at rest lengths), where it takes
    the barrier smoothly to 0 as they become parallel. Fills g (12,), H (12, 12)."""
    d = edge_edge_distance_hessian(y, g, H, dtype)
    e = _mollified_chain(y, d, g, H, eps_x, dhat, kappa, np.empty(12), np.empty((12, 12)))
    if project:
        project_psd(H)
    return e


@njit(cache=True)
def point_point_barrier(y, dhat, kappa, g, H, project=False):
    """Barrier energy b(|p - q|) of y = (p, q) (the boundary-node correction term); fills g (4,)
    and H (4, 4) (PSD-projected if `project`)."""
    g[:] = 0.0
    H[:, :] = 0.0
    d = _pp_blocks(y, 0, 2, g, H, True, False)
    return _chain(d, g, H, dhat, kappa, project)


@njit(cache=True)
def point_edge_barrier_pairs(points, verts, edges, pairs, dhat, kappa, weights, grads, hessians, project=True):
    """Barrier energies of many point-edge pairs. pairs (k, 2) = (point index, edge index);
    weights (n_points,) scale kappa per point (w_p); fills grads (k, 6) and hessians (k, 6, 6)
    in the stacked order (p, e0, e1) and returns the total energy."""
    y = np.empty(6)
    total = 0.0
    for k in range(pairs.shape[0]):
        i = pairs[k, 0]
        j = pairs[k, 1]
        a = edges[j, 0]
        b = edges[j, 1]
        y[0] = points[i, 0]
        y[1] = points[i, 1]
        y[2] = verts[a, 0]
        y[3] = verts[a, 1]
        y[4] = verts[b, 0]
        y[5] = verts[b, 1]
        total += point_edge_barrier(y, dhat, kappa * weights[i], grads[k], hessians[k], project)
    return total


@njit(cache=True)
def point_node_barrier_pairs(points, verts, edges, node_edges, pairs, dhat, kappa, weights, node_weight, others,
                             grads, hessians, project):
    """The boundary-node correction of BFEMP (Eq. 31): -sum w_p (deg_v - 1) b(|p - v|) over
    point-node pairs (k, 2) = (point index, vertex index); node_weight (n_verts,) = deg - 1,
    node_edges (n_verts, 2) the two boundary edges at each vertex (into edges). Returns the
    (negative) total; fills others (k, 3) = (v, n1, n2) (v and the far ends of its two edges),
    and over the local points (p, v, n1, n2) each pair's gradient grads (k, 8) and Hessian
    hessians (k, 8, 8).

    The Hessian is PSD(H1 + H2 - Hv) - H1 - H2, with H1, H2 the PSD-projected Hessians of the
    point's barrier against the two edges at v (the point-edge terms add exactly those) and Hv
    that of b(|p - v|): the three terms together contribute the projection of their sum. Where
    the point sees v as an end of an edge (a straight or convex boundary) the sum is already
    PSD and this is just -Hv, exact; where it sees both edges from their middles (a boundary
    bent inwards) the projection keeps Newton's matrix PSD without losing the curvature.
    Without `project` the Hessian is the correction's own, -(deg_v - 1) w_p Hv, unprojected as
    the point-edge terms then are: the exact second derivative of the sum."""
    y4 = np.empty(4)
    y6 = np.empty(6)
    g4 = np.empty(4)
    g6 = np.empty(6)
    H4 = np.empty((4, 4))
    H6 = np.empty((6, 6))
    M = np.empty((8, 8))
    S = np.empty((8, 8))
    slots = np.empty(3, dtype=np.int64)
    total = 0.0
    for k in range(pairs.shape[0]):
        i = pairs[k, 0]
        v = pairs[k, 1]
        others[k, 0] = v
        for c in range(2):
            j = node_edges[v, c]
            others[k, 1 + c] = edges[j, 1] if edges[j, 0] == v else edges[j, 0]
        s = weights[i] * node_weight[v]
        y4[0], y4[1], y4[2], y4[3] = points[i, 0], points[i, 1], verts[v, 0], verts[v, 1]
        total -= point_point_barrier(y4, dhat, kappa * s, g4, H4, project)
        grads[k, :] = 0.0
        for a in range(4):
            grads[k, a] = -g4[a]
        if not project:
            hessians[k, :, :] = 0.0
            for a in range(4):
                for b in range(4):
                    hessians[k, a, b] = -H4[a, b]
            continue
        M[:, :] = 0.0
        S[:, :] = 0.0
        for a in range(4):
            for b in range(4):
                M[a, b] -= H4[a, b]
        # the two point-edge terms at v, as the point-edge kernel projects them
        for c in range(2):
            j = node_edges[v, c]
            ea, eb = edges[j, 0], edges[j, 1]
            slots[0] = 0
            slots[1] = 1 if ea == v else 2 + c
            slots[2] = 1 if eb == v else 2 + c
            y6[0], y6[1] = points[i, 0], points[i, 1]
            y6[2], y6[3], y6[4], y6[5] = verts[ea, 0], verts[ea, 1], verts[eb, 0], verts[eb, 1]
            point_edge_barrier(y6, dhat, kappa * weights[i], g6, H6, True)
            for a in range(3):
                for b in range(3):
                    for da in range(2):
                        for db in range(2):
                            h = H6[2 * a + da, 2 * b + db]
                            M[2 * slots[a] + da, 2 * slots[b] + db] += h
                            S[2 * slots[a] + da, 2 * slots[b] + db] += h
        project_psd(M)
        for a in range(8):
            for b in range(8):
                hessians[k, a, b] = M[a, b] - S[a, b]
    return total


@njit(cache=True)
def vertex_edges(edges, n_verts):
    """(n_verts, 2) the (at most two) boundary edges at each vertex, -1 where none."""
    out = np.full((n_verts, 2), -1, dtype=np.int64)
    for j in range(edges.shape[0]):
        for c in range(2):
            v = edges[j, c]
            if out[v, 0] < 0:
                out[v, 0] = j
            elif out[v, 1] < 0:
                out[v, 1] = j
    return out
