"""Constitutive kernels. One dispatch on the material type code; 2D plane strain runs the
same 3x3 algebra with F33 = 1 and zero out-of-plane velocity gradient.

Materials with internal energy (Mie–Grüneisen, or any material under artificial viscosity)
exchange it through a small `eos` row: [U, p, q, J0, rho0, 1 - S1 eta] (in/out, see
`mie_gruneisen_stress`); the others never read it.

Stress is Cauchy, stored in Voigt order [xx, yy, zz, xy, yz, xz] (ParaView's order for
symmetric tensors).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from . import ANISOTROPIC, COMPRESSIBLE_NH, MIE_GRUNEISEN, NEO_HOOKEAN

# Voigt slot of tensor component (a, b)
VOIGT = np.array([[0, 3, 5], [3, 1, 4], [5, 4, 2]], dtype=np.int64)


@njit(cache=True, inline="always")
def det3(A):
    return (A[0, 0] * (A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1])
            - A[0, 1] * (A[1, 0] * A[2, 2] - A[1, 2] * A[2, 0])
            + A[0, 2] * (A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]))


@njit(cache=True, inline="always")
def inv3(A, out):
    d = det3(A)
    out[0, 0] = (A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1]) / d
    out[0, 1] = (A[0, 2] * A[2, 1] - A[0, 1] * A[2, 2]) / d
    out[0, 2] = (A[0, 1] * A[1, 2] - A[0, 2] * A[1, 1]) / d
    out[1, 0] = (A[1, 2] * A[2, 0] - A[1, 0] * A[2, 2]) / d
    out[1, 1] = (A[0, 0] * A[2, 2] - A[0, 2] * A[2, 0]) / d
    out[1, 2] = (A[0, 2] * A[1, 0] - A[0, 0] * A[1, 2]) / d
    out[2, 0] = (A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]) / d
    out[2, 1] = (A[0, 1] * A[2, 0] - A[0, 0] * A[2, 1]) / d
    out[2, 2] = (A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]) / d


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
    cj = np.cbrt(J)
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
    cj = np.cbrt(J)
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
def rotate_stress(L, dt, s, W, A, Ai, Q):
    """sigma <- Q sigma Q^T with the Hughes–Winget increment Q = (I - W/2)^-1 (I + W/2),
    W = skew(L) dt: the objective part of a hypoelastic update."""
    for a in range(3):
        for b in range(3):
            W[a, b] = 0.5 * (L[a, b] - L[b, a]) * dt
    for a in range(3):
        for b in range(3):
            A[a, b] = (1.0 if a == b else 0.0) - 0.5 * W[a, b]
    inv3(A, Ai)
    for a in range(3):
        for b in range(3):
            q = 0.0
            for c in range(3):
                q += Ai[a, c] * ((1.0 if c == b else 0.0) + 0.5 * W[c, b])
            Q[a, b] = q
    for a in range(3):
        for b in range(3):
            A[a, b] = s[VOIGT[a, b]]
    for a in range(3):
        for b in range(a, 3):
            r = 0.0
            for c in range(3):
                for d in range(3):
                    r += Q[a, c] * A[c, d] * Q[b, d]
            W[a, b] = r  # W reused as the rotated stress (upper triangle)
    s[0] = W[0, 0]
    s[1] = W[1, 1]
    s[2] = W[2, 2]
    s[3] = W[0, 1]
    s[4] = W[1, 2]
    s[5] = W[0, 2]


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
def anisotropic_stress(props, L, dt, s, W, A, Ai, Q):
    """Linear elastic increment with a full stiffness C (props[0:36], Voigt xx yy zz xy yz xz,
    engineering shear strains) after the rotation: sigma <- Q sigma Q^T + C de."""
    rotate_stress(L, dt, s, W, A, Ai, Q)
    de0 = L[0, 0] * dt
    de1 = L[1, 1] * dt
    de2 = L[2, 2] * dt
    de3 = (L[0, 1] + L[1, 0]) * dt
    de4 = (L[1, 2] + L[2, 1]) * dt
    de5 = (L[0, 2] + L[2, 0]) * dt
    for a in range(6):
        r = 6 * a
        s[a] += (props[r] * de0 + props[r + 1] * de1 + props[r + 2] * de2 + props[r + 3] * de3
                 + props[r + 4] * de4 + props[r + 5] * de5)
    return max(props[0], max(props[7], props[14]))


@njit(cache=True, inline="always")
def compliance_energy(props, s):
    """1/2 sigma . S sigma with the compliance S in props[36:72]."""
    e = 0.0
    for a in range(6):
        for b in range(6):
            e += s[a] * props[36 + 6 * a + b] * s[b]
    return 0.5 * e


@njit(cache=True, inline="always")
def linear_elastic_energy(E, nu, mu, s):
    """Complementary energy density 1/2 sigma : C^-1 : sigma (exact for linear elasticity)."""
    normal = s[0] ** 2 + s[1] ** 2 + s[2] ** 2 - 2.0 * nu * (s[0] * s[1] + s[1] * s[2] + s[0] * s[2])
    shear = s[3] ** 2 + s[4] ** 2 + s[5] ** 2
    return 0.5 * normal / E + 0.5 * shear / mu


# slots of the eos row
EOS_U, EOS_P, EOS_Q, EOS_J0, EOS_RHO0, EOS_DEN = 0, 1, 2, 3, 4, 5
EOS_N = 6


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
    J = det3(F3)
    eta = 1.0 - J
    U0, p0, q, J0, rho0 = eos[EOS_U], eos[EOS_P], eos[EOS_Q], eos[EOS_J0], eos[EOS_RHO0]
    pc, dpc, den = mg_cold(K, gamma0, S1, eta)
    dJ = J - J0
    U = (U0 - (0.5 * (p0 + pc) + q) * dJ / rho0) / (1.0 + 0.5 * gamma0 * dJ)
    p = pc + rho0 * gamma0 * U
    shear = neo_hookean_stress(0.0, G, F3, s)  # deviatoric part only (K = 0)
    for a in range(3):
        s[a] -= p
    eos[EOS_U] = U
    eos[EOS_P] = p
    eos[EOS_DEN] = den
    return J * (dpc + gamma0 * p) + shear


@njit(cache=True, inline="always")
def bulk_wave_modulus(code, props, J, p):
    """Tangent bulk modulus J dp/deta at J (pressure p) for the artificial viscosity's C."""
    if code == MIE_GRUNEISEN:
        _, dpc, _ = mg_cold(props[0], props[2], props[3], 1.0 - J)
        return J * (dpc + props[2] * p)
    if code == NEO_HOOKEAN:
        return 0.5 * props[0] * (J + 1.0 / J)
    if code == ANISOTROPIC:  # 1 / (sum of the normal-normal compliances)
        c = 0.0
        for a in range(3):
            for b in range(3):
                c += props[36 + 6 * a + b]
        return 1.0 / c
    return props[0] + 2.0 / 3.0 * props[1]


@njit(cache=True, inline="always")
def compressible_nh_energy(lam, mu, F3, J):
    """psi = mu/2 (tr F^T F - 3) - mu ln J + lam/2 (ln J)^2 per reference volume (the model of
    FEM bodies and of particles under the implicit integrator; plane strain: F33 = 1)."""
    i1 = 0.0
    for a in range(3):
        for b in range(3):
            i1 += F3[a, b] * F3[a, b]
    lnJ = np.log(J)
    return 0.5 * mu * (i1 - 3.0) - mu * lnJ + 0.5 * lam * lnJ * lnJ


@njit(cache=True, inline="always")
def energy_density(code, props, F3, s, J):
    """Strain energy per *current* volume (Mie–Grüneisen: its shear part; the volumetric part
    is in the internal energy U)."""
    if code == COMPRESSIBLE_NH:
        return compressible_nh_energy(props[0], props[1], F3, J) / J
    if code == NEO_HOOKEAN:
        return neo_hookean_energy(props[0], props[1], F3) / J
    if code == MIE_GRUNEISEN:
        return neo_hookean_energy(0.0, props[1], F3) / J
    if code == ANISOTROPIC:
        return compliance_energy(props, s)
    return linear_elastic_energy(props[2], props[3], props[1], s)


@njit(cache=True, inline="always")
def initial_modulus(code, props):
    if code == NEO_HOOKEAN or code == MIE_GRUNEISEN:
        return props[0] + 4.0 / 3.0 * props[1]
    if code == ANISOTROPIC:
        return max(props[0], max(props[7], props[14]))
    return props[0] + 2.0 * props[1]
