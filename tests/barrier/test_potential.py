"""Barrier b(d) and its derivatives, the point-edge / point-point barrier energies by the chain
rule, and the PSD projection: against finite differences, closed-form limits and `ipctk`."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.contact.barrier import (PE_P_E, PE_P_E0, PE_P_E1, barrier, barrier_first_derivative, barrier_normal_force,
                            barrier_second_derivative, point_edge_barrier, point_edge_barrier_pairs,
                            point_edge_distance, point_edge_distance_type, point_point_barrier, project_psd)

from .fd import fd_gradient, fd_jacobian, rel_err

pytestmark = pytest.mark.implicit

DHAT = 0.1
KAPPA = 1e3


def test_barrier_values_limits_and_derivatives():
    us = np.linspace(0.02, 0.98, 97)
    for u in us:
        d = u * DHAT
        assert barrier(d, DHAT, KAPPA) == pytest.approx(-KAPPA * DHAT * (u - 1) ** 2 * np.log(u), rel=1e-14)
        h = 1e-6 * d  # barrier derivatives scale like 1/d: relative steps
        fd1 = (barrier(d + h, DHAT, KAPPA) - barrier(d - h, DHAT, KAPPA)) / (2 * h)
        fd2 = (barrier_first_derivative(d + h, DHAT, KAPPA) - barrier_first_derivative(d - h, DHAT, KAPPA)) / (2 * h)
        assert barrier_first_derivative(d, DHAT, KAPPA) == pytest.approx(fd1, rel=1e-6)
        assert barrier_second_derivative(d, DHAT, KAPPA) == pytest.approx(fd2, rel=1e-6)
        assert barrier_first_derivative(d, DHAT, KAPPA) < 0 < barrier_second_derivative(d, DHAT, KAPPA)
        assert barrier_normal_force(d, DHAT, KAPPA) == -barrier_first_derivative(d, DHAT, KAPPA)
    # C^2 clamping at dhat, zero beyond, infinite at contact
    for f in (barrier, barrier_first_derivative, barrier_second_derivative):
        assert f(DHAT, DHAT, KAPPA) == 0.0 and f(2 * DHAT, DHAT, KAPPA) == 0.0
        assert abs(f(DHAT * (1 - 1e-7), DHAT, KAPPA)) < 1e-4 * KAPPA
    assert barrier(0.0, DHAT, KAPPA) == np.inf
    assert barrier_first_derivative(-1.0, DHAT, KAPPA) == -np.inf
    assert barrier(1e-300, DHAT, KAPPA) > 0


def test_barrier_matches_ipctk():
    """ipctk.barrier(d, dhat) = -(d - dhat)^2 ln(d/dhat) on the same (unsquared) argument:
    ours = kappa/dhat times it, for the value and both derivatives."""
    ipctk = pytest.importorskip("ipctk")
    worst = 0.0
    for u in np.linspace(0.01, 1.2, 120):
        d = u * DHAT
        s = KAPPA / DHAT
        worst = max(worst,
                    abs(barrier(d, DHAT, KAPPA) - s * ipctk.barrier(d, DHAT)) / (abs(barrier(d, DHAT, KAPPA)) + 1e-300),
                    abs(barrier_first_derivative(d, DHAT, KAPPA) - s * ipctk.barrier_first_derivative(d, DHAT))
                    / (abs(barrier_first_derivative(d, DHAT, KAPPA)) + 1e-300),
                    abs(barrier_second_derivative(d, DHAT, KAPPA) - s * ipctk.barrier_second_derivative(d, DHAT))
                    / (abs(barrier_second_derivative(d, DHAT, KAPPA)) + 1e-300))
    assert worst < 1e-12, worst


def near_sample(region, rng):
    """y = (p, e0, e1) with the point inside the barrier's support (0.15 dhat < d < 0.9 dhat),
    well inside the given region."""
    a = rng.uniform(-1, 1, 2)
    L = rng.uniform(0.3, 2.0)
    th = rng.uniform(0, 2 * np.pi)
    t = np.array([np.cos(th), np.sin(th)])
    n = np.array([-t[1], t[0]])
    b = a + L * t
    d = rng.uniform(0.15, 0.9) * DHAT
    if region == PE_P_E:
        p = a + rng.uniform(0.1, 0.9) * L * t + d * rng.choice([-1, 1]) * n
    else:
        phi = rng.uniform(np.pi / 2 + 0.2, 3 * np.pi / 2 - 0.2)  # away from the edge's half-plane
        u = np.cos(phi) * t + np.sin(phi) * n
        p = (a + d * u) if region == PE_P_E0 else (b - d * u)
    return np.r_[p, a, b]


def energy_grad(y, region):
    g = np.zeros(6)
    point_edge_barrier(y, DHAT, KAPPA, g, np.zeros((6, 6)), False, region)
    return g


@pytest.mark.parametrize("region", [PE_P_E0, PE_P_E1, PE_P_E])
def test_point_edge_barrier_derivatives_match_finite_differences(region):
    """Gradient and (unprojected) Hessian of b(d(y)) against central differences with a step
    of 1e-7 (the barrier varies on the scale of d ~ 0.01-0.09); tolerance 1e-6 relative."""
    rng = np.random.default_rng(50 + region)
    worst_g = worst_h = 0.0
    for _ in range(60):
        y = near_sample(region, rng)
        assert point_edge_distance_type(y) == region
        g = np.zeros(6)
        H = np.zeros((6, 6))
        E = point_edge_barrier(y, DHAT, KAPPA, g, H, False)
        assert E == pytest.approx(barrier(point_edge_distance(y), DHAT, KAPPA), rel=1e-14)
        h = 1e-7
        g_fd = fd_gradient(lambda z: point_edge_barrier(z, DHAT, KAPPA, np.zeros(6), np.zeros((6, 6)), False, region),
                           y, h)
        H_fd = fd_jacobian(lambda z: energy_grad(z, region), y, h)
        worst_g = max(worst_g, rel_err(g, g_fd))
        worst_h = max(worst_h, rel_err(H, H_fd))
    assert worst_g < 1e-6 and worst_h < 1e-6, (worst_g, worst_h)


def test_point_edge_barrier_outside_support_and_projection():
    rng = np.random.default_rng(8)
    g = np.ones(6)
    H = np.ones((6, 6))
    y = np.array([0.5, 2 * DHAT, 0.0, 0.0, 1.0, 0.0])
    assert point_edge_barrier(y, DHAT, KAPPA, g, H, True) == 0.0
    assert not g.any() and not H.any()
    y[1] = 0.0
    assert point_edge_barrier(y, DHAT, KAPPA, g, H, True) == np.inf
    for region in (PE_P_E0, PE_P_E1, PE_P_E):
        for _ in range(30):
            y = near_sample(region, rng)
            H = np.zeros((6, 6))
            Hp = np.zeros((6, 6))
            point_edge_barrier(y, DHAT, KAPPA, np.zeros(6), H, False)
            point_edge_barrier(y, DHAT, KAPPA, np.zeros(6), Hp, True)
            w, V = np.linalg.eigh(H)
            ref = (V * np.maximum(w, 0)) @ V.T
            assert rel_err(Hp, ref) < 1e-12
            assert np.linalg.eigvalsh(Hp).min() >= -1e-12 * np.abs(Hp).max()


def test_point_point_barrier_derivatives():
    rng = np.random.default_rng(9)
    for _ in range(40):
        q = rng.uniform(-1, 1, 2)
        phi = rng.uniform(0, 2 * np.pi)
        z = np.r_[q + rng.uniform(0.15, 0.9) * DHAT * np.array([np.cos(phi), np.sin(phi)]), q]

        def grad(w):
            gw = np.zeros(4)
            point_point_barrier(w, DHAT, KAPPA, gw, np.zeros((4, 4)), False)
            return gw

        def val(w):
            return point_point_barrier(w, DHAT, KAPPA, np.zeros(4), np.zeros((4, 4)), False)

        g = np.zeros(4)
        H = np.zeros((4, 4))
        val0 = point_point_barrier(z, DHAT, KAPPA, g, H, False)
        assert val0 == pytest.approx(barrier(np.linalg.norm(z[:2] - z[2:]), DHAT, KAPPA), rel=1e-14)
        assert rel_err(g, fd_gradient(val, z, 1e-7)) < 1e-6
        assert rel_err(H, fd_jacobian(grad, z, 1e-7)) < 1e-6


def test_batched_pairs_equal_single_calls():
    rng = np.random.default_rng(11)
    pts = rng.uniform(0, 1, (20, 2))
    verts = rng.uniform(0, 1, (10, 2))
    edges = np.array([[i, i + 1] for i in range(9)], dtype=np.int64)
    pairs = np.array([[i, j] for i in range(20) for j in range(9)], dtype=np.int64)
    w = rng.uniform(0.5, 2.0, 20)
    G = np.zeros((len(pairs), 6))
    Hs = np.zeros((len(pairs), 6, 6))
    total = point_edge_barrier_pairs(pts, verts, edges, pairs, 0.3, KAPPA, w, G, Hs, True)
    ref = 0.0
    for k, (i, j) in enumerate(pairs):
        y = np.r_[pts[i], verts[edges[j, 0]], verts[edges[j, 1]]]
        g = np.zeros(6)
        H = np.zeros((6, 6))
        ref += point_edge_barrier(y, 0.3, KAPPA * w[i], g, H, True)
        assert np.array_equal(g, G[k]) and np.array_equal(H, Hs[k])
    assert total == pytest.approx(ref, rel=1e-14)


@pytest.mark.parametrize("n", [2, 3, 4, 6, 9, 12])
def test_psd_projection_of_stencil_sized_matrices(n):
    rng = np.random.default_rng(n)
    for _ in range(50):
        A = rng.normal(size=(n, n)) * 10 ** rng.uniform(-3, 3)
        A = A + A.T
        P = A.copy()
        wmin = project_psd(P)
        assert wmin == pytest.approx(np.linalg.eigvalsh(A).min(), abs=1e-13 * np.abs(A).max())
        ew, EV = np.linalg.eigh(A)
        assert rel_err(P, (EV * np.maximum(ew, 0)) @ EV.T) < 1e-12
    S = rng.normal(size=(n, n))
    S = S @ S.T
    P = S.copy()
    project_psd(P)
    assert np.array_equal(P, S)  # PSD input untouched


def test_psd_projection_matches_ipctk():
    ipctk = pytest.importorskip("ipctk")
    rng = np.random.default_rng(12)
    for n in (4, 6, 9, 12):
        for _ in range(20):
            A = rng.normal(size=(n, n))
            A = A + A.T
            P = A.copy()
            project_psd(P)
            assert rel_err(P, np.asarray(ipctk.project_to_psd(A))) < 1e-12


def _polyline_corner(angle_deg):
    """Vertex 1 at the origin between edges (0, 1) and (1, 2), the second edge turned by
    angle_deg from the first's continuation (0: straight; > 0: a convex corner seen from
    below; < 0: concave)."""
    a = np.radians(angle_deg)
    verts = np.array([[-1.0, 0.0], [0.0, 0.0], [np.cos(a), -np.sin(a)]])
    edges = np.array([[0, 1], [1, 2]])
    return verts, edges


def _corrected(points, verts, edges):
    """(energy, gradient over (p, v0, v1, v2), PSD-projected Hessian of the sum) of the two
    point-edge terms plus the vertex correction, assembled as the implicit step does."""
    from mpmsim.contact.barrier.potential import point_node_barrier_pairs, vertex_edges

    w = np.ones(1)
    pe = np.array([[0, 0], [0, 1]])
    gb, Hb = np.zeros((2, 6)), np.zeros((2, 6, 6))
    e = point_edge_barrier_pairs(points, verts, edges, pe, DHAT, KAPPA, w, gb, Hb, True)
    node_weight = np.array([0.0, 1.0, 0.0])
    pn = np.array([[0, 1]])
    others, gn, Hn = np.zeros((1, 3), np.int64), np.zeros((1, 8)), np.zeros((1, 8, 8))
    e += point_node_barrier_pairs(points, verts, edges, vertex_edges(edges, 3), pn, DHAT, KAPPA, w, node_weight,
                                  others, gn, Hn, True)
    g, H = np.zeros(8), np.zeros((8, 8))  # local points: p, v0, v1, v2 -> slots 0..3
    for k, (a, b) in enumerate(edges):
        idx = np.r_[0, 1, 2 + 2 * a, 3 + 2 * a, 2 + 2 * b, 3 + 2 * b]
        g[idx] += gb[k]
        H[np.ix_(idx, idx)] += Hb[k]
    idx = np.concatenate([[0, 1]] + [[2 + 2 * n, 3 + 2 * n] for n in others[0]])
    g[idx] += gn[0]
    H[np.ix_(idx, idx)] += Hn[0]
    return e, g, H


@pytest.mark.parametrize("angle", [0.0, 40.0, -40.0])
def test_vertex_correction_gives_the_polyline_barrier_and_keeps_newton_psd(angle):
    """BFEMP's (deg - 1) correction: two edges plus -b(|p - v|). On a straight or convex corner
    the sum is b(distance to the polyline) wherever the point sees v as an edge's end; its
    gradient matches finite differences and the assembled Hessian is PSD for every corner,
    also where a concave corner makes the point see both edges from their middles."""
    verts, edges = _polyline_corner(angle)
    rng = np.random.default_rng(11)
    for _ in range(40):
        p = np.array([rng.uniform(-0.08, 0.08), rng.uniform(0.005, 0.09)])
        e, g, H = _corrected(p[None, :], verts, edges)
        if not np.isfinite(e) or e == 0.0:
            continue
        d_poly = min(point_edge_distance(np.r_[p, verts[a], verts[b]]) for a, b in edges)
        kinds = [point_edge_distance_type(np.r_[p, verts[a], verts[b]]) for a, b in edges]
        sees_end = kinds[0] == PE_P_E1 or kinds[1] == PE_P_E0
        if angle >= 0.0 and sees_end:
            assert e == pytest.approx(barrier(d_poly, DHAT, KAPPA), rel=1e-12, abs=1e-12 * KAPPA * DHAT)

        def energy(z):
            pts = z[:2][None, :]
            vv = z[2:].reshape(3, 2)
            return _corrected(pts, vv, edges)[0]

        z = np.r_[p, verts.ravel()]
        assert rel_err(g, fd_gradient(energy, z, 1e-8)) < 1e-5
        assert np.linalg.eigvalsh(H)[0] > -1e-9 * np.abs(H).max()
