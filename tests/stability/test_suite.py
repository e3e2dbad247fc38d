"""Every row of the stability suite (scenarios.py): the known failure reproduced on its scene,
the recommended method within its threshold (table and numbers in docs/stability-suite.md)."""

from __future__ import annotations

import pytest

from .scenarios import SCENARIOS


@pytest.mark.parametrize("row", SCENARIOS, ids=[s.id for s in SCENARIOS])
def test_row(row):
    m = row.measure()
    side = ">" if row.expect == "above" else "<"
    stop = {True: "stopped as unstable", False: "finished", None: "either"}[row.must_stop]
    assert row.passed(m), (f"{row.scene}, {row.method}: {row.metric} = {m.value:.4g}, expected {side} "
                           f"{row.threshold:g}; run must have {stop}, it {'stopped: ' + m.stopped if m.stopped else 'finished'}")
