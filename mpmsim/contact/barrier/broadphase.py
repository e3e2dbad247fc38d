"""Broad phase: candidate contact pairs from a uniform-grid spatial hash.

A pair is a candidate when the swept axis-aligned boxes of its primitives come within dhat of
each other: the point's box spans p and p + dp, the edge's box spans e0, e1, e0 + de0, e1 + de1
and is inflated by dhat on every side; the pair is kept when the boxes overlap (closed intervals)
on every axis. This is a superset of every pair whose distance drops below dhat at some time of
the linear motion over the step (each primitive stays in its box), so the barrier and the CCD
see every pair that can matter (IPC, Li et al. 2020, Sec. 4.3; with zero displacements it is the
static candidate set for the barrier).

Hash. The inflated edge (or node) boxes are inserted into every grid cell they cover, cells
keyed by integer coordinates hashed into a power-of-two table (CSR layout, counting sort; the
stored cell coordinates make hash collisions harmless). Each point box then visits the cells
it covers. A pair met in several shared cells is reported once, from the cell holding the lower
corner of the two boxes' intersection (a point both boxes cover, in exactly one cell), so no
deduplication pass is needed. The cell size defaults to the larger of the mean box extents, so
a box covers O(1) cells on average. No all-pairs loop; cost O(n + m + pairs).

Self-exclusion. When points and edge vertices share one index space (e.g. FEM boundary nodes
as points against FEM boundary edges), pass `point_ids[i]` = the vertex index of point i; pairs
whose edge has that vertex as an endpoint (node equal to it) are skipped. Use -1 for points
that are not vertices (MPM particles).

Boundary-node correction (notes / BFEMP Eq. 31): Phi_b = sum_p w_p [sum_e b(d_pe) - sum_v
(deg(v) - 1) b(|x_p - x_v|)], deg(v) the number of boundary edges incident to node v. The
candidate point-node pairs come from `point_node_candidates` with the nodes of nonzero
deg - 1 (`correction_nodes`).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def point_boxes(points, dpoints):
    """Swept boxes (lo, hi) (n, dim) of points moving from points to points + dpoints."""
    lo = np.minimum(points, points + dpoints)
    hi = np.maximum(points, points + dpoints)
    return lo, hi


@njit(cache=True)
def simplex_boxes(verts, dverts, simplices, inflate):
    """Swept boxes (lo, hi) (m, dim) of simplices (m, k) (edges: k = 2, nodes: k = 1) over
    vertices verts moving by dverts, inflated by `inflate` on every side."""
    m = simplices.shape[0]
    dim = verts.shape[1]
    lo = np.empty((m, dim))
    hi = np.empty((m, dim))
    for j in range(m):
        for c in range(dim):
            a = np.inf
            b = -np.inf
            for q in range(simplices.shape[1]):
                v = simplices[j, q]
                x0 = verts[v, c]
                x1 = x0 + dverts[v, c]
                a = min(a, x0, x1)
                b = max(b, x0, x1)
            lo[j, c] = a - inflate
            hi[j, c] = b + inflate
    return lo, hi


@njit(cache=True, inline="always")
def _cell(x, o, inv):
    return np.int64(np.floor((x - o) * inv))


@njit(cache=True, inline="always")
def _hash(ix, iy, iz, mask):
    h = (ix * np.int64(73856093)) ^ (iy * np.int64(19349663)) ^ (iz * np.int64(83492791))
    return h & mask


@njit(cache=True)
def box_pairs(alo, ahi, blo, bhi, a_ids, b_ids, cell=0.0):
    """All (i, j) with box a_i and box b_j overlapping (closed) on every axis, excluding pairs
    with a_ids[i] >= 0 and a_ids[i] in b_ids[j, :]. Boxes (n, dim), (m, dim), dim = 2 or 3.
    cell <= 0 picks the cell size automatically. Returns pairs (K, 2) int64, sorted by i and,
    for each i, in cell-visit order."""
    n = alo.shape[0]
    m = blo.shape[0]
    dim = alo.shape[1]
    if n == 0 or m == 0:
        return np.empty((0, 2), dtype=np.int64)
    origin = np.empty(3)
    origin[:] = 0.0
    for c in range(dim):
        origin[c] = min(alo[:, c].min(), blo[:, c].min())
    if cell <= 0.0:
        ea = 0.0
        eb = 0.0
        for i in range(n):
            e = 0.0
            for c in range(dim):
                e = max(e, ahi[i, c] - alo[i, c])
            ea += e
        for j in range(m):
            e = 0.0
            for c in range(dim):
                e = max(e, bhi[j, c] - blo[j, c])
            eb += e
        cell = max(ea / n, eb / m)
        if not cell > 0.0:
            span = 0.0
            for c in range(dim):
                span = max(span, max(ahi[:, c].max(), bhi[:, c].max()) - origin[c])
            cell = span if span > 0.0 else 1.0
    inv = 1.0 / cell
    # cell ranges of the b boxes
    bl = np.zeros((m, 3), dtype=np.int64)
    bh = np.zeros((m, 3), dtype=np.int64)
    total = 0
    for j in range(m):
        cnt = 1
        for c in range(dim):
            bl[j, c] = _cell(blo[j, c], origin[c], inv)
            bh[j, c] = _cell(bhi[j, c], origin[c], inv)
            cnt *= bh[j, c] - bl[j, c] + 1
        total += cnt
    size = 16
    while size < 2 * total:
        size *= 2
    mask = np.int64(size - 1)
    start = np.zeros(size + 1, dtype=np.int64)
    for j in range(m):
        for ix in range(bl[j, 0], bh[j, 0] + 1):
            for iy in range(bl[j, 1], bh[j, 1] + 1):
                for iz in range(bl[j, 2], bh[j, 2] + 1):
                    start[_hash(ix, iy, iz, mask) + 1] += 1
    for h in range(size):
        start[h + 1] += start[h]
    fill = start[:-1].copy()
    ent = np.empty(total, dtype=np.int64)
    ecell = np.empty((total, 3), dtype=np.int64)
    for j in range(m):
        for ix in range(bl[j, 0], bh[j, 0] + 1):
            for iy in range(bl[j, 1], bh[j, 1] + 1):
                for iz in range(bl[j, 2], bh[j, 2] + 1):
                    h = _hash(ix, iy, iz, mask)
                    e = fill[h]
                    fill[h] += 1
                    ent[e] = j
                    ecell[e, 0] = ix
                    ecell[e, 1] = iy
                    ecell[e, 2] = iz
    al = np.zeros(3, dtype=np.int64)
    ah = np.zeros(3, dtype=np.int64)
    ref = np.zeros(3, dtype=np.int64)
    nb_ids = b_ids.shape[1]
    out = np.empty((0, 2), dtype=np.int64)
    for write in range(2):
        k = 0
        for i in range(n):
            for c in range(dim):
                al[c] = _cell(alo[i, c], origin[c], inv)
                ah[c] = _cell(ahi[i, c], origin[c], inv)
            aid = a_ids[i]
            for ix in range(al[0], ah[0] + 1):
                for iy in range(al[1], ah[1] + 1):
                    for iz in range(al[2], ah[2] + 1):
                        h = _hash(ix, iy, iz, mask)
                        for e in range(start[h], start[h + 1]):
                            if ecell[e, 0] != ix or ecell[e, 1] != iy or ecell[e, 2] != iz:
                                continue
                            j = ent[e]
                            skip = False
                            if aid >= 0:
                                for q in range(nb_ids):
                                    if b_ids[j, q] == aid:
                                        skip = True
                            if skip:
                                continue
                            overlap = True
                            for c in range(dim):
                                if alo[i, c] > bhi[j, c] or blo[j, c] > ahi[i, c]:
                                    overlap = False
                            if not overlap:
                                continue
                            # report from the cell of the intersection's lower corner only
                            for c in range(dim):
                                ref[c] = _cell(max(alo[i, c], blo[j, c]), origin[c], inv)
                            if ref[0] != ix or ref[1] != iy or ref[2] != iz:
                                continue
                            if write == 1:
                                out[k, 0] = i
                                out[k, 1] = j
                            k += 1
        if write == 0:
            out = np.empty((k, 2), dtype=np.int64)
    return out


@njit(cache=True)
def point_edge_candidates(points, dpoints, verts, dverts, edges, dhat, point_ids, cell=0.0):
    """Candidate (point, edge) pairs (K, 2): swept point box within dhat of the swept edge box.
    points, dpoints (n, dim); verts, dverts (nv, dim); edges (m, 2) into verts; point_ids (n,)
    vertex index of each point in the edges' index space, or -1 (see the module docstring).
    Pass zero displacements for a static query."""
    alo, ahi = point_boxes(points, dpoints)
    blo, bhi = simplex_boxes(verts, dverts, edges, dhat)
    return box_pairs(alo, ahi, blo, bhi, point_ids, edges, cell)


@njit(cache=True)
def point_node_candidates(points, dpoints, verts, dverts, nodes, dhat, point_ids, cell=0.0):
    """Candidate (point, node vertex index) pairs (K, 2) for the point-point boundary-node
    correction: swept point box within dhat of the swept node box. nodes (k,) vertex indices."""
    nodes2 = nodes.reshape((nodes.shape[0], 1))
    alo, ahi = point_boxes(points, dpoints)
    blo, bhi = simplex_boxes(verts, dverts, nodes2, dhat)
    pairs = box_pairs(alo, ahi, blo, bhi, point_ids, nodes2, cell)
    for k in range(pairs.shape[0]):
        pairs[k, 1] = nodes[pairs[k, 1]]
    return pairs


@njit(cache=True)
def boundary_vertex_degree(edges, n_verts):
    """Number of boundary edges incident to each vertex (n_verts,)."""
    deg = np.zeros(n_verts, dtype=np.int64)
    for j in range(edges.shape[0]):
        deg[edges[j, 0]] += 1
        deg[edges[j, 1]] += 1
    return deg


@njit(cache=True)
def correction_nodes(edges, n_verts):
    """Boundary nodes with a nonzero correction weight deg - 1 (BFEMP Eq. 31) and those weights:
    returns (nodes (k,) int64, weights (k,) float). On a closed polyline every node has weight 1;
    an open polyline's end nodes (deg 1) get none."""
    deg = boundary_vertex_degree(edges, n_verts)
    k = 0
    for v in range(n_verts):
        if deg[v] > 1:
            k += 1
    nodes = np.empty(k, dtype=np.int64)
    weights = np.empty(k)
    k = 0
    for v in range(n_verts):
        if deg[v] > 1:
            nodes[k] = v
            weights[k] = deg[v] - 1.0
            k += 1
    return nodes, weights
