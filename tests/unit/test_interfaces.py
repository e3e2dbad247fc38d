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
