"""The history CSV holds the recorder's rows exactly: every float64 is written as the
shortest string that reads back as the same value (Python's float repr), so a sum
conserved to 1e-13 can be checked from the file, and the file is no larger than it needs to be."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from mpmsim.deck.overrides import with_overrides
from mpmsim.output.history import csv_line, read_history
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation

from ..conftest import deck_from
from .test_seams import BLOCKS as SEAM_BLOCKS

pytestmark = pytest.mark.architecture

# the seam tests' two blocks and a platen (per-body, per-material, reaction and contact
# columns), with a history row every step
BLOCKS = with_overrides(SEAM_BLOCKS, {"output": {"vtu_interval": 1.0, "history_interval": 1e-9}})

# values that 10 significant digits (the old format) do not keep, and edge cases of the repr
AWKWARD = [0.1 + 0.2, 1e-300, 5e-324, -2.2250738585072014e-308, 1.7976931348623157e308, 2.0 / 3.0, np.pi,
           -1.0000000000000002, 12345678901234567.0, 1e22, 1e-13, -0.0, np.float64(1.0) / 3.0,
           np.float32(0.1), float("inf"), float("-inf"), float("nan")]


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal bit for bit where not NaN (so -0.0 differs from 0.0); NaN where the other is NaN."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    nan = np.isnan(a)
    return (a.shape == b.shape and np.array_equal(nan, np.isnan(b))
            and np.array_equal(a[~nan].view(np.uint64), b[~nan].view(np.uint64)))


def test_the_history_csv_reads_back_as_the_rows_in_memory(tmp_path):
    sim = Simulation(build_scene(deck_from(BLOCKS)), out_dir=tmp_path, threads=1)
    result = sim.run()
    rows = np.array(sim.recorder.rows, dtype=np.float64)
    assert rows.shape[0] > 10
    # the run's own values need more than 10 digits (else the test would not tell the formats apart)
    assert any(float(f"{v:.10g}") != v for v in rows.ravel())
    df = pd.read_csv(result.history_path)
    assert list(df.columns) == sim.recorder.names
    assert np.array_equal(df.to_numpy(dtype=np.float64), rows, equal_nan=True)
    assert _same(df.to_numpy(dtype=np.float64), rows)
    cols = read_history(result.history_path)
    assert list(cols) == sim.recorder.names
    assert _same(np.column_stack(list(cols.values())), rows)
    # the step stays an integer column
    assert df["step"].dtype.kind == "i"
    assert np.array_equal(df["step"].to_numpy(), sim.recorder.column("step"))


def test_awkward_values_round_trip_through_a_csv_line(tmp_path):
    row = [np.int64(7), 3, *AWKWARD]
    names = [f"c{i}" for i in range(len(row))]
    path = tmp_path / "x_history.csv"
    path.write_text(",".join(names) + "\n" + csv_line(row) + csv_line(row[::-1]))
    want = np.array([row, row[::-1]], dtype=np.float64)
    assert _same(pd.read_csv(path).to_numpy(dtype=np.float64), want)
    assert _same(np.column_stack(list(read_history(path).values())), want)
    # shortest round-trip strings, not a fixed 17 digits
    assert csv_line([0.5, 0.1, 0.1 + 0.2, 1e-300, 3, np.int64(-4)]) == "0.5,0.1,0.30000000000000004,1e-300,3,-4\n"
