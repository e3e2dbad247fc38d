"""Isotropic linear elastic: hypoelastic MPM update with the Hughes–Winget rotation, the
small-strain energy and stress of FEM bodies and implicit particles."""

from __future__ import annotations

import numpy as np
from numba import njit
from pydantic import Field
from typing import Literal

from ..schema_base import Strict
from .kernels import det_small, rotate_stress
from .model import LINEAR_ELASTIC, NPROP, MaterialModel, register


class LinearElastic(Strict):
    """Isotropic linear elastic, integrated as hypoelastic with the Hughes–Winget rotation
    (objective for large rotations, linear in strain increments)."""

    type: Literal["linear_elastic"]
    E: float = Field(gt=0, description="Young's modulus (stress unit).")
    nu: float = Field(gt=-1.0, lt=0.5, description="Poisson's ratio, -1 < nu < 0.5.")
    density: float = Field(gt=0, description="Mass density (density unit of the deck's units).")


def lame(E: float, nu: float) -> tuple[float, float]:
    return E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))


def row(m) -> np.ndarray:
    """[lambda, mu, E, nu]"""
    out = np.zeros(NPROP)
    lam, mu = lame(m.E, m.nu)
    out[:4] = (lam, mu, m.E, m.nu)
    return out


@njit(cache=True, inline="always")
def hypoelastic_stress(lam, mu, L, dt, s, W, A, Ai, Q):
    """Isotropic linear elastic increment after the rotation:
    sigma <- Q sigma Q^T + lam tr(de) I + 2 mu de."""
    rotate_stress(L, dt, s, W, A, Ai, Q)
    tr = (L[0, 0] + L[1, 1] + L[2, 2]) * dt
    s[0] += lam * tr + 2.0 * mu * L[0, 0] * dt
    s[1] += lam * tr + 2.0 * mu * L[1, 1] * dt
    s[2] += lam * tr + 2.0 * mu * L[2, 2] * dt
    s[3] += mu * (L[0, 1] + L[1, 0]) * dt
    s[4] += mu * (L[1, 2] + L[2, 1]) * dt
    s[5] += mu * (L[0, 2] + L[2, 0]) * dt
    return lam + 2.0 * mu


@njit(cache=True, inline="always")
def linear_elastic_energy(E, nu, mu, s):
    """Complementary energy density 1/2 sigma : C^-1 : sigma (exact for linear elasticity)."""
    normal = s[0] ** 2 + s[1] ** 2 + s[2] ** 2 - 2.0 * nu * (s[0] * s[1] + s[1] * s[2] + s[0] * s[2])
    shear = s[3] ** 2 + s[4] ** 2 + s[5] ** 2
    return 0.5 * normal / E + 0.5 * shear / mu


@njit(cache=True, inline="always")
def stress(pr, L, dt, F3, J, f00, f01, f10, f11, s, W, A, Ai, Q, eos, hs):
    return hypoelastic_stress(pr[0], pr[1], L, dt, s, W, A, Ai, Q)


@njit(cache=True, inline="always")
def energy(pr, F3, s, J):
    return linear_elastic_energy(pr[2], pr[3], pr[1], s)


@njit(cache=True, inline="always")
def bulk_modulus(pr, J, p):
    return pr[0] + 2.0 / 3.0 * pr[1]


@njit(cache=True, inline="always")
def fem_energy(props, F):
    """psi = mu |eps|^2 + lambda/2 (tr eps)^2 per reference volume (small strain)."""
    lam = props[0]
    mu = props[1]
    d = F.shape[0]
    ee = 0.0
    tr = 0.0
    for a in range(d):
        tr += F[a, a] - 1.0
        for b in range(d):
            e = 0.5 * (F[a, b] + F[b, a]) - (1.0 if a == b else 0.0)
            ee += e * e
    return mu * ee + 0.5 * lam * tr * tr


@njit(cache=True, inline="always")
def fem_piola(props, F, P, Finv):
    """P = 2 mu eps + lambda tr(eps) I; returns J."""
    lam = props[0]
    mu = props[1]
    d = F.shape[0]
    tr = 0.0
    for a in range(d):
        tr += F[a, a] - 1.0
    for a in range(d):
        for b in range(d):
            P[a, b] = mu * (F[a, b] + F[b, a]) - (2.0 * mu - lam * tr if a == b else 0.0)
    return det_small(F)


@njit(cache=True, inline="always")
def fem_tangent(props, F, C, Finv):
    """C = mu (d_ac d_be + d_ae d_bc) + lambda d_ab d_ce; returns J."""
    lam = props[0]
    mu = props[1]
    d = F.shape[0]
    for a in range(d):
        for b in range(d):
            for c in range(d):
                for e in range(d):
                    v = 0.0
                    if a == c and b == e:
                        v += mu
                    if a == e and b == c:
                        v += mu
                    if a == b and c == e:
                        v += lam
                    C[a * d + b, c * d + e] = v
    return det_small(F)


@njit(cache=True, inline="always")
def fem_cauchy_zz(props, F, J):
    """Plane strain sigma_zz = lambda tr(eps) / J."""
    return props[0] * (F[0, 0] + F[1, 1] - 2.0) / J


MODEL = register(MaterialModel(
    "linear_elastic", LinearElastic, row, wave_modulus=lambda r: r[0] + 2.0 * r[1], energy=energy,
    bulk_modulus=bulk_modulus, stress_2d=stress, stress_3d=stress, fem=True), LINEAR_ELASTIC)
