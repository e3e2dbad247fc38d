"""Cohesive traction-separation laws with damage, for interfaces between materials.

An interface that fails: it carries traction like an imperfect interface (docs/interfaces.md)
until its opening reaches a peak traction, then softens with a scalar damage d (0 intact, 1
failed) that never decreases, unloads and reloads towards the origin along the damaged stiffness
(1 - d) K, and, once failed, hands the pair to a contact law. Compression never softens: a
closing normal keeps the intact stiffness.

Openings and tractions. dn is the normal opening (> 0 opening), dt the magnitude of the
tangential opening; Kn, Kt the intact stiffnesses. The law works in *scaled* openings

    yn = sqrt(Kn) <dn>,   yt = sqrt(Kt) |dt|,   lam = sqrt(yn^2 + yt^2),

in which it is isotropic with unit stiffness: the stored energy per area is (1 - d) lam^2 / 2,
the normal traction (1 - d) Kn dn (Kn dn in compression), the tangential (1 - d) Kt dt, and
B = yt^2 / lam^2 is the mode mixity (G_II over G_I + G_II under proportional loading). With
Kn = Kt this is Camanho and Davila's mixed-mode formulation (NASA/TM-2002-211737); the scaling
lets the two stiffnesses differ without changing it.

- Onset (bilinear): the quadratic traction criterion (sigma/sigma_c)^2 + (tau/tau_c)^2 = 1,
  lam0(B) = 1 / sqrt((1 - B) / yn0^2 + B / yt0^2), yn0 = sigma_c / sqrt(Kn), yt0 = tau_c / sqrt(Kt).
- Toughness at mixity B: the power law (G_I / G_Ic)^a + (G_II / G_IIc)^a = 1, or
  Benzeggagh and Kenane's G_c = G_Ic + (G_IIc - G_Ic) B^eta (Compos. Sci. Technol. 56 (1996)
  439, doi:10.1016/0266-3538(96)00005-X).
- bilinear (triangular): in lam, a line of unit slope to lam0, then straight to zero at
  lamf = 2 G_c(B) / lam0; d(kappa) = lamf (kappa - lam0) / (kappa (lamf - lam0)), kappa the
  largest lam so far. The triangle's area is G_c(B).
- exponential: Xu and Needleman's normal law (J. Mech. Phys. Solids 42 (1994) 1397,
  doi:10.1016/0022-5096(94)90003-5), T = e sigma_c (dn / dc) exp(-dn / dc), G_Ic = e sigma_c dc,
  taken in the effective opening as Ortiz and Pandolfi do (Int. J. Numer. Meth. Eng. 44 (1999)
  1267): in lam, T = lam exp(-lam / lamc), lamc = sqrt(G_c(B)), so d(kappa) = 1 - exp(-kappa /
  lamc); the intact stiffness follows from the law, Kn = (e sigma_c)^2 / G_Ic, Kt = (e tau_c)^2
  / G_IIc. It fails (d = 1) where what is left to dissipate, (1 + x) exp(-x) of G_c with x =
  kappa / lamc, falls below 1e-12 (x > 32).

The damage carried from step to step is d itself (the particles carry it, mpmsim/contact/
cohesive_history.py): d_new = max(d_old, d(lam, B)). What a damage change dissipates is exact in
d at fixed mixity (`dissipation`): the integral of lam(d)^2 / 2 dd, which sums to G_c(B) from
intact to failed along any loading path of constant mixity.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

BILINEAR, EXPONENTIAL = 0, 1
SHAPE_CODES = {"bilinear": BILINEAR, "exponential": EXPONENTIAL}
POWER_LAW, BK = 0, 1
MIXED_CODES = {"power_law": POWER_LAW, "bk": BK}
X_FAIL = 32.0  # exponential: failed where kappa / lamc exceeds this ((1 + x) e^-x < 1e-12)

# the parameter vector of one cohesive law (a pair's row in the law table)
SHAPE, MIXED, EXPONENT, SQRT_KN, SQRT_KT, YN0, YT0, GIC, GIIC, N_PARAMS = range(10)


def law_parameters(shape: str, sigma_c: float, tau_c: float, GIc: float, GIIc: float, Kn: float | None = None,
                   Kt: float | None = None, mixed: str = "bk", exponent: float = 2.0) -> np.ndarray:
    """The parameter vector of a law. Kn, Kt: the bilinear law's intact stiffnesses (the
    exponential law sets its own); exponent: the power law's a or BK's eta."""
    p = np.zeros(N_PARAMS)
    p[SHAPE] = SHAPE_CODES[shape]
    p[MIXED] = MIXED_CODES[mixed]
    p[EXPONENT] = exponent
    p[GIC], p[GIIC] = GIc, GIIc
    if shape == "exponential":
        Kn, Kt = (math.e * sigma_c) ** 2 / GIc, (math.e * tau_c) ** 2 / GIIc
    p[SQRT_KN], p[SQRT_KT] = math.sqrt(Kn), math.sqrt(Kt)
    p[YN0], p[YT0] = sigma_c / p[SQRT_KN], tau_c / p[SQRT_KT]
    return p


def stiffnesses(p: np.ndarray) -> tuple[float, float]:
    """The intact (Kn, Kt)."""
    return float(p[SQRT_KN] ** 2), float(p[SQRT_KT] ** 2)


@njit(cache=True, inline="always")
def scaled_opening(dn, dt, p):
    """(lam, B): the scaled effective opening and the mode mixity of openings dn (normal), dt
    (tangential magnitude). A closed normal contributes nothing; B = 0 at lam = 0."""
    yn = p[SQRT_KN] * max(dn, 0.0)
    yt = p[SQRT_KT] * abs(dt)
    lam2 = yn * yn + yt * yt
    if lam2 == 0.0:
        return 0.0, 0.0
    return math.sqrt(lam2), yt * yt / lam2


@njit(cache=True, inline="always")
def toughness(B, p):
    """G_c at mixity B by the law's mixed-mode criterion."""
    g1, g2, a = p[GIC], p[GIIC], p[EXPONENT]
    if p[MIXED] == BK:
        return g1 + (g2 - g1) * B ** a
    s = 0.0
    if B < 1.0:
        s += ((1.0 - B) / g1) ** a
    if B > 0.0:
        s += (B / g2) ** a
    return s ** (-1.0 / a)


@njit(cache=True, inline="always")
def law_points(B, p):
    """(lam0, lamf) of the bilinear law at mixity B; (lamc, lamc X_FAIL) of the exponential."""
    G = toughness(B, p)
    if p[SHAPE] == EXPONENTIAL:
        lamc = math.sqrt(G)
        return lamc, lamc * X_FAIL
    yn0, yt0 = p[YN0], p[YT0]
    lam0 = 1.0 / math.sqrt((1.0 - B) / (yn0 * yn0) + B / (yt0 * yt0))
    return lam0, 2.0 * G / lam0


@njit(cache=True, inline="always")
def damage_at(lam, B, p):
    """The damage a monotonic opening to lam at mixity B reaches."""
    l0, lf = law_points(B, p)
    if p[SHAPE] == EXPONENTIAL:
        if lam >= lf:
            return 1.0
        return 1.0 - math.exp(-lam / l0)
    if lam <= l0:
        return 0.0
    if lam >= lf:
        return 1.0
    return lf * (lam - l0) / (lam * (lf - l0))


@njit(cache=True, inline="always")
def updated_damage(dn, dt, d_old, p):
    """The damage after an opening (dn, dt): never below d_old."""
    lam, B = scaled_opening(dn, dt, p)
    return max(d_old, damage_at(lam, B, p))


@njit(cache=True, inline="always")
def tractions(dn, dt, d, p):
    """(normal, tangential) traction at openings (dn, dt) with damage d: the damaged
    stiffness in opening and shear, the intact one in compression."""
    kn = p[SQRT_KN] * p[SQRT_KN]
    kt = p[SQRT_KT] * p[SQRT_KT]
    tn = kn * dn if dn < 0.0 else (1.0 - d) * kn * dn
    return tn, (1.0 - d) * kt * dt


@njit(cache=True, inline="always")
def _lam_integral(d, l0, lf, exponential):
    """An antiderivative of lam(d)^2 / 2 in d (lam(d): the damage law inverted)."""
    if exponential:
        u = max(1.0 - d, 0.0)
        if u == 0.0:
            return 0.0  # the limit of u (ln^2 u - 2 ln u + 2) as u -> 0
        lu = math.log(u)
        return -0.5 * l0 * l0 * u * (lu * lu - 2.0 * lu + 2.0)
    a = lf * l0
    c = lf - l0
    return 0.5 * a * a / (c * (lf - c * d))


@njit(cache=True, inline="always")
def dissipation(d1, d2, B, p):
    """Energy per area dissipated when the damage grows from d1 to d2 at mixity B (zero when
    it does not grow). Intact to failed it is G_c(B). The exponential law's last 1e-12 of G_c,
    beyond X_FAIL, goes with the step that fails it."""
    if d2 <= d1:
        return 0.0
    l0, lf = law_points(B, p)
    ex = p[SHAPE] == EXPONENTIAL
    if ex and d2 >= 1.0:
        return _lam_integral(1.0, l0, lf, ex) - _lam_integral(d1, l0, lf, ex)
    return _lam_integral(d2, l0, lf, ex) - _lam_integral(d1, l0, lf, ex)
