"""`mpmsim check`'s run-time estimate for FEM and implicit scenes, in the parts that do not
depend on the machine, and the run's closing line splitting its wall time into compiling and
stepping.

`check` probes the scene's first steps (implicit: up to 40; explicit FEM: up to 200, 1 s after
the first) on one thread and extrapolates over the run (mpmsim/cost.py): run time = steps x
Newton iterations per step x time per iteration (an explicit step is one iteration). The time
per iteration is a timing, which depends on the machine and its load: how close the estimate
comes to a measured run is measured on a quiet machine by bench/estimate.py. Checked here: the
steps `check` expects are the run's steps, and for implicit scenes the Newton iterations it
extrapolates from the probe (past it, through contact that develops after it) are the run's
within 50% (0.5 < predicted / counted < 1.5); and the extrapolation's arithmetic
(Probe.run_seconds) on probes whose answer is known.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys

import pytest
import yaml
from typer.testing import CliRunner

from mpmsim.cli import app
from mpmsim.cost import Probe
from mpmsim.deck import load_deck
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation

from ..conftest import ROOT

pytestmark = pytest.mark.speed


def python(*args: str) -> str:
    run = subprocess.run([sys.executable, *args], capture_output=True, text=True, timeout=600,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert run.returncode == 0, run.stderr[-2000:]
    return run.stdout


def check_line(deck) -> str:
    result = CliRunner().invoke(app, ["check", str(deck)])
    assert result.exit_code == 0, result.output
    text = " ".join(result.output.split())
    line = re.search(r"cost: the probe ran (\d+) steps of about (\d+).*?about ([\d.e+-]+) s for the run", text)
    assert line, text
    return line


def whole_run(deck) -> tuple[int, int]:
    """(steps, Newton iterations) of the whole run on one thread (an explicit step counts one)."""
    sim = Simulation(build_scene(load_deck(deck)), out_dir=None, threads=1)
    steps = iterations = 0
    while sim.state.t < sim.end * (1 - 1e-9):
        sim.step()
        steps += 1
        iterations += sim.integrator.stats[-1][0] if hasattr(sim.integrator, "stats") else 1
    return steps, iterations


@pytest.mark.parametrize("name", ["implicit_rings_2d", "implicit_slope_2d", "implicit_mpm_slope_2d"])
def test_check_predicts_an_implicit_runs_newton_iterations_within_50_percent(name):
    deck = ROOT / "inputs" / f"{name}.yaml"
    line = check_line(deck)
    probed, steps = int(line[1]), int(line[2])
    assert probed < steps  # the estimate extrapolates past the probe
    per_step = float(re.search(r"([\d.e+-]+) iterations per step", line[0]).group(1))
    done = int(re.search(r"(\d+) Newton iterations", line[0]).group(1))
    predicted = done + (steps - probed) * per_step
    run_steps, run_iterations = whole_run(deck)
    print(f"{name}: {run_steps} steps, {run_iterations} Newton iterations; predicted {predicted:.0f}; {line[0]}")
    assert run_steps == steps
    assert 0.5 < predicted / run_iterations < 1.5, f"{name}: predicted {predicted:.0f}, counted {run_iterations}"


@pytest.mark.parametrize("name", ["fem_blocks_2d", "fem_ramp_2d", "fem_blocks"])
def test_check_counts_an_explicit_fem_runs_steps(name):
    deck = ROOT / "inputs" / f"{name}.yaml"
    line = check_line(deck)
    steps = int(line[2])
    assert int(line[1]) < steps
    data = yaml.safe_load(deck.read_text())
    assert steps == round(data["time"]["end"] / data["time"]["dt"])  # these decks step at a fixed dt
    ms = float(re.search(r"about ([\d.e+-]+) ms per step on one thread", line[0]).group(1))
    # the steps after the probe at the probe's time per step (the probe's own steps as they were
    # measured: a step that compiled counts whole)
    assert float(line[3]) >= 0.99 * (steps - int(line[1])) * ms / 1e3


def test_the_probe_extrapolates_iterations_and_time_as_documented():
    # implicit: 4 probe steps, contact from the third; the phase is the later half of the contact
    # steps (the fourth): 6 iterations per step, its time per iteration 0.5 s / 6
    p = Probe(iterations=[2, 3, 5, 6], seconds=[9.0, 0.3, 0.4, 0.5], contact=[False, False, True, True])
    assert p.per_step == 6.0 and p.per_iteration == pytest.approx(0.5 / 6)
    # the first (compiling) step at per_iteration, the others as measured, then 100 - 4 steps
    assert p.run_seconds(100) == pytest.approx(2 * 0.5 / 6 + 1.2 + 96 * 6 * 0.5 / 6)
    # explicit: one iteration per step, no contact: the later half of the steps
    q = Probe(iterations=[1] * 6, seconds=[5.0, 0.1, 0.1, 0.2, 0.2, 0.2], contact=[False] * 6)
    assert q.per_step == 1.0 and q.per_iteration == pytest.approx(0.2)
    assert q.run_seconds(1000) == pytest.approx(0.2 + 0.8 + 994 * 0.2)
    # a step that compiled mid-probe (20x the typical) is left out of the time per iteration
    r = Probe(iterations=[1] * 6, seconds=[5.0, 0.1, 0.1, 0.1, 9.0, 0.1], contact=[False] * 6)
    assert r.per_iteration == pytest.approx(0.1)


def test_the_run_closes_with_its_compiling_and_stepping_time(tmp_path):
    deck = yaml.safe_load((ROOT / "inputs" / "fem_blocks_2d.yaml").read_text())
    deck["time"]["end"] = 40 * deck["time"]["dt"]
    path = tmp_path / "short.yaml"
    path.write_text(yaml.safe_dump(deck))
    text = python("-m", "mpmsim", "run", str(path), "--out", str(tmp_path / "out"))
    last = text.strip().splitlines()[-1]
    got = re.fullmatch(r"time: +([\d.]+) s wall = ([\d.]+) s compiling or loading kernels \(the first step less a "
                       r"warm one\) \+ ([\d.]+) s stepping \(40 steps, output included\)", " ".join(last.split()))
    assert got, last
    wall, compiling, stepping = map(float, got.groups())
    assert compiling + stepping == pytest.approx(wall, abs=0.011)
