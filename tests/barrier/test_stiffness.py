"""Adaptive barrier stiffness (mpmsim/contact/barrier/stiffness.py): the bounds put the barrier's
stiffness at 1e-8 of the scene's size at 1e11 times the mean mass, the initial value is the
least-squares balance of the barrier's gradient against the rest, and the raise rule is the IPC
toolkit's update_barrier_stiffness (ipctk, on squared distances)."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.contact.barrier.potential import barrier_second_derivative
from mpmsim.contact.barrier.stiffness import initial_stiffness, raised_stiffness, stiffness_bounds

pytestmark = pytest.mark.implicit


@pytest.mark.parametrize("dt", [1e-2, 1e-4])
def test_bounds_give_the_barrier_1e11_mean_masses_of_stiffness_at_a_tiny_distance(dt):
    m, L, w, dhat = 0.4, 0.34, 0.013, 1e-3
    c = dt * dt
    kmin, kmax = stiffness_bounds(m, L, c, w, dhat)
    assert kmax == pytest.approx(100.0 * kmin, rel=1e-15)
    d = 1e-8 * L
    assert c * w * barrier_second_derivative(d, dhat, kmin) == pytest.approx(1e11 * m, rel=1e-4)


def test_initial_stiffness_is_the_least_squares_balance_clamped_to_the_bounds():
    rng = np.random.default_rng(4)
    for _ in range(100):
        gb, ge = rng.normal(size=30), rng.normal(size=30)
        best = np.linalg.lstsq(gb[:, None], -ge, rcond=None)[0][0]
        assert initial_stiffness(gb, ge, -1e9, 1e9) == pytest.approx(best, rel=1e-12)
        assert initial_stiffness(gb, ge, 10.0, 20.0) == float(np.clip(best, 10.0, 20.0))
    assert initial_stiffness(np.zeros(3), np.ones(3), 5.0, 500.0) == 5.0


def test_the_raise_rule_is_ipctks():
    ipctk = pytest.importorskip("ipctk")
    rng = np.random.default_rng(5)
    raised = 0
    for _ in range(2000):
        L = 10 ** rng.uniform(-2, 1)
        before, now = (10 ** rng.uniform(-11, -7, 2)) * L
        kappa = 10 ** rng.uniform(2, 8)
        kmax = kappa * 10 ** rng.uniform(-0.5, 2)
        ours = raised_stiffness(before, now, kappa, kmax, L)
        ref = ipctk.update_barrier_stiffness(before**2, now**2, kmax, kappa, L)
        assert ours == pytest.approx(ref, rel=1e-15)
        raised += ours != kappa
    assert raised > 100
