"""Imperfect-interface integration: the per-direction oscillator and the paper's force limit."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.contact.laws import direction_force, oscillator
from mpmsim.contact.spec import FORCE_LIMIT, OSCILLATOR


@pytest.mark.parametrize("phi", [1e-5, 0.3, 1.0, 1.5])
def test_oscillator_lands_the_mpm_update_on_the_exact_opening(phi):
    """m delta'' = df - k delta from (delta0, d/m): the returned constant force moves the
    ordinary update delta0 + dt/m (d + dt/2 (df - f)) exactly onto the analytic end opening."""
    m, dt, delta0, d, df = 2.0, 0.1, 0.3, -0.7, 0.4
    k = phi**2 * m / dt**2
    f, end = oscillator(k, m, delta0, d, df, dt)
    w = np.sqrt(k / m)
    # (1 - cos wt)/w^2 as 2 sin^2(wt/2)/w^2: no cancellation as k -> 0
    exact = delta0 * np.cos(w * dt) + d / (m * w) * np.sin(w * dt) + df / m * 2 * np.sin(0.5 * w * dt) ** 2 / w**2
    assert end == pytest.approx(exact, rel=1e-9, abs=1e-12)
    assert delta0 + dt / m * (d + 0.5 * dt * (df - f)) == pytest.approx(end, rel=1e-9, abs=1e-12)


def test_oscillator_tends_to_the_first_order_force():
    m, dt, delta0 = 1.0, 1e-4, 0.02
    k = 1e-3
    f, _ = oscillator(k, m, delta0, 0.0, 0.0, dt)
    assert f == pytest.approx(k * delta0, rel=1e-8)
    f0, end0 = oscillator(0.0, m, delta0, 0.5, 0.2, dt)  # D = 0: a free direction
    assert f0 == 0.0 and end0 == pytest.approx(delta0 + dt * 0.5 / m + 0.5 * 0.2 * dt**2 / m)


def test_force_limit_switches_a_stiff_direction_to_bonded():
    """The 2013 paper: force D A delta unless it exceeds the force that brings both materials
    to the centre of mass within the step (Eq. 26); then the direction acts as perfect."""
    m, dt, delta0 = 1.0, 1e-3, 1e-3
    soft = direction_force(1.0, 1.0, m, delta0, 0.0, 0.0, dt, FORCE_LIMIT)
    assert soft[0] == pytest.approx(1.0 * delta0) and soft[1] == pytest.approx(0.5 * delta0**2) and not soft[2]
    stiff = direction_force(1e9, 1.0, m, delta0, 0.0, 0.0, dt, FORCE_LIMIT)
    assert stiff[2] and stiff[1] == 0.0
    # the oscillator never switches by itself (the geometry does, at phi > 1.5)
    assert not direction_force(1e9, 1.0, m, delta0, 0.0, 0.0, dt, OSCILLATOR)[2]


def test_point_bond_zeroes_the_interpolated_jump_and_conserves_momentum():
    """The consistent normal bond (contact.bond) on a mid-plane pair of nodes (weights 1/2,
    1/2) and a node on the interface (weight 1): afterwards each constraint's interpolated
    relative normal velocity is zero, the tangential velocities are untouched, and the
    momentum of each node (both materials) is unchanged; with unequal jumps the pair keeps
    their difference (the in-cell strain jump the node-wise bond would remove)."""
    from mpmsim.contact.bond import point_bond

    nn = 1  # one grid node before the slots; slots 0..5 are fields 1..6
    mass = np.array([1.0, 2.0, 1.0, 3.0, 1.5, 2.0, 0.5])
    rng = np.random.default_rng(3)
    v = rng.normal(size=(7, 2))
    n = np.zeros((6, 2))
    n[:, 0] = 1.0
    con_ptr = np.array([0, 2, 3])
    ent_a, ent_b, ent_w = np.array([0, 2, 4]), np.array([1, 3, 5]), np.array([0.5, 0.5, 1.0])
    mom = v * mass[:, None]
    before = mom.copy()
    sweeps = point_bond(2, con_ptr, ent_a, ent_b, ent_w, nn, mass, mom, True, np.zeros((1, 3)), 0.0, n, 2)
    assert sweeps <= 2
    vel = mom / mass[:, None]
    jump = [vel[nn + b, 0] - vel[nn + a, 0] for a, b in zip(ent_a, ent_b)]
    assert 0.5 * jump[0] + 0.5 * jump[1] == pytest.approx(0.0, abs=1e-14)
    assert jump[2] == pytest.approx(0.0, abs=1e-14)
    assert abs(jump[0]) > 0.1  # not clamped node by node
    np.testing.assert_allclose(mom[:, 1], before[:, 1], rtol=0, atol=0)
    for a, b in zip(ent_a, ent_b):
        np.testing.assert_allclose(mom[nn + a] + mom[nn + b], before[nn + a] + before[nn + b], atol=1e-14)
