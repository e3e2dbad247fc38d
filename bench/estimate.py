"""How close `mpmsim check`'s run-time estimate comes to the measured run, on this machine.

Explicit particle decks (disks, two_blocks, stretch): the per-task cost model a + b n K
(task_costs.json, fitted by bench/calibrate.py on the calibration machine), scaled by this
machine's speed relative to that one, measured on the column deck, against 40 warm steps on one
thread (the better of two rounds). FEM and implicit decks: `check`'s probe of the first steps
extrapolated over the run, against the whole run on one thread in a fresh interpreter (CPU
time, the first step counted at the mean of the others, as the estimate counts it).

A timing depends on the machine and on what else runs on it, so it is measured here, not in
the test suite: the tests check the parts of the estimate that do not depend on the machine
(tests/speed/test_estimate*.py). Run on a quiet machine; prints one line per deck and the
ratio estimate / measured, and exits non-zero when a ratio falls outside the bound
(explicit particle decks 0.7-1.3, FEM and implicit decks 0.5-1.5).

    python bench/estimate.py [--decks disks fem_ramp_2d ...]
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PARTICLE_DECKS = ["disks", "two_blocks", "stretch"]
PROBED_DECKS = ["implicit_rings_2d", "implicit_slope_2d", "implicit_mpm_slope_2d", "fem_blocks_2d", "fem_ramp_2d",
                "fem_blocks"]

WARM_STEPS = """
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

WHOLE_RUN = """
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
print((time.process_time() - t0) * n / (n - 1))
"""


def python(*args: str) -> str:
    """stdout of a fresh interpreter (as a user's run is: a process that has run much else carries
    a large heap, and Python's collector then adds to every step)."""
    run = subprocess.run([sys.executable, *args], capture_output=True, text=True, timeout=1800,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    if run.returncode:
        raise SystemExit(run.stderr[-2000:])
    return run.stdout


def check_text(deck: Path) -> str:
    return " ".join(python("-m", "mpmsim", "check", str(deck)).split())


def particle_estimate_us(deck: Path) -> float:
    return 1e3 * float(re.search(r"about ([\d.e+-]+) ms per step on one thread", check_text(deck)).group(1))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--decks", nargs="*", default=PARTICLE_DECKS + PROBED_DECKS)
    args = ap.parse_args(argv)
    print(f"{datetime.date.today()}, {platform.node()}, {platform.processor() or platform.machine()}, one thread")
    bad = 0
    column = ROOT / "inputs" / "column.yaml"
    factor = None
    for name in args.decks:
        deck = ROOT / "inputs" / f"{name}.yaml"
        if name in PARTICLE_DECKS:
            if factor is None:
                factor = float(python("-c", WARM_STEPS, str(column)).split()[-1]) / particle_estimate_us(column)
                print(f"machine factor (column, measured / estimated): {factor:.2f}")
            estimate = particle_estimate_us(deck) * factor
            got = float(python("-c", WARM_STEPS, str(deck)).split()[-1])
            ratio, lo, hi, unit = estimate / got, 0.7, 1.3, "us/step"
        else:
            line = re.search(r"about ([\d.e+-]+) s for the run", check_text(deck))
            estimate = float(line.group(1))
            got = float(python("-c", WHOLE_RUN, str(deck)).split()[-1])
            ratio, lo, hi, unit = estimate / got, 0.5, 1.5, "s"
        ok = lo < ratio < hi
        bad += not ok
        print(f"{name:24s} estimate {estimate:10.4g} {unit:8s} measured {got:10.4g}  ratio {ratio:5.2f}"
              f"  {'ok' if ok else f'OUTSIDE {lo}-{hi}'}", flush=True)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
