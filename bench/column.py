"""Benchmark: particle-steps per second on the standard column problem, per task, after a line
naming the machine (bench/machine.py: CPU model, numba's target CPU and its vector features),
with the step's bytes per particle-step and their share of a memory triad timed in the same run
(bench/traffic.py's accounting).

The LR paper's 40 x 100 mm neo-Hookean column, 1 mm cells, 4 particles per cell (16 000
particles), uGIMP, one material, rigid platen at 0.05% of the wave speed; a fixed number
of steps with 1 and 2 threads. A ratio to the reference code is printed only when its rate is
given (`--reference M1 [M2]`: its particle-steps/s on 1 [and 2] threads, run on this machine in
the same sitting, as docs/performance.md measures it); a figure from another machine or day
would mislead.

    python bench/column.py [--steps N] [--threads 1 2] [--deck bench/column.yaml] [--matrix-steps N]
                           [--reference 0.62e6 1.1e6]

Then a table for every shape function x {FLIP, XPIC(5), APIC} (all threads).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numba
import yaml

from mpmsim.deck import load_deck, load_deck_text
from mpmsim.scene import build_scene
from mpmsim.shapes import SHAPE_FUNCTIONS
from mpmsim.solver import Simulation
from mpmsim.stability import total_sums

from machine import describe, steps_wall  # (bench/machine.py: run as python bench/column.py)

ROOT = Path(__file__).resolve().parents[1]
SCHEMES = {"flip": {"scheme": "flip"}, "xpic(5)": {"scheme": "xpic", "order": 5}, "apic": {"scheme": "apic"}}


def load(deck: Path, shape: str | None = None, update: dict | None = None):
    if shape is None and update is None:
        return load_deck(deck)
    data = yaml.safe_load(deck.read_text())
    if shape:
        data["shape_function"] = shape
    if update:
        data["update"] = {**data.get("update", {}), **update}
    return load_deck_text(yaml.safe_dump(data), deck)


def measure(deck: Path, steps: int, threads: int, warmup: int = 5, shape=None, update=None, keep: list | None = None):
    numba.set_num_threads(threads)
    sim = Simulation(build_scene(load(deck, shape, update)), out_dir=None, threads=threads)
    wall = steps_wall(sim, steps, warmup)
    n = sim.state.particles.n
    if keep is not None:
        keep.append(sim)
    return n * steps / wall, dict(sim.timers), n


def traffic_line(sim, rate: float) -> str:
    """The step's bytes per particle-step (bench/traffic.py's accounting of what each task
    streams; grid gathers and scatters apart), the bandwidth that makes at `rate`, and its share
    of a memory triad (a[i] = b[i] + s c[i] over 3 x 128 MiB) timed now."""
    from traffic import TRAFFIC, task_bytes, triad_gbs  # (bench/traffic.py; imported when asked for: it builds its own kernels)

    per_task = [task_bytes(sim, t) for t in sim.integrator.timers if t in TRAFFIC]
    streamed = sum(b[0] for b in per_task)
    gathered = sum(b[1] for b in per_task)
    triad = triad_gbs(1 << 24, 7)
    gbs = streamed * rate / 1e9
    return (f"  traffic: {streamed:.0f} B streamed + {gathered:.0f} B gathered/scattered per particle-step; "
            f"{gbs:.2f} GB/s = {100 * gbs / triad:.0f}% of the memory triad ({triad:.1f} GB/s, timed now)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--deck", type=Path, default=ROOT / "bench" / "column.yaml")
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--matrix-steps", type=int, default=100, help="steps per shape x scheme cell (0: skip)")
    ap.add_argument("--reference", type=float, nargs="+", metavar="RATE",
                    help="the reference code's particle-steps/s on 1 [and 2] threads, measured here in this sitting")
    args = ap.parse_args()
    print(describe())
    t0 = time.perf_counter()
    numba.set_num_threads(1)
    sim = Simulation(build_scene(load_deck(args.deck)), out_dir=None, threads=1)
    total_sums(sim.state)  # load/compile kernels: the energy sums (as a run's start) and a step
    sim.step()
    print(f"warm start (load deck, build scene, first step incl. JIT/cache load): {time.perf_counter() - t0:.2f} s")
    reference = dict(zip((1, 2), args.reference or []))
    for th in args.threads:
        if th > numba.config.NUMBA_NUM_THREADS:
            print(f"skipping {th} threads: this machine allows {numba.config.NUMBA_NUM_THREADS}")
            continue
        kept: list = []
        rate, timers, n = measure(args.deck, args.steps, th, keep=kept)
        ref = reference.get(th)
        vs = f"  (C++ reference {ref / 1e6:.2f} M: x{rate / ref:.2f})" if ref else ""
        print(f"\n{th} thread(s): {n} particles x {args.steps} steps: {rate / 1e6:.3f} M particle-steps/s{vs}")
        print(traffic_line(kept[0], rate))
        total = sum(timers.values())
        for name, sec in timers.items():
            if name == "output":
                continue
            print(f"  {name:22s} {sec / args.steps * 1e6:9.1f} us/step  {100 * sec / total:5.1f} %"
                  f"  {n * args.steps / sec / 1e6 if sec > 0 else float('inf'):9.2f} M p-steps/s")
    if args.matrix_steps <= 0:
        return
    threads = numba.config.NUMBA_NUM_THREADS
    print(f"\nM particle-steps/s, every shape function x update ({threads} threads, {args.matrix_steps} steps):")
    print(f"  {'shape':10s}" + "".join(f"{k:>10s}" for k in SCHEMES))
    for shape in SHAPE_FUNCTIONS:
        row = []
        for update in SCHEMES.values():
            rate, _, _ = measure(args.deck, args.matrix_steps, threads, warmup=3, shape=shape, update=update)
            row.append(f"{rate / 1e6:10.2f}")
        print(f"  {shape:10s}" + "".join(row), flush=True)


if __name__ == "__main__":
    main()
