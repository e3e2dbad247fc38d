"""The augury transfers (mpmsim/contact/augury/transfers.py): kernels, exactness for affine fields, momentum
conservation of the correction, and the paper's two-particle problem (Section 3.1) produced by
the transfer code itself."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.contact.augury.transfers import (BSPLINE2, FOUR_NODE, FRICTION, LINEAR, AuguryGrid, apply_h, augury_correction,
                           grid_entries, kernel_weights)

pytestmark = pytest.mark.fem


@pytest.mark.parametrize("kernel", ["linear", "bspline2", "four_node"])
def test_kernels_are_a_partition_of_unity_and_reproduce_linear_fields(kernel):
    for xi in np.random.default_rng(1).uniform(-5.0, 5.0, 200):
        base, w = kernel_weights(kernel, xi)
        nodes = base + np.arange(len(w))
        assert w.sum() == pytest.approx(1.0, abs=1e-14)
        assert w @ nodes == pytest.approx(xi, abs=1e-13)
        assert np.all(w >= 0.0)
        second = w @ (nodes - xi) ** 2  # D_p / h^2
        if kernel == "bspline2":
            assert second == pytest.approx(0.25, abs=1e-13)
        elif kernel == "four_node":
            assert second == pytest.approx(0.5, abs=1e-13)
    # the four-node kernel as printed in the paper (1/8 coefficients) is not a partition of
    # unity: its weights sum to 5/8 at t = 0 (the implementation notes' fix halves it to 1/4)
    t = 0.0
    a, b, c = (1 - t) ** 2, 1 + 2 * t - 2 * t * t, t * t
    assert (a + (a + b) + (b + c) + c) / 8 == pytest.approx(0.5)


def cloud(dim, n, seed):
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.3, 2.7, (n, dim))
    m = rng.uniform(0.5, 2.0, n)
    return rng, x, m


def angular(x, m, v, B):
    """Sum m x cross v + sum m eps:B (2D: scalar, 3D: vector)."""
    if x.shape[1] == 2:
        return np.sum(m * (x[:, 0] * v[:, 1] - x[:, 1] * v[:, 0] + B[:, 1, 0] - B[:, 0, 1]))
    L = np.cross(x, v)
    L[:, 0] += B[:, 2, 1] - B[:, 1, 2]
    L[:, 1] += B[:, 0, 2] - B[:, 2, 0]
    L[:, 2] += B[:, 1, 0] - B[:, 0, 1]
    return (m[:, None] * L).sum(axis=0)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("kernel", [LINEAR, BSPLINE2, FOUR_NODE])
def test_apic_transfer_is_exact_for_affine_fields_and_conserves_momentum(dim, kernel):
    rng, x, m = cloud(dim, 40, 7 + dim + kernel)
    grid = AuguryGrid(0.4, kernel, True)
    ent = grid_entries(x, grid)
    v0, L = rng.normal(size=dim), rng.normal(size=(dim, dim))
    v = v0 + x @ L.T
    # B = L D_p with D_p = sum_i N_ip r r^T from the same weights (computed here independently)
    D = np.einsum("pk,pka,pkb->pab", ent.weight, ent.r, ent.r)
    B = np.einsum("ab,pbc->pac", L, D)
    out_v, out_B = apply_h(ent, m, v, B, True)
    np.testing.assert_allclose(out_v, v, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out_B, B, rtol=0, atol=1e-12)
    # any field: linear and angular momentum unchanged
    v, B = rng.normal(size=v.shape), rng.normal(size=B.shape)
    out_v, out_B = apply_h(ent, m, v, B, True)
    scale = np.abs(m[:, None] * v).sum()  # round-off scale of the sums
    np.testing.assert_allclose((m[:, None] * out_v).sum(axis=0), (m[:, None] * v).sum(axis=0), rtol=0,
                               atol=1e-13 * scale)
    np.testing.assert_allclose(angular(x, m, out_v, out_B), angular(x, m, v, B), rtol=0, atol=1e-12 * scale * 3)


@pytest.mark.parametrize("apic", [True, False], ids=["APIC", "PIC"])
@pytest.mark.parametrize("iterations", [0, 1, 2])
def test_augury_correction_has_no_net_momentum(apic, iterations):
    rng, x, m = cloud(2, 60, 3)
    v = rng.normal(size=(60, 2))
    B = rng.normal(size=(60, 2, 2)) if apic else np.zeros((60, 2, 2))
    n = rng.normal(size=(60, 2))
    n /= np.linalg.norm(n, axis=1)[:, None]
    mu = np.full(60, 0.3)
    acc, acc_B = augury_correction(x, m, v, B, n, mu, AuguryGrid(0.5, BSPLINE2, apic), iterations, 1e-3, FRICTION)
    scale = np.abs(m[:, None] * acc).sum()
    assert np.abs((m[:, None] * acc).sum(axis=0)).max() < 1e-13 * scale
    if apic:
        assert abs(angular(x, m, acc, acc_B)) < 1e-12 * scale * np.abs(x).max()
    else:
        assert abs(angular(x, m, acc, acc_B)) > 1e-6 * scale  # PIC does not conserve it


def two_particles(tau: float, apic: bool, t_end: float, dt_over_tau: float = 0.0025):
    """The paper's Section 3.1 problem run through the transfer code: two equal particles in
    one cell [-1, 1] of a linear-kernel grid (spacing 2, shifted so nodes sit at -1 and 1;
    2D, both at mid-cell height, which keeps the problem one-dimensional), left one at
    x = -0.9 moving right at 1, the other mirrored; no mechanical force, N = 0. Time
    integration as the FEM bodies do it (velocity Verlet, the correction from the half-step
    velocity). Returns (times, x of the left particle)."""
    grid = AuguryGrid(2.0, LINEAR, apic)
    x = np.array([[1.0 - 0.9, 1.0], [1.0 + 0.9, 1.0]])
    v = np.array([[1.0, 0.0], [-1.0, 0.0]])
    B = np.zeros((2, 2, 2))
    m, normal, mu = np.ones(2), np.array([[1.0, 0.0], [-1.0, 0.0]]), np.zeros(2)
    dt = dt_over_tau * tau
    acc, acc_B = augury_correction(x, m, v, B, normal, mu, grid, 0, tau)
    t, ts, xs = 0.0, [0.0], [x[0, 0] - 1.0]
    while t < t_end - 1e-12:
        v_half, B_half = v + 0.5 * dt * acc, B + 0.5 * dt * acc_B
        x = x + dt * v_half
        acc, acc_B = augury_correction(x, m, v_half, B_half, normal, mu, grid, 0, tau)
        v, B = v_half + 0.5 * dt * acc, B_half + 0.5 * dt * acc_B
        t += dt
        ts.append(t)
        xs.append(x[0, 0] - 1.0)
        if not apic and abs(v[0, 0]) < 1e-10:  # PIC: stalled for good (v decays exponentially)
            break
    return np.array(ts), np.array(xs)


@pytest.mark.parametrize("tau,stall", [(0.05, -0.7446), (0.2, -0.4982), (0.5, -0.1583)])
def test_pic_augury_stalls_at_a_gap(tau, stall):
    """PIC: v(x) = 1 + [(x^3/3 - x) - (x0^3/3 - x0)]/tau, so the particles stop where that is
    zero, at a finite gap that shrinks as tau grows (the paper's Fig. 7)."""
    _, xs = two_particles(tau, False, 20.0)
    assert xs[-1] == pytest.approx(stall, abs=1e-3)


def test_apic_augury_closes_the_gap():
    """APIC: the only rest state with B != 0 is x = 0 (the paper's Fig. 6): the particles meet."""
    ts, xs = two_particles(0.2, True, 20.0, dt_over_tau=0.005)
    assert abs(xs[-1]) < 1e-3
    assert xs.min() > -0.9 - 1e-12 and np.all(xs <= 1e-3)  # approached monotonically-ish, never crossed


@pytest.mark.parametrize("apic", [False, True])
def test_each_augury_iteration_quarters_the_sliding_loss_between_offset_rows(apic):
    """Two long rows of equal-mass boundary nodes in contact (spacing h = 2 h_c, the ramp test's
    ratio), the upper one sliding at unit speed, shifted by h / 2 so that every node sits on a
    grid node with the other row's nodes one cell either side (B-spline weights 3/4, 1/8, 1/8).
    The first transfer gives the slider's grid nodes 3/4, the bed's 1/4; gathered back, the
    slider keeps 5/8 and the bed gets 3/8: the relative speed drops by 3/4. Each frictionless
    iteration sends the undesired tangential change (-a, +a) through the grid, which returns
    -a/4: it removes 3/4 of what is left. So the loss of relative sliding speed per step is
    exactly (3/4) 4^-N; by symmetry B stays zero and APIC agrees with PIC."""
    h, k = 0.5, 41
    s = (np.arange(k) - k // 2) * h
    x = np.r_[np.c_[s + 0.5 * h, np.zeros(k)], np.c_[s, np.zeros(k)]]
    v = np.zeros((2 * k, 2))
    v[:k, 0] = 1.0
    normal = np.zeros((2 * k, 2))
    normal[:k, 1], normal[k:, 1] = -1.0, 1.0
    mid = slice(k // 4, k - k // 4)
    for n in range(5):
        acc, _ = augury_correction(x, np.ones(2 * k), v, np.zeros((2 * k, 2, 2)), normal, np.zeros(2 * k),
                                   AuguryGrid(0.5 * h, BSPLINE2, apic), n, 1.0, FRICTION)
        relative = (1.0 + acc[:k][mid, 0]) - acc[k:][mid, 0]
        assert np.allclose(1.0 - relative, 0.75 * 4.0**-n, rtol=1e-12, atol=1e-14)
        assert np.abs(acc[:, 1]).max() < 1e-13  # nothing normal: the rows neither push nor pull
