"""Smoothly clamped log barrier on unsigned distances, and the per-pair barrier energies.

Distance form of the IPC barrier (Li et al. 2020, "Incremental Potential Contact",
doi:10.1145/3386569.3392425, Eq. 6; BFEMP Eq. 27; implementation notes, "BFEMP"):
    b(d) = -kappa dhat (u - 1)^2 ln u,  u = d/dhat,  for 0 < d < dhat;  0 for d >= dhat
    b'(d)  = kappa [-2 (u - 1) ln u - (u - 1)^2 / u]
    b''(d) = (kappa/dhat) [-2 ln u - 4 (u - 1)/u + (u - 1)^2 / u^2]
d is the unsigned distance (not squared) in length units; kappa is in stress units (energy per
length^2 in 2D, i.e. the energy b has units kappa * length: multiply by the particle weight
w_p, a length in 2D, to get energy per unit thickness), so b' is a force per unit weight. The
relation to the IPC toolkit's unit-stiffness barrier (ipctk.barrier(d, dhat) =
-(d - dhat)^2 ln(d/dhat), same d) is b = (kappa/dhat) * ipctk.barrier(d, dhat), and likewise for
both derivatives. b is C^2 at d = dhat (b = b' = b'' = 0 there) and b -> +inf as d -> 0+;
for d <= 0 the functions return +inf (energy), -inf (b') and +inf (b'').

Per-pair energies follow by the chain rule on the stacked vector y:
    E = b(d(y)),  grad E = b'(d) grad d,  hess E = b''(d) grad d grad d^T + b'(d) hess d,
with the distance derivatives of `distance.py`; the Hessian can be projected to PSD per stencil
(projected Newton). The caller scales kappa by the quadrature weight (w_p for a particle-edge
pair; -(deg - 1) w_p for the boundary-node correction of the notes / BFEMP Eq. 31).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .distance import _pe_dispatch, _pp_blocks
from ..fem.elements import project_psd


@njit(cache=True)
def barrier(d, dhat, kappa):
    """b(d) = -kappa dhat (u - 1)^2 ln u, u = d/dhat, for 0 < d < dhat; 0 beyond; +inf for d <= 0."""
    if d >= dhat:
        return 0.0
    if d <= 0.0:
        return np.inf
    u = d / dhat
    return -kappa * dhat * (u - 1.0) ** 2 * np.log(u)


@njit(cache=True)
def barrier_first_derivative(d, dhat, kappa):
    """b'(d) = kappa [-2 (u - 1) ln u - (u - 1)^2 / u] (<= 0): minus the normal force per unit
    weight."""
    if d >= dhat:
        return 0.0
    if d <= 0.0:
        return -np.inf
    u = d / dhat
    return kappa * (-2.0 * (u - 1.0) * np.log(u) - (u - 1.0) ** 2 / u)


@njit(cache=True)
def barrier_second_derivative(d, dhat, kappa):
    """b''(d) = (kappa/dhat) [-2 ln u - 4 (u - 1)/u + (u - 1)^2/u^2] (>= 0)."""
    if d >= dhat:
        return 0.0
    if d <= 0.0:
        return np.inf
    u = d / dhat
    return kappa / dhat * (-2.0 * np.log(u) - 4.0 * (u - 1.0) / u + (u - 1.0) ** 2 / (u * u))


@njit(cache=True)
def barrier_normal_force(d, dhat, kappa):
    """Contact force magnitude -b'(d) >= 0 per unit weight: the lagged lambda_k of friction is
    w_p times this (notes, "Lagged friction")."""
    return -barrier_first_derivative(d, dhat, kappa)


@njit(cache=True, inline="always")
def _chain(d, g, H, dhat, kappa, project):
    """Turn (d, grad d, hess d) in g, H into the barrier's energy, gradient and Hessian."""
    n = g.shape[0]
    if d >= dhat:
        g[:] = 0.0
        H[:, :] = 0.0
        return 0.0
    if d <= 0.0:
        g[:] = 0.0
        H[:, :] = 0.0
        return np.inf
    b1 = barrier_first_derivative(d, dhat, kappa)
    b2 = barrier_second_derivative(d, dhat, kappa)
    for a in range(n):
        for c in range(n):
            H[a, c] = b2 * g[a] * g[c] + b1 * H[a, c]
    for a in range(n):
        g[a] *= b1
    if project:
        project_psd(H)
    return barrier(d, dhat, kappa)


@njit(cache=True)
def point_edge_barrier(y, dhat, kappa, g, H, project=False, dtype=-1):
    """Barrier energy b(d) of the point-edge pair y = (p, e0, e1) (unsigned distance d);
    fills its gradient g (6,) and Hessian H (6, 6) (PSD-projected if `project`)."""
    d = _pe_dispatch(y, g, H, dtype, True, False)
    return _chain(d, g, H, dhat, kappa, project)


@njit(cache=True)
def point_point_barrier(y, dhat, kappa, g, H, project=False):
    """Barrier energy b(|p - q|) of y = (p, q) (the boundary-node correction term); fills g (4,)
    and H (4, 4) (PSD-projected if `project`)."""
    g[:] = 0.0
    H[:, :] = 0.0
    d = _pp_blocks(y, 0, 2, g, H, True, False)
    return _chain(d, g, H, dhat, kappa, project)


@njit(cache=True)
def point_edge_barrier_pairs(points, verts, edges, pairs, dhat, kappa, weights, grads, hessians, project=True):
    """Barrier energies of many point-edge pairs. pairs (k, 2) = (point index, edge index);
    weights (n_points,) scale kappa per point (w_p); fills grads (k, 6) and hessians (k, 6, 6)
    in the stacked order (p, e0, e1) and returns the total energy."""
    y = np.empty(6)
    total = 0.0
    for k in range(pairs.shape[0]):
        i = pairs[k, 0]
        j = pairs[k, 1]
        a = edges[j, 0]
        b = edges[j, 1]
        y[0] = points[i, 0]
        y[1] = points[i, 1]
        y[2] = verts[a, 0]
        y[3] = verts[a, 1]
        y[4] = verts[b, 0]
        y[5] = verts[b, 1]
        total += point_edge_barrier(y, dhat, kappa * weights[i], grads[k], hessians[k], project)
    return total
