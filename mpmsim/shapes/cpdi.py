"""CPDI shape functions (notes §7.3–7.4): linear CPDI, 9-point qCPDI (2D), B2CPDI; 2D and 3D.

The particle domain is the parallelepiped x_p + J s, s in [-1, 1]^dim, J = F diag(a) with a the
undeformed semi-lengths. A grid function N_i (linear or quadratic B-spline) is sampled at
points s_q with weights ws_q; gradients use the divergence theorem over the domain, which
for every scheme here takes the form wg_q = coef_q J^-T s_q:

    S_ip = sum_q ws_q N_i(x_q),        G_ip = sum_q N_i(x_q) coef_q J^-T s_q

- corners (cpdi, b2cpdi): s in {-1, 1}^dim, ws = coef = 1/2^dim (2D: the notes' w_c);
- 9 points (cpdi_q, 2D): s in {-1, 0, 1}^2, ws = Simpson weights (1/36 corners, 1/9 edges,
  4/9 centre), coef = 1/12 at corners, 1/3 at edge midpoints, 0 at the centre.
Both satisfy sum_i S_ip = 1, sum_i S_ip x_i = x_p and sum_i x_i (x) G_ip = I exactly.

Each particle's weights are gathered into a box of `cap` nodes per axis starting at its
lowest node, so the node list has a fixed length cap^dim for any deformation up to about
two cells across. Larger particles, inverted ones, and sample points outside the grid are
flagged (the step then stops with a message) instead of writing outside the arrays.
"""

from __future__ import annotations

import itertools

import numpy as np
from numba import njit, prange

from ..gridops import chunk_range
from ..materials.kernels import inv3
from ..parallel import chunk_kernel
from .grid_functions import weights_1d
from .tensor import BAD_SUPPORT, clear_entries

CORNERS = 0
NINE_POINT = 1
BAD_SPAN = 6  # the deformed particle spans more nodes than the node box holds
BAD_DOMAIN = 7  # det J <= 0: the particle domain inverted


def corner_signs(d: int) -> np.ndarray:
    """(2^d, d) sign patterns of a box's corners: corner c of a particle is x + F (signs[c] * l)."""
    return np.array(list(itertools.product((-1.0, 1.0), repeat=d)))


@njit(cache=True, inline="always")
def sample_points(scheme, dim, s, ws, coef):
    """Fill reference points s (in [-1, 1]^dim), S weights and gradient coefficients."""
    if scheme == NINE_POINT:
        simpson = (1.0 / 6.0, 4.0 / 6.0, 1.0 / 6.0)
        q = 0
        for j in range(3):
            for i in range(3):
                s[q, 0] = i - 1.0
                s[q, 1] = j - 1.0
                s[q, 2] = 0.0
                ws[q] = simpson[i] * simpson[j]
                edges = abs(i - 1) + abs(j - 1)
                coef[q] = 1.0 / 12.0 if edges == 2 else (1.0 / 3.0 if edges == 1 else 0.0)
                q += 1
        return 9
    npts = 1 << dim
    for q in range(npts):
        for a in range(3):
            s[q, a] = (2.0 * ((q >> a) & 1) - 1.0) if a < dim else 0.0
        ws[q] = 1.0 / npts
        coef[q] = 1.0 / npts
    return npts


@chunk_kernel
def cpdi_shape_functions(x, F, grid, semi, sk, nchunk, sd, boxes):
    """As tensor_shape_functions, for CPDI: sample points of each particle's deformed domain
    (corners, or nine points for qCPDI) weighted by the grid function; boxes.code says why a
    particle was flagged."""
    origin, h, shape = grid.origin, grid.h, grid.shape
    grid_kind, npc, scheme, cap = sk.grid_kind, sk.npc, sk.cpdi_scheme, sk.per_axis
    nodes, S, G, lowest = sd.nodes, sd.S, sd.G, sd.lowest
    chunk_lo, chunk_hi, chunk_bad, chunk_code = boxes.lo, boxes.hi, boxes.bad, boxes.code
    n, dim = x.shape
    K = S.shape[1]
    for c in prange(nchunk):
        start, stop = chunk_range(c, nchunk, n)
        jac = np.zeros((2, 3, 3))  # the domain's Jacobian and its inverse
        J, Ji = jac[0], jac[1]
        s = np.zeros((9, 3))
        ws = np.zeros(9)
        coef = np.zeros(9)
        base = np.zeros((9, 3), dtype=np.int64)
        wts = np.ones((9, 3, 4))
        dw = np.zeros(4)
        wg = np.zeros(3)
        box = np.zeros(3, dtype=np.int64)
        Sbox = np.zeros(K)
        Gbox = np.zeros((K, 3))
        chunk_bad[c] = -1
        chunk_code[c] = 0
        for d in range(3):
            chunk_lo[c, d] = 1 << 60 if d < dim else 0
            chunk_hi[c, d] = -1 if d < dim else 0
        npts = sample_points(scheme, dim, s, ws, coef)
        for p in range(start, stop):
            # J = F diag(a), padded to 3x3 (2D: J33 = 1)
            for a in range(3):
                for b in range(3):
                    J[a, b] = F[p, a, b] * semi[b] if (a < dim and b < dim) else (1.0 if a == b else 0.0)
            bad = 0
            detJ = J[0, 0] * (J[1, 1] * J[2, 2] - J[1, 2] * J[2, 1]) - J[0, 1] * (J[1, 0] * J[2, 2] - J[1, 2] * J[2, 0]) \
                + J[0, 2] * (J[1, 0] * J[2, 1] - J[1, 1] * J[2, 0])
            if not (detJ > 0.0):
                bad = BAD_DOMAIN
            else:
                inv3(J, Ji)
                for d in range(dim):
                    box[d] = 1 << 60
                hi0 = -1
                hi1 = -1
                hi2 = -1
                for q in range(npts):
                    for d in range(dim):
                        xq = x[p, d]
                        for b in range(dim):
                            xq += J[d, b] * s[q, b]
                        xi = (xq - origin[d]) / h[d]
                        if not (xi > -1e9 and xi < 1e9):
                            xi = 0.0
                            bad = BAD_SUPPORT
                        bq = weights_1d(grid_kind, xi, 0.0, 1.0 / h[d], wts[q, d], dw)
                        base[q, d] = bq
                        if bq < 0 or bq + npc > shape[d]:
                            bad = BAD_SUPPORT
                        box[d] = min(box[d], bq)
                    hi0 = max(hi0, base[q, 0] + npc - 1)
                    hi1 = max(hi1, base[q, 1] + npc - 1)
                    if dim == 3:
                        hi2 = max(hi2, base[q, 2] + npc - 1)
                if bad == 0 and (hi0 - box[0] >= cap or hi1 - box[1] >= cap or (dim == 3 and hi2 - box[2] >= cap)):
                    bad = BAD_SPAN
            if bad != 0:
                clear_entries(p, nodes, S, G)
                if chunk_bad[c] < 0:
                    chunk_bad[c] = p
                    chunk_code[c] = bad
                continue
            for k in range(K):
                Sbox[k] = 0.0
                for d in range(3):
                    Gbox[k, d] = 0.0
            nz = npc if dim == 3 else 1
            for q in range(npts):
                # gradient weight of this sample point: coef J^-T s
                for d in range(dim):
                    g = 0.0
                    for b in range(dim):
                        g += Ji[b, d] * s[q, b]
                    wg[d] = coef[q] * g
                for cc in range(nz):
                    wz = wts[q, 2, cc] if dim == 3 else 1.0
                    oz = (base[q, 2] + cc - box[2]) if dim == 3 else 0
                    for b in range(npc):
                        wyz = wts[q, 1, b] * wz
                        oy = base[q, 1] + b - box[1]
                        for a in range(npc):
                            W = wts[q, 0, a] * wyz
                            if W == 0.0:
                                continue
                            k = (base[q, 0] + a - box[0]) + cap * (oy + cap * oz)
                            Sbox[k] += ws[q] * W
                            for d in range(dim):
                                Gbox[k, d] += W * wg[d]
            for k in range(K):
                a = k % cap
                b = (k // cap) % cap
                cc = k // (cap * cap)
                i = min(box[0] + a, shape[0] - 1)
                j = min(box[1] + b, shape[1] - 1)
                kk = min(box[2] + cc, shape[2] - 1) if dim == 3 else 0
                nodes[p, k] = i + shape[0] * (j + shape[1] * kk)
                S[p, k] = Sbox[k]
                for d in range(dim):
                    G[p, k, d] = Gbox[k, d]
            for d in range(dim):
                lowest[p, d] = box[d]
                chunk_lo[c, d] = min(chunk_lo[c, d], box[d])
            chunk_hi[c, 0] = max(chunk_hi[c, 0], hi0)
            chunk_hi[c, 1] = max(chunk_hi[c, 1], hi1)
            if dim == 3:
                chunk_hi[c, 2] = max(chunk_hi[c, 2], hi2)
