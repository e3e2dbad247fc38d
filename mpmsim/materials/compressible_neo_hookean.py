"""Compressible neo-Hookean solid of the FEM contact papers,
psi = mu/2 (tr F^T F - d) - mu ln J + lambda/2 (ln J)^2: the FEM forms (energy, first Piola
stress, tangent) of FEM bodies and implicit particles, written without cancellation near
F = I (ln J = log1p(J - 1) with J - 1 from the invariants of F - I). No explicit MPM update."""

from __future__ import annotations

import numpy as np
from numba import njit
from pydantic import Field
from typing import Literal

from ..schema_base import Strict
from .kernels import det_minus_one, inv_small
from .linear_elastic import row  # the same property row [lambda, mu, E, nu]
from .model import COMPRESSIBLE_NH, MaterialModel, register


class CompressibleNeoHookean(Strict):
    """Compressible neo-Hookean solid of the FEM contact papers:
    psi = mu/2 (tr F^T F - d) - mu ln J + lambda/2 (ln J)^2, with Lame constants from E and nu
    (FEM bodies)."""

    type: Literal["compressible_neo_hookean"]
    E: float = Field(gt=0, description="Young's modulus (stress unit).")
    nu: float = Field(gt=-1.0, lt=0.5, description="Poisson's ratio, -1 < nu < 0.5.")
    density: float = Field(gt=0, description="Mass density (density unit of the deck's units).")


@njit(cache=True, inline="always")
def fem_energy(props, F):
    """psi(F) per reference volume; inf for J <= 0 (a line search then rejects the step)."""
    lam = props[0]
    mu = props[1]
    d = F.shape[0]
    j1 = det_minus_one(F)
    if not (j1 > -1.0):
        return np.inf
    lnJ = np.log1p(j1)
    # tr F^T F - d = |F - I|^2 + 2 tr(F - I): no cancellation of the O(1) parts
    s = 0.0
    tr = 0.0
    for a in range(d):
        tr += F[a, a] - 1.0
        for b in range(d):
            h = F[a, b] - (1.0 if a == b else 0.0)
            s += h * h
    return 0.5 * mu * (s + 2.0 * tr) - mu * lnJ + 0.5 * lam * lnJ * lnJ


@njit(cache=True, inline="always")
def inverse_and_log_det(F, Finv):
    """J, with F^-1 into Finv, and ln J (NaN for J <= 0)."""
    J = inv_small(F, Finv)
    return J, (np.log1p(det_minus_one(F)) if J > 0.0 else np.nan)


@njit(cache=True, inline="always")
def fem_piola(props, F, P, Finv):
    """P = mu (F - F^-T) + lambda ln J F^-T into P; Finv scratch; returns J (P NaN for J <= 0)."""
    J, lnJ = inverse_and_log_det(F, Finv)
    lam, mu, d = props[0], props[1], F.shape[0]
    for a in range(d):
        for b in range(d):
            P[a, b] = mu * (F[a, b] - Finv[b, a]) + lam * lnJ * Finv[b, a]
    return J


@njit(cache=True, inline="always")
def fem_tangent(props, F, C, Finv):
    """dP/dF = mu d_ac d_be + (mu - lambda ln J) Finv_ea Finv_bc + lambda Finv_ba Finv_ec; returns J."""
    J, lnJ = inverse_and_log_det(F, Finv)
    lam, mu, d = props[0], props[1], F.shape[0]
    k = mu - lam * lnJ
    for a in range(d):
        for b in range(d):
            for c in range(d):
                for e in range(d):
                    v = k * Finv[e, a] * Finv[b, c] + lam * Finv[b, a] * Finv[e, c]
                    if a == c and b == e:
                        v += mu
                    C[a * d + b, c * d + e] = v
    return J


@njit(cache=True, inline="always")
def fem_cauchy_zz(props, F, J):
    """Plane strain sigma_zz = lambda ln J / J."""
    return props[0] * np.log(J) / J


@njit(cache=True, inline="always")
def energy(pr, F3, s, J):
    """Per current volume, from the FEM form (the padded 3x3 F of a particle)."""
    return fem_energy(pr, F3) / J


@njit(cache=True, inline="always")
def bulk_modulus(pr, J, p):
    return pr[0] + 2.0 / 3.0 * pr[1]


MODEL = register(MaterialModel(
    "compressible_neo_hookean", CompressibleNeoHookean, row, wave_modulus=lambda r: r[0] + 2.0 * r[1],
    energy=energy, bulk_modulus=bulk_modulus, fem=True), COMPRESSIBLE_NH)
