"""Global sums over particles: volume-integrated stress, volume, energies, momentum."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .gridops import chunk_range
from .materials.kernels import det3, energy_density

# slots of the particle_sums result
STRESS, VOLUME, KINETIC, STRAIN, MOMENTUM, INTERNAL = slice(0, 6), 6, 7, 8, slice(9, 12), 12
NSUMS = 13


@njit(parallel=True, cache=True)
def global_sums(stress, vol, v, mass, F, mat, code, props, energy, U, nchunk, out):
    """Per chunk: [vol*stress (6), vol, kinetic, strain energy, momentum (3), internal energy]."""
    n, dim = v.shape
    for c in prange(nchunk):
        start, stop = chunk_range(c, nchunk, n)
        F3 = np.zeros((3, 3))
        acc = np.zeros(NSUMS)
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
            if energy[mt]:
                acc[12] += mass[p] * U[p]
        for a in range(NSUMS):
            out[c, a] = acc[a]


def particle_sums(state) -> np.ndarray:
    """[vol*stress (6), volume, kinetic energy, strain energy, momentum (3), internal energy]
    summed over particles."""
    P, m = state.particles, state.materials
    out = np.zeros((state.nchunk, NSUMS))
    global_sums(P.stress, P.vol, P.v, P.mass, P.F, P.mat, m.type_code, m.props, m.energy, P.U, state.nchunk, out)
    return out.sum(axis=0)


@njit(cache=True)
def _noise_kernel(nodes, S, pmass, v, gm, gp):
    """||V - S S+ V|| / ||V||: the part of the particle velocities the grid cannot represent."""
    n, K = S.shape
    dim = v.shape[1]
    for p in range(n):  # zero only the nodes in use
        for k in range(K):
            i = nodes[p, k]
            gm[i] = 0.0
            for d in range(dim):
                gp[i, d] = 0.0
    for p in range(n):
        for k in range(K):
            w = S[p, k] * pmass[p]
            i = nodes[p, k]
            gm[i] += w
            for d in range(dim):
                gp[i, d] += w * v[p, d]
    num = 0.0
    den = 0.0
    for p in range(n):
        for d in range(dim):
            sv = 0.0
            for k in range(K):
                i = nodes[p, k]
                if gm[i] > 0.0:
                    sv += S[p, k] * gp[i, d] / gm[i]
            num += (v[p, d] - sv) ** 2
            den += v[p, d] ** 2
    return np.sqrt(num / den) if den > 0.0 else 0.0


def _current_shape_data(state):
    """Shape functions at the particles' current positions (history times only), or None if a
    particle cannot be evaluated (the step that follows stops the run)."""
    from .shapes import ShapeData

    P = state.particles
    scratch = state._noise_scratch
    if scratch is None:
        K = state.sd.S.shape[1]
        scratch = (ShapeData.empty(P.n, K, state.dim), np.zeros(state.grid.n_nodes),
                   np.zeros((state.grid.n_nodes, state.dim)))
        state._noise_scratch = scratch
    sd = scratch[0]
    _, (bad, _) = state.shape.compute(P.x, P.F, state.scene.semi_size, state.grid, state.nchunk, sd)
    return None if bad >= 0 else sd


def velocity_noise(state) -> float:
    """||V - S S+ V|| / ||V|| with the lumped extrapolation S+ = M^-1 S^T Mp the transfers use
    (a P2G and a G2P at the current positions). S S+ is a smoothing, not a projection: even
    velocities the grid represents exactly score above zero (boundaries, partly filled cells),
    so this mixes null-space noise with that smoothing. `null_space_noise` separates them."""
    sd = _current_shape_data(state)
    if sd is None:
        return float("nan")
    _, gm, gp = state._noise_scratch
    P = state.particles
    return float(_noise_kernel(sd.nodes, sd.S, P.mass, P.v, gm, gp))


def null_space_noise(state) -> float:
    """||V - S S+ V|| / ||V|| with S+ the mass-weighted pseudo-inverse (S^T Mp S)^-1 S^T Mp, so
    S S+ is the Mp-orthogonal projection onto the velocities the grid can represent and the
    residual is exactly the part the grid cannot see (null space of the P2G transfer).
    One sparse solve over the nodes in use; history times only, when the deck asks for it."""
    import scipy.sparse as sparse
    from scipy.sparse.linalg import spsolve

    sd = _current_shape_data(state)
    if sd is None:
        return float("nan")
    P = state.particles
    n, K = sd.S.shape
    used, cols = np.unique(sd.nodes.ravel(), return_inverse=True)
    S = sparse.csr_matrix((sd.S.ravel(), (np.repeat(np.arange(n), K), cols.ravel())), shape=(n, used.size))
    SM = S.T.multiply(P.mass[None, :]).tocsr()  # S^T Mp
    N = (SM @ S).tocsc()
    # nodes touched only by shape-function tails make N nearly singular (condition ~1e16);
    # a 1e-10 relative diagonal shift keeps the solve defined and moves nothing measurable
    N = N + sparse.diags(1e-10 * N.diagonal() + 1e-300)
    w = spsolve(N, SM @ P.v)
    residual = P.v - S @ w.reshape(used.size, -1)
    den = float((P.v * P.v).sum())
    return float(np.sqrt((residual * residual).sum() / den)) if den > 0.0 else 0.0
