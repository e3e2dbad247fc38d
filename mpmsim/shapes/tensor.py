"""Tensor-product shape functions (linear, uGIMP) for 2D and 3D in one kernel.

Per axis, a 1D function gives weights w and derivatives dw/dx on `per_axis` consecutive
nodes starting at `base`; S_ip and G_ip are products over axes. uGIMP uses the undeformed
particle semi-length l (in cell units), never updated (notes §7.1):
    S(xi) = 1 - (xi^2 + l^2)/(2l)      0 <= xi < l
          = 1 - xi                      l <= xi <= 1 - l
          = (1 + l - xi)^2/(4l)         1 - l < xi < 1 + l
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..gridops import chunk_range

LINEAR = 0
GIMP = 1


@njit(cache=True, inline="always")
def gimp_1d(r, l):
    """uGIMP weight and d/dr for signed distance r (cell units) from node to particle."""
    xi = abs(r)
    sgn = 1.0 if r >= 0.0 else -1.0
    if xi < l:
        return 1.0 - (xi * xi + l * l) / (2.0 * l), -sgn * xi / l
    if xi <= 1.0 - l:
        return 1.0 - xi, -sgn
    if xi < 1.0 + l:
        t = 1.0 + l - xi
        return t * t / (4.0 * l), -sgn * t / (2.0 * l)
    return 0.0, 0.0


@njit(cache=True, inline="always")
def weights_1d(kind, xi, l, inv_h, w, dw):
    """Fill w[0:n], dw[0:n] for nodes base..base+n-1 along one axis; return base."""
    if kind == LINEAR:
        base = int(np.floor(xi))
        t = xi - base
        w[0] = 1.0 - t
        w[1] = t
        dw[0] = -inv_h
        dw[1] = inv_h
        return base
    # GIMP: the nearest node and its two neighbours cover the support (l <= 1/2)
    base = int(np.floor(xi + 0.5)) - 1
    for a in range(3):
        s, ds = gimp_1d(xi - (base + a), l)
        w[a] = s
        dw[a] = ds * inv_h
    return base


@njit(parallel=True, cache=True)
def tensor_shape_functions(x, origin, h, semi, kind, per_axis, shape, nchunk, nodes, S, G, lowest,
                           chunk_lo, chunk_hi):
    """Fill nodes/S/G; `lowest[p]` is the particle's lowest node (i, j, k) and chunk_lo/hi the
    node box each particle chunk touches (for the active box and the scatter slabs)."""
    n, dim = x.shape
    K = S.shape[1]
    for c in prange(nchunk):
        start, stop = chunk_range(c, nchunk, n)
        w = np.ones((3, 4))
        dw = np.zeros((3, 4))
        base = np.zeros(3, dtype=np.int64)
        for d in range(3):
            chunk_lo[c, d] = 1 << 60 if d < dim else 0
            chunk_hi[c, d] = -1 if d < dim else 0
        for p in range(start, stop):
            for d in range(dim):
                xi = (x[p, d] - origin[d]) / h[d]
                base[d] = weights_1d(kind, xi, semi[d] / h[d], 1.0 / h[d], w[d], dw[d])
                lowest[p, d] = base[d]
                chunk_lo[c, d] = min(chunk_lo[c, d], base[d])
                chunk_hi[c, d] = max(chunk_hi[c, d], base[d] + per_axis - 1)
            for k in range(K):
                a = k % per_axis
                b = (k // per_axis) % per_axis
                cc = k // (per_axis * per_axis)
                nodes[p, k] = (base[0] + a) + shape[0] * ((base[1] + b) + shape[1] * (base[2] + cc))
                wx = w[0, a]
                wy = w[1, b]
                wz = w[2, cc]
                S[p, k] = wx * wy * wz
                G[p, k, 0] = dw[0, a] * wy * wz
                G[p, k, 1] = wx * dw[1, b] * wz
                if dim == 3:
                    G[p, k, 2] = wx * wy * dw[2, cc]
