"""Checkpoint and restart: a run stopped (Ctrl-C, SIGTERM) or killed (SIGKILL) and restarted
from its checkpoint ends exactly as the uninterrupted run, to the last bit: history, every
state array, every VTU file. A checkpoint of another deck or version is refused."""

from __future__ import annotations

import json
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import meshio
import pytest
import yaml
from typer.testing import CliRunner

from mpmsim.cli import app
from mpmsim.deck.overrides import with_overrides
from mpmsim.output.checkpoint import CheckpointError, _Encoder, checkpoint_path, read_manifest
from mpmsim.output.history import read_history
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation, StopRequested
from tests.conftest import ROOT, deck_from

pytestmark = pytest.mark.reliability


def _sim(deck: str, overrides: dict, out: Path | None, resume: bool = False) -> Simulation:
    data = with_overrides(yaml.safe_load((ROOT / "inputs" / f"{deck}.yaml").read_text()), overrides)
    return Simulation(build_scene(deck_from(data, ROOT / "inputs", deck)), out_dir=out, threads=1, resume=resume)


def _everything(sim: Simulation) -> tuple[str, list[bytes]]:
    """The state as the checkpoint writer sees it: its structure and every array's bytes."""
    enc = _Encoder()
    tree = enc.node(sim.state, "state")
    return json.dumps(tree), [a.tobytes() for a in enc.arrays.values()]


def _files(folder: Path) -> dict[str, bytes]:
    """Every file's bytes; a history CSV's without its wall_s column (the wall clock: no two
    runs share it), every other column to the byte; the run log by its exit line only (it
    records the command, dates and timings of the run that wrote it)."""
    return {p.name: _without_wall_clock(p.read_bytes()) if p.name.endswith("_history.csv") else
            _exit_line(p.read_bytes()) if p.name.endswith("_run.log") else p.read_bytes()
            for p in sorted(folder.iterdir())}


def _exit_line(log: bytes) -> bytes:
    return log.rstrip().split(b"\n")[-1]


def _without_wall_clock(csv: bytes) -> bytes:
    lines = csv.split(b"\n")
    i = lines[0].split(b",").index(b"wall_s")
    return b"\n".join(b",".join(f for j, f in enumerate(line.split(b",")) if j != i) if line else line
                      for line in lines)


def _rows(sim: Simulation) -> list[list]:
    """The history rows without wall_s."""
    i = sim.recorder.names.index("wall_s")
    return [r[:i] + r[i + 1:] for r in sim.recorder.rows]


# (deck, steps, stop after, overrides): explicit LR contact with a rigid platen (and with the
# energy ledger, whose running sums the checkpoint must carry), imperfect interfaces, shocks
# (Mie-Grueneisen, artificial viscosity), FEM with augury contact, implicit MPM + FEM
CASES = [("two_blocks", 30, 13, {}), ("two_blocks", 30, 13, {"output.energy_ledger": True}),
         ("two_layer", 30, 11, {}), ("nickel_shock", 40, 17, {}), ("fem_blocks_2d", 30, 12, {}),
         ("implicit_rings_2d", 6, 2, {})]


@pytest.mark.parametrize("deck,steps,stop,extra", CASES, ids=[c[0] + ("+" + "+".join(c[3]) if c[3] else "")
                                                               for c in CASES])
def test_a_run_stopped_and_restarted_ends_bit_for_bit_as_the_uninterrupted_run(tmp_path, deck, steps, stop, extra):
    probe = _sim(deck, {}, None)
    end = steps * probe.integrator.stable_dt(probe.state) * (1.0 + 1e-7)
    ov = {"time.end": end, "output.vtu_interval": end / 7, "output.history_interval": end / 23,
          "output.checkpoint_interval": "off", **extra}
    whole = _sim(deck, ov, tmp_path / "whole")
    whole.run()
    part = _sim(deck, ov, tmp_path / "part")

    def stop_here():
        if part.state.step == stop:
            raise StopRequested()

    with pytest.raises(StopRequested):
        part.run(between_steps=stop_here)
    ckpt = checkpoint_path(tmp_path / "part", deck)
    assert read_manifest(ckpt)["step"] == stop
    # the stopped run wrote its last state as a frame; the restart takes it back out
    assert len(_files(tmp_path / "part")) > 3
    again = _sim(deck, ov, tmp_path / "part", resume=True)
    again.resume()
    assert again.state.step == stop and again.state.t == pytest.approx(part.state.t, rel=0, abs=0)
    again.run()
    assert again.state.step == whole.state.step > stop
    assert _everything(again) == _everything(whole)
    assert _rows(again) == _rows(whole) and len(again.recorder.rows[0]) == len(_rows(again)[0]) + 1
    assert _files(tmp_path / "part") == _files(tmp_path / "whole")  # VTU, .pvd, CSV; checkpoint removed
    assert not ckpt.exists()


def test_a_restart_without_the_restore_would_differ(tmp_path):
    """The comparison above can fail: a run restarted from scratch at the checkpoint's step
    count differs from the uninterrupted one."""
    ov = {"time.end": 0.05, "output.checkpoint_interval": "off"}
    whole = _sim("two_blocks", ov, None)
    whole.run()
    other = _sim("two_blocks", with_overrides(ov, {"contact.default": {"law": "coulomb", "friction": 0.21}}), None)
    other.run()
    assert whole.state.step == other.state.step
    assert _everything(other) != _everything(whole)


def test_a_checkpoint_of_another_deck_or_version_is_refused(tmp_path):
    ov = {"time.end": 0.05, "output.checkpoint_interval": "off"}
    sim = _sim("two_blocks", ov, tmp_path)

    def stop_now():
        raise StopRequested()

    with pytest.raises(StopRequested):
        sim.run(between_steps=stop_now)
    changed = _sim("two_blocks", dict(ov, **{"time.end": 0.06}), tmp_path, resume=True)
    with pytest.raises(CheckpointError, match="different deck"):
        changed.resume()
    import mpmsim.solver as solver

    same = _sim("two_blocks", ov, tmp_path, resume=True)
    old, solver.__version__ = solver.__version__, "0.0.1"
    try:
        with pytest.raises(CheckpointError, match="was written by mpmsim"):
            same.resume()
    finally:
        solver.__version__ = old
    (tmp_path / "junk").mkdir()
    (tmp_path / "junk" / "two_blocks_checkpoint.npz").write_bytes(b"not a zip")
    deck = tmp_path / "two_blocks.yaml"
    deck.write_text(yaml.safe_dump(with_overrides(yaml.safe_load((ROOT / "inputs" / "two_blocks.yaml").read_text()),
                                                  ov)))
    for folder, words in ((tmp_path / "junk", "not a readable checkpoint"), (tmp_path / "none", "no checkpoint")):
        result = CliRunner().invoke(app, ["run", str(deck), "--restart", str(folder), "--quiet"])
        assert result.exit_code == 2, result.output
        assert words in result.output and "Traceback" not in result.output


# ---------------------------------------------------------------- the command line, killed
def _deck_file(folder: Path) -> Path:
    """two_blocks (LR contact, friction, rigid platen) for ~3 s of stepping, a checkpoint
    every 1/8 of the run."""
    data = yaml.safe_load((ROOT / "inputs" / "two_blocks.yaml").read_text())
    data["time"]["end"] = 3.0
    data["output"] = {"vtu_interval": 0.3, "history_interval": 0.03, "checkpoint_interval": 3.0 / 8}
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "blocks.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _mpmsim(*args) -> list[str]:
    return [sys.executable, "-m", "mpmsim", *map(str, args)]


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    folder = tmp_path_factory.mktemp("whole")
    deck = _deck_file(folder)
    run = subprocess.run(_mpmsim("run", deck, "--out", folder / "out", "--threads", "1", "--quiet"),
                         capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr
    return _files(folder / "out")


@pytest.mark.parametrize("how", ["SIGKILL", "SIGTERM", "SIGINT"])
def test_a_killed_or_stopped_run_restarts_to_the_uninterrupted_result(tmp_path, uninterrupted, how):
    deck = _deck_file(tmp_path)
    out = tmp_path / "out"
    p = subprocess.Popen(_mpmsim("run", deck, "--out", out, "--threads", "1", "--quiet"),
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    ckpt = checkpoint_path(out, "blocks")
    t0 = time.time()
    while not ckpt.exists() and p.poll() is None and time.time() - t0 < 600:
        time.sleep(0.05)
    assert p.poll() is None, "the run ended before it could be stopped"
    p.send_signal(getattr(signal, how))
    _, err = p.communicate(timeout=300)
    assert p.returncode == {"SIGKILL": -9, "SIGTERM": 143, "SIGINT": 130}[how], err
    assert "Traceback" not in err
    if how != "SIGKILL":
        word = "terminated" if how == "SIGTERM" else "interrupted"
        assert f"{word} at step" in err and f"--restart {out}" in " ".join(err.split())
        assert not list(out.glob(".*.tmp"))
    stopped_at = read_manifest(ckpt)["step"]
    assert 0 < stopped_at
    rows = read_history(out / "blocks_history.csv")  # what the stopped run left reads whole
    listed = re.findall(r'file="([^"]+)"', (out / "blocks.pvd").read_text())
    assert set(listed) <= {p.name for p in out.glob("*.vtu")} and len(rows["time"]) > 1
    for name in listed:
        assert len(meshio.read(out / name).points) > 0
    if how != "SIGKILL":  # stopped at the end of a step: the checkpoint is that step's
        assert rows["step"][-1] == stopped_at
    run = subprocess.run(_mpmsim("run", deck, "--restart", out, "--quiet"), capture_output=True, text=True,
                         timeout=900)
    assert run.returncode == 0, run.stderr
    assert not list(out.glob(".*.tmp"))
    got = _files(out)
    assert sorted(got) == sorted(uninterrupted)
    for name in got:
        assert got[name] == uninterrupted[name], name


def test_a_run_taken_in_pieces_with_steps_and_restart_ends_as_one_run(tmp_path):
    """`mpmsim run --steps N` twice, then `--restart` to the end (each piece restarting from the
    last one's checkpoint) writes the same files as one run."""
    data = yaml.safe_load((ROOT / "inputs" / "fem_blocks_2d.yaml").read_text())
    data["time"] = {"end": 0.002, "dt": 2.5e-5}
    data["output"] = {"vtu_interval": 0.0004, "history_interval": 0.0001, "checkpoint_interval": "off"}
    deck = tmp_path / "pieces.yaml"
    deck.write_text(yaml.safe_dump(data))
    runner = CliRunner()
    whole, pieces = tmp_path / "whole", tmp_path / "pieces"
    assert runner.invoke(app, ["run", str(deck), "--out", str(whole), "--quiet", "--threads", "1"]).exit_code == 0
    first = runner.invoke(app, ["run", str(deck), "--out", str(pieces), "--quiet", "--threads", "1", "--steps", "23"])
    assert first.exit_code == 0 and "stopped after 23 steps" in first.output, first.output
    assert read_manifest(checkpoint_path(pieces, "pieces"))["step"] == 23
    second = runner.invoke(app, ["run", str(deck), "--restart", str(pieces), "--quiet", "--steps", "30"])
    assert second.exit_code == 0 and read_manifest(checkpoint_path(pieces, "pieces"))["step"] == 53, second.output
    last = runner.invoke(app, ["run", str(deck), "--restart", str(pieces), "--quiet"])
    assert last.exit_code == 0, last.output
    assert _files(pieces) == _files(whole)


def test_the_checkpoint_codec_keeps_values_exact_and_shared_arrays_shared(tmp_path):
    """Numbers round-trip to the bit (hex floats, numpy scalar types kept), an array reached by two
    paths comes back as one array, numeric rows come back as lists, mpmsim objects are rebuilt,
    and what was not saved (a function in a list) is left as the fresh run has it."""
    import numpy as np

    from mpmsim.output.checkpoint import restore_checkpoint, write_checkpoint
    from mpmsim.solver import Schedule

    a = np.array([0.1, 1.0 / 3.0, np.nan, -np.inf, 5e-324])
    saved = {"a": a, "b": a, "f": [len, 0.1 + 0.2, np.float32(0.1), (1, "s")], "rows": [[1, 2.5], [3, 4.5]],
             "sch": Schedule(0.1, 2.0, np.inf, 4.0, 5.0)}
    write_checkpoint(tmp_path / "c.npz", {"x": saved}, {"t": 0.0})
    fresh = {"a": np.zeros(5), "b": np.zeros(5), "f": [print, 0.0, np.float32(0), (0, "")], "rows": [],
             "sch": Schedule(0, 0, 0, 0, 0)}
    restore_checkpoint(tmp_path / "c.npz", {"x": fresh})
    assert fresh["a"].tobytes() == a.tobytes() and fresh["b"] is fresh["a"]
    assert fresh["f"][0] is print and fresh["f"][1] == 0.1 + 0.2 and fresh["f"][2] == np.float32(0.1)
    assert type(fresh["f"][2]) is np.float32 and fresh["f"][3] == (1, "s")
    assert fresh["rows"] == [[1, 2.5], [3, 4.5]] and type(fresh["rows"][0][0]) is int
    assert fresh["sch"] == Schedule(0.1, 2.0, np.inf, 4.0, 5.0)
