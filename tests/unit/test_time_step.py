"""The run's step length (mpmsim.solver.step_length): steps of one length that land on
time.end, never longer than the step the rule allows (the CFL bound or time.dt)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mpmsim.solver import step_length


def steps_to(end: float, rules) -> list[float]:
    """The steps a run takes to `end` when the rule of each step is next(rules)."""
    t, out = 0.0, []
    while t < end * (1.0 - 1e-9):
        rule = next(rules)
        dt = step_length(rule, end - t)
        assert 0.0 < dt <= rule * (1.0 + 1e-6)
        out.append(dt)
        t += dt
    assert t == pytest.approx(end, rel=1e-12)
    return out


def constant(rule: float):
    while True:
        yield rule


def test_a_constant_rule_gives_equal_steps_that_land_on_the_end():
    """end / rule = 3.33: four steps of 0.25, the last one not a sliver (cutting only the last
    step short would take 0.3, 0.3, 0.3 and 0.1)."""
    dts = steps_to(1.0, constant(0.3))
    assert len(dts) == 4
    assert np.allclose(dts, 0.25, rtol=1e-14, atol=0.0)
    dts = steps_to(0.344757, constant(2.1546e-4))  # a Hertz run's: 1601 steps, one length
    assert len(dts) == math.ceil(0.344757 / 2.1546e-4)
    assert max(dts) / min(dts) - 1.0 < 1e-9


def test_a_rule_that_divides_the_time_is_taken_as_it_is():
    """time.dt = 2.5e-5 to 1e-3: forty steps, each exactly the rule (the quotient is 40 only to
    rounding), so decks whose end is a whole number of steps run as before, bit for bit."""
    dts = steps_to(1e-3, constant(2.5e-5))
    assert len(dts) == 40
    assert all(dt == 2.5e-5 for dt in dts[:-1])
    assert dts[-1] == pytest.approx(2.5e-5, rel=1e-9)


def test_the_clocks_rounding_over_a_long_run_does_not_split_the_last_step():
    """time.dt = 6.25e-6 to 0.1 (a ramp deck at half its step): 16,000 steps of exactly the rule;
    the clock's sum drifts by about 1e-9 of a step by the end, and a tolerance below that split
    the last step in two (16,001 steps)."""
    dts = steps_to(0.1, constant(6.25e-6))
    assert len(dts) == 16000
    assert all(dt == 6.25e-6 for dt in dts[:-1])


def test_a_varying_rule_is_never_exceeded_and_the_steps_stay_even():
    """A CFL bound that wanders by 10% (0.2% a step): each step within its rule; a step grows
    when the rule has grown past the next whole number of steps (by 1/n, n the steps left:
    2.1% at most here, 47 steps from the end), and the last ten steps are of one length."""
    rng = np.random.default_rng(4)
    rules = iter(1e-3 * (1.0 + 0.1 * np.sin(np.arange(100000) / 50.0)) * (1.0 + 1e-3 * rng.random(100000)))
    dts = np.array(steps_to(1.0, rules))
    assert np.abs(np.diff(dts) / dts[:-1]).max() < 0.025
    assert np.abs(dts[-10:] / dts[-1] - 1.0).max() < 1e-12


def test_no_bound_takes_the_remaining_time():
    assert step_length(math.inf, 0.5) == 0.5
    assert step_length(0.2, 0.1) == 0.1
