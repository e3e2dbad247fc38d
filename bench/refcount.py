"""Benchmark: what numba's reference counting costs on this machine.

numba counts references to arrays (an NRT incref and decref, each an atomic add through a
function pointer). Where an inlined helper that takes arrays branches, its pruning keeps a pair
per array per call (docs/architecture.md, "Reference counting"); mpmsim's hot loops avoid that.
This bench says what it would cost here, so that machines can be compared (atomics cost more
on some CPUs than on others; a step that paid many of them gains less on those): the benchmark
column's grid velocities (`tasks.boundary.grid_velocity`, a call of `bc.node_bc` per node
component, 2 per field in 2D) with the grid view's faces as tuples, as mpmsim passes them, and as
arrays (two arrays the helper keeps a pair of references to per call: 4 pairs a field), and the
difference per pair.

    python bench/refcount.py [--repeat 50]
"""

from __future__ import annotations

import argparse
import timeit
from pathlib import Path

import numba
import numpy as np

from machine import describe  # (bench/machine.py: run as python bench/refcount.py)

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=50, help="kernel calls per timing (best of 5)")
    args = ap.parse_args()
    numba.set_num_threads(1)
    print(describe(1))
    from mpmsim.deck import load_deck
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation
    from mpmsim.tasks.boundary import grid_velocity, held_by

    sim = Simulation(build_scene(load_deck(ROOT / "bench" / "column.yaml")), out_dir=None, threads=1)
    sim.step()
    st = sim.state
    view = st.grid.view
    arrays = view._replace(face_type=np.array(view.face_type), wall_index=np.array(view.wall_index))
    active, fields = st.box.active(), st.fields
    held = held_by(st, st.rigid.v_start)
    nf = active.fields.size
    kernel = grid_velocity.serial
    per_field = {}
    for name, grid in (("faces as tuples (mpmsim)", view), ("faces as arrays", arrays)):
        def calls():
            for _ in range(args.repeat):
                kernel(active, grid, held, fields.mass, fields.mom, fields.vel)

        calls()  # (compiles the kernel for the arrays' types)
        t = min(timeit.repeat(calls, number=1, repeat=5))
        per_field[name] = t / args.repeat / nf
        print(f"column grid velocities, {name}: {t / args.repeat * 1e6:.1f} us for {nf} fields, "
              f"{per_field[name] * 1e9:.1f} ns a field")
    extra = per_field["faces as arrays"] - per_field["faces as tuples (mpmsim)"]
    print(f"one reference pair (incref + decref): {extra / 4 * 1e9:.1f} ns")


if __name__ == "__main__":
    main()
