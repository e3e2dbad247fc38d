"""J2 (von Mises) plasticity at finite strain with isotropic hardening: the multiplicative split
F = Fe Fp, Hencky (logarithmic) elasticity and the exponential return map (Simo 1992,
doi:10.1016/0045-7825(92)90123-2; de Souza Neto, Peric, Owen 2008, ch. 14,
doi:10.1002/9780470694626).

Each particle keeps the elastic left Cauchy-Green tensor be = Fe Fe^T (as be - I: zero at the
start; see j2_stress), the equivalent plastic strain eps_p and the plastic work per unit mass.
A stress update with the increment f = F_{n+1} F_n^-1 (= I + dt L, the stress kernel's own):

1. be_tr = f be_n f^T; its spectral decomposition be_tr = sum_i lam_i^2 n_i (x) n_i (Jacobi,
   mpmsim.linalg.symmetric_eigen: no LAPACK);
2. trial principal logarithmic elastic strains e_i = 1/2 ln lam_i^2, Kirchhoff stress
   tau_i = K tr(e) + 2 G dev(e)_i;
3. von Mises test on the Kirchhoff stress, q = sqrt(3/2) |dev tau| against the flow stress
   sigma_y(eps_p); when q > sigma_y, radial return of dev(e) along its own direction by the
   plastic multiplier dg solving q - 3 G dg = sigma_y(eps_p + dg) (closed form for linear
   hardening, safeguarded Newton to 1e-14 relative otherwise);
4. be_{n+1} = sum_i exp(2 e_i) n_i (x) n_i, Cauchy stress sigma = tau / J.

The update uses only the invariant content of be_tr, so a rigid rotation of a state changes
its invariants by round-off only (exact objectivity), and on paths with fixed principal axes
it is exact in logarithmic strain for any step size. In plane strain the out-of-plane stretch
is 1 while be_zz evolves (the 3x3 be is kept). Plastic work per unit mass:
d w_p = dg sigma_y(eps_p + dg) / rho0 (= tau : d eps_p per unit mass, since the return leaves
q = sigma_y). Johnson-Cook hardening adds the rate of the step's plastic strain, dg / dt, and
the particle's temperature (state slot S_TEMP), raised by beta d w_p / c_p after each step.
"""

from __future__ import annotations

from typing import Literal, Union

import numpy as np
from numba import njit
from pydantic import Field

from .. import linalg
from ..schema_base import Strict
from .kernels import VOIGT, voigt_from_upper
from .model import J2_PLASTICITY, NPROP, MaterialModel, register

# hardening laws (property row slot LAW)
LINEAR, POWER, VOCE, JOHNSON_COOK = 0, 1, 2, 3
# property row: bulk and shear moduli, initial yield stress (Johnson-Cook: A), law, its two
# constants (Johnson-Cook: B, n), density; Johnson-Cook's rate and temperature constants and
# its adiabatic heating (Taylor-Quinney factor beta, heat capacity cp)
P_K, P_G, P_YIELD, P_LAW, P_H1, P_H2, P_RHO = range(7)
P_C, P_RATE0, P_TMELT, P_TROOM, P_M, P_BETA, P_CP = range(7, 14)
# material state row: be - I (Voigt xx yy zz xy yz xz), equivalent plastic strain, plastic work
# per unit mass; Johnson-Cook: temperature
S_BE, S_EPS, S_WORK, S_TEMP = 0, 6, 7, 8
STATE0 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
NEWTON_TOL = 1e-14


class LinearHardening(Strict):
    """sigma_y = yield + modulus eps_p."""

    law: Literal["linear"]
    modulus: float = Field(default=0.0, ge=0, description="Plastic (hardening) modulus H (stress unit): "
                           "sigma_y = yield + H eps_p; 0: perfectly plastic.")


class PowerHardening(Strict):
    """sigma_y = yield (1 + K eps_p)^n."""

    law: Literal["power"]
    K: float = Field(ge=0, description="Hardening coefficient K (dimensionless): sigma_y = yield (1 + K eps_p)^n.")
    n: float = Field(ge=0, description="Hardening exponent n (dimensionless), n >= 0.")


class VoceHardening(Strict):
    """sigma_y = yield + (saturation - yield)(1 - exp(-rate eps_p))."""

    law: Literal["voce"]
    saturation: float = Field(gt=0, description="Saturation flow stress sigma_s >= yield (stress unit): "
                              "sigma_y = yield + (sigma_s - yield)(1 - exp(-rate eps_p)).")
    rate: float = Field(ge=0, description="Saturation rate b (dimensionless), b >= 0.")


class JohnsonCookHardening(Strict):
    """sigma_y = (A + B eps_p^n)(1 + C ln max(rate*, 1))(1 - T*^m): rate* the step's plastic
    strain rate d eps_p / dt over reference_rate (rates below it take the quasi-static flow
    stress), T* = (T - room_temperature)/(melt_temperature - room_temperature) (T* <= 0: factor 1;
    T* >= 1: melted, sigma_y = 0). Each particle's temperature starts at room_temperature and
    rises adiabatically by taylor_quinney times the plastic work over heat_capacity; the flow
    stress of a step takes the temperature at its start."""

    law: Literal["johnson_cook"]
    A: float = Field(gt=0, description="Quasi-static yield stress A at room temperature (stress unit); "
                     "the material's `yield` is left out.")
    B: float = Field(ge=0, description="Strain-hardening coefficient B (stress unit).")
    n: float = Field(gt=0, description="Strain-hardening exponent n > 0.")
    C: float = Field(ge=0, description="Strain-rate coefficient C (dimensionless).")
    reference_rate: float = Field(gt=0, description="Reference plastic strain rate (1/time unit).")
    m: float = Field(gt=0, description="Thermal-softening exponent m > 0.")
    melt_temperature: float = Field(gt=0, description="Melting temperature T_m (K), above room_temperature.")
    room_temperature: float = Field(default=293.0, gt=0, description="Reference and initial temperature T_r (K).")
    heat_capacity: float = Field(gt=0, description="Specific heat capacity c_p (energy per unit mass per K: "
                                 "J/(kg K) in SI, mJ/(g K) = J/(kg K) in mm-g-ms).")
    taylor_quinney: float = Field(default=0.9, ge=0, le=1, description="Fraction of the plastic work that heats "
                                  "the particle (Taylor-Quinney factor beta).")


class J2Plasticity(Strict):
    """J2 (von Mises) plasticity at finite strain: F = Fe Fp, Hencky elasticity with moduli
    E and nu, the exponential return map, isotropic hardening of the flow stress sigma_y with
    the equivalent plastic strain eps_p (docs/materials.md)."""

    type: Literal["j2_plasticity"]
    E: float = Field(gt=0, description="Young's modulus (stress unit).")
    nu: float = Field(gt=-1.0, lt=0.5, description="Poisson's ratio, -1 < nu < 0.5.")
    density: float = Field(gt=0, description="Mass density (density unit of the deck's units).")
    yield_: float | None = Field(default=None, alias="yield", gt=0, description="Initial yield stress "
                                 "sigma_y0 > 0 (stress unit), on the Kirchhoff stress; required except with "
                                 "Johnson-Cook hardening (its A).")
    hardening: Union[LinearHardening, PowerHardening, VoceHardening, JohnsonCookHardening] = Field(
        default_factory=lambda: LinearHardening(law="linear", modulus=0.0), discriminator="law",
        description="Hardening law: {law: linear, modulus} (the default, modulus 0: perfectly plastic), "
                    "{law: power, K, n}, {law: voce, saturation, rate} or {law: johnson_cook, A, B, n, C, "
                    "reference_rate, m, melt_temperature, room_temperature, heat_capacity, taylor_quinney}.")


def row(m) -> np.ndarray:
    """[K, G, yield, law, h1, h2, density] (+ Johnson-Cook's [C, reference_rate, T_m, T_r, m,
    beta, c_p])"""
    out = np.zeros(NPROP)
    E, nu = m.E, m.nu
    h = m.hardening
    y0 = m.yield_ if m.yield_ is not None else 0.0
    if h.law == "johnson_cook":
        law, y0, h1, h2 = JOHNSON_COOK, h.A, h.B, h.n
        out[P_C:P_CP + 1] = (h.C, h.reference_rate, h.melt_temperature, h.room_temperature, h.m, h.taylor_quinney,
                             h.heat_capacity)
    else:
        law, h1, h2 = ((LINEAR, h.modulus, 0.0) if h.law == "linear" else (POWER, h.K, h.n) if h.law == "power"
                       else (VOCE, h.saturation, h.rate))
    out[:7] = (E / (3.0 * (1.0 - 2.0 * nu)), E / (2.0 * (1.0 + nu)), y0, law, h1, h2, m.density)
    return out


def check(m, dim: int) -> list[tuple[tuple, str]]:
    h = m.hardening
    if h.law == "johnson_cook":
        out = []
        if m.yield_ is not None:
            out.append((("yield",), "with johnson_cook hardening the initial yield stress is hardening.A: "
                                    "leave yield out"))
        if h.melt_temperature <= h.room_temperature:
            out.append((("hardening", "melt_temperature"), f"the melting temperature {h.melt_temperature:g} K must "
                                                           f"be above room_temperature ({h.room_temperature:g} K)"))
        return out
    if m.yield_ is None:
        return [(("yield",), f"required key is missing (the initial yield stress of {h.law} hardening)")]
    if h.law == "voce" and h.saturation < m.yield_:
        return [(("hardening", "saturation"), f"the saturation stress {h.saturation:g} is below the yield stress "
                                               f"{m.yield_:g}: Voce hardening here does not soften")]
    return []


def initial_state(m) -> tuple:
    """be - I = 0, eps_p = 0, no plastic work; Johnson-Cook: the temperature, room temperature."""
    h = m.hardening
    return STATE0 + ((h.room_temperature,) if h.law == "johnson_cook" else ())


def state_fields(m) -> dict:
    out = {"plastic_strain": S_EPS, "plastic_work": S_WORK}
    if m.hardening.law == "johnson_cook":
        out["temperature"] = S_TEMP
    return out


@njit(cache=True, inline="always")
def flow_stress(pr, eps, dg, dt, T):
    """(sigma_y, d sigma_y / d dg) at equivalent plastic strain eps = eps_n + dg after a step
    that adds dg in time dt, at temperature T (Johnson-Cook's rate and temperature factors;
    the other laws read eps only)."""
    y0, law, h1, h2 = pr[P_YIELD], pr[P_LAW], pr[P_H1], pr[P_H2]
    if law == LINEAR:
        return y0 + h1 * eps, h1
    if law == POWER:
        base = 1.0 + h1 * eps
        return y0 * base ** h2, y0 * h2 * h1 * base ** (h2 - 1.0)
    if law == VOCE:
        decay = np.exp(-h2 * eps)
        return y0 + (h1 - y0) * (1.0 - decay), (h1 - y0) * h2 * decay
    # Johnson-Cook
    hard = y0 + h1 * eps ** h2
    dhard = h2 * h1 * eps ** (h2 - 1.0) if eps > 0.0 else (h1 if h2 == 1.0 else (0.0 if h2 > 1.0 else np.inf))
    rate, drate = 1.0, 0.0
    x = dg / (dt * pr[P_RATE0]) if dt > 0.0 else 0.0
    if x > 1.0:
        rate, drate = 1.0 + pr[P_C] * np.log(x), pr[P_C] / dg
    ts = (T - pr[P_TROOM]) / (pr[P_TMELT] - pr[P_TROOM])
    heat = 1.0 if ts <= 0.0 else (0.0 if ts >= 1.0 else 1.0 - ts ** pr[P_M])
    return hard * rate * heat, (dhard * rate + hard * drate) * heat


@njit(cache=True, inline="always")
def plastic_multiplier(pr, G, q, eps, dt, T):
    """dg >= 0 with q - 3 G dg = sigma_y(eps + dg), for a trial q > sigma_y(eps): closed form for
    linear hardening; otherwise Newton's method kept inside the bracket [lo, hi] where the
    residual changes sign (bisection when a step leaves it), to |step| <= 1e-14 dg. A flow
    stress that vanishes (a melted Johnson-Cook particle) returns the whole deviator."""
    if pr[P_LAW] == LINEAR:
        return (q - pr[P_YIELD] - pr[P_H1] * eps) / (3.0 * G + pr[P_H1])
    lo, hi = 0.0, q / (3.0 * G)  # residual > 0 at lo, <= 0 at hi (sigma_y >= 0)
    sy, h = flow_stress(pr, eps + hi, hi, dt, T)
    if sy == 0.0:
        return hi
    sy, h = flow_stress(pr, eps, 0.0, dt, T)
    dg = (q - sy) / (3.0 * G + h)
    for it in range(100):
        if not (lo < dg < hi):
            dg = 0.5 * (lo + hi)
        sy, h = flow_stress(pr, eps + dg, dg, dt, T)
        r = q - 3.0 * G * dg - sy
        if r > 0.0:
            lo = dg
        elif r < 0.0:
            hi = dg
        else:
            return dg
        step = r / (3.0 * G + h)
        dg += step
        # converged: the step, or the residual at round-off of q, or the bracket
        if abs(step) <= NEWTON_TOL * dg or abs(r) <= 4e-16 * q or hi - lo <= NEWTON_TOL * lo:
            return dg
    return dg


@njit(cache=True, inline="always")
def j2_stress(pr, L, dt, J, s, h, B, work, vecs, hs):
    """The update of the module's text for one particle: hs its state row (in place), s its
    Cauchy stress (Voigt, written), h, B, work, vecs 3x3 scratch. Returns the wave modulus.

    The state holds be - I, not be: with f = I + h (h = dt L),
        be_tr - I = (h + h^T + h h^T) + f (be_n - I) f^T,
    and its eigenvalues mu_i give e_i = 1/2 log1p(mu_i); be_{n+1} - I = sum expm1(2 e_i) n_i (x) n_i.
    Elastic strains of metals are ~1e-3: be itself would hold them to 1e-16 of 1, i.e. three
    digits fewer than be - I does, and a long rigid spin would show it."""
    K, G = pr[P_K], pr[P_G]
    for a in range(3):
        for b in range(3):
            h[a, b] = dt * L[a, b]
            vecs[a, b] = hs[S_BE + VOIGT[a, b]]
    for a in range(3):  # work = f (be_n - I) = (be_n - I) + h (be_n - I)
        for b in range(3):
            r = vecs[a, b]
            for c in range(3):
                r += h[a, c] * vecs[c, b]
            work[a, b] = r
    for a in range(3):  # B = be_tr - I = work f^T + h + h^T + h h^T, symmetric by construction
        for b in range(a, 3):
            r = work[a, b]
            hh = h[a, b] + h[b, a]
            for c in range(3):
                r += work[a, c] * h[b, c]
                hh += h[a, c] * h[b, c]
            B[a, b] = r + hh
            B[b, a] = B[a, b]
    mu = s[0:3]  # (the stress row is the scratch of the eigenvalues: it is written last)
    linalg.symmetric_eigen(B, 3, work, mu, vecs)
    e0 = 0.5 * np.log1p(mu[0])
    e1 = 0.5 * np.log1p(mu[1])
    e2 = 0.5 * np.log1p(mu[2])
    tr = e0 + e1 + e2
    m = tr / 3.0
    d0, d1, d2 = e0 - m, e1 - m, e2 - m
    q = 2.0 * G * np.sqrt(1.5 * (d0 * d0 + d1 * d1 + d2 * d2))  # von Mises Kirchhoff stress
    eps = hs[S_EPS]
    jc = pr[P_LAW] == JOHNSON_COOK
    T = hs[S_TEMP] if jc else 0.0  # (the temperature at the step's start)
    sy, _ = flow_stress(pr, eps, 0.0, dt, T)
    if q > sy:
        dg = plastic_multiplier(pr, G, q, eps, dt, T)
        scale = 1.0 - 3.0 * G * dg / q
        d0 *= scale
        d1 *= scale
        d2 *= scale
        eps += dg
        sy, _ = flow_stress(pr, eps, dg, dt, T)
        hs[S_EPS] = eps
        dw = dg * sy / pr[P_RHO]
        hs[S_WORK] += dw
        if jc:  # adiabatic heating by the Taylor-Quinney share of the plastic work
            hs[S_TEMP] = T + pr[P_BETA] * dw / pr[P_CP]
    # be - I from the returned strains, tau_i = K tr + 2 G d_i, sigma = tau / J (axes: vecs)
    b0, b1, b2 = np.expm1(2.0 * (m + d0)), np.expm1(2.0 * (m + d1)), np.expm1(2.0 * (m + d2))
    p = K * tr
    t0, t1, t2 = (p + 2.0 * G * d0) / J, (p + 2.0 * G * d1) / J, (p + 2.0 * G * d2) / J
    for a in range(3):
        for b in range(a, 3):
            va0, va1, va2 = vecs[a, 0] * vecs[b, 0], vecs[a, 1] * vecs[b, 1], vecs[a, 2] * vecs[b, 2]
            hs[S_BE + VOIGT[a, b]] = b0 * va0 + b1 * va1 + b2 * va2
            work[a, b] = t0 * va0 + t1 * va1 + t2 * va2
    voigt_from_upper(work, s)
    # rho c^2 of the Hencky solid: the bulk part K (1 - ln J) / J (d p / d rho of p = -K ln J / J)
    return (K * (1.0 - np.log(J)) + 4.0 / 3.0 * G) / J


@njit(cache=True, inline="always")
def stress(pr, L, dt, F3, J, f00, f01, f10, f11, s, W, A, Ai, Q, eos, hs):
    return j2_stress(pr, L, dt, J, s, W, A, Ai, Q, hs)


@njit(cache=True, inline="always")
def energy(pr, F3, s, J):
    """Hencky stored energy per current volume from the stress: with tau = J sigma,
    W = |dev tau|^2 / (4 G) + (tr tau)^2 / (18 K) per reference volume, over J."""
    K, G = pr[P_K], pr[P_G]
    m = (s[0] + s[1] + s[2]) / 3.0
    dev2 = (s[0] - m) ** 2 + (s[1] - m) ** 2 + (s[2] - m) ** 2 + 2.0 * (s[3] ** 2 + s[4] ** 2 + s[5] ** 2)
    return J * (dev2 / (4.0 * G) + m * m / (2.0 * K))


@njit(cache=True, inline="always")
def bulk_modulus(pr, J, p):
    """J dp/d(eta) of the Hencky pressure p = -K ln J / J: K (1 - ln J) / J."""
    return pr[P_K] * (1.0 - np.log(J)) / J


MODEL = register(MaterialModel(
    "j2_plasticity", J2Plasticity, row, wave_modulus=lambda r: r[P_K] + 4.0 / 3.0 * r[P_G], energy=energy,
    bulk_modulus=bulk_modulus, stress_2d=stress, stress_3d=stress, reads_F3_2d=False, check=check, state=initial_state,
    state_output=state_fields, dissipation={"plastic_work": S_WORK}),
    J2_PLASTICITY)
