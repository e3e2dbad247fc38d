"""Velocity noise of the particles: how much of their velocity field the grid cannot carry
(history columns velocity_noise and null_space_noise; history times only)."""

from __future__ import annotations

import numpy as np
from numba import njit


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
    scratch = state.noise_scratch
    if scratch is None:
        K = state.sd.S.shape[1]
        scratch = (ShapeData.empty(P.n, K, state.dim, state.shape.axisymmetric), np.zeros(state.grid.n_nodes),
                   np.zeros((state.grid.n_nodes, state.dim)))
        state.noise_scratch = scratch
    sd = scratch[0]
    _, (bad, _) = state.shape.compute(P.x, P.F, P.semi, state.grid, state.nchunk, sd)
    return None if bad >= 0 else sd


def velocity_noise(state) -> float:
    """||V - S S+ V|| / ||V|| with the lumped extrapolation S+ = M^-1 S^T Mp the transfers use
    (a P2G and a G2P at the current positions). S S+ is a smoothing, not a projection: even
    velocities the grid represents exactly score above zero (boundaries, partly filled cells),
    so this mixes null-space noise with that smoothing. `null_space_noise` separates them."""
    sd = _current_shape_data(state)
    if sd is None:
        return float("nan")
    _, gm, gp = state.noise_scratch
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
