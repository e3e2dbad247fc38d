"""Every row of the stability suite (scenarios.py): the known failure reproduced on its scene,
the recommended method within its threshold (table and numbers in docs/stability-suite.md)."""

from __future__ import annotations

import pytest

from .scenarios import SCENARIOS


@pytest.mark.validation
@pytest.mark.parametrize("row", SCENARIOS, ids=[s.id for s in SCENARIOS])
def test_row(row, measure):
    m = row.measure()
    side = ">" if row.expect == "above" else "<"
    measure(f"{row.scene}, {row.method}: {row.metric}", f"{m.value:.4g}", f"{side} {row.threshold:g}")
    stop = {True: "stopped as unstable", False: "finished", None: "either"}[row.must_stop]
    assert row.passed(m), (f"{row.scene}, {row.method}: {row.metric} = {m.value:.4g}, expected {side} "
                           f"{row.threshold:g}; run must have {stop}, it {'stopped: ' + m.stopped if m.stopped else 'finished'}")


def test_the_fixed_step_row_runs_past_the_linear_limit():
    """The fixed-step row's claim, from the exact wave speed of the bar in uniaxial strain
    (Eq. 18): c = c0 unstretched, 1.92 c0 at stretch 3, so dt = 0.8 h/c0 ends at CFL 1.54 (and
    crosses 1 near stretch 1.67)."""
    from .scenarios import C0, wave_speed

    assert wave_speed(1.0) == pytest.approx(C0, rel=1e-6)
    assert 0.8 * wave_speed(3.0) / C0 == pytest.approx(1.536, abs=1e-3)
    assert 0.8 * wave_speed(1.6) / C0 < 1.0 < 0.8 * wave_speed(1.7) / C0
