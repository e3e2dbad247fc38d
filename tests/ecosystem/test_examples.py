"""examples/: every script runs from a folder of its own and does what its docstring says."""

from __future__ import annotations

import io
import os
import subprocess
import sys

import pandas as pd
import pytest

from ..conftest import ROOT

pytestmark = pytest.mark.ecosystem


def test_every_example_is_tested():
    assert sorted(p.name for p in (ROOT / "examples").glob("*.py")) == ["parameter_loop.py"]


def test_parameter_loop(tmp_path):
    run = subprocess.run([sys.executable, str(ROOT / "examples" / "parameter_loop.py")], cwd=tmp_path,
                         env={**os.environ, "PYTHONPATH": str(ROOT)}, capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-3000:]
    table = pd.read_csv(io.StringIO(run.stdout), sep=r"\s+")
    assert list(table.E_block) == [0.5e7, 1.0e7, 4.0e7]
    # the same disk (314 particles, seeded in rings that follow its surface: it is in contact)
    # bounces off each block; the time step follows the block's wave speed (CFL), so the step
    # count grows as sqrt(E)
    assert (table.disk_particles == 314).all()
    assert table.steps[1] / table.steps[0] == pytest.approx(2**0.5, rel=0.01)
    assert table.steps[2] / table.steps[1] == pytest.approx(2.0, rel=0.01)
    # measured: 0.924, 0.896, 0.838 with the contact defaults (the 1e7 block is the tutorial's:
    # 0.90; with `pass_3: keep` 0.936, 0.903, 0.841; on the lattice, 316 particles and keep:
    # 0.914, 0.898, 0.821)
    assert table.restitution.is_monotonic_decreasing
    assert table.restitution[1] == pytest.approx(0.896, abs=0.005)
    assert ((table.restitution > 0.75) & (table.restitution < 0.95)).all()
    assert (tmp_path / "restitution.png").stat().st_size > 10_000
