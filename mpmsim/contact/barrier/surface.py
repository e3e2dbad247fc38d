"""3D barrier contact: contact points (FEM boundary nodes, MPM particles) against the boundary
triangles of other FEM bodies, edge-edge terms between FEM bodies, and lagged friction (BFEMP
Eq. 32; docs/bfemp.md).

Potential of one point p (weight w_p, an area: kappa is a pressure):

    Phi_p = w_p [ sum_t b(d_pt) - sum_e (deg_e - 1) b(d_pe) + sum_{v in V_I} b(d_pv) ]

over the boundary triangles t, edges e (deg_e the triangles at e: 2 on a closed surface) and
surface-interior vertices v (all of a closed surface) within dhat. On a flat or convex patch the
corrections cancel the duplicates exactly: a point over an edge sees the two triangles at the same
distance as the edge, a point over a vertex sees its n triangles and n edges at the vertex's
distance, and either way one barrier remains. Distances come from closest.py (point-edge and
point-point pairs are point-triangle types with a placeholder third/fourth vertex).

Grouping and projection: the terms of one point form one stencil (the point and every FEM node of
its triangles); their Hessians are summed unprojected and the sum is projected to PSD once, so
the correction terms (negative barriers) never leave Newton's matrix indefinite and where the sum
is PSD (a flat or convex surface) the Hessian is exact. This extends the 2D kernel's
PSD(H1 + H2 - Hv) - H1 - H2 at a boundary vertex (potential.point_node_barrier_pairs).

Contact areas: an FEM boundary node carries a third of its triangles' areas (half that when there
are other FEM bodies: below); a particle the
largest cross-section pi r^2 of the sphere of its volume (the paper's choice), or with
`particle_contact: corners` each of its 8 corners a quarter of a face, l^2/4.

FEM-FEM contact: the boundary nodes of each FEM body are points against the other bodies'
triangles (both ways round), and boundary edges of different FEM bodies meet through edge-edge
terms with IPC's mollifier m (potential.mollified_edge_edge_barrier; eps_x from rest lengths).
Grouped per edge a (weight w_a):

    Phi_a = w_a [ sum_b m_ab b(d_ab) - sum_p (sum_{e at p} m_a,e - 1) b(d_pa) ]

over the edges b of other bodies and their ends p within reach, d_pa the point-edge distance of p
to a. Where p's closest point on a is inside a and p is the nearest point of its n edges, the n
pair terms equal b(d_pa) and the correction leaves one; nearly parallel pairs enter with their
mollifier in both places. This is the IPC toolkit's IMPROVED_MAX_APPROX collision set (ipctk 1.6,
area weighting: vertex-face 1/4 of the vertex area, edge-edge 1/4 of the two edge areas, each
edge-edge correction 1/4 of a's), and the whole FEM-FEM potential is twice it: node weights half
their area share (a third of their triangles' areas), w_a half the edge's (a third of its two
triangles' areas). In 2D the two directions of point-edge contact likewise sum to twice the
one-sided integral; an MPM particle's weight (one side only) stays its full area. Each group's
Hessian is summed unprojected and projected to PSD once (in derivatives(): the line search asks
only for values). Step bound: edge-edge additive CCD over the candidate pairs, with the
point-triangle one. Friction acts on both (below).

Friction (SurfaceFriction): per point, lagged at the step's start on its nearest triangle: the
normal force lambda = |dPhi_p/dp| (the whole group's force on the point, corrections included),
the closest point's barycentric coordinates beta and a tangent basis T (3, 2) of the plane normal
to p - c; slip u = T^T (dp - sum_j beta_j dt_j), D = mu lambda f0(|u|) (friction.lagged_friction).
Per FEM boundary edge a likewise, on the nearest edge b of another FEM body: lambda = |the edge
group's force on a| (mollifier and corrections included), the closest points' parameters s on a
and t on b, T normal to the line between them; u = T^T ((1 - s) da0 + s da1 - (1 - t) db0 -
t db1). Both directions of a pair carry half weights, as the barrier's edge terms do.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ...linalg import dot
from ...energy import Blocks, Derivatives, Scatter
from ...fem.elements import project_psd
from .broadphase import box_pairs, point_edge_candidates, simplex_boxes
from .ccd import edge_edge_ccd, point_triangle_ccd
from .closest import (EE_EA0_EB0, EE_EA1_EB0, EE_EA_EB0, PT_P_E0, PT_P_T0, PT_P_T1, edge_edge_distance2,
                      edge_edge_distance_hessian, point_triangle_distance_hessian)
from .energy import BarrierContact, ContactPoints, LaggedFriction, min_pair_distance
from .friction import lagged_friction
from .potential import _chain, _mollified_chain, edge_edge_mollifier_threshold


class Surface(NamedTuple):
    """Boundary surface topology of the FEM bodies (built once)."""

    triangles: np.ndarray  # (m, 3)
    edges: np.ndarray  # (E, 2)
    triangle_edges: np.ndarray  # (m, 3) edge ids of each triangle
    edge_coef: np.ndarray  # (E,) -(deg_e - 1)
    vertex_coef: np.ndarray  # (n,) 1 at surface-interior vertices, else 0
    vertex_start: np.ndarray  # (n + 1,) the edges at vertex v: vertex_edges[vertex_start[v]:vertex_start[v + 1]]
    vertex_edges: np.ndarray  # (2 E,)


def surface_topology(triangles: np.ndarray, n_verts: int) -> Surface:
    """Edges, their triangle counts and the surface-interior vertices (every edge at them shared)."""
    m = len(triangles)
    local = np.array([[0, 1], [1, 2], [2, 0]])
    e = np.sort(triangles[:, local].reshape(-1, 2), axis=1)
    edges, inverse, deg = np.unique(e, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(m, 3)
    open_vertex = np.zeros(n_verts, bool)
    open_vertex[edges[deg < 2].ravel()] = True
    on_surface = np.zeros(n_verts, bool)
    on_surface[triangles.ravel()] = True
    vertex_coef = (on_surface & ~open_vertex).astype(float)
    ends = edges.ravel()
    order = np.argsort(ends, kind="stable")
    vertex_start = np.r_[0, np.cumsum(np.bincount(ends, minlength=n_verts))].astype(np.int64)
    return Surface(np.ascontiguousarray(triangles, np.int64), np.ascontiguousarray(edges, np.int64),
                   np.ascontiguousarray(inverse, np.int64), -(deg - 1.0), vertex_coef, vertex_start,
                   (order // 2).astype(np.int64))


def edge_weights(x: np.ndarray, triangles: np.ndarray, triangle_edges: np.ndarray, n_edges: int) -> np.ndarray:
    """(E,) a third of the summed area of each edge's triangles (the IPC toolkit's edge area)."""
    a, b, c = (x[triangles[:, k]] for k in range(3))
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    w = np.zeros(n_edges)
    for k in range(3):
        np.add.at(w, triangle_edges[:, k], area / 3.0)
    return w


def triangle_weights(x: np.ndarray, triangles: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """(len(nodes),) a third of the summed area of each node's boundary triangles."""
    a, b, c = (x[triangles[:, k]] for k in range(3))
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    w = np.zeros(len(x))
    for k in range(3):
        np.add.at(w, triangles[:, k], area / 3.0)
    return w[nodes]


class Groups(NamedTuple):
    """The barrier terms of one evaluation, grouped by contact point."""

    point: np.ndarray  # (g,) contact point of each group
    start: np.ndarray  # (g + 1,) its terms: simplex[start[i]:start[i + 1]]
    simplex: np.ndarray  # (t, 3) FEM nodes of each term (-1 padded: edge, vertex)
    coef: np.ndarray  # (t,) +1 (triangle, interior vertex) or -(deg_e - 1) (edge)
    nodes: np.ndarray  # (g, s) the group's FEM nodes (padded with its first)
    pairs: np.ndarray  # (k, 2) the candidate (point, triangle) pairs (CCD)


NO_GROUPS = Groups(np.zeros(0, np.int64), np.zeros(1, np.int64), np.zeros((0, 3), np.int64), np.zeros(0),
                   np.zeros((0, 1), np.int64), np.zeros((0, 2), np.int64))


@njit(cache=True)
def _add_unique(buf, n, v):
    for i in range(n):
        if buf[i] == v:
            return n
    buf[n] = v
    return n + 1


@njit(cache=True)
def group_terms(pairs, bounds, triangles, triangle_edges, edges, edge_coef, vertex_coef):
    """Terms per point from (point, triangle) pairs sorted by point, group g being the pairs
    bounds[g]:bounds[g + 1]: each triangle, each of their edges with a nonzero correction, each
    of their surface-interior vertices, once per point. Returns (point, start, simplex, coef,
    nodes) of Groups."""
    k = pairs.shape[0]
    n_groups = bounds.shape[0] - 1
    smax = 1
    for g in range(n_groups):
        smax = max(smax, 3 * (bounds[g + 1] - bounds[g]))
    point = np.empty(n_groups, np.int64)
    start = np.zeros(n_groups + 1, np.int64)
    simplex = np.full((7 * k, 3), -1, np.int64)
    coef = np.empty(7 * k)
    nodes = np.empty((n_groups, smax), np.int64)
    ebuf = np.empty(3 * k + 1, np.int64)
    vbuf = np.empty(3 * k + 1, np.int64)
    t = 0
    s_used = 1
    for g in range(n_groups):
        point[g] = pairs[bounds[g], 0]
        ne = 0
        nv = 0
        for q in range(bounds[g], bounds[g + 1]):
            tri = pairs[q, 1]
            for c in range(3):
                simplex[t, c] = triangles[tri, c]
                nv = _add_unique(vbuf, nv, triangles[tri, c])
                ne = _add_unique(ebuf, ne, triangle_edges[tri, c])
            coef[t] = 1.0
            t += 1
        for q in range(ne):
            e = ebuf[q]
            if edge_coef[e] != 0.0:
                simplex[t, 0] = edges[e, 0]
                simplex[t, 1] = edges[e, 1]
                coef[t] = edge_coef[e]
                t += 1
        for q in range(nv):
            nodes[g, q] = vbuf[q]
            if vertex_coef[vbuf[q]] != 0.0:
                simplex[t, 0] = vbuf[q]
                coef[t] = vertex_coef[vbuf[q]]
                t += 1
        for q in range(nv, smax):
            nodes[g, q] = vbuf[0]
        s_used = max(s_used, nv)
        start[g + 1] = t
    return point, start, simplex[:t], coef[:t], np.ascontiguousarray(nodes[:, :s_used])


def group_bounds(points: np.ndarray) -> np.ndarray:
    """(g + 1,) where each run of equal values of the sorted `points` starts, and the end."""
    return np.r_[0, np.flatnonzero(np.diff(points)) + 1, len(points)].astype(np.int64)


@njit(cache=True, inline="always")
def _term_distance(y, n_nodes, g, H):
    """Distance (with gradient g (12,) and Hessian H (12, 12)) of the point y[0:3] to the simplex
    of n_nodes vertices at y[3:] (placeholders beyond them): triangle, segment or vertex."""
    if n_nodes == 3:
        return point_triangle_distance_hessian(y, g, H, -1)
    if n_nodes == 1:
        return point_triangle_distance_hessian(y, g, H, PT_P_T0)
    num = 0.0
    den = 0.0
    for a in range(3):
        e = y[6 + a] - y[3 + a]
        num += (y[a] - y[3 + a]) * e
        den += e * e
    kind = PT_P_T0 if num <= 0.0 else (PT_P_T1 if num >= den else PT_P_E0)
    return point_triangle_distance_hessian(y, g, H, kind)


@njit(cache=True, inline="always")
def _add_local(grad, hess, slot, m, g12, H12):
    """Add a term's gradient g12 and Hessian H12 over its first m vertices into a group's grad
    and hess, vertex A going to the group's node slot[A]."""
    for A in range(m):
        for a in range(3):
            grad[3 * slot[A] + a] += g12[3 * A + a]
            for B in range(m):
                for b in range(3):
                    hess[3 * slot[A] + a, 3 * slot[B] + b] += H12[3 * A + a, 3 * B + b]


@njit(cache=True)
def surface_barrier_groups(points, verts, point, start, simplex, coef, nodes, dhat, kappa, weights, grads,
                           hessians, project=True):
    """Phi = sum over groups of the point's terms (module docstring); fills each group's gradient
    grads (g, 3 (1 + s)) and Hessian hessians (g, 3 (1 + s), 3 (1 + s)) over (point, nodes[g]),
    projected to PSD if `project`. Returns the total (inf if a pair touches)."""
    y = np.empty(12)
    g12 = np.empty(12)
    H12 = np.empty((12, 12))
    s = nodes.shape[1]
    slot = np.empty(4, np.int64)
    total = 0.0
    for grp in range(point.shape[0]):
        i = point[grp]
        grads[grp, :] = 0.0
        hessians[grp, :, :] = 0.0
        for a in range(3):
            y[a] = points[i, a]
        slot[0] = 0
        for term in range(start[grp], start[grp + 1]):
            m = 0
            for c in range(3):
                v = simplex[term, c]
                if v < 0:
                    break
                m += 1
                for q in range(s):
                    if nodes[grp, q] == v:
                        slot[1 + c] = 1 + q
                        break
            for c in range(3):
                v = simplex[term, min(c, m - 1)]
                for a in range(3):
                    y[3 + 3 * c + a] = verts[v, a]
            d = _term_distance(y, m, g12, H12)
            total += _chain(d, g12, H12, dhat, kappa * weights[i] * coef[term], False)
            _add_local(grads[grp], hessians[grp], slot, 1 + m, g12, H12)
        if project:
            project_psd(hessians[grp])
    return total


@njit(cache=True)
def point_triangle_ccd_pairs(points, dpoints, verts, dverts, triangles, pairs, t_max=1.0):
    """Largest common step in [0, t_max] for all (point, triangle) pairs (point_triangle_ccd)."""
    y = np.empty(12)
    dy = np.empty(12)
    t = t_max
    for k in range(pairs.shape[0]):
        i = pairs[k, 0]
        for a in range(3):
            y[a] = points[i, a]
            dy[a] = dpoints[i, a]
            for c in range(3):
                v = triangles[pairs[k, 1], c]
                y[3 + 3 * c + a] = verts[v, a]
                dy[3 + 3 * c + a] = dverts[v, a]
        t = min(t, point_triangle_ccd(y, dy, t_max=t))
        if t == 0.0:
            break
    return t


# ------------------------------------------------------------------------------ edge-edge (FEM-FEM)
EE_PAIR, EE_MINUS, EE_PLUS = 0, 1, 2  # kinds of edge terms (EdgeGroups.kind)


class EdgeGroups(NamedTuple):
    """The edge-edge terms of one evaluation, grouped by FEM boundary edge (module docstring)."""

    edge: np.ndarray  # (g,) the group's edge a
    start: np.ndarray  # (g + 1,) its terms: simplex[start[i]:start[i + 1]]
    simplex: np.ndarray  # (t, 4) (a0, a1, b0, b1): EE_PAIR the edge b; EE_MINUS (p, q) an edge at p;
    #                      EE_PLUS (p, p)
    kind: np.ndarray  # (t,) EE_PAIR, EE_MINUS, EE_PLUS
    nodes: np.ndarray  # (g, s) the group's FEM nodes, a0 and a1 first (padded with a0)
    pairs: np.ndarray  # (k, 2) the candidate (edge, edge) pairs, each unordered pair once (CCD)


NO_EDGE_GROUPS = EdgeGroups(np.zeros(0, np.int64), np.zeros(1, np.int64), np.zeros((0, 4), np.int64),
                            np.zeros(0, np.int64), np.zeros((0, 2), np.int64), np.zeros((0, 2), np.int64))


@njit(cache=True)
def group_edge_terms(pairs, bounds, edges, vertex_start, vertex_edges):
    """Terms per edge a from candidate (a, b) pairs sorted by a, group g being the pairs
    bounds[g]:bounds[g + 1]: each pair (EE_PAIR), and for each end p of the b's, once, the
    point-edge term of p (EE_PLUS) and one EE_MINUS term per edge (p, q) at p. Returns (edge,
    start, simplex, kind, nodes) of EdgeGroups."""
    k = pairs.shape[0]
    n_groups = bounds.shape[0] - 1
    maxdeg = 1
    for v in range(vertex_start.shape[0] - 1):
        maxdeg = max(maxdeg, vertex_start[v + 1] - vertex_start[v])
    cap = k + 2 * k * (1 + maxdeg)
    simplex = np.empty((cap, 4), np.int64)
    kind = np.empty(cap, np.int64)
    edge = np.empty(n_groups, np.int64)
    start = np.zeros(n_groups + 1, np.int64)
    smax = 2
    for g in range(n_groups):
        smax = max(smax, 2 + 2 * (bounds[g + 1] - bounds[g]) * (1 + maxdeg))
    nodes = np.empty((n_groups, smax), np.int64)
    pbuf = np.empty(2 * k + 1, np.int64)
    t = 0
    s_used = 2
    for g in range(n_groups):
        a = pairs[bounds[g], 0]
        a0, a1 = edges[a, 0], edges[a, 1]
        edge[g] = a
        nodes[g, 0] = a0
        nodes[g, 1] = a1
        ns = 2
        npt = 0
        for q in range(bounds[g], bounds[g + 1]):
            b = pairs[q, 1]
            simplex[t, 0], simplex[t, 1], simplex[t, 2], simplex[t, 3] = a0, a1, edges[b, 0], edges[b, 1]
            kind[t] = EE_PAIR
            t += 1
            for c in range(2):
                npt = _add_unique(pbuf, npt, edges[b, c])
        for r in range(npt):
            p = pbuf[r]
            ns = _add_unique(nodes[g], ns, p)
            simplex[t, 0], simplex[t, 1], simplex[t, 2], simplex[t, 3] = a0, a1, p, p
            kind[t] = EE_PLUS
            t += 1
            for j in range(vertex_start[p], vertex_start[p + 1]):
                e = vertex_edges[j]
                other = edges[e, 1] if edges[e, 0] == p else edges[e, 0]
                simplex[t, 0], simplex[t, 1], simplex[t, 2], simplex[t, 3] = a0, a1, p, other
                kind[t] = EE_MINUS
                t += 1
                ns = _add_unique(nodes[g], ns, other)
        for q in range(ns, smax):
            nodes[g, q] = a0
        s_used = max(s_used, ns)
        start[g + 1] = t
    return edge, start, simplex[:t], kind[:t], np.ascontiguousarray(nodes[:, :s_used])


@njit(cache=True)
def edge_barrier_groups(verts, rest, edge, start, simplex, kind, nodes, dhat, kappa, weights, grads, hessians,
                        project=True):
    """Phi = sum over edges a of w_a [sum_b m_ab b(d_ab) - sum_p (sum_{(p, q)} m_a,pq - 1) b(d_pa)]
    (module docstring); fills each group's gradient grads (g, 3 s) and Hessian hessians (g, 3 s,
    3 s) over nodes[g], projected to PSD if `project`. m the mollifier at rest threshold,
    weights (E,) w_a. Returns the total (inf if a pair touches)."""
    y = np.empty(12)
    yr = np.empty(12)
    g12 = np.empty(12)
    H12 = np.empty((12, 12))
    gx = np.empty(12)
    Hx = np.empty((12, 12))
    s = nodes.shape[1]
    slot = np.empty(4, np.int64)
    total = 0.0
    for grp in range(edge.shape[0]):
        grads[grp, :] = 0.0
        hessians[grp, :, :] = 0.0
        w = kappa * weights[edge[grp]]
        for term in range(start[grp], start[grp + 1]):
            for c in range(4):
                v = simplex[term, c]
                for q in range(s):
                    if nodes[grp, q] == v:
                        slot[c] = q
                        break
                for a in range(3):
                    y[3 * c + a] = verts[v, a]
                    yr[3 * c + a] = rest[v, a]
            kd = kind[term]
            if kd == EE_PAIR:
                d = edge_edge_distance_hessian(y, g12, H12, -1)
                e = _mollified_chain(y, d, g12, H12, edge_edge_mollifier_threshold(yr), dhat, w, gx, Hx)
            else:
                # the point p = b0 against the edge a, typed as the point-edge distance
                num = 0.0
                den = 0.0
                for a in range(3):
                    ea = y[3 + a] - y[a]
                    num += (y[6 + a] - y[a]) * ea
                    den += ea * ea
                dtype = EE_EA0_EB0 if num < 0.0 else (EE_EA1_EB0 if num > den else EE_EA_EB0)
                d = edge_edge_distance_hessian(y, g12, H12, dtype)
                if kd == EE_PLUS:
                    e = _chain(d, g12, H12, dhat, w, False)
                else:
                    e = _mollified_chain(y, d, g12, H12, edge_edge_mollifier_threshold(yr), dhat, -w, gx, Hx)
            total += e
            _add_local(grads[grp], hessians[grp], slot, 4, g12, H12)
        if project:
            project_active(hessians[grp])
    return total


@njit(cache=True)
def project_active(H):
    """Project the symmetric H to PSD in place through its block on the rows that are not all
    zero (the same result: the zero rows and columns split off with eigenvalues 0). An edge's
    stencil holds every node its terms could reach over the sweep; most terms are beyond dhat
    at any one evaluation, and a smaller eigenproblem is much cheaper."""
    n = H.shape[0]
    idx = np.empty(n, np.int64)
    m = 0
    for i in range(n):
        for j in range(n):
            if H[i, j] != 0.0:
                idx[m] = i
                m += 1
                break
    if m == 0:
        return
    sub = np.empty((m, m))
    for a in range(m):
        for b in range(m):
            sub[a, b] = H[idx[a], idx[b]]
    project_psd(sub)
    for a in range(m):
        for b in range(m):
            H[idx[a], idx[b]] = sub[a, b]


@njit(cache=True)
def project_all(hessians):
    """Each of the Hessians (g, n, n) projected to PSD (project_active), in place."""
    for k in range(hessians.shape[0]):
        project_active(hessians[k])


@njit(cache=True)
def edge_edge_ccd_pairs(verts, dverts, edges, pairs, t_max=1.0):
    """Largest common step in [0, t_max] for all (edge, edge) pairs (edge_edge_ccd)."""
    y = np.empty(12)
    dy = np.empty(12)
    t = t_max
    for k in range(pairs.shape[0]):
        for c in range(4):
            v = edges[pairs[k, c // 2], c % 2]
            for a in range(3):
                y[3 * c + a] = verts[v, a]
                dy[3 * c + a] = dverts[v, a]
        t = min(t, edge_edge_ccd(y, dy, t_max=t))
        if t == 0.0:
            break
    return t


@njit(cache=True)
def min_edge_distance(verts, edges, pairs):
    """The smallest distance over (edge, edge) pairs."""
    y = np.empty(12)
    best = np.inf
    for k in range(pairs.shape[0]):
        for c in range(4):
            v = edges[pairs[k, c // 2], c % 2]
            for a in range(3):
                y[3 * c + a] = verts[v, a]
        best = min(best, edge_edge_distance2(y))
    return np.sqrt(best)


def edge_candidates(x: np.ndarray, dx: np.ndarray, edges: np.ndarray, edge_body: np.ndarray, dhat: float) -> np.ndarray:
    """(k, 2) the (edge, edge) pairs of different bodies whose swept boxes come within dhat,
    both orders, sorted by the first."""
    lo, hi = simplex_boxes(x, dx, edges, 0.0)
    pairs = box_pairs(lo - dhat, hi + dhat, lo, hi, np.full(len(edges), -1, np.int64), edges)
    if len(pairs):
        pairs = pairs[edge_body[pairs[:, 0]] != edge_body[pairs[:, 1]]]
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))] if len(pairs) else pairs


def surface_gaps(x: np.ndarray, triangles: np.ndarray, node_body: np.ndarray, reach: float) -> dict:
    """{(a, b): gap} for the pairs of FEM bodies a < b whose boundary surfaces come within
    `reach`: the smallest node-triangle or edge-edge distance between them (3D)."""
    nodes = np.unique(triangles)
    pairs = point_edge_candidates(x[nodes], np.zeros((len(nodes), 3)), x, np.zeros_like(x), triangles, reach, nodes)
    out = {}

    def note(a, b, d):
        key = (min(a, b), max(a, b))
        out[key] = min(out.get(key, np.inf), d)

    tri_body = node_body[triangles[:, 0]]
    for i, t in pairs:
        a, b = node_body[nodes[i]], tri_body[t]
        if a != b:
            note(a, b, min_pair_distance(x[nodes[i:i + 1]], x, triangles, np.array([[0, t]], np.int64)))
    S = surface_topology(triangles, len(x))
    edge_body = node_body[S.edges[:, 0]]
    ee = edge_candidates(x, np.zeros_like(x), S.edges, edge_body, reach)
    for i, j in ee[ee[:, 0] < ee[:, 1]] if len(ee) else ():
        note(edge_body[i], edge_body[j], min_edge_distance(x, S.edges, np.array([[i, j]], np.int64)))
    return out


class SurfaceBarrier(BarrierContact):
    """The log barrier between the contact points and the FEM boundary triangles of other bodies
    (3D; the module docstring)."""

    def __init__(self, fem, grid, dhat: float, kappa: float, particle_contact: str):
        self.fem, self.grid = fem, grid
        self.dhat, self.kappa = dhat, kappa
        self.thickness = 1.0
        self.particle_contact = particle_contact
        self.n_fem_bodies = len(fem.infos)
        self.surface = S = surface_topology(fem.facets, fem.n)
        self.triangle_body = fem.node_body[fem.facets[:, 0]]
        # FEM nodes meet only other FEM bodies, both ways round and together with the edge-edge
        # terms: half weights (module docstring). With one FEM body they meet nothing and their
        # weights only enter adaptive kappa's mean weight, kept as it was.
        self.edge_contact = self.n_fem_bodies > 1
        share = 0.5 if self.edge_contact else 1.0
        self.boundary_weight = share * triangle_weights(fem.X, fem.facets, fem.boundary)
        self.edge_body = fem.node_body[S.edges[:, 0]]
        self.edge_weight = 0.5 * edge_weights(fem.X, S.triangles, S.triangle_edges, len(S.edges))
        self.points = None
        self.current = NO_GROUPS
        self.edge_current = NO_EDGE_GROUPS
        self._local = None
        self._edge_local = None

    def particle_weights(self, vol0: np.ndarray, owner: np.ndarray, corners: bool) -> np.ndarray:
        if corners:  # a quarter of a face of the particle's cube
            return 0.25 * np.cbrt(vol0[owner]) ** 2
        r = np.cbrt(3.0 * vol0 / (4.0 * np.pi))
        return np.pi * r * r

    def pairs(self, y: np.ndarray, p: np.ndarray) -> Groups:
        fem, pts = self.fem, self.points
        nf = fem.n
        z, dz = pts.positions(y), pts.moves(p)
        tris = self.surface.triangles
        pairs = point_edge_candidates(z, dz, y[:nf], p[:nf], tris, self.dhat, pts.vertex)
        if len(pairs):
            pairs = pairs[pts.body[pairs[:, 0]] != self.triangle_body[pairs[:, 1]]]
        if not len(pairs):
            return NO_GROUPS
        pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
        s = self.surface
        return Groups(*group_terms(pairs, group_bounds(pairs[:, 0]), tris, s.triangle_edges, s.edges, s.edge_coef,
                                   s.vertex_coef), pairs)

    def edge_pairs(self, y: np.ndarray, p: np.ndarray) -> EdgeGroups:
        """The edge-edge terms between boundary edges of different FEM bodies whose swept boxes
        over y -> y + p come within dhat, grouped by edge (both orders)."""
        if not self.edge_contact:
            return NO_EDGE_GROUPS
        nf, S = self.fem.n, self.surface
        pairs = edge_candidates(y[:nf], p[:nf], S.edges, self.edge_body, self.dhat)
        if not len(pairs):
            return NO_EDGE_GROUPS
        terms = group_edge_terms(pairs, group_bounds(pairs[:, 0]), S.edges, S.vertex_start, S.vertex_edges)
        return EdgeGroups(*terms, pairs[pairs[:, 0] < pairs[:, 1]])

    def sweep(self, y, p):
        self.current = self.pairs(y, p)
        self.edge_current = self.edge_pairs(y, p)

    @property
    def in_contact(self) -> bool:
        return len(self.current.point) > 0 or len(self.edge_current.edge) > 0

    def min_distance(self, y) -> float:
        """The smallest point-triangle or edge-edge distance over the pairs of the last sweep,
        taken at y (inf if none)."""
        pairs, ee = self.current.pairs, self.edge_current.pairs
        d = min_pair_distance(self.points.positions(y), y[:self.fem.n], self.surface.triangles, pairs) \
            if len(pairs) else np.inf
        return min(d, min_edge_distance(y[:self.fem.n], self.surface.edges, ee)) if len(ee) else d

    def value(self, y):
        phi, self._local = self._groups_at(y, True)
        eg = self.edge_current
        k, s = eg.nodes.shape
        ge, He = np.zeros((k, 3 * s)), np.zeros((k, 3 * s, 3 * s))
        if k:
            # projected in derivatives(): the line search's evaluations need only the value
            phi += edge_barrier_groups(y[:self.fem.n], self.fem.X, eg.edge, eg.start, eg.simplex, eg.kind, eg.nodes,
                                       self.dhat, self.kappa, self.edge_weight, ge, He, False)
        self._edge_local = (ge, He)
        return phi

    def _groups_at(self, y, project):
        """The point-triangle groups' barrier at y, their gradients and Hessians (each group's
        sum PSD-projected with `project`)."""
        grp = self.current
        k, s = grp.nodes.shape
        gl, Hl = np.zeros((k, 3 * (1 + s))), np.zeros((k, 3 * (1 + s), 3 * (1 + s)))
        phi = 0.0
        if k:
            phi = surface_barrier_groups(self.points.positions(y), y[:self.fem.n], grp.point, grp.start, grp.simplex,
                                         grp.coef, grp.nodes, self.dhat, self.kappa, self.points.weight, gl, Hl,
                                         project)
        return phi, (gl, Hl)

    def derivatives(self, y, force, exact=False):
        grp, eg = self.current, self.edge_current
        if exact:  # the unprojected Hessians (the value's point groups are projected)
            self._local = self._groups_at(y, False)[1]
        scatters, hessians = [], []
        if len(grp.point):
            s, h = self.points.pair_terms(grp.point, grp.nodes, *self._local, 3)
            scatters.append(s)
            hessians.append(h)
        if len(eg.edge):
            ge, He = self._edge_local
            if not exact:
                project_all(He)
            k, s = eg.nodes.shape
            scatters.append(Scatter(eg.nodes, ge.reshape(k, s, 3)))
            hessians.append(Blocks(eg.nodes, He))
        return Derivatives(tuple(scatters), tuple(hessians))

    def step_bound(self, y, p):
        pairs, ee = self.current.pairs, self.edge_current.pairs
        pts, nf = self.points, self.fem.n
        t = 1.0
        if len(pairs):  # every argument given: numba's dispatch of defaults is slow
            t = point_triangle_ccd_pairs(pts.positions(y), pts.moves(p), y[:nf], p[:nf], self.surface.triangles, pairs,
                                         1.0)
        if len(ee) and t > 0.0:
            t = edge_edge_ccd_pairs(y[:nf], p[:nf], self.surface.edges, ee, t)
        return t


@njit(cache=True)
def lag_surface_friction(points, verts, triangles, point, start, simplex, grads, pair_mu, dhat, tri, G, mu_lambda):
    """Per group: the nearest triangle tri (g, 3), the slip operator G (g, 12, 2) over (point,
    tri) and mu lambda, lambda = |the group's force on its point| (grads[:, :3])."""
    y = np.empty(12)
    g12 = np.empty(12)
    H12 = np.empty((12, 12))
    for grp in range(point.shape[0]):
        i = point[grp]
        for a in range(3):
            y[a] = points[i, a]
        best = np.inf
        for term in range(start[grp], start[grp + 1]):
            if simplex[term, 2] < 0:
                continue
            for c in range(3):
                for a in range(3):
                    y[3 + 3 * c + a] = verts[simplex[term, c], a]
            d = point_triangle_distance_hessian(y, g12, H12, -1)
            if d < best:
                best = d
                for c in range(3):
                    tri[grp, c] = simplex[term, c]
        for c in range(3):
            for a in range(3):
                y[3 + 3 * c + a] = verts[tri[grp, c], a]
        d = point_triangle_distance_hessian(y, g12, H12, -1)
        # closest point c = p - d n, n = grad_p d; its barycentric coordinates on the triangle
        n = g12[:3].copy()
        cp = y[:3] - d * n
        e1 = y[6:9] - y[3:6]
        e2 = y[9:12] - y[3:6]
        r = cp - y[3:6]
        a11, a12, a22 = dot(e1, e1), dot(e1, e2), dot(e2, e2)
        b1, b2 = dot(r, e1), dot(r, e2)
        det = a11 * a22 - a12 * a12
        s1 = (a22 * b1 - a12 * b2) / det
        s2 = (a11 * b2 - a12 * b1) / det
        beta = np.array([1.0 - s1 - s2, s1, s2])
        # tangent basis of the plane normal to n
        t1 = np.cross(n, np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0]))
        t1 /= np.sqrt(dot(t1, t1))
        t2 = np.cross(n, t1)
        for a in range(3):
            G[grp, a, 0] = t1[a]
            G[grp, a, 1] = t2[a]
            for c in range(3):
                G[grp, 3 + 3 * c + a, 0] = -beta[c] * t1[a]
                G[grp, 3 + 3 * c + a, 1] = -beta[c] * t2[a]
        f = np.sqrt(grads[grp, 0] ** 2 + grads[grp, 1] ** 2 + grads[grp, 2] ** 2)
        mu_lambda[grp] = pair_mu[grp] * f if d < dhat else 0.0


@njit(cache=True)
def surface_friction_pairs(x, x0, point_rows, point, tri, G, mu_lambda, eps, grads, hessians):
    """Lagged friction sum_g mu lambda_g f0(|G_g^T dz_g|) over the groups' (point, triangle)
    stencils of the step's displacement x - x0 (points at rows point_rows[point])."""
    dz = np.empty(12)
    total = 0.0
    for k in range(point.shape[0]):
        if mu_lambda[k] == 0.0:
            grads[k, :] = 0.0
            hessians[k, :, :] = 0.0
            continue
        i = point_rows[point[k]]
        for a in range(3):
            dz[a] = x[i, a] - x0[i, a]
            for c in range(3):
                v = tri[k, c]
                dz[3 + 3 * c + a] = x[v, a] - x0[v, a]
        total += lagged_friction(dz, G[k], mu_lambda[k], eps, grads[k], hessians[k])
    return total


@njit(cache=True)
def lag_edge_friction(verts, start, simplex, kind, grads, dhat, nodes, G, lam):
    """Per edge group (an FEM boundary edge a, EdgeGroups): the nearest edge b of another body
    within dhat, nodes (g, 4) = (a0, a1, b0, b1); the slip operator G (g, 12, 2) of the two
    closest points' relative tangential motion, u = T^T (sum_j c_j dz_j) with c = (1 - s, s,
    -(1 - t), -t) (read off the distance's gradient: its block j is c_j n); and lambda = |the
    group's force on a| (grads over a0 and a1, its first six entries: mollifier and corrections
    included), 0 where no pair is within dhat."""
    y = np.empty(12)
    g12 = np.empty(12)
    H12 = np.empty((12, 12))
    for grp in range(start.shape[0] - 1):
        lam[grp] = 0.0
        best, pick = dhat, -1
        for term in range(start[grp], start[grp + 1]):
            if kind[term] != EE_PAIR:
                continue
            for c in range(4):
                for a in range(3):
                    y[3 * c + a] = verts[simplex[term, c], a]
            d = edge_edge_distance_hessian(y, g12, H12, -1)
            if d < best:
                best, pick = d, term
        if pick < 0:
            continue
        for c in range(4):
            nodes[grp, c] = simplex[pick, c]
            for a in range(3):
                y[3 * c + a] = verts[simplex[pick, c], a]
        edge_edge_distance_hessian(y, g12, H12, -1)
        n = g12[0:3] + g12[3:6]  # (1 - s) n + s n: the unit normal from b's closest point to a's
        n /= np.sqrt(dot(n, n))
        t1 = np.cross(n, np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0]))
        t1 /= np.sqrt(dot(t1, t1))
        t2 = np.cross(n, t1)
        for c in range(4):
            coef = dot(g12[3 * c:3 * c + 3], n)
            for a in range(3):
                G[grp, 3 * c + a, 0] = coef * t1[a]
                G[grp, 3 * c + a, 1] = coef * t2[a]
        f = 0.0
        for a in range(3):
            f += (grads[grp, a] + grads[grp, 3 + a]) ** 2
        lam[grp] = np.sqrt(f)


class EdgeLag(NamedTuple):
    nodes: np.ndarray  # (g, 4) an FEM boundary edge and the nearest edge of another body
    first: np.ndarray  # (g,) nodes[:, 0], and
    rest: np.ndarray  # (g, 3) nodes[:, 1:], contiguous: the stencil as surface_friction_pairs reads it
    rows: np.ndarray  # (nf,) the FEM nodes' rows in the friction's positions (themselves)
    G: np.ndarray  # (g, 12, 2) slip operators
    mu_lambda: np.ndarray  # (g,)


class SurfaceLag(NamedTuple):
    point: np.ndarray  # (g,) contact points
    tri: np.ndarray  # (g, 3) their nearest triangles' nodes
    G: np.ndarray  # (g, 12, 2) slip operators
    mu_lambda: np.ndarray  # (g,)


class SurfaceFriction(LaggedFriction):
    """Lagged, smoothed Coulomb friction on the 3D barrier's contacts (module docstring): the 2D
    term's lag bookkeeping with per-point frames on the nearest triangle, and per FEM boundary
    edge on the nearest edge of another FEM body."""

    edge_lag = None
    _edge_local = None

    @property
    def active(self) -> bool:
        return self.lag is not None or self.edge_lag is not None

    def relag(self, y):
        self.edge_lag = self._lag_edges(y)
        return self._lag_points(y) or self.edge_lag is not None

    def _lag_edges(self, y):
        """The edge-edge contacts' lag (EdgeLag) at y, None without any within dhat."""
        c = self.contact
        if not c.edge_contact:
            return None
        eg = c.edge_pairs(y, np.zeros_like(y))
        k = len(eg.edge)
        if not k:
            return None
        fem, s = c.fem, eg.nodes.shape[1]
        ge, He = np.zeros((k, 3 * s)), np.zeros((k, 3 * s, 3 * s))
        edge_barrier_groups(y[:fem.n], fem.X, eg.edge, eg.start, eg.simplex, eg.kind, eg.nodes, c.dhat, c.kappa,
                            c.edge_weight, ge, He, False)
        nodes, G, lam = np.zeros((k, 4), np.int64), np.zeros((k, 12, 2)), np.zeros(k)
        lag_edge_friction(y[:fem.n], eg.start, eg.simplex, eg.kind, ge, c.dhat, nodes, G, lam)
        mu_lambda = self.mu[fem.node_mat[nodes[:, 0]], fem.node_mat[nodes[:, 2]]] * lam
        keep = mu_lambda > 0.0
        if not keep.any():
            return None
        nodes = nodes[keep]
        return EdgeLag(nodes, nodes[:, 0].copy(), np.ascontiguousarray(nodes[:, 1:]), np.arange(fem.n), G[keep],
                       mu_lambda[keep])

    def _lag_points(self, y) -> bool:
        c = self.contact
        grp = c.pairs(y, np.zeros_like(y))
        k = len(grp.point)
        if not k:
            self.lag = None
            return False
        fem, pts = c.fem, c.points
        s = grp.nodes.shape[1]
        gl, Hl = np.zeros((k, 3 * (1 + s))), np.zeros((k, 3 * (1 + s), 3 * (1 + s)))
        z = pts.positions(y)
        surface_barrier_groups(z, y[:fem.n], grp.point, grp.start, grp.simplex, grp.coef, grp.nodes, c.dhat,
                               c.kappa, pts.weight, gl, Hl, True)
        tri, G, mu_lambda = np.zeros((k, 3), np.int64), np.zeros((k, 12, 2)), np.zeros(k)
        first = grp.simplex[grp.start[:-1], 0]  # a node of the point's first triangle (its body)
        mu = self.mu[pts.mat[grp.point], fem.node_mat[first]]
        lag_surface_friction(z, y[:fem.n], c.surface.triangles, grp.point, grp.start, grp.simplex, gl, mu, c.dhat,
                             tri, G, mu_lambda)
        self.lag = SurfaceLag(grp.point, tri, G, mu_lambda)
        return True

    def _friction(self, ext, ids, gf, Hf) -> float:
        lag = self.lag
        return surface_friction_pairs(ext, self.start, ids, lag.point, lag.tri, lag.G, lag.mu_lambda, self.eps, gf,
                                      Hf)

    def _stencils(self):
        return self.lag.point, self.lag.tri

    def value(self, y):
        total = super().value(y)
        lag, self._edge_local = self.edge_lag, None
        if lag is not None:
            k = len(lag.nodes)
            ge, He = np.zeros((k, 12)), np.zeros((k, 12, 12))
            # the edges' stencils (a0; a1, b0, b1) are FEM nodes: rows of ext as they are
            total += surface_friction_pairs(self._extended(y)[0], self.start, lag.rows, lag.first, lag.rest, lag.G,
                                            lag.mu_lambda, self.eps, ge, He)
            self._edge_local = (ge, He)
        return total

    def derivatives(self, y, force, exact=False):  # its Hessian is exact either way
        parts = super().derivatives(y, force)
        if self._edge_local is None:
            return parts
        ge, He = self._edge_local
        nodes = self.edge_lag.nodes
        return Derivatives(parts.local + (Scatter(nodes, ge.reshape(len(nodes), 4, 3)),),
                           parts.hessian + (Blocks(nodes, He),))


__all__ = ["SurfaceBarrier", "SurfaceFriction", "ContactPoints", "surface_topology", "group_terms", "group_bounds",
           "surface_barrier_groups", "group_edge_terms", "edge_barrier_groups", "edge_candidates", "edge_weights"]
