"""Tensor-product shape functions (linear, uGIMP, quadratic and cubic B-splines), 2D and 3D
in one kernel, compiled per grid function and dimension (`tensor_kernel`): S_ip and G_ip are
products of the 1D weights of `grid_functions`."""

from __future__ import annotations

from functools import cache

import numpy as np
from numba import njit, prange

from ..gridops import chunk_range
from ..parallel import chunk_kernel, specialize
from .axisymmetric import BAD_AXIS, radial_weights
from .grid_functions import LINEAR, NODES, weights_1d

BAD_SUPPORT = 5  # a particle's support (or a CPDI sample point's) left the grid

# the constants of one compiled kernel, bound per grid function, dimension and geometry by `tensor_kernel`
GRID_KIND, PER_AXIS, DIM, AXISYMMETRIC = LINEAR, 2, 2, False


@njit(cache=True, inline="always")
def clear_entries(p, nodes, S, G):
    """A flagged particle weighs nothing: every entry on node 0 with zero weight."""
    for k in range(S.shape[1]):
        nodes[p, k] = 0
        S[p, k] = 0.0
        for d in range(G.shape[2]):
            G[p, k, d] = 0.0


def tensor_shape_functions(x, grid, semi, nchunk, sd, boxes):
    """Fill sd (shapes.ShapeData) for particles at x on grid (views.GridView) with the grid
    function GRID_KIND in DIM dimensions (compiled per function: `tensor_kernel`);
    `sd.lowest[p]` is the particle's lowest node (i, j, k) and boxes.lo/hi the node box each
    particle chunk touches (active box and scatter slabs). A particle whose nodes would fall
    outside the grid gets zero weights on node 0 and is flagged in boxes.bad."""
    origin, h, shape = grid.origin, grid.h, grid.shape
    kind, per_axis, axisymmetric, dim = GRID_KIND, PER_AXIS, AXISYMMETRIC, DIM
    nodes, S, G, lowest, T = sd.nodes, sd.S, sd.G, sd.lowest, sd.T
    chunk_lo, chunk_hi, chunk_bad, chunk_code = boxes.lo, boxes.hi, boxes.bad, boxes.code
    n = x.shape[0]
    for c in prange(nchunk):
        start, stop = chunk_range(c, nchunk, n)
        w = np.ones((3, 4))
        dw = np.zeros((3, 4))
        wt = np.zeros(4)  # axisymmetric: the hoop function's r factor
        base = np.zeros(3, dtype=np.int64)
        chunk_bad[c] = -1
        for d in range(3):
            chunk_lo[c, d] = 1 << 60 if d < dim else 0
            chunk_hi[c, d] = -1 if d < dim else 0
        for p in range(start, stop):
            inside = True
            for d in range(dim):
                if d == 0 and axisymmetric:
                    base[0], ok = radial_weights(kind, x[p, 0], origin[0], h[0], semi[0], per_axis, shape[0], w[0],
                                                 dw[0], wt)
                else:
                    base[d], ok = axis_weights(kind, x[p, d], origin[d], h[d], semi[d], per_axis, shape[d], w[d],
                                               dw[d])
                inside = inside and ok
            if not inside:
                clear_entries(p, nodes, S, G)
                for k in range(T.shape[1] if axisymmetric else 0):
                    T[p, k] = 0.0
                if chunk_bad[c] < 0:
                    chunk_bad[c] = p
                    if axisymmetric:
                        chunk_code[c] = BAD_AXIS
                continue
            for d in range(dim):
                lowest[p, d] = base[d]
                chunk_lo[c, d] = min(chunk_lo[c, d], base[d])
                chunk_hi[c, d] = max(chunk_hi[c, d], base[d] + per_axis - 1)
            fill_entries(p, base, w, dw, per_axis, dim, shape, nodes, S, G)
            if axisymmetric:  # T_ip = T_r(r) N_z(z) (2D: node k = a + per_axis b)
                k = 0
                for bb in range(per_axis):
                    wz = w[1, bb]
                    for a in range(per_axis):
                        T[p, k] = wt[a] * wz
                        k += 1


@cache
def tensor_kernel(kind: int, dim: int, axisymmetric: bool):
    """`tensor_shape_functions` compiled for one grid function (grid_functions kinds), dimension
    and geometry, bound as constants: the 1D weights keep only that function's branch and the
    node loops have fixed trip counts (on the benchmark column, uGIMP in 2D: 1.7x faster than one
    kernel taking them as arguments, the same numbers to the bit). A scene compiles only its own."""
    tag = f"k{kind}_{dim}d{'_rz' if axisymmetric else ''}"
    return chunk_kernel(specialize(tensor_shape_functions, tag, GRID_KIND=int(kind), PER_AXIS=NODES[kind], DIM=int(dim),
                                   AXISYMMETRIC=bool(axisymmetric)))


@njit(cache=True, inline="always")
def fill_entries(p, base, w, dw, per_axis, dim, shape, nodes, S, G):
    """Node list, S and G of particle p from its 1D weights w, dw (3, 4) and lowest node `base`
    (node k = a + per_axis (b + per_axis cc): nested loops, no divisions; what the inner loop
    reuses is read into locals first, as the stores into nodes, S and G would otherwise force
    reloads of the scratch rows). Also the GPU step's (gpu/kernels.py).

    Inlined at numba's IR level (inline="always") it costs nothing here (same time as the loops
    written in place, the same NRT calls in the kernel's LLVM). That does not hold for every
    helper taking arrays: numba binds each array argument of an inlined call with an NRT
    incref/decref, and where its reference-count pruning does not remove them they stay, a
    call per array per particle. Measured: the weights loop above as a helper taking x, w, dw,
    base whole (making the rows w[d], dw[d] for weights_1d itself) made this kernel 2.6x
    slower, where axis_weights (scalars and the rows, made by the caller) costs nothing; a
    helper taking the grid update's arrays and calling node_bc 4.2x, the node force taking G
    3%. So the helpers take scalars where they can (axis_weights, forces.node_force,
    grid_update.held_force); a new helper is checked by timing and by counting `NRT_incref`
    in the kernel's `inspect_llvm()` against the kernel without it."""
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


@njit(cache=True, inline="always")
def axis_weights(kind, xp, o, h, semi, per_axis, n, w, dw):
    """The 1D weights w, dw (that axis's rows) of a particle at xp along one axis (grid origin
    o, spacing h, n nodes; semi: its half-length for uGIMP); returns (lowest node, whether its
    support lies on the grid). Also the GPU step's."""
    ok = True
    xi = (xp - o) / h
    if not (xi > -1e9 and xi < 1e9):  # NaN or absurd position
        xi = 0.0
        ok = False
    b = weights_1d(kind, xi, semi / h, 1.0 / h, w, dw)
    if b < 0 or b + per_axis > n:
        ok = False
    return b, ok
