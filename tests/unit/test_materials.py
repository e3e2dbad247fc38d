"""Constitutive kernels against closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.materials.kernels import VOIGT
from mpmsim.materials.linear_elastic import hypoelastic_stress, linear_elastic_energy
from mpmsim.materials.neo_hookean import neo_hookean_energy, neo_hookean_stress

K, G = 2450.0, 940.0


def full(s):
    return np.array([[s[VOIGT[a, b]] for b in range(3)] for a in range(3)])


def test_neo_hookean_stress_is_the_derivative_of_eq18():
    """sigma = (1/J) dW/dF F^T for random deformations (central differences of W)."""
    rng = np.random.default_rng(0)
    for _ in range(5):
        F = np.eye(3) + 0.3 * rng.normal(size=(3, 3))
        if np.linalg.det(F) < 0.3:
            continue
        s = np.zeros(6)
        neo_hookean_stress(K, G, F, s)
        P = np.zeros((3, 3))
        eps = 1e-6
        for a in range(3):
            for b in range(3):
                Fp, Fm = F.copy(), F.copy()
                Fp[a, b] += eps
                Fm[a, b] -= eps
                P[a, b] = (neo_hookean_energy(K, G, Fp) - neo_hookean_energy(K, G, Fm)) / (2 * eps)
        sigma = P @ F.T / np.linalg.det(F)
        np.testing.assert_allclose(full(s), sigma, rtol=1e-6, atol=1e-4)


@pytest.mark.parametrize("lam", [0.8, 0.9, 1.0, 1.2, 1.5])
def test_neo_hookean_uniaxial_strain_closed_form_and_wave_modulus(lam):
    F = np.diag([1.0, lam, 1.0])
    s = np.zeros(6)
    modulus = neo_hookean_stress(K, G, F, s)
    syy = 0.5 * K * (lam - 1 / lam) + (2 * G / 3) * lam ** (-5 / 3) * (lam**2 - 1)
    assert s[1] == pytest.approx(syy, rel=1e-12, abs=1e-12)
    # exact Eulerian longitudinal modulus in uniaxial strain: lam * d(sigma_yy)/d(lam)
    h = 1e-6
    sp, sm = np.zeros(6), np.zeros(6)
    neo_hookean_stress(K, G, np.diag([1.0, lam + h, 1.0]), sp)
    neo_hookean_stress(K, G, np.diag([1.0, lam - h, 1.0]), sm)
    exact = lam * (sp[1] - sm[1]) / (2 * h)
    # the time-step modulus is an upper bound, and not a loose one (wave speed within ~10%)
    assert modulus >= exact * (1 - 1e-9)
    assert np.sqrt(modulus / exact) < 1.12


def test_hypoelastic_small_strain_and_objectivity():
    lam, mu = 1000.0, 500.0
    W, A, Ai, Q = (np.zeros((3, 3)) for _ in range(4))
    # a pure stretch increment gives Hooke's law
    L = np.diag([1e-3, -2e-3, 0.0])
    s = np.zeros(6)
    hypoelastic_stress(lam, mu, L, 1.0, s, W, A, Ai, Q)
    tr = L.trace()
    np.testing.assert_allclose(s[:3], lam * tr + 2 * mu * np.diag(L), rtol=1e-12)
    # a pure spin rotates the stress without changing its invariants (Hughes–Winget is exact for them)
    s0 = np.array([100.0, -50.0, 20.0, 30.0, 0.0, 0.0])
    s = s0.copy()
    spin = np.array([[0.0, 0.3, 0.0], [-0.3, 0.0, 0.0], [0.0, 0.0, 0.0]])
    for _ in range(50):
        hypoelastic_stress(lam, mu, spin, 0.1, s, W, A, Ai, Q)
    np.testing.assert_allclose(np.linalg.eigvalsh(full(s)), np.linalg.eigvalsh(full(s0)), rtol=1e-12)
    # the rotation angle is 50 x 2 atan(0.03/2 ...): stress is not left unchanged
    assert abs(s[3] - s0[3]) > 1.0


def test_linear_elastic_energy_is_half_stress_strain():
    E, nu = 200.0, 0.25
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    eps = np.array([[1e-3, 2e-4, 0], [2e-4, -5e-4, 0], [0, 0, 0]])
    sigma = lam * np.trace(eps) * np.eye(3) + 2 * mu * eps
    s = np.array([sigma[0, 0], sigma[1, 1], sigma[2, 2], sigma[0, 1], sigma[1, 2], sigma[0, 2]])
    assert linear_elastic_energy(E, nu, mu, s) == pytest.approx(0.5 * np.sum(sigma * eps), rel=1e-12)


def test_transversely_isotropic_compliance():
    """Isotropic constants give the isotropic compliance; the axis picks the stiff direction;
    the 2013 paper's wood is positive definite and its axial modulus is EA along the axis."""
    from mpmsim.materials import transversely_isotropic_compliance

    E, nu = 2400.0, 0.33
    S = transversely_isotropic_compliance(E, E, E / (2 * (1 + nu)), nu, nu, [0.3, 0.4, 0.5])
    iso = np.zeros((6, 6))
    iso[:3, :3] = -nu / E
    np.fill_diagonal(iso[:3, :3], 1 / E)
    iso[3:, 3:] = np.eye(3) * 2 * (1 + nu) / E
    np.testing.assert_allclose(S, iso, atol=1e-12 / E)
    wood = transversely_isotropic_compliance(10000.0, 1000.0, 500.0, 0.2, 0.3, [0.0, 1.0])
    assert wood[1, 1] == pytest.approx(1 / 10000.0)
    assert wood[0, 0] == pytest.approx(1 / 1000.0) and wood[2, 2] == pytest.approx(1 / 1000.0)
    assert wood[0, 1] == pytest.approx(-0.2 / 10000.0)
    assert wood[3, 3] == pytest.approx(1 / 500.0)  # xy: axial shear
    assert np.linalg.eigvalsh(wood).min() > 0
    np.testing.assert_allclose(wood, wood.T, atol=1e-18)


def test_anisotropic_increment_and_energy():
    """One increment from rest: sigma = C de, and the energy 1/2 sigma.S.sigma = 1/2 de.C.de."""
    from mpmsim.materials import transversely_isotropic_compliance
    from mpmsim.materials.transversely_isotropic import anisotropic_stress, compliance_energy

    S = transversely_isotropic_compliance(10000.0, 1000.0, 500.0, 0.2, 0.3, [1.0, 1.0, 0.0])
    C = np.linalg.inv(S)
    props = np.concatenate([C.ravel(), S.ravel()])
    L = np.array([[1e-3, 2e-4, 0.0], [0.0, -5e-4, 0.0], [0.0, 0.0, 0.0]])
    s = np.zeros(6)
    w = [np.zeros((3, 3)) for _ in range(4)]
    modulus = anisotropic_stress(props, L, 1.0, s, *w)
    de = np.array([1e-3, -5e-4, 0.0, 2e-4, 0.0, 0.0])  # engineering shear: L01 + L10
    np.testing.assert_allclose(s, C @ de, rtol=1e-12, atol=1e-14)
    assert compliance_energy(props, s) == pytest.approx(0.5 * de @ C @ de, rel=1e-12)
    assert modulus == pytest.approx(max(C[0, 0], C[1, 1], C[2, 2]))


def _cube_root_in_numpy(x):
    """materials.kernels.cube_root's operations, in numpy (uncompiled, element-wise IEEE
    arithmetic: the same bits on any platform): (where they apply, their result)."""
    from mpmsim.materials.kernels import CBRT2, CBRT_POLY, SQR_CBRT2

    cases = [(x >= 0.5) & (x < 1.0), (x >= 1.0) & (x < 2.0), (x >= 0.25) & (x < 0.5), (x >= 2.0) & (x < 4.0)]
    m = np.select(cases, [x, x * 0.5, x * 2.0, x * 0.25], 0.75)
    f = np.select(cases, [1.0, CBRT2, 1.0 / CBRT2, SQR_CBRT2], 1.0)
    c0, c1, c2, c3, c4, c5, c6 = CBRT_POLY
    u = c0 + (c1 + (c2 + (c3 + (c4 + (c5 + c6 * m) * m) * m) * m) * m) * m
    t2 = u * u * u
    return np.any(cases, axis=0), u * (t2 + 2.0 * m) / (2.0 * t2 + m) * f


@pytest.mark.speed
def test_the_inlined_cube_root_gives_np_cbrt_to_the_last_bit():
    """materials.kernels.cube_root (the neo-Hookean J^(1/3)), compiled, on 3 million volume
    ratios over [0.2, 5], around every branch edge, the edges and their neighbours, and the
    values it hands to np.cbrt: (1) the same bits as its operations done in numpy (any
    platform; outside [0.25, 4) the compiled np.cbrt's, which it calls there); (2) within 4
    ulp of the true cube root (exact rational check on a sample; the C library's cbrt, one
    polynomial guess and one Halley step, is up to about 3 ulp off);
    (3) where np.cbrt is the GNU C library's (Linux), the same bits as np.cbrt, which is what
    makes the change invisible in results. A wrong coefficient, a Python-style exponent split or
    a reordered Halley step fails (1) and (3)."""
    import platform
    from fractions import Fraction

    from numba import njit

    from mpmsim.materials.kernels import cube_root

    @njit
    def both(x, a, b):
        for i in range(x.size):
            a[i] = np.cbrt(x[i])
            b[i] = cube_root(x[i])

    rng = np.random.default_rng(3)
    edges = np.array([0.25, 0.5, 1.0, 2.0, 4.0])
    x = np.concatenate([rng.uniform(0.2, 5.0, 2_000_000)]
                       + [rng.uniform(e * (1 - 1e-3), e * (1 + 1e-3), 200_000) for e in edges]
                       + [edges, np.nextafter(edges, 0.0), np.nextafter(edges, 9.0),
                          np.array([1e-300, 1e-5, 0.1, 7.9, 1e5, 1e300, 0.0, -0.0, -1.0, -0.6])])
    a, b = np.empty_like(x), np.empty_like(x)
    both(x, a, b)
    inline, y = _cube_root_in_numpy(x)
    assert inline.mean() > 0.75 and np.array_equal(b[inline].view(np.int64), y[inline].view(np.int64))
    assert np.array_equal(b[~inline].view(np.int64), a[~inline].view(np.int64))  # elsewhere the call itself
    for i in rng.choice(x.size, 2000, replace=False):
        if x[i] > 0.0:
            y, ulp = Fraction(float(b[i])), Fraction(float(np.spacing(b[i])))
            assert (y - 4 * ulp) ** 3 < Fraction(float(x[i])) < (y + 4 * ulp) ** 3, x[i]
    if platform.libc_ver()[0] == "glibc":
        assert np.array_equal(a.view(np.int64), b.view(np.int64)), int((a != b).sum())
    a, b = np.empty(3), np.empty(3)
    both(np.array([np.nan, np.inf, -np.inf]), a, b)
    assert np.isnan(b[0]) and b[1] == np.inf and b[2] == -np.inf
