"""`mpmsim check`'s run-time estimate for FEM and implicit scenes, against the measured run,
within 50% (0.5 < estimate / measured < 1.5: an estimate off by 2x either way fails), and the
run's closing line splitting its wall time into compiling and stepping.

Implicit scenes: `check` probes the scene's first steps (up to 40, on one thread) for the
Newton iterations per step and the time per iteration, and extrapolates over the run
(mpmsim/cost.py, newton_probe). Each deck here runs longer than the probe (100 or 300 steps),
so the estimate extrapolates past it, through contact that develops after the probe. The
measurement is the whole run on one thread in a fresh interpreter, the first (compiling) step
counted at the mean time of the others, as the estimate counts it. Both are CPU times (the
probe's and the run's): on this shared machine wall times swing with the other jobs' load.

Explicit FEM scenes: `check` probes up to 200 steps (1 s after the first) and takes the mean
warm step of the probe's later half; measured against the whole run (1 200 to 16 000 steps,
12 to 80 times the probe) in the same way as the implicit ones.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys

import pytest
import yaml

from ..conftest import ROOT

pytestmark = pytest.mark.speed

RUN = """
import sys, time, numba
numba.set_num_threads(1)
from mpmsim.deck import load_deck
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation
sim = Simulation(build_scene(load_deck(sys.argv[1])), out_dir=None, threads=1)
sim.step()
t0, n = time.process_time(), 1
while sim.state.t < sim.end * (1 - 1e-9):
    sim.step()
    n += 1
rest = time.process_time() - t0
print(rest * n / (n - 1), sum(s[0] for s in getattr(sim.integrator, "stats", [(1,)] * n)) / n)
"""


def python(*args: str) -> str:
    run = subprocess.run([sys.executable, *args], capture_output=True, text=True, timeout=600,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert run.returncode == 0, run.stderr[-2000:]
    return run.stdout


def estimate_and_run(name: str) -> tuple[float, float, str]:
    """(check's estimate of the run, s; the run measured, s; check's cost line)."""
    deck = ROOT / "inputs" / f"{name}.yaml"
    text = " ".join(python("-m", "mpmsim", "check", str(deck)).split())  # a fresh process, as the run's
    line = re.search(r"cost: the probe ran (\d+) steps of about (\d+).*?about ([\d.e+-]+) s for the run", text)
    assert line, text
    assert int(line[1]) < int(line[2])  # the estimate extrapolates past the probe
    seconds, _ = map(float, python("-c", RUN, str(deck)).split())
    return float(line[3]), seconds, line[0]


@pytest.mark.parametrize("name", ["implicit_rings_2d", "implicit_slope_2d", "implicit_mpm_slope_2d"])
def test_check_estimates_an_implicit_run_within_50_percent(name):
    estimate, seconds, line = estimate_and_run(name)
    print(f"{name}: measured {seconds:.3g} s; {line}")
    assert 0.5 < estimate / seconds < 1.5, f"{name}: check {estimate:.3g} s, measured {seconds:.3g} s"


@pytest.mark.parametrize("name", ["fem_blocks_2d", "fem_ramp_2d", "fem_blocks"])
def test_check_estimates_an_explicit_fem_run_within_50_percent(name):
    estimate, seconds, line = estimate_and_run(name)
    print(f"{name}: measured {seconds:.3g} s; {line}")
    assert 0.5 < estimate / seconds < 1.5, f"{name}: check {estimate:.3g} s, measured {seconds:.3g} s"


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
