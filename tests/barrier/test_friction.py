"""Smoothed friction mollifier and the lagged friction pseudo-potential: derivatives against
finite differences, PSD-ness, the Coulomb limit, and the mollifier against `ipctk`."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.contact.barrier import (friction_f0, friction_f1, friction_f1_over_y, friction_f2, friction_f2_y_minus_f1_over_y3,
                            lagged_friction, point_edge_friction, point_edge_friction_operator,
                            point_point_friction_operator)

from .fd import fd_gradient, fd_jacobian, rel_err

pytestmark = pytest.mark.implicit

EPS = 1e-3


def ys_away_from_kink():
    """Slip magnitudes in (0, eps) and (eps, 5 eps), 2% clear of eps (f2 jumps there)."""
    return np.r_[np.linspace(0.02, 0.98, 49), np.linspace(1.02, 5.0, 40)] * EPS


def test_mollifier_derivatives_and_continuity():
    for y in ys_away_from_kink():
        h = 1e-6 * EPS
        assert friction_f1(y, EPS) == pytest.approx(
            (friction_f0(y + h, EPS) - friction_f0(y - h, EPS)) / (2 * h), rel=1e-6, abs=1e-9)
        assert friction_f2(y, EPS) == pytest.approx(
            (friction_f1(y + h, EPS) - friction_f1(y - h, EPS)) / (2 * h), rel=1e-6, abs=1e-6 / EPS)
        assert friction_f1_over_y(y, EPS) == pytest.approx(friction_f1(y, EPS) / y, rel=1e-13)
        assert friction_f2_y_minus_f1_over_y3(y, EPS) == pytest.approx(
            (friction_f2(y, EPS) * y - friction_f1(y, EPS)) / y ** 3, rel=1e-9)
        assert 0.0 <= friction_f1(y, EPS) <= 1.0 and friction_f2(y, EPS) >= 0.0
    # C^1 at eps, the values at 0 and the static limit f1/y -> 2/eps
    assert friction_f0(EPS, EPS) == pytest.approx(EPS, rel=1e-15)
    assert friction_f0(EPS * (1 - 1e-9), EPS) == pytest.approx(EPS, rel=1e-8)
    assert friction_f1(EPS * (1 - 1e-9), EPS) == pytest.approx(1.0, abs=1e-8)
    assert friction_f0(0.0, EPS) == pytest.approx(EPS / 3)
    assert friction_f1(0.0, EPS) == 0.0 and friction_f1_over_y(0.0, EPS) == 2.0 / EPS
    assert friction_f0(7 * EPS, EPS) == 7 * EPS and friction_f1(7 * EPS, EPS) == 1.0


def test_mollifier_matches_ipctk():
    """ipctk.smooth_friction_{f0,f1,f1_over_x,f2,f2_x_minus_f1_over_x3}(y, eps_v): the same
    functions with the same threshold argument (we pass slip displacements and eps = eps_v dt;
    ipctk's docs call y a speed, the formula is identical)."""
    ipctk = pytest.importorskip("ipctk")
    worst = 0.0
    pairs = [(friction_f0, ipctk.smooth_friction_f0), (friction_f1, ipctk.smooth_friction_f1),
             (friction_f1_over_y, ipctk.smooth_friction_f1_over_x), (friction_f2, ipctk.smooth_friction_f2),
             (friction_f2_y_minus_f1_over_y3, ipctk.smooth_friction_f2_x_minus_f1_over_x3)]
    for y in np.r_[ys_away_from_kink(), [EPS, 10 * EPS]]:
        for ours, theirs in pairs:
            a, b = ours(y, EPS), theirs(y, EPS)
            worst = max(worst, abs(a - b) / max(abs(b), 1e-300))
    assert worst < 1e-13, worst


def slip_sample(rng, regime):
    tau = rng.normal(size=2)
    tau /= np.linalg.norm(tau)
    r = rng.uniform(0, 1)
    dz = rng.normal(size=6)
    G = np.zeros((6, 1))
    point_edge_friction_operator(tau, r, G)
    u = G[:, 0] @ dz
    target = rng.uniform(0.05, 0.9) * EPS if regime == "static" else rng.uniform(1.2, 5) * EPS
    dz *= target / abs(u)
    return dz, tau, r


@pytest.mark.parametrize("regime", ["static", "sliding"])
def test_point_edge_lagged_friction_matches_finite_differences(regime):
    """Gradient and Hessian of D(dz) = mu lambda f0(|u|), u = tau.(dp - (1-r) de0 - r de1), against
    central differences (step 1e-4 eps): gradients 1e-6 relative; Hessians 1e-6 relative to the
    natural scale mu lambda |G|^2/eps (in the sliding regime the exact 2D Hessian is zero)."""
    rng = np.random.default_rng(1 if regime == "static" else 2)
    mu_lam = 3.7
    for _ in range(50):
        dz, tau, r = slip_sample(rng, regime)
        g = np.zeros(6)
        H = np.zeros((6, 6))
        D = point_edge_friction(dz, tau, r, mu_lam, EPS, g, H)
        u = tau @ (dz[0:2] - (1 - r) * dz[2:4] - r * dz[4:6])
        assert D == pytest.approx(mu_lam * friction_f0(abs(u), EPS), rel=1e-14)

        def val(z, tau=tau, r=r):
            return point_edge_friction(z, tau, r, mu_lam, EPS, np.zeros(6), np.zeros((6, 6)))

        def grad(z, tau=tau, r=r):
            gz = np.zeros(6)
            point_edge_friction(z, tau, r, mu_lam, EPS, gz, np.zeros((6, 6)))
            return gz

        h = 1e-4 * EPS
        assert rel_err(g, fd_gradient(val, dz, h)) < 1e-6
        Gn2 = 1 + (1 - r) ** 2 + r ** 2
        assert np.linalg.norm(H - fd_jacobian(grad, dz, h)) < 1e-6 * mu_lam * Gn2 / EPS
        assert np.linalg.eigvalsh(H).min() >= -1e-12 * mu_lam * Gn2 / EPS
        # force on the point: Coulomb magnitude mu lambda f1(|u|) along -tau sign(u)
        assert g[0:2] @ tau == pytest.approx(mu_lam * friction_f1(abs(u), EPS) * np.sign(u), rel=1e-12)
        # momentum balance: forces on point and edge sum to zero
        assert np.allclose(g[0:2] + g[2:4] + g[4:6], 0, atol=1e-12 * mu_lam)


def test_general_tangent_space_friction_is_psd_and_consistent():
    """The k = 2 form (3D point-triangle-like stencil, n = 12) with a random lagged operator."""
    rng = np.random.default_rng(3)
    mu_lam = 0.8
    for regime in ("static", "sliding"):
        for _ in range(30):
            G = rng.normal(size=(12, 2))
            dz = rng.normal(size=12)
            u = G.T @ dz
            target = rng.uniform(0.05, 0.9) * EPS if regime == "static" else rng.uniform(1.2, 5) * EPS
            dz *= target / np.linalg.norm(u)
            g = np.zeros(12)
            H = np.zeros((12, 12))
            lagged_friction(dz, G, mu_lam, EPS, g, H)

            def val(z, G=G):
                return lagged_friction(z, G, mu_lam, EPS, np.zeros(12), np.zeros((12, 12)))

            def grad(z, G=G):
                gz = np.zeros(12)
                lagged_friction(z, G, mu_lam, EPS, gz, np.zeros((12, 12)))
                return gz

            h = 1e-4 * EPS
            scale = mu_lam * np.linalg.norm(G) ** 2 / EPS
            assert rel_err(g, fd_gradient(val, dz, h)) < 1e-6
            assert np.linalg.norm(H - fd_jacobian(grad, dz, h)) < 1e-6 * scale
            assert np.linalg.eigvalsh(H).min() >= -1e-12 * scale


def test_zero_slip_is_finite_and_static():
    G = np.zeros((4, 1))
    point_point_friction_operator(np.array([0.6, 0.8]), G)
    g = np.ones(4)
    H = np.zeros((4, 4))
    D = lagged_friction(np.zeros(4), G, 2.0, EPS, g, H)
    assert D == pytest.approx(2.0 * EPS / 3) and not g.any()
    assert np.allclose(H, 2.0 * (2.0 / EPS) * G @ G.T)  # f2(0) = 2/eps
