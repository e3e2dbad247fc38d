"""`mpmsim check`'s time per step against the measured warm step on one thread, within 30%,
for three kinds of deck: one material (disks), LR contact with a rigid platen (two_blocks),
CPDI with XPIC and a rigid body (stretch). The measurement is the task timers of 40 warm
steps after 3 compiling ones (the check stability task included, output left out), the
better of two rounds.

The task costs were measured on the development machine (bench/calibrate.py); a machine of
another speed scales every task alike, so the estimates are first scaled by this machine's
speed relative to it, measured on the column deck (one material, uGIMP, no contact), which
then checks the estimate's shape: how the cost follows particles, nodes per particle and the
tasks a scene needs. The factor is reported and bounded (0.33-3: a faster or slower machine
of the same kind, not a broken model)."""

from __future__ import annotations

import os
import re
import subprocess
import sys

import pytest
from typer.testing import CliRunner

from mpmsim.cli import app

from ..conftest import ROOT

pytestmark = pytest.mark.speed


MEASURE = """
import sys, numba
numba.set_num_threads(1)
from mpmsim.deck import load_deck
from mpmsim.scene import build_scene
from mpmsim.solver import OUTPUT, Simulation
sim = Simulation(build_scene(load_deck(sys.argv[1])), out_dir=None, threads=1)
for _ in range(3):
    sim.step()
best = float("inf")
for _ in range(2):  # the better of two rounds: a shared machine only ever adds time
    sim.reset_timers()
    for _ in range(40):
        sim.step()
    best = min(best, sum(v for k, v in sim.timers.items() if k != OUTPUT) / 40 * 1e6)
print(best)
"""


def measured_us(deck) -> float:
    """Measured in a fresh interpreter, as a user's run is (a test process that has run hundreds
    of tests carries a large heap: Python's collector then adds to every step's Python side)."""
    run = subprocess.run([sys.executable, "-c", MEASURE, str(deck)], capture_output=True, text=True, timeout=600,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert run.returncode == 0, run.stderr[-2000:]
    return float(run.stdout.split()[-1])


def check_us(deck) -> float:
    result = CliRunner().invoke(app, ["check", str(deck)])
    assert result.exit_code == 0, result.output
    assert "no cost measured" not in result.output
    return 1e3 * float(re.search(r"about ([\d.e+-]+) ms per step on one thread", result.output).group(1))


@pytest.fixture(scope="module")
def machine_speed() -> float:
    """This machine's time per step over the calibration machine's, on the column deck."""
    deck = ROOT / "inputs" / "column.yaml"
    factor = measured_us(deck) / check_us(deck)
    print(f"machine factor {factor:.2f}")
    assert 0.33 < factor < 3.0
    return factor


@pytest.mark.parametrize("name", ["disks", "two_blocks", "stretch"])
def test_check_estimates_the_step_within_30_percent(name, machine_speed):
    deck = ROOT / "inputs" / f"{name}.yaml"
    estimate = check_us(deck) * machine_speed
    got = measured_us(deck)
    assert estimate == pytest.approx(got, rel=0.3), \
        f"{name}: check {estimate:.0f} us/step (machine factor {machine_speed:.2f}), measured {got:.0f}"
