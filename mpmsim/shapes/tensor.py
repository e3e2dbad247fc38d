"""Tensor-product shape functions (linear, uGIMP, quadratic and cubic B-splines), 2D and 3D
in one kernel: S_ip and G_ip are products of the 1D weights of `grid_functions`."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..gridops import chunk_range
from ..parallel import chunk_kernel
from .grid_functions import weights_1d

BAD_SUPPORT = 5  # a particle's support (or a CPDI sample point's) left the grid


@njit(cache=True, inline="always")
def clear_entries(p, nodes, S, G):
    """A flagged particle weighs nothing: every entry on node 0 with zero weight."""
    for k in range(S.shape[1]):
        nodes[p, k] = 0
        S[p, k] = 0.0
        for d in range(G.shape[2]):
            G[p, k, d] = 0.0


@chunk_kernel
def tensor_shape_functions(x, grid, semi, sk, nchunk, sd, boxes):
    """Fill sd (shapes.ShapeData) for particles at x on grid (views.GridView) with the shape
    function sk (shapes.ShapeKind); `sd.lowest[p]` is the particle's lowest node (i, j, k) and
    boxes.lo/hi the node box each particle chunk touches (active box and scatter slabs). A
    particle whose nodes would fall outside the grid gets zero weights on node 0 and is
    flagged in boxes.bad."""
    origin, h, shape = grid.origin, grid.h, grid.shape
    kind, per_axis = sk.grid_kind, sk.per_axis
    nodes, S, G, lowest = sd.nodes, sd.S, sd.G, sd.lowest
    chunk_lo, chunk_hi, chunk_bad = boxes.lo, boxes.hi, boxes.bad
    n, dim = x.shape
    K = S.shape[1]
    for c in prange(nchunk):
        start, stop = chunk_range(c, nchunk, n)
        w = np.ones((3, 4))
        dw = np.zeros((3, 4))
        base = np.zeros(3, dtype=np.int64)
        chunk_bad[c] = -1
        for d in range(3):
            chunk_lo[c, d] = 1 << 60 if d < dim else 0
            chunk_hi[c, d] = -1 if d < dim else 0
        for p in range(start, stop):
            inside = True
            for d in range(dim):
                xi = (x[p, d] - origin[d]) / h[d]
                if not (xi > -1e9 and xi < 1e9):  # NaN or absurd position
                    xi = 0.0
                    inside = False
                base[d] = weights_1d(kind, xi, semi[d] / h[d], 1.0 / h[d], w[d], dw[d])
                if base[d] < 0 or base[d] + per_axis > shape[d]:
                    inside = False
            if not inside:
                clear_entries(p, nodes, S, G)
                if chunk_bad[c] < 0:
                    chunk_bad[c] = p
                continue
            for d in range(dim):
                lowest[p, d] = base[d]
                chunk_lo[c, d] = min(chunk_lo[c, d], base[d])
                chunk_hi[c, d] = max(chunk_hi[c, d], base[d] + per_axis - 1)
            fill_entries(p, base, w, dw, per_axis, dim, shape, nodes, S, G)


@njit(cache=True, inline="always")
def fill_entries(p, base, w, dw, per_axis, dim, shape, nodes, S, G):
    """Node list, S and G of particle p from its 1D weights w, dw (3, 4) and lowest node `base`
    (node k = a + per_axis (b + per_axis cc): nested loops, no divisions; what the inner loop
    reuses is read into locals first, as the stores into nodes, S and G would otherwise force
    reloads of the scratch rows). Also the GPU step's (gpu/kernels.py).

    Inlined at numba's IR level and free there (same time as the loops written in place): its
    body makes no array views and calls nothing. A helper that does (the 1D weights call with
    the rows w[d], dw[d]) keeps one NRT incref/decref pair per array argument per particle,
    as numba's reference-count pruning cannot pair them across the views' own: 2.6x slower."""
    k = 0
    b0, b1, b2 = base[0], base[1], base[2]
    for cc in range(per_axis if dim == 3 else 1):
        wz, dwz = w[2, cc], dw[2, cc]
        for b in range(per_axis):
            wy, dwy = w[1, b], dw[1, b]
            row = (b1 + b) + shape[1] * (b2 + cc)
            for a in range(per_axis):
                nodes[p, k] = (b0 + a) + shape[0] * row
                wx = w[0, a]
                S[p, k] = wx * wy * wz
                G[p, k, 0] = dw[0, a] * wy * wz
                G[p, k, 1] = wx * dwy * wz
                if dim == 3:
                    G[p, k, 2] = wx * wy * dwz
                k += 1
