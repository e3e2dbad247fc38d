"""The implicit step with barrier contact: cost per step (`make bench`).

    python bench/implicit.py [--h 0.025] [--rings-end 0.1]

inputs/implicit_blocks_2d.yaml (FEM on FEM) at element size h, and inputs/implicit_rings_2d.yaml
(an MPM ring against an FEM ring), one thread: DOFs, Newton iterations per step and the time per
step split into assembly, sparse solve, CCD and line search, after a first (compiling) step.
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


def measure(name: str, d: dict) -> None:
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
    st = sim.state
    its = sum(s[0] for s in stats)
    parts = []
    dofs = 0
    if st.fem is not None:
        parts.append(f"{len(st.fem.cells)} triangles")
        dofs += st.fem.x.size - int(st.fem.held.sum())
    if sim.integrator.grid is not None:
        grid = sim.integrator.grid
        parts.append(f"{st.particles.n} particles on {grid.n} active grid nodes")
        dofs += grid.X.size
    print(f"{name}: {', '.join(parts)}, {dofs} free DOFs (last step), {steps} steps, {its / steps:.2f} Newton "
          f"iterations per step, {wall / steps * 1e3:.1f} ms per step ({wall / its * 1e3:.1f} ms per Newton "
          "iteration), one thread")
    for part, sec in sim.integrator.timers.items():
        print(f"  {part:12s} {sec / steps * 1e3:8.2f} ms/step  {100 * sec / wall:5.1f}%")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--h", type=float, default=0.025, help="element size of the blocks (default 0.025)")
    ap.add_argument("--rings-end", type=float, default=0.1, help="end time of the rings run (default 0.1 s)")
    args = ap.parse_args()
    numba.set_num_threads(1)
    d = yaml.safe_load((ROOT / "inputs" / "implicit_blocks_2d.yaml").read_text())
    for b in d["bodies"]:
        b["element_size"] = args.h
    d["output"] = {"history_interval": d["time"]["end"]}
    measure(f"implicit blocks, h = {args.h:g}", d)
    d = yaml.safe_load((ROOT / "inputs" / "implicit_rings_2d.yaml").read_text())
    d["time"]["end"] = args.rings_end
    d["output"] = {"history_interval": args.rings_end}
    measure("implicit rings (MPM ring against FEM ring)", d)


if __name__ == "__main__":
    main()
