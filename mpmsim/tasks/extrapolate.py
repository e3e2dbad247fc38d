"""Task: extrapolate mass and momentum to the grid (and rigid volumes for their BCs).

m_i = sum_p S_ip m_p,  p_i = sum_p S_ip m_p V_p. The same scatter, without mass, is the
re-extrapolation of momentum that USL/USAVG runs after the particle update.
"""

from __future__ import annotations

from numba import njit, prange

from ..gridops import zero_box

# a rigid particle constrains a node only where its weight is clearly non-zero
RIGID_MIN_WEIGHT = 1e-12


@njit(parallel=True, cache=True)
def p2g_momentum(order, ptr, nodes, S, pmass, pvel, with_mass, gmass, gmom):
    n_slab = ptr.size - 1
    K = S.shape[1]
    dim = pvel.shape[1]
    for color in range(2):
        for s in prange((n_slab - color + 1) // 2):
            slab = color + 2 * s
            for q in range(ptr[slab], ptr[slab + 1]):
                p = order[q]
                mp = pmass[p]
                for k in range(K):
                    w = S[p, k]
                    if w == 0.0:
                        continue
                    i = nodes[p, k]
                    wm = w * mp
                    if with_mass:
                        gmass[i] += wm
                    for d in range(dim):
                        gmom[i, d] += wm * pvel[p, d]


@njit(cache=True)
def p2g_rigid_volume(nodes, S, vol, mat, rigid_vol):
    n, K = S.shape
    for p in range(n):
        r = mat[p]
        for k in range(K):
            w = S[p, k]
            if w > RIGID_MIN_WEIGHT:
                rigid_vol[nodes[p, k], r] += w * vol[p]


def extrapolate(state) -> None:
    f, box, P, sd = state.fields, state.box, state.particles, state.sd
    zero_box(box.lo, box.hi, box.shape, f.mass.reshape(-1, 1))
    zero_box(box.lo, box.hi, box.shape, f.mom)
    p2g_momentum(box.order, box.ptr, sd.nodes, sd.S, P.mass, P.v, True, f.mass, f.mom)
    if state.rigid.n:
        zero_box(box.lo, box.hi, box.shape, f.rigid_vol)
        R = state.rigid
        p2g_rigid_volume(state.rigid_sd.nodes, state.rigid_sd.S, R.vol, R.mat, f.rigid_vol)


def reextrapolate_momentum(state) -> None:
    f, box, P, sd = state.fields, state.box, state.particles, state.sd
    zero_box(box.lo, box.hi, box.shape, f.mom)
    p2g_momentum(box.order, box.ptr, sd.nodes, sd.S, P.mass, P.v, False, f.mass, f.mom)
