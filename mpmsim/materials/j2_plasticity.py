"""J2 (von Mises) plasticity at finite strain with isotropic hardening: the multiplicative split
F = Fe Fp, Hencky (logarithmic) elasticity and the exponential return map (Simo 1992,
doi:10.1016/0045-7825(92)90123-2; de Souza Neto, Peric, Owen 2008, ch. 14,
doi:10.1002/9780470694626).

Each particle keeps the elastic left Cauchy-Green tensor be = Fe Fe^T (as be - I: zero at the
start; see j2_stress), the equivalent plastic strain eps_p and the plastic work per unit mass. A stress update with the increment
f = F_{n+1} F_n^-1 (= I + dt L, the stress kernel's own increment):

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
q = sigma_y).
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
LINEAR, POWER, VOCE = 0, 1, 2
# property row: bulk and shear moduli, initial yield stress, law, its two constants, density
P_K, P_G, P_YIELD, P_LAW, P_H1, P_H2, P_RHO = range(7)
# material state row: be - I (Voigt xx yy zz xy yz xz), equivalent plastic strain, plastic work per unit mass
S_BE, S_EPS, S_WORK = 0, 6, 7
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


class J2Plasticity(Strict):
    """J2 (von Mises) plasticity at finite strain: F = Fe Fp, Hencky elasticity with moduli
    E and nu, the exponential return map, isotropic hardening of the flow stress sigma_y with
    the equivalent plastic strain eps_p (docs/materials.md)."""

    type: Literal["j2_plasticity"]
    E: float = Field(gt=0, description="Young's modulus (stress unit).")
    nu: float = Field(gt=-1.0, lt=0.5, description="Poisson's ratio, -1 < nu < 0.5.")
    density: float = Field(gt=0, description="Mass density (density unit of the deck's units).")
    yield_: float = Field(alias="yield", gt=0, description="Initial yield stress sigma_y0 > 0 (stress unit), "
                          "on the Kirchhoff stress.")
    hardening: Union[LinearHardening, PowerHardening, VoceHardening] = Field(
        default_factory=lambda: LinearHardening(law="linear", modulus=0.0), discriminator="law",
        description="Hardening law: {law: linear, modulus} (the default, modulus 0: perfectly plastic), "
                    "{law: power, K, n} or {law: voce, saturation, rate}.")


def row(m) -> np.ndarray:
    """[K, G, yield, law, h1, h2, density]"""
    out = np.zeros(NPROP)
    E, nu = m.E, m.nu
    h = m.hardening
    law, h1, h2 = ((LINEAR, h.modulus, 0.0) if h.law == "linear" else (POWER, h.K, h.n) if h.law == "power"
                   else (VOCE, h.saturation, h.rate))
    out[:7] = (E / (3.0 * (1.0 - 2.0 * nu)), E / (2.0 * (1.0 + nu)), m.yield_, law, h1, h2, m.density)
    return out


def check(m, dim: int) -> list[tuple[tuple, str]]:
    h = m.hardening
    if h.law == "voce" and h.saturation < m.yield_:
        return [(("hardening", "saturation"), f"the saturation stress {h.saturation:g} is below the yield stress "
                                               f"{m.yield_:g}: Voce hardening here does not soften")]
    return []


@njit(cache=True, inline="always")
def flow_stress(pr, eps):
    """(sigma_y, d sigma_y / d eps_p) at equivalent plastic strain eps."""
    y0, law, h1, h2 = pr[P_YIELD], pr[P_LAW], pr[P_H1], pr[P_H2]
    if law == LINEAR:
        return y0 + h1 * eps, h1
    if law == POWER:
        base = 1.0 + h1 * eps
        return y0 * base ** h2, y0 * h2 * h1 * base ** (h2 - 1.0)
    decay = np.exp(-h2 * eps)
    return y0 + (h1 - y0) * (1.0 - decay), (h1 - y0) * h2 * decay


@njit(cache=True, inline="always")
def plastic_multiplier(pr, G, q, eps):
    """dg >= 0 with q - 3 G dg = sigma_y(eps + dg), for a trial q > sigma_y(eps): closed form for
    linear hardening; otherwise Newton's method kept inside the bracket [lo, hi] where the
    residual changes sign (bisection when a step leaves it), to |step| <= 1e-14 dg."""
    if pr[P_LAW] == LINEAR:
        return (q - pr[P_YIELD] - pr[P_H1] * eps) / (3.0 * G + pr[P_H1])
    lo, hi = 0.0, q / (3.0 * G)  # residual > 0 at lo, <= 0 at hi (sigma_y >= 0)
    sy, h = flow_stress(pr, eps)
    dg = (q - sy) / (3.0 * G + h)
    for it in range(100):
        if not (lo < dg < hi):
            dg = 0.5 * (lo + hi)
        sy, h = flow_stress(pr, eps + dg)
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
    sy, _ = flow_stress(pr, eps)
    if q > sy:
        dg = plastic_multiplier(pr, G, q, eps)
        scale = 1.0 - 3.0 * G * dg / q
        d0 *= scale
        d1 *= scale
        d2 *= scale
        eps += dg
        sy, _ = flow_stress(pr, eps)
        hs[S_EPS] = eps
        hs[S_WORK] += dg * sy / pr[P_RHO]
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
    bulk_modulus=bulk_modulus, stress_2d=stress, stress_3d=stress, reads_F3_2d=False, check=check, state=STATE0,
    state_output={"plastic_strain": S_EPS, "plastic_work": S_WORK}, dissipation={"plastic_work": S_WORK}),
    J2_PLASTICITY)
