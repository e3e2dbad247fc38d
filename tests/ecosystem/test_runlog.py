"""The run log beside the results: command, versions, resolved deck, messages, task table,
exit reason -- for a completed run, a run stopped by --steps and an unstable one."""

from __future__ import annotations

import platform
import re
from pathlib import Path

import numba
import numpy
import pytest
import yaml
from typer.testing import CliRunner

from mpmsim import __version__
from mpmsim.cli import app

pytestmark = pytest.mark.ecosystem
HERE = Path(__file__).parent
INPUTS = HERE.parents[1] / "inputs"


def sections(text: str) -> dict[str, str]:
    parts = re.split(r"^# (.+)$", text, flags=re.M)
    return {"head": parts[0], **{parts[i]: parts[i + 1] for i in range(1, len(parts), 2)}}


def test_completed_run(tmp_path):
    out = tmp_path / "res"
    result = CliRunner().invoke(app, ["run", str(HERE / "platens.yaml"), "--out", str(out), "--threads", "1"])
    assert result.exit_code == 0, result.output
    log = (out / "platens_run.log").read_text()
    s = sections(log)
    head = s["head"]
    assert head.splitlines()[0] == f"command: mpmsim run {HERE / 'platens.yaml'} --out {out} --threads 1"
    for name, v in (("mpmsim", __version__), ("numba", numba.__version__), ("numpy", numpy.__version__),
                    ("python", platform.python_version())):
        assert f"\n{name}: {v}\n" in head
    assert "threads: 1\n" in head
    deck = yaml.safe_load(s["deck, as resolved (defaults filled in)"])
    assert deck["title"] == "Two blocks between rigid platens"
    assert deck["thickness"] == 1.0 and deck["grid"]["cell_size"] == 2.5  # a default and a given value
    table = s["time per task"]
    for task in ("time step", "contact pass 1", "particle update", "check stability"):
        assert task in table
    assert re.search(r"exit: completed at t = 0\.5 ms, step \d+ \(exit 0\)\n$", log)
    assert "platens_run.log" in result.output


def test_stopped_and_unstable_runs(tmp_path):
    out = tmp_path / "res"
    result = CliRunner().invoke(app, ["run", str(HERE / "platens.yaml"), "--out", str(out), "-q", "--steps", "3"])
    assert result.exit_code == 0, result.output
    log = (out / "platens_run.log").read_text()
    assert log.rstrip().endswith("exit: stopped after 3 steps (--steps), checkpoint written (exit 0)")
    assert "# time per task" not in log
    result = CliRunner().invoke(app, ["run", str(INPUTS / "faults" / "inverting_bar.yaml"), "--out", str(out), "-q"])
    assert result.exit_code == 3
    log = (out / "inverting_bar_run.log").read_text()
    assert re.search(r"exit: unstable at step 1, t = \S+ \S+ \(exit 3\)\n$", log)
    assert "J = -0.2094 <= 0: the particle inverted" in sections(log)["warnings and messages"]


def test_a_warning_during_the_run_reaches_the_log(tmp_path, monkeypatch):
    """A Python warning raised while the run steps is shown as usual and kept in the log."""
    import warnings

    from mpmsim.solver import Simulation

    step = Simulation.step

    def warn_once(self):
        if self.state.step == 2:
            warnings.warn("a test warning from step 2", RuntimeWarning)
        return step(self)

    monkeypatch.setattr(Simulation, "step", warn_once)
    out = tmp_path / "res"
    with pytest.warns(RuntimeWarning, match="a test warning"):
        result = CliRunner().invoke(app, ["run", str(HERE / "platens.yaml"), "--out", str(out), "-q", "--steps", "5"])
    assert result.exit_code == 0, result.output
    messages = sections((out / "platens_run.log").read_text())["warnings and messages"]
    assert "warning: RuntimeWarning: a test warning from step 2 (test_runlog.py:" in messages
