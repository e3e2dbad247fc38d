"""Point-edge and point-point distances: values, regions, and closed-form gradients/Hessians
against central finite differences and against the IPC toolkit (`ipctk`, squared distances)."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.contact.barrier import (PE_P_E, PE_P_E0, PE_P_E1, point_edge_closest_param, point_edge_distance,
                            point_edge_distance2, point_edge_distance_gradient,
                            point_edge_distance_hessian, point_edge_distance_type, point_edge_friction_frame,
                            point_edge_tangent, point_line_signed_distance_hessian, point_point_distance,
                            point_point_distance2_hessian, point_point_distance_hessian)

from .fd import fd_gradient, fd_jacobian, rel_err

pytestmark = pytest.mark.implicit

H_FD = 1e-6  # coordinates are O(1), distances >= 0.05
TOL = 1e-6


def sample(region, rng):
    """A random y = (p, e0, e1) well inside the given region (|t - boundary| >= 0.1, d >= 0.05)."""
    a = rng.uniform(-1, 1, 2)
    L = rng.uniform(0.3, 2.0)
    th = rng.uniform(0, 2 * np.pi)
    t = np.array([np.cos(th), np.sin(th)])
    n = np.array([-t[1], t[0]])
    b = a + L * t
    h = rng.uniform(0.05, 1.0) * rng.choice([-1, 1])
    if region == PE_P_E:
        p = a + rng.uniform(0.1, 0.9) * L * t + h * n
    elif region == PE_P_E0:
        p = a - rng.uniform(0.1, 1.0) * L * t + h * n
    else:
        p = b + rng.uniform(0.1, 1.0) * L * t + h * n
    return np.r_[p, a, b]


def d_grad(y, dtype=-1):
    g = np.zeros(6)
    point_edge_distance_gradient(y, g, dtype)
    return g


def d_hess(y, dtype=-1):
    g = np.zeros(6)
    H = np.zeros((6, 6))
    d = point_edge_distance_hessian(y, g, H, dtype)
    return d, g, H


def reference_distance(y):
    p, a, b = y[0:2], y[2:4], y[4:6]
    e = b - a
    t = np.clip((p - a) @ e / (e @ e), 0, 1)
    return np.linalg.norm(p - (a + t * e))


@pytest.mark.parametrize("region", [PE_P_E0, PE_P_E1, PE_P_E])
def test_point_edge_distance_value_and_type(region):
    rng = np.random.default_rng(10 + region)
    for _ in range(200):
        y = sample(region, rng)
        assert point_edge_distance_type(y) == region
        assert point_edge_distance(y) == pytest.approx(reference_distance(y), rel=1e-13)
        assert point_edge_distance2(y) == pytest.approx(reference_distance(y) ** 2, rel=1e-12)
        d, _, H = d_hess(y)
        assert d == pytest.approx(reference_distance(y), rel=1e-13)
        assert np.allclose(H, H.T, rtol=0, atol=1e-14 * np.abs(H).max())


@pytest.mark.parametrize("region", [PE_P_E0, PE_P_E1, PE_P_E])
def test_point_edge_distance_derivatives_match_finite_differences(region):
    rng = np.random.default_rng(20 + region)
    worst_g = worst_h = 0.0
    for _ in range(100):
        y = sample(region, rng)
        _, g, H = d_hess(y)
        assert np.array_equal(g, d_grad(y))
        g_fd = fd_gradient(lambda z: point_edge_distance(z, region), y, H_FD)
        H_fd = fd_jacobian(lambda z: d_grad(z, region), y, H_FD)
        worst_g = max(worst_g, rel_err(g, g_fd))
        worst_h = max(worst_h, rel_err(H, H_fd))
    assert worst_g < TOL and worst_h < TOL, (worst_g, worst_h)


@pytest.mark.parametrize("region", [PE_P_E0, PE_P_E1, PE_P_E])
def test_squared_point_edge_distance_derivatives_match_finite_differences(region):
    rng = np.random.default_rng(30 + region)
    for _ in range(50):
        y = sample(region, rng)
        g = np.zeros(6)
        H = np.zeros((6, 6))
        d2 = point_edge_distance_hessian(y, g, H, squared=True)
        assert d2 == pytest.approx(point_edge_distance(y) ** 2, rel=1e-12)

        def grad2(z):
            gz = np.zeros(6)
            point_edge_distance_hessian(z, gz, np.zeros((6, 6)), region, True)
            return gz

        assert rel_err(g, fd_gradient(lambda z: point_edge_distance2(z, region), y, H_FD)) < TOL
        assert rel_err(H, fd_jacobian(grad2, y, H_FD)) < TOL


def test_signed_point_line_distance_and_point_point():
    rng = np.random.default_rng(4)
    for _ in range(50):
        y = rng.uniform(-1, 1, 6)
        g = np.zeros(6)
        H = np.zeros((6, 6))
        s = point_line_signed_distance_hessian(y, g, H)
        e = y[4:6] - y[2:4]
        r = y[0:2] - y[2:4]
        assert s == pytest.approx((e[0] * r[1] - e[1] * r[0]) / np.linalg.norm(e), rel=1e-12)

        def sgrad(z):
            gz = np.zeros(6)
            point_line_signed_distance_hessian(z, gz, np.zeros((6, 6)))
            return gz

        def sval(z):
            return point_line_signed_distance_hessian(z, np.zeros(6), np.zeros((6, 6)))

        assert rel_err(g, fd_gradient(sval, y, H_FD)) < TOL
        assert rel_err(H, fd_jacobian(sgrad, y, H_FD)) < TOL
        # point-point on (p, q)
        z = rng.uniform(-1, 1, 4)
        if np.linalg.norm(z[:2] - z[2:]) < 0.05:
            continue
        g4 = np.zeros(4)
        H4 = np.zeros((4, 4))
        assert point_point_distance_hessian(z, g4, H4) == pytest.approx(np.linalg.norm(z[:2] - z[2:]), rel=1e-14)

        def pgrad(w):
            gw = np.zeros(4)
            point_point_distance_hessian(w, gw, np.zeros((4, 4)))
            return gw

        assert rel_err(g4, fd_gradient(point_point_distance, z, H_FD)) < TOL
        assert rel_err(H4, fd_jacobian(pgrad, z, H_FD)) < TOL
        point_point_distance2_hessian(z, g4, H4)
        assert np.allclose(g4, 2 * np.r_[z[:2] - z[2:], z[2:] - z[:2]], rtol=1e-14)


def test_distance_is_c1_across_region_boundaries():
    """At t = 0 (t = 1) the endpoint and interior formulas agree in value and gradient."""
    rng = np.random.default_rng(5)
    for _ in range(50):
        a = rng.uniform(-1, 1, 2)
        b = rng.uniform(-1, 1, 2)
        e = b - a
        n = np.array([-e[1], e[0]]) / np.linalg.norm(e)
        for end, region in ((a, PE_P_E0), (b, PE_P_E1)):
            y = np.r_[end + rng.uniform(0.1, 1) * n, a, b]
            assert point_edge_distance(y, region) == pytest.approx(point_edge_distance(y, PE_P_E), rel=1e-12)
            assert rel_err(d_grad(y, region), d_grad(y, PE_P_E)) < 1e-12


def test_closest_param_tangent_and_friction_frame():
    rng = np.random.default_rng(6)
    tau = np.zeros(2)
    for region in (PE_P_E0, PE_P_E1, PE_P_E):
        for _ in range(50):
            y = sample(region, rng)
            p, a, b = y[0:2], y[2:4], y[4:6]
            e = b - a
            t = (p - a) @ e / (e @ e)
            assert point_edge_closest_param(y) == pytest.approx(np.clip(t, 0, 1), abs=1e-15)
            assert point_edge_tangent(y, tau) == pytest.approx(np.linalg.norm(e))
            assert np.allclose(tau, e / np.linalg.norm(e), atol=1e-15)
            r = point_edge_friction_frame(y, tau)
            assert r == pytest.approx(np.clip(t, 0, 1), abs=1e-15)
            assert np.linalg.norm(tau) == pytest.approx(1.0) and tau @ e >= 0
            c = a + r * e
            assert abs(tau @ (p - c)) < 1e-12  # tangent is perpendicular to the contact normal


# ---------------------------------------------------------------------------------------------
# ipctk oracle (squared distances)
# ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("region", [PE_P_E0, PE_P_E1, PE_P_E])
def test_point_edge_distance_matches_ipctk(region):
    """ipctk.point_edge_distance{,_gradient,_hessian} return the SQUARED distance and its
    derivatives; compare them with ours squared, and our unsquared derivatives with the chain
    rule d = sqrt(s): grad d = grad s/(2d), hess d = hess s/(2d) - grad s grad s^T/(4 d^3)."""
    ipctk = pytest.importorskip("ipctk")
    rng = np.random.default_rng(40 + region)
    worst = 0.0
    for _ in range(100):
        y = sample(region, rng)
        p, a, b = y[0:2], y[2:4], y[4:6]
        assert int(ipctk.point_edge_distance_type(p, a, b).value) == region
        s = ipctk.point_edge_distance(p, a, b)
        gs = np.asarray(ipctk.point_edge_distance_gradient(p, a, b)).ravel()
        Hs = np.asarray(ipctk.point_edge_distance_hessian(p, a, b))
        g2 = np.zeros(6)
        H2 = np.zeros((6, 6))
        assert point_edge_distance_hessian(y, g2, H2, squared=True) == pytest.approx(s, rel=1e-12)
        worst = max(worst, rel_err(g2, gs), rel_err(H2, Hs))
        d, g, H = d_hess(y)
        worst = max(worst, rel_err(g, gs / (2 * d)), rel_err(H, Hs / (2 * d) - np.outer(gs, gs) / (4 * d ** 3)))
        # explicit-type evaluation agrees too
        t = ipctk.PointEdgeDistanceType(region)
        assert ipctk.point_edge_distance(p, a, b, t) == pytest.approx(point_edge_distance2(y, region), rel=1e-12)
    assert worst < 1e-10, worst


def test_closest_point_and_tangent_match_ipctk():
    ipctk = pytest.importorskip("ipctk")
    rng = np.random.default_rng(7)
    tau = np.zeros(2)
    for region in (PE_P_E0, PE_P_E1, PE_P_E):
        for _ in range(20):
            y = sample(region, rng)
            p, a, b = y[0:2], y[2:4], y[4:6]
            t_ipc = ipctk.point_edge_closest_point(p, a, b)  # unclamped line parameter
            e = b - a
            assert t_ipc == pytest.approx((p - a) @ e / (e @ e), rel=1e-12, abs=1e-14)
            assert point_edge_closest_param(y) == pytest.approx(np.clip(t_ipc, 0, 1), abs=1e-14)
            basis = np.asarray(ipctk.point_edge_tangent_basis(p, a, b)).ravel()
            point_edge_tangent(y, tau)
            assert abs(abs(basis @ tau) - 1.0) < 1e-12
