"""Task: extrapolate mass and momentum to the grid (and rigid volumes for their BCs).

m_i = sum_p S_ip m_p,  p_i = sum_p S_ip m_p (V_p + C_p (x_i - x_p)). The affine term is
APIC's (C_p = B_p D_p^-1, D_p = sum_i S_ip (x_i - x_p)(x_i - x_p)^T from the same weights, so
P2G then G2P reproduces any affine velocity field and conserves angular momentum); it is
zero for the other schemes. The same scatter, without mass, is the re-extrapolation of
momentum that USL/USAVG runs after the particle update.
"""

from __future__ import annotations

import numpy as np  # noqa: F401  (numba kernels use np)
from numba import njit, prange

from ..contact.grid import extrapolate_contact
from ..gridops import chunk_range, slab, zero_fields
from ..parallel import chunk_kernel
from .boundary import find_ghosts, has_walls
from ..materials.kernels import inv3

# a rigid particle constrains a node only where its weight is clearly non-zero
RIGID_MIN_WEIGHT = 1e-12


@chunk_kernel
def p2g_momentum(sc, pmass, pvel, with_mass, gmass, gmom, affine, C, lowest, offs, grid, xref):
    """Scatter m and m (v + C (x_i - x_p)) of the particles to their fields (sc: views.Scatter;
    the affine term only with `affine`; masses only `with_mass`)."""
    nodes, S = sc.fidx, sc.S
    origin, h = grid.origin, grid.h
    K = S.shape[1]
    dim = pvel.shape[1]
    order, ptr = sc.order, sc.ptr
    for color in range(2):
        for s in prange((ptr.size - color) // 2):
            r = np.zeros(3)
            for q in slab(ptr, color, s):
                p = order[q]
                mp = pmass[p]
                # the velocity in locals: stores into gmom cannot then force its reloads
                vx, vy = pvel[p, 0], pvel[p, 1]
                vz = pvel[p, 2] if dim == 3 else 0.0
                for k in range(K):
                    w = S[p, k]
                    if w == 0.0:
                        continue
                    i = np.uint64(nodes[p, k])  # (unsigned: no negative-index wrap per access)
                    wm = w * mp
                    if with_mass:
                        gmass[i] += wm
                    if affine:
                        for b in range(dim):
                            r[b] = origin[b] + (lowest[p, b] + offs[k, b]) * h[b] - xref[p, b]
                        for d in range(dim):
                            vd = pvel[p, d]
                            for b in range(dim):
                                vd += C[p, d, b] * r[b]
                            gmom[i, d] += wm * vd
                    else:
                        gmom[i, 0] += wm * vx
                        gmom[i, 1] += wm * vy
                        if dim == 3:
                            gmom[i, 2] += wm * vz


@chunk_kernel
def apic_affine(sd, offs, grid, x, B, nchunk, C):
    """C_p = B_p D_p^-1 with D_p = sum_i S_ip (x_i - x_p)(x_i - x_p)^T (sd: the particles'
    shapes.ShapeData)."""
    S, lowest, origin, h = sd.S, sd.lowest, grid.origin, grid.h
    n, K = S.shape
    dim = x.shape[1]
    for c in prange(nchunk):
        start, stop = chunk_range(c, nchunk, n)
        inertia = np.zeros((2, 3, 3))  # D_p and its inverse
        D, Di = inertia[0], inertia[1]
        r = np.zeros(3)
        for p in range(start, stop):
            affine_of(p, S, lowest, offs, origin, h, x, B, dim, D, Di, r, C)


@njit(cache=True, inline="always")
def affine_of(p, S, lowest, offs, origin, h, x, B, dim, D, Di, r, C):
    """C_p = B_p D_p^-1 of particle p (D, Di: 3x3 scratch, r: 3). Also the GPU step's."""
    for a in range(3):
        for b in range(3):
            D[a, b] = 0.0
    D[2, 2] = 1.0 if dim == 2 else 0.0  # plane strain: pad so the 3x3 inverse serves
    for k in range(S.shape[1]):
        w = S[p, k]
        for b in range(dim):
            r[b] = origin[b] + (lowest[p, b] + offs[k, b]) * h[b] - x[p, b]
        for a in range(dim):
            for b in range(dim):
                D[a, b] += w * r[a] * r[b]
    inv3(D, Di)
    for a in range(dim):
        for b in range(dim):
            cab = 0.0
            for m in range(dim):
                cab += B[p, a, m] * Di[m, b]
            C[p, a, b] = cab


@njit(cache=True)
def p2g_rigid_volume(nodes, S, vol, mat, rigid_vol):
    n, K = S.shape
    for p in range(n):
        r = mat[p]
        for k in range(K):
            w = S[p, k]
            if w > RIGID_MIN_WEIGHT:
                rigid_vol[nodes[p, k], r] += w * vol[p]


def _scatter_momentum(state, with_mass: bool) -> None:
    f, box, P, sd, g = state.fields, state.box, state.particles, state.sd, state.grid
    affine = P.affine
    if affine:
        apic_affine(sd, state.entry_offsets, g.view, P.xref, P.B, state.nchunk, P.C)
    p2g_momentum(box.scatter(state.field_index, sd.S), P.mass, P.v, with_mass, f.mass, f.mom, affine, P.C, sd.lowest,
                 state.entry_offsets, g.view, P.xref)


def extrapolate(state) -> None:
    f, box = state.fields, state.box
    zero_fields(box.fields, f.mass.reshape(-1, 1))
    zero_fields(box.fields, f.mom)
    _scatter_momentum(state, with_mass=True)
    if state.contact is not None:
        extrapolate_contact(state, with_mass=True)
    if state.rigid.n:
        zero_fields(box.fields[: box.n_box], f.rigid_vol)
        R = state.rigid
        p2g_rigid_volume(state.rigid_sd.nodes, state.rigid_sd.S, R.vol, R.mat, f.rigid_vol)
    if has_walls(state):  # which field each ghost mirrors, now that rigid bodies' nodes are known
        find_ghosts(state)


def reextrapolate(state) -> None:
    """USL+/USAVG+: momenta from the updated particle velocities (masses kept)."""
    f, box = state.fields, state.box
    zero_fields(box.fields, f.mom)
    _scatter_momentum(state, with_mass=False)
    if state.contact is not None:
        extrapolate_contact(state, with_mass=False)

