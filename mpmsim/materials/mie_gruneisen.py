"""Mie–Grüneisen solid for shocks (LR paper Eq. 51) with the neo-Hookean shear term: the
explicit MPM update, which also updates the internal energy U and the pressure."""

from __future__ import annotations

import numpy as np
from numba import njit
from pydantic import Field
from typing import Literal

from ..schema_base import Strict
from .kernels import EOS_DEN, EOS_J0, EOS_P, EOS_Q, EOS_RHO0, EOS_U, det3
from .model import MIE_GRUNEISEN, NPROP, MaterialModel, register
from .neo_hookean import neo_hookean_energy, neo_hookean_stress


class MieGruneisen(Strict):
    """Mie–Grüneisen solid for shocks, LR paper Eq. (51): in compression (eta = 1 - J > 0)
    p = K eta (1 - gamma0 eta/2) / (1 - S1 eta)^2 + rho0 gamma0 U, in tension p = K eta + rho0 gamma0 U,
    with U the internal energy per unit mass tracked on each particle; the deviatoric stress is
    the neo-Hookean shear term of Eq. (18). Its Hugoniot is the linear Us = C0 + S1 up,
    C0 = sqrt(K/rho0) (docs/shock.md)."""

    type: Literal["mie_gruneisen"]
    K: float = Field(gt=0, description="Bulk modulus rho0 C0^2 (stress unit).")
    G: float = Field(default=0.0, ge=0, description="Shear modulus of the neo-Hookean shear term (stress unit); "
                     "0: pressure only.")
    gamma0: float = Field(ge=0, description="Grüneisen parameter gamma0 (gamma rho = gamma0 rho0).")
    S1: float = Field(ge=0, description="Slope S1 of the linear shock-speed / particle-speed Hugoniot. The "
                      "pressure diverges at eta = 1/S1; a compression that reaches it stops the run.")
    density: float = Field(gt=0, description="Reference mass density rho0 (density unit of the deck's units).")


def row(m) -> np.ndarray:
    """[K, G, gamma0, S1]"""
    out = np.zeros(NPROP)
    out[:4] = (m.K, m.G, m.gamma0, m.S1)
    return out


@njit(cache=True, inline="always")
def mg_cold(K, gamma0, S1, eta):
    """Eq. (51) without the energy term, and its derivative d/d(eta). The Hugoniot branch
    applies in compression (eta = 1 - J > 0: the paper's case labels are swapped, since only
    there can 1 - S1 eta vanish); tension is linear. Returns (p, dp/deta, 1 - S1 eta)."""
    if eta <= 0.0:
        return K * eta, K, 1.0
    d = 1.0 - S1 * eta
    f = eta * (1.0 - 0.5 * gamma0 * eta)
    return K * f / (d * d), K * ((1.0 - gamma0 * eta) / (d * d) + 2.0 * S1 * f / (d * d * d)), d


@njit(cache=True, inline="always")
def mie_gruneisen_stress(K, G, gamma0, S1, F3, s, eos):
    """Mie–Grüneisen pressure (Eq. 51) with the neo-Hookean shear term of Eq. (18).

    The energy update is the trapezoidal rule on the increment J0 -> J:
        U = U0 - ((p0 + p) / 2 + q) (J - J0) / rho0,   p = p_c(J) + rho0 gamma0 U,
    solved exactly for the end-of-increment U (p is linear in U). Using the end value makes
    each increment a discrete Rankine–Hugoniot energy jump (mean pressure times volume change),
    so the EOS lands on the linear Us-up Hugoniot; an explicit U0 lags the pressure by the
    energy the increment deposits, which at a shock is most of it. Returns the wave modulus
    J dp/deta|_S (with dU = p deta / rho0 along the isentrope) + 4/3 of the stretched shear."""
    p, bulk = mg_pressure(K, gamma0, S1, det3(F3), eos)
    shear = neo_hookean_stress(0.0, G, F3, s)  # deviatoric part only (K = 0)
    for a in range(3):
        s[a] -= p
    return bulk + shear


@njit(cache=True, inline="always")
def mg_pressure(K, gamma0, S1, J, eos):
    """The pressure of Eq. (51) at J with the energy update of mie_gruneisen_stress, written into the eos row (U, p,
    1 - S1 eta); returns (p, J dp/deta|_S). Shared by every model with this equation of state."""
    eta = 1.0 - J
    U0, p0, q, J0, rho0 = eos[EOS_U], eos[EOS_P], eos[EOS_Q], eos[EOS_J0], eos[EOS_RHO0]
    pc, dpc, den = mg_cold(K, gamma0, S1, eta)
    dJ = J - J0
    U = (U0 - (0.5 * (p0 + pc) + q) * dJ / rho0) / (1.0 + 0.5 * gamma0 * dJ)
    p = pc + rho0 * gamma0 * U
    eos[EOS_U] = U
    eos[EOS_P] = p
    eos[EOS_DEN] = den
    return p, J * (dpc + gamma0 * p)


@njit(cache=True, inline="always")
def stress(pr, L, dt, F3, J, f00, f01, f10, f11, s, W, A, Ai, Q, eos, hs):
    return mie_gruneisen_stress(pr[0], pr[1], pr[2], pr[3], F3, s, eos)


@njit(cache=True, inline="always")
def energy(pr, F3, s, J):
    """The shear part (the volumetric part is in the internal energy U)."""
    return neo_hookean_energy(0.0, pr[1], F3) / J


@njit(cache=True, inline="always")
def bulk_modulus(pr, J, p):
    _, dpc, _ = mg_cold(pr[0], pr[2], pr[3], 1.0 - J)
    return J * (dpc + pr[2] * p)


MODEL = register(MaterialModel(
    "mie_gruneisen", MieGruneisen, row, wave_modulus=lambda r: r[0] + 4.0 / 3.0 * r[1], energy=energy,
    bulk_modulus=bulk_modulus, stress_2d=stress, stress_3d=stress, internal_energy=True), MIE_GRUNEISEN)
