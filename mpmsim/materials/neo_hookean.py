"""Compressible neo-Hookean solid of the LR paper, Eq. (18): the explicit MPM update."""

from __future__ import annotations

import numpy as np
from numba import njit
from pydantic import Field
from typing import Literal

from ..schema_base import Strict
from .kernels import cube_root, det3
from .model import NEO_HOOKEAN, NPROP, MaterialModel, register


class NeoHookean(Strict):
    """Compressible neo-Hookean solid, LR paper Eq. (18):
    W = G/2 (I1/J^(2/3) - 3) + K/2 ((J^2 - 1)/2 - ln J)."""

    type: Literal["neo_hookean"]
    K: float = Field(gt=0, description="Bulk modulus (stress unit).")
    G: float = Field(ge=0, description="Shear modulus (stress unit); 0 gives a fluid-like solid.")
    density: float = Field(gt=0, description="Mass density (density unit of the deck's units).")


def row(m) -> np.ndarray:
    """[K, G]"""
    out = np.zeros(NPROP)
    out[:2] = (m.K, m.G)
    return out


@njit(cache=True, inline="always")
def neo_hookean_stress(K, G, F3, s):
    """Cauchy stress of Eq. (18): sigma = K/2 (J - 1/J) I + G J^(-5/3) dev(F F^T)."""
    J = det3(F3)
    bxx = F3[0, 0] ** 2 + F3[0, 1] ** 2 + F3[0, 2] ** 2
    byy = F3[1, 0] ** 2 + F3[1, 1] ** 2 + F3[1, 2] ** 2
    bzz = F3[2, 0] ** 2 + F3[2, 1] ** 2 + F3[2, 2] ** 2
    bxy = F3[0, 0] * F3[1, 0] + F3[0, 1] * F3[1, 1] + F3[0, 2] * F3[1, 2]
    byz = F3[1, 0] * F3[2, 0] + F3[1, 1] * F3[2, 1] + F3[1, 2] * F3[2, 2]
    bxz = F3[0, 0] * F3[2, 0] + F3[0, 1] * F3[2, 1] + F3[0, 2] * F3[2, 2]
    tr3 = (bxx + byy + bzz) / 3.0
    pres = 0.5 * K * (J - 1.0 / J)
    cj = cube_root(J)
    c = G / (J * cj * cj)  # G J^(-5/3) without the slow pow
    s[0] = pres + c * (bxx - tr3)
    s[1] = pres + c * (byy - tr3)
    s[2] = pres + c * (bzz - tr3)
    s[3] = c * bxy
    s[4] = c * byz
    s[5] = c * bxz
    # wave-speed modulus: tangent bulk modulus + 4/3 of the stretched shear modulus
    # (Gershgorin bound on the largest eigenvalue of B; exact at B = I)
    bmax = max(bxx + abs(bxy) + abs(bxz), max(byy + abs(bxy) + abs(byz), bzz + abs(bxz) + abs(byz)))
    return 0.5 * K * (J + 1.0 / J) + 4.0 / 3.0 * c * bmax


@njit(cache=True, inline="always")
def neo_hookean_stress_2d(K, G, J, f00, f01, f10, f11, s):
    """neo_hookean_stress for plane strain (F33 = 1, no out-of-plane entries), from F's four
    in-plane entries and J = f00 f11 - f01 f10: the same operations without the terms that are
    exactly zero, so the same numbers bit for bit (the zero shear terms come out +0, as there)."""
    bxx = f00 ** 2 + f01 ** 2
    byy = f10 ** 2 + f11 ** 2
    bxy = f00 * f10 + f01 * f11 + 0.0  # (+ 0.0: the 3D sum's last term, which turns -0 into +0)
    tr3 = (bxx + byy + 1.0) / 3.0
    pres = 0.5 * K * (J - 1.0 / J)
    cj = cube_root(J)
    c = G / (J * cj * cj)
    s[0] = pres + c * (bxx - tr3)
    s[1] = pres + c * (byy - tr3)
    s[2] = pres + c * (1.0 - tr3)
    s[3] = c * bxy
    s[4] = c * 0.0
    s[5] = c * 0.0
    bmax = max(bxx + abs(bxy) + 0.0, max(byy + abs(bxy) + 0.0, 1.0 + 0.0 + 0.0))
    return 0.5 * K * (J + 1.0 / J) + 4.0 / 3.0 * c * bmax


@njit(cache=True, inline="always")
def neo_hookean_energy(K, G, F3):
    """Strain energy per reference volume, Eq. (18)."""
    J = det3(F3)
    i1 = 0.0
    for a in range(3):
        for b in range(3):
            i1 += F3[a, b] * F3[a, b]
    return 0.5 * G * (i1 * J ** (-2.0 / 3.0) - 3.0) + 0.5 * K * (0.5 * (J * J - 1.0) - np.log(J))


@njit(cache=True, inline="always")
def stress_2d(pr, L, dt, F3, J, f00, f01, f10, f11, s, W, A, Ai, Q, eos, hs):
    return neo_hookean_stress_2d(pr[0], pr[1], J, f00, f01, f10, f11, s)


@njit(cache=True, inline="always")
def stress_3d(pr, L, dt, F3, J, f00, f01, f10, f11, s, W, A, Ai, Q, eos, hs):
    return neo_hookean_stress(pr[0], pr[1], F3, s)


@njit(cache=True, inline="always")
def energy(pr, F3, s, J):
    return neo_hookean_energy(pr[0], pr[1], F3) / J


@njit(cache=True, inline="always")
def bulk_modulus(pr, J, p):
    return 0.5 * pr[0] * (J + 1.0 / J)


MODEL = register(MaterialModel(
    "neo_hookean", NeoHookean, row, wave_modulus=lambda r: r[0] + 4.0 / 3.0 * r[1], energy=energy,
    bulk_modulus=bulk_modulus, stress_2d=stress_2d, stress_3d=stress_3d, reads_L_2d=False, reads_F3_2d=False),
    NEO_HOOKEAN)
