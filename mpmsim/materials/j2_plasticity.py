"""J2 (von Mises) plasticity at finite strain with isotropic hardening: the multiplicative split
F = Fe Fp, Hencky (logarithmic) elasticity and the exponential return map (Simo 1992,
doi:10.1016/0045-7825(92)90123-2; de Souza Neto, Peric, Owen 2008, ch. 14,
doi:10.1002/9780470694626).

Each particle keeps the elastic left Cauchy-Green tensor be = Fe Fe^T (as be - I: zero at the
start; see j2_stress), the equivalent plastic strain eps_p and the plastic work per unit mass.
A stress update with the increment f = F_{n+1} F_n^-1 (= I + dt L, the stress kernel's own):

1. be_tr = f be_n f^T; its logarithm, the trial logarithmic elastic strain e = 1/2 ln be_tr
   (a power series of be_tr - I where that is small, as a metal's elastic strains always are;
   else by the spectral decomposition be_tr = sum_i lam_i^2 n_i (x) n_i, Jacobi,
   mpmsim.linalg.symmetric_eigen: no LAPACK);
2. the trial Kirchhoff stress tau = K tr(e) I + 2 G dev(e);
3. von Mises test on the Kirchhoff stress, q = sqrt(3/2) |dev tau| against the flow stress
   sigma_y(eps_p); when q > sigma_y, radial return of dev(e) along its own direction by the
   plastic multiplier dg solving q - 3 G dg = sigma_y(eps_p + dg) (closed form for linear
   hardening, safeguarded Newton to 1e-14 relative otherwise);
4. be_{n+1} = exp(2 e_{n+1}) (be_tr itself after an elastic step), Cauchy stress sigma = tau / J.

The update uses only the invariant content of be_tr, so a rigid rotation of a state changes
its invariants by round-off only (exact objectivity), and on paths with fixed principal axes
it is exact in logarithmic strain for any step size. In plane strain the out-of-plane stretch
is 1 while be_zz evolves (the 3x3 be is kept). Plastic work per unit mass:
d w_p = dg sigma_y(eps_p + dg) / rho0 (= tau : d eps_p per unit mass, since the return leaves
q = sigma_y). Johnson-Cook hardening adds the rate of the step's plastic strain, dg / dt, and
the particle's temperature (state slot S_TEMP), raised by beta d w_p / c_p after each step.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Literal, Union

import numpy as np
from numba import njit
from pydantic import Field

from .. import linalg
from ..schema_base import Strict
from .kernels import VOIGT, voigt_from_upper
from .mie_gruneisen import mg_cold, mg_pressure
from .model import J2_MIE_GRUNEISEN, J2_PLASTICITY, NPROP, MaterialModel, register

# hardening laws (property row slot LAW)
LINEAR, POWER, VOCE, JOHNSON_COOK = 0, 1, 2, 3
# property row: bulk and shear moduli, initial yield stress (Johnson-Cook: A), law, its two
# constants (Johnson-Cook: B, n), density; Johnson-Cook's rate and temperature constants and
# its adiabatic heating (Taylor-Quinney factor beta, heat capacity cp)
P_K, P_G, P_YIELD, P_LAW, P_H1, P_H2, P_RHO = range(7)
P_C, P_RATE0, P_TMELT, P_TROOM, P_M, P_BETA, P_CP = range(7, 14)
# with a Mie-Grüneisen equation of state: its Grüneisen parameter and Hugoniot slope
P_GAMMA0, P_S1 = 14, 15
# material state row: be - I (Voigt xx yy zz xy yz xz), equivalent plastic strain, plastic work
# per unit mass; Johnson-Cook: temperature
S_BE, S_EPS, S_WORK, S_TEMP = 0, 6, 7, 8
STATE0 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
NEWTON_TOL = 1e-14
# |be_tr - I| (Frobenius) up to which log and exp are summed as series (j2_stress), and their stop
SERIES_RADIUS = 0.1
SERIES_STOP = 2.0 ** -56


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


class MieGruneisenEOS(Strict):
    """The Mie-Grüneisen pressure of the LR paper's Eq. (51) with the bulk modulus K = E/(3(1 - 2 nu))
    and the particle's internal energy (docs/shock.md), in place of Hencky's."""

    type: Literal["mie_gruneisen"]
    gamma0: float = Field(ge=0, description="Grüneisen parameter gamma0 (gamma rho = gamma0 rho0).")
    S1: float = Field(ge=0, description="Slope S1 of the linear shock-speed / particle-speed Hugoniot "
                      "(Us = C0 + S1 up, C0 = sqrt(K / density)).")


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
    eos: MieGruneisenEOS | None = Field(
        default=None, description="Equation of state for the pressure: {type: mie_gruneisen, gamma0, S1}, the "
        "Mie-Grüneisen pressure (LR paper Eq. 51, K = E/(3(1 - 2 nu)), the particle's internal energy tracked) "
        "with the J2 deviator; none: Hencky's p = -K ln J / J.")


def row(m) -> np.ndarray:
    """[K, G, yield, law, h1, h2, density] (+ Johnson-Cook's [C, reference_rate, T_m, T_r, m,
    beta, c_p]; + a Mie-Grüneisen eos's [gamma0, S1])"""
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
    if m.eos is not None:
        out[P_GAMMA0], out[P_S1] = m.eos.gamma0, m.eos.S1
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
def thermal_factor(pr, T):
    """Johnson-Cook's thermal softening 1 - T*^m at temperature T (0 when melted); 1 for the
    other laws."""
    if pr[P_LAW] != JOHNSON_COOK:
        return 1.0
    ts = (T - pr[P_TROOM]) / (pr[P_TMELT] - pr[P_TROOM])
    return 1.0 if ts <= 0.0 else (0.0 if ts >= 1.0 else 1.0 - ts ** pr[P_M])


@njit(cache=True, inline="always")
def flow_stress(pr, eps, dg, dt, heat):
    """(sigma_y, d sigma_y / d dg) at equivalent plastic strain eps = eps_n + dg after a step
    that adds dg in time dt, with Johnson-Cook's rate factor and its thermal factor `heat`
    (thermal_factor at the step's starting temperature); the other laws read eps only."""
    y0, law, h1, h2 = pr[P_YIELD], pr[P_LAW], pr[P_H1], pr[P_H2]
    if law == LINEAR:
        return y0 + h1 * eps, h1
    if law == POWER:
        base = 1.0 + h1 * eps
        lower = base ** (h2 - 1.0)
        return y0 * lower * base, y0 * h2 * h1 * lower
    if law == VOCE:
        decay = np.exp(-h2 * eps)
        return y0 + (h1 - y0) * (1.0 - decay), (h1 - y0) * h2 * decay
    # Johnson-Cook
    if eps > 0.0:
        lower = eps ** (h2 - 1.0)  # (one power for the hardening and its slope)
        hard, dhard = y0 + h1 * lower * eps, h2 * h1 * lower
    else:
        hard, dhard = y0, (h1 if h2 == 1.0 else (0.0 if h2 > 1.0 else np.inf))
    rate, drate = 1.0, 0.0
    x = dg / (dt * pr[P_RATE0]) if dt > 0.0 else 0.0
    if x > 1.0:
        rate, drate = 1.0 + pr[P_C] * np.log(x), pr[P_C] / dg
    return hard * rate * heat, (dhard * rate + hard * drate) * heat


@njit(cache=True, inline="always")
def plastic_multiplier(pr, G, q, eps, dt, heat, sy, h):
    """dg >= 0 with q - 3 G dg = sigma_y(eps + dg), for a trial q > sigma_y(eps) = sy (slope h):
    closed form for linear hardening; otherwise Newton's method kept inside the bracket [lo, hi]
    where the residual changes sign (bisection when a step leaves it), to |step| <= 1e-14 dg.
    A flow stress that vanishes (a melted Johnson-Cook particle, heat 0) returns the whole
    deviator."""
    if pr[P_LAW] == LINEAR:
        return (q - pr[P_YIELD] - pr[P_H1] * eps) / (3.0 * G + pr[P_H1])
    lo, hi = 0.0, q / (3.0 * G)  # residual > 0 at lo, <= 0 at hi (sigma_y >= 0)
    if heat == 0.0:
        return hi
    dg = (q - sy) / (3.0 * G + h)
    for it in range(100):
        if not (lo < dg < hi):
            dg = 0.5 * (lo + hi)
        sy, h = flow_stress(pr, eps + dg, dg, dt, heat)
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
def sym_product(a, b):
    """The product a b of two commuting symmetric 3x3 tensors (Voigt 6-tuples: xx yy zz xy yz
    xz), itself symmetric; here a polynomial in b times b."""
    return (a[0] * b[0] + a[3] * b[3] + a[5] * b[5],
            a[3] * b[3] + a[1] * b[1] + a[4] * b[4],
            a[5] * b[5] + a[4] * b[4] + a[2] * b[2],
            a[0] * b[3] + a[3] * b[1] + a[5] * b[4],
            a[3] * b[5] + a[1] * b[4] + a[4] * b[2],
            a[0] * b[5] + a[3] * b[4] + a[5] * b[2])


@njit(cache=True, inline="always")
def sym_axpy(c, a, b):
    """b + c a for Voigt 6-tuples."""
    return (b[0] + c * a[0], b[1] + c * a[1], b[2] + c * a[2], b[3] + c * a[3], b[4] + c * a[4], b[5] + c * a[5])


@njit(cache=True, inline="always")
def sym_amax(a):
    return max(abs(a[0]), abs(a[1]), abs(a[2]), abs(a[3]), abs(a[4]), abs(a[5]))


@njit(cache=True, inline="always")
def half_log1p(b):
    """1/2 log(I + b) for a symmetric b with |b| <= SERIES_RADIUS (Frobenius), by Gregory's series
    log(I + b) = 2 artanh(x) = 2 x (I + x^2/3 + x^4/5 + ...), x = b (2 I + b)^-1 (a function of b:
    it commutes with b, and |x| ~ |b| / 2), summed by Horner's rule in x^2 up to the first term
    below 2^-56 of x (3 terms at |b| = 1e-3, 4 at 1e-2, 7 at 0.1)."""
    m00, m11, m22, m01, m12, m02 = 2.0 + b[0], 2.0 + b[1], 2.0 + b[2], b[3], b[4], b[5]
    c00, c11, c22 = m11 * m22 - m12 * m12, m00 * m22 - m02 * m02, m00 * m11 - m01 * m01
    c01, c12, c02 = m02 * m12 - m01 * m22, m01 * m02 - m00 * m12, m01 * m12 - m02 * m11
    r = 1.0 / (m00 * c00 + m01 * c01 + m02 * c02)  # (2 I + b)^-1 = cofactors / det
    x = sym_product(b, (c00 * r, c11 * r, c22 * r, c01 * r, c12 * r, c02 * r))
    x2 = sym_product(x, x)
    r2 = x2[0] + x2[1] + x2[2]  # |x|^2: the series' ratio
    n = 0
    bound = 1.0
    while n < 40 and bound > SERIES_STOP * (2 * n + 1):
        n += 1
        bound *= r2
    c = 1.0 / (2 * n - 1)  # (n >= 1: the terms x^(2j) / (2j + 1), j < n; the first left out is below the stop)
    total = (c, c, c, 0.0, 0.0, 0.0)
    for j in range(n - 2, -1, -1):
        total = sym_product(total, x2)
        c = 1.0 / (2 * j + 1)
        total = (total[0] + c, total[1] + c, total[2] + c, total[3], total[4], total[5])
    return sym_product(x, total)


@njit(cache=True, inline="always")
def expm1_sym(x):
    """exp(x) - I = sum_k x^k / k! for a small symmetric x, summed as half_log1p is."""
    total = x
    term = x
    stop = SERIES_STOP * sym_amax(x)
    for k in range(2, 64):
        term = sym_product(term, x)
        c = 1.0 / k
        term = (c * term[0], c * term[1], c * term[2], c * term[3], c * term[4], c * term[5])
        total = sym_axpy(1.0, term, total)
        if sym_amax(term) <= stop:
            break
    return total


@njit(cache=True, inline="always")
def radial_return(pr, G, q, dt, hs):
    """The von Mises test of a trial Kirchhoff stress of equivalent value q and, when it yields,
    the return: the state row hs (plastic strain, work, temperature) advanced, and the factor on
    the trial deviatoric strain returned (1: elastic)."""
    eps = hs[S_EPS]
    jc = pr[P_LAW] == JOHNSON_COOK
    T = hs[S_TEMP] if jc else 0.0  # (the temperature at the step's start)
    heat = thermal_factor(pr, T)
    sy, h = flow_stress(pr, eps, 0.0, dt, heat)
    if not q > sy:
        return 1.0
    dg = plastic_multiplier(pr, G, q, eps, dt, heat, sy, h)
    hs[S_EPS] = eps + dg
    dw = dg * (q - 3.0 * G * dg) / pr[P_RHO]  # dg sigma_y(eps + dg): the return meets the flow stress
    hs[S_WORK] += dw
    if jc:  # adiabatic heating by the Taylor-Quinney share of the plastic work
        hs[S_TEMP] = T + pr[P_BETA] * dw / pr[P_CP]
    return 1.0 - 3.0 * G * dg / q


@njit(cache=True, inline="always")
def trial_be(L, dt, hs):
    """be_tr - I = (h + h^T + h h^T) + f (be_n - I) f^T with f = I + h, h = dt L, be_n - I the
    state row's (Voigt 6-tuple out). In scalar locals: loops over scratch arrays would be
    reloaded at every step, since the compiler must assume they overlap what they read."""
    a = (hs[S_BE], hs[S_BE + 1], hs[S_BE + 2], hs[S_BE + 3], hs[S_BE + 4], hs[S_BE + 5])
    h00, h01, h02 = dt * L[0, 0], dt * L[0, 1], dt * L[0, 2]
    h10, h11, h12 = dt * L[1, 0], dt * L[1, 1], dt * L[1, 2]
    h20, h21, h22 = dt * L[2, 0], dt * L[2, 1], dt * L[2, 2]
    w00 = a[0] + h00 * a[0] + h01 * a[3] + h02 * a[5]  # w = f (be_n - I)
    w01 = a[3] + h00 * a[3] + h01 * a[1] + h02 * a[4]
    w02 = a[5] + h00 * a[5] + h01 * a[4] + h02 * a[2]
    w10 = a[3] + h10 * a[0] + h11 * a[3] + h12 * a[5]
    w11 = a[1] + h10 * a[3] + h11 * a[1] + h12 * a[4]
    w12 = a[4] + h10 * a[5] + h11 * a[4] + h12 * a[2]
    w20 = a[5] + h20 * a[0] + h21 * a[3] + h22 * a[5]
    w21 = a[4] + h20 * a[3] + h21 * a[1] + h22 * a[4]
    w22 = a[2] + h20 * a[5] + h21 * a[4] + h22 * a[2]
    return ((w00 + w00 * h00 + w01 * h01 + w02 * h02) + (h00 + h00 + h00 * h00 + h01 * h01 + h02 * h02),
            (w11 + w10 * h10 + w11 * h11 + w12 * h12) + (h11 + h11 + h10 * h10 + h11 * h11 + h12 * h12),
            (w22 + w20 * h20 + w21 * h21 + w22 * h22) + (h22 + h22 + h20 * h20 + h21 * h21 + h22 * h22),
            (w01 + w00 * h10 + w01 * h11 + w02 * h12) + (h01 + h10 + h00 * h10 + h01 * h11 + h02 * h12),
            (w12 + w10 * h20 + w11 * h21 + w12 * h22) + (h12 + h21 + h10 * h20 + h11 * h21 + h12 * h22),
            (w02 + w00 * h20 + w01 * h21 + w02 * h22) + (h02 + h20 + h00 * h20 + h01 * h21 + h02 * h22))


@njit(cache=True, inline="always")
def j2_stress(pr, L, dt, J, s, h, B, work, vecs, hs):
    """The update of the module's text for one particle: hs its state row (in place), s its
    Cauchy stress (Voigt, written), h, B, work, vecs 3x3 scratch. Returns the wave modulus.

    The state holds be - I, not be: with f = I + h (h = dt L),
        be_tr - I = (h + h^T + h h^T) + f (be_n - I) f^T.
    Elastic strains of metals are ~1e-3: be itself would hold them to 1e-16 of 1, i.e. three
    digits fewer than be - I does, and a long rigid spin would show it.

    Where |be_tr - I| <= SERIES_RADIUS (Frobenius; every elastic strain a metal reaches) the
    logarithm is summed as a series in be_tr - I (the same tensor as the spectral form, to
    round-off, at a fraction of Jacobi's cost); an elastic step keeps be_tr - I as it is, a
    plastic one multiplies be_tr by exp(-2 (1 - scale) dev e), the return's own factor (it
    commutes with be_tr), whose series is short: its argument is the step's plastic strain.
    Larger elastic strains take the spectral path: eigenvalues mu_i of be_tr - I,
    e_i = 1/2 log1p(mu_i), be_{n+1} - I = sum expm1(2 e_i) n_i (x) n_i."""
    K, G = pr[P_K], pr[P_G]
    bt = trial_be(L, dt, hs)
    tangent = (K * (1.0 - np.log(J)) + 4.0 / 3.0 * G) / J  # rho c^2 of the Hencky solid (d p / d rho
    # of p = -K ln J / J gives the bulk part K (1 - ln J) / J)
    if bt[0] ** 2 + bt[1] ** 2 + bt[2] ** 2 + 2.0 * (bt[3] ** 2 + bt[4] ** 2 + bt[5] ** 2) <= SERIES_RADIUS ** 2:
        e = half_log1p(bt)
        tr = e[0] + e[1] + e[2]
        m = tr / 3.0
        d = (e[0] - m, e[1] - m, e[2] - m, e[3], e[4], e[5])
        q = 2.0 * G * np.sqrt(1.5 * (d[0] ** 2 + d[1] ** 2 + d[2] ** 2 + 2.0 * (d[3] ** 2 + d[4] ** 2 + d[5] ** 2)))
        scale = radial_return(pr, G, q, dt, hs)
        be = bt
        if scale != 1.0:  # be = be_tr exp(-2 (1 - scale) dev e): the plastic step's factor is near I
            y = expm1_sym(sym_axpy(-2.0 * (1.0 - scale), d, (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)))
            be = sym_axpy(1.0, sym_product(bt, y), sym_axpy(1.0, y, bt))
            d = (scale * d[0], scale * d[1], scale * d[2], scale * d[3], scale * d[4], scale * d[5])
        p = K * tr
        for i in range(6):
            hs[S_BE + i] = be[i]
            s[i] = ((p if i < 3 else 0.0) + 2.0 * G * d[i]) / J
        return tangent
    return spectral_return(pr, K, G, J, dt, tangent, bt, s, B, work, vecs, hs)


@njit(cache=True)
def spectral_return(pr, K, G, J, dt, tangent, bt, s, B, work, vecs, hs):
    """j2_stress past the series' radius: the return map on the eigenvalues of be_tr - I (Jacobi),
    compiled once and called, not inlined: the rare large-strain path is most of the update's
    code, and every stress kernel (2D, r-z, 3D, the Mie-Grueneisen form) links this one copy.
    Returns the wave modulus `tangent`."""
    for a in range(3):
        for b in range(3):
            B[a, b] = bt[VOIGT[a, b]]
    mu = s[0:3]  # (the stress row is the scratch of the eigenvalues: it is written last)
    linalg.symmetric_eigen(B, 3, work, mu, vecs)
    e0 = 0.5 * np.log1p(mu[0])
    e1 = 0.5 * np.log1p(mu[1])
    e2 = 0.5 * np.log1p(mu[2])
    tr = e0 + e1 + e2
    m = tr / 3.0
    d0, d1, d2 = e0 - m, e1 - m, e2 - m
    scale = radial_return(pr, G, 2.0 * G * np.sqrt(1.5 * (d0 * d0 + d1 * d1 + d2 * d2)), dt, hs)
    d0 *= scale
    d1 *= scale
    d2 *= scale
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
    return tangent


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


@njit(cache=True, inline="always")
def stress_mie_gruneisen(pr, L, dt, F3, J, f00, f01, f10, f11, s, W, A, Ai, Q, eos, hs):
    """The J2 update's deviatoric Cauchy stress with the Mie-Grüneisen pressure of mie_gruneisen.py
    (and its internal-energy update) in place of Hencky's; wave modulus J dp/deta|_S + 4/3 G / J."""
    j2_stress(pr, L, dt, J, s, W, A, Ai, Q, hs)
    mean = (s[0] + s[1] + s[2]) / 3.0
    p, bulk = mg_pressure(pr[P_K], pr[P_GAMMA0], pr[P_S1], J, eos)
    for a in range(3):
        s[a] = (s[a] - mean) - p
    return bulk + 4.0 / 3.0 * pr[P_G] / J


@njit(cache=True, inline="always")
def energy_deviatoric(pr, F3, s, J):
    """The Hencky shear energy per current volume, J |dev sigma|^2 / (4 G) (the volumetric part is
    in the internal energy U)."""
    m = (s[0] + s[1] + s[2]) / 3.0
    dev2 = (s[0] - m) ** 2 + (s[1] - m) ** 2 + (s[2] - m) ** 2 + 2.0 * (s[3] ** 2 + s[4] ** 2 + s[5] ** 2)
    return J * dev2 / (4.0 * pr[P_G])


@njit(cache=True, inline="always")
def bulk_modulus_mie_gruneisen(pr, J, p):
    _, dpc, _ = mg_cold(pr[P_K], pr[P_GAMMA0], pr[P_S1], 1.0 - J)
    return J * (dpc + pr[P_GAMMA0] * p)


MODEL = register(MaterialModel(
    "j2_plasticity", J2Plasticity, row, wave_modulus=lambda r: r[P_K] + 4.0 / 3.0 * r[P_G], energy=energy,
    bulk_modulus=bulk_modulus, stress_2d=stress, stress_3d=stress, reads_F3_2d=False, check=check, state=initial_state,
    state_output=state_fields, dissipation={"plastic_work": S_WORK},
    variant=lambda m: "j2_plasticity_mie_gruneisen" if m.eos is not None else None),
    J2_PLASTICITY)
# the same deck type with `eos: mie_gruneisen`: its kernel tracks each particle's internal energy
MIE_GRUNEISEN_MODEL = register(replace(
    MODEL, name="j2_plasticity_mie_gruneisen", energy=energy_deviatoric, bulk_modulus=bulk_modulus_mie_gruneisen,
    stress_2d=stress_mie_gruneisen, stress_3d=stress_mie_gruneisen, internal_energy=True, variant=None, tag=""),
    J2_MIE_GRUNEISEN)
