"""Output faults: a full disk, a read-only folder, a file where the folder should be. Each
stops the run with one line naming the path and the cause, exit 4, no traceback, and the
files already written whole and consistent (the .pvd lists exactly the frames there)."""

from __future__ import annotations

import errno
import os
import re
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from mpmsim.cli import EXIT_IO, app
from mpmsim.output.history import read_history
from tests.conftest import ROOT

pytestmark = pytest.mark.reliability


def _deck(tmp_path: Path, checkpoint="off") -> Path:
    data = yaml.safe_load((ROOT / "inputs" / "fem_blocks_2d.yaml").read_text())
    data["time"] = {"end": 0.004, "dt": 2.5e-5}
    data["output"] = {"vtu_interval": 0.0005, "history_interval": 0.0001, "checkpoint_interval": checkpoint}
    path = tmp_path / "faults.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _consistent(out: Path) -> None:
    """No temporary file; the .pvd lists exactly the VTU files there; the CSV reads."""
    assert not list(out.glob(".faults*.tmp")), list(out.iterdir())
    listed = set(re.findall(r'file="([^"]+)"', (out / "faults.pvd").read_text()))
    present = {p.name for p in out.glob("*.vtu")}
    assert listed == present and listed
    assert len(read_history(out / "faults_history.csv")["time"]) >= 1


def _failing_after(n_ok: int, err: int, what):
    """A stand-in for a writer that works n_ok times, then fails as a full disk or a
    read-only folder does."""
    calls = [0]

    def write(*args, **kwargs):
        calls[0] += 1
        if calls[0] > n_ok:
            raise OSError(err, os.strerror(err), str(args[0]) if args else None)
        return what(*args, **kwargs)

    return write


# a read-only folder is a writer failing with EACCES or EROFS (a chmod cannot show it to root)
@pytest.mark.parametrize("err", [errno.ENOSPC, errno.EACCES, errno.EROFS], ids=["disk full", "no permission",
                                                                              "read-only"])
def test_a_write_failing_mid_run_stops_with_exit_4_and_whole_files(tmp_path, monkeypatch, err):
    import meshio

    import mpmsim.output.vtu as vtu

    monkeypatch.setattr(vtu.meshio, "write", _failing_after(4, err, meshio.write))
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["run", str(_deck(tmp_path)), "--out", str(out), "--quiet"])
    assert result.exit_code == EXIT_IO, result.output
    text = " ".join(result.output.split())
    assert "output failed at step" in text and os.strerror(err) in text and str(out) in text
    assert "Traceback" not in result.output and len(result.output.strip().splitlines()) == 1
    _consistent(out)


def test_a_checkpoint_that_cannot_be_written_stops_with_exit_4_and_leaves_no_part_of_it(tmp_path, monkeypatch):
    import numpy as np

    import mpmsim.output.checkpoint as checkpoint

    monkeypatch.setattr(checkpoint.np, "savez", _failing_after(1, errno.ENOSPC, np.savez))
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["run", str(_deck(tmp_path, checkpoint=0.001)), "--out", str(out), "--quiet"])
    assert result.exit_code == EXIT_IO, result.output
    assert os.strerror(errno.ENOSPC) in result.output and "Traceback" not in result.output
    _consistent(out)
    assert (out / "faults_checkpoint.npz").is_file()  # the first one, whole


def test_a_run_removes_the_temporary_files_a_killed_run_of_its_deck_left(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    left = [".faults_history.csv.tmp", ".faults_history.json.tmp", ".faults.pvd.tmp", ".faults_checkpoint.npz.tmp",
            ".faults_000003.vtu.tmp", ".faults_fem_000003.vtu.tmp"]
    for name in left + [".other.pvd.tmp"]:
        (out / name).write_text("x")
    result = CliRunner().invoke(app, ["run", str(_deck(tmp_path)), "--out", str(out), "--quiet"])
    assert result.exit_code == 0, result.output
    assert [p.name for p in out.glob(".*.tmp")] == [".other.pvd.tmp"]  # another deck's: not ours to remove
    _consistent(out)
