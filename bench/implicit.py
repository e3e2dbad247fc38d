"""Implicit FEM with barrier contact: cost per step (`make bench`).

    python bench/implicit.py [--h 0.025]

inputs/implicit_blocks_2d.yaml at element size h (one thread): DOFs, Newton iterations per step
and the time per step split into assembly, sparse solve, CCD and line search, after a first
(compiling) step.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numba
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mpmsim.deck import load_deck_text  # noqa: E402
from mpmsim.scene import build_scene  # noqa: E402
from mpmsim.solver import Simulation  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--h", type=float, default=0.025, help="element size (default 0.025)")
    h = ap.parse_args().h
    numba.set_num_threads(1)
    d = yaml.safe_load((ROOT / "inputs" / "implicit_blocks_2d.yaml").read_text())
    for b in d["bodies"]:
        b["element_size"] = h
    d["output"] = {"history_interval": d["time"]["end"]}
    sim = Simulation(build_scene(load_deck_text(yaml.safe_dump(d), ROOT / "inputs" / "bench.yaml")), threads=1)
    sim.step()
    sim.reset_timers()
    first = len(sim.integrator.stats)
    t0 = time.perf_counter()
    while sim.state.t < sim.end * (1 - 1e-9):
        sim.step()
    wall = time.perf_counter() - t0
    stats = sim.integrator.stats[first:]
    steps = len(stats)
    fem = sim.state.fem
    its = sum(s[0] for s in stats)
    print(f"implicit blocks, h = {h:g}: {len(fem.cells)} triangles, {fem.x.size - int(fem.held.sum())} free DOFs, "
          f"{steps} steps, {its / steps:.2f} Newton iterations per step, {wall / steps * 1e3:.1f} ms per step "
          f"({wall / its * 1e3:.1f} ms per Newton iteration), one thread")
    for name, sec in sim.integrator.timers.items():
        print(f"  {name:12s} {sec / steps * 1e3:8.2f} ms/step  {100 * sec / wall:5.1f}%")


if __name__ == "__main__":
    main()
