"""Global sums over particles: volume-integrated stress, volume, energies, momentum."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .gridops import chunk_range
from .materials.kernels import det3, energy_density

# slots of the particle_sums result
STRESS, VOLUME, KINETIC, STRAIN, MOMENTUM = slice(0, 6), 6, 7, 8, slice(9, 12)


@njit(parallel=True, cache=True)
def global_sums(stress, vol, v, mass, F, mat, code, props, nchunk, out):
    """Per chunk: [vol*stress (6), vol, kinetic, strain energy, momentum (3)]."""
    n, dim = v.shape
    for c in prange(nchunk):
        start, stop = chunk_range(c, nchunk, n)
        F3 = np.zeros((3, 3))
        acc = np.zeros(12)
        for p in range(start, stop):
            vp = vol[p]
            for a in range(6):
                acc[a] += vp * stress[p, a]
            acc[6] += vp
            v2 = 0.0
            for d in range(dim):
                v2 += v[p, d] * v[p, d]
                acc[9 + d] += mass[p] * v[p, d]
            acc[7] += 0.5 * mass[p] * v2
            for a in range(3):
                for b in range(3):
                    F3[a, b] = F[p, a, b] if (a < dim and b < dim) else (1.0 if a == b else 0.0)
            J = det3(F3)
            mt = mat[p]
            acc[8] += vp * energy_density(code[mt], props[mt], F3, stress[p], J)
        for a in range(12):
            out[c, a] = acc[a]


def particle_sums(state) -> np.ndarray:
    """[vol*stress (6), volume, kinetic energy, strain energy, momentum (3)] summed over particles."""
    P, m = state.particles, state.materials
    out = np.zeros((state.nchunk, 12))
    global_sums(P.stress, P.vol, P.v, P.mass, P.F, P.mat, m.type_code, m.props, state.nchunk, out)
    return out.sum(axis=0)
