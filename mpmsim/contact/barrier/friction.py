"""Smoothed, lagged Coulomb friction (IPC: Li et al. 2020, doi:10.1145/3386569.3392425, Sec. 5;
BFEMP Eqs. 36-38; implementation notes, "Lagged friction").

Mollifier of the slip magnitude y = |u| >= 0 (u the tangential slip *displacement* over the step,
so epsilon = eps_v * dt is a length):
    f0(y) = -y^3/(3 eps^2) + y^2/eps + eps/3   (y < eps),   y   (y >= eps)
    f1(y) = f0'(y) = -y^2/eps^2 + 2 y/eps      (y < eps),   1
    f1(y)/y        = -y/eps^2 + 2/eps          (y < eps),   1/y   (finite as y -> 0: 2/eps)
    f2(y) = f1'(y) = -2 y/eps^2 + 2/eps        (y < eps),   0
    (f2 y - f1)/y^3 = -1/(y eps^2)             (y < eps),   -1/y^3
These are the IPC toolkit's smooth_friction_f0/f1/f1_over_x/f2_x_minus_f1_over_x3 (ipctk 1.6).

Lagged friction of one contact (pair stencil with n stacked DOFs, k = dim - 1 tangent
directions): with the step displacement dz of the stencil's points, the lagged operator
G (n, k) maps dz to the tangential slip u = G^T dz (point-edge in 2D: G = (tau, -(1 - r) tau,
-r tau) for (p, e0, e1), tau the lagged unit tangent, r the lagged closest-point parameter),
    D(dz) = mu lambda f0(|u|)
    grad D = mu lambda (f1(|u|)/|u|) G u
    hess D = mu lambda G [ (f1/|u|) I + ((f2 |u| - f1)/|u|^3) u u^T ] G^T .
The bracket has eigenvalue f2(|u|) >= 0 along u and f1/|u| >= 0 across it, so hess D is PSD by
construction (no projection needed); in 2D (k = 1) it reduces to mu lambda f2(|u|) G G^T, the
exact second derivative of mu lambda f0(|u|).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def friction_f0(y, eps):
    """Smoothed slip magnitude f0(y) (y >= 0): C^1 extension of y, f0(0) = eps/3."""
    y = abs(y)
    if y >= eps:
        return y
    return -y * y * y / (3.0 * eps * eps) + y * y / eps + eps / 3.0


@njit(cache=True)
def friction_f1(y, eps):
    """f1 = f0': the friction force magnitude factor, rising from 0 to 1 over [0, eps]."""
    y = abs(y)
    if y >= eps:
        return 1.0
    return -y * y / (eps * eps) + 2.0 * y / eps


@njit(cache=True)
def friction_f1_over_y(y, eps):
    """f1(y)/y, evaluated without the division (2/eps at y = 0)."""
    y = abs(y)
    if y >= eps:
        return 1.0 / y
    return -y / (eps * eps) + 2.0 / eps


@njit(cache=True)
def friction_f2(y, eps):
    """f2 = f1' = f0'' (>= 0; 0 for y >= eps)."""
    y = abs(y)
    if y >= eps:
        return 0.0
    return -2.0 * y / (eps * eps) + 2.0 / eps


@njit(cache=True)
def friction_f2_y_minus_f1_over_y3(y, eps):
    """(f2(y) y - f1(y))/y^3, the coefficient of u u^T in the Hessian of f0(|u|) for u in R^k."""
    y = abs(y)
    if y >= eps:
        return -1.0 / (y * y * y)
    return -1.0 / (y * eps * eps)


@njit(cache=True)
def point_edge_friction_operator(tau, r, G):
    """Lagged slip operator of a 2D point-edge contact: G (6, 1) with u = G^T dz = tau.(dp -
    ((1 - r) de0 + r de1)) for dz = (dp, de0, de1)."""
    for a in range(2):
        G[a, 0] = tau[a]
        G[2 + a, 0] = -(1.0 - r) * tau[a]
        G[4 + a, 0] = -r * tau[a]


@njit(cache=True)
def point_point_friction_operator(tau, G):
    """Lagged slip operator of a 2D point-point contact: G (4, 1), u = tau.(dp - dq)."""
    for a in range(2):
        G[a, 0] = tau[a]
        G[2 + a, 0] = -tau[a]


@njit(cache=True)
def lagged_friction(dz, G, mu_lambda, eps, g, H):
    """Lagged friction pseudo-potential D = mu lambda f0(|G^T dz|) of one contact stencil.
    dz (n,) step displacements of the stencil's points (stacked like its distance), G (n, k)
    the lagged slip operator, mu_lambda = mu * lambda (lagged normal force, >= 0), eps =
    eps_v * dt. Fills g (n,) and the PSD Hessian H (n, n); returns D."""
    n = G.shape[0]
    k = G.shape[1]
    u = np.zeros(k)
    for j in range(k):
        acc = 0.0
        for a in range(n):
            acc += G[a, j] * dz[a]
        u[j] = acc
    y = np.sqrt(np.sum(u * u))
    f1y = friction_f1_over_y(y, eps)
    # M = (f1/y) I + c u u^T, c = (f2 y - f1)/y^3, applied as (c y^2) uhat uhat^T so that nothing
    # overflows as y -> 0 (c y^2 = -y/eps^2 -> 0 there)
    cy2 = 0.0
    if y > 0.0:
        cy2 = friction_f2_y_minus_f1_over_y3(y, eps) * y * y
        for j in range(k):
            u[j] /= y
    Gu = np.zeros(n)  # G u (y times G uhat)
    Gh = np.zeros(n)  # G uhat
    for a in range(n):
        acc = 0.0
        for j in range(k):
            acc += G[a, j] * u[j]
        Gh[a] = acc
        Gu[a] = acc * y
        g[a] = mu_lambda * f1y * Gu[a]
    for a in range(n):
        for b in range(n):
            acc = 0.0
            for j in range(k):
                acc += G[a, j] * G[b, j]
            H[a, b] = mu_lambda * (f1y * acc + cy2 * Gh[a] * Gh[b])
    return mu_lambda * friction_f0(y, eps)


@njit(cache=True)
def point_edge_friction(dz, tau, r, mu_lambda, eps, g, H):
    """Lagged friction of a 2D point-edge contact as a function of the step displacements
    dz = (dp, de0, de1) (6,), given the lagged unit tangent tau (2,), closest-point parameter
    r in [0, 1] and mu * lambda. Fills g (6,) and the PSD Hessian H (6, 6); returns D."""
    G = np.empty((6, 1))
    point_edge_friction_operator(tau, r, G)
    return lagged_friction(dz, G, mu_lambda, eps, g, H)
