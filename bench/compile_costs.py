"""Calibrate `mpmsim check`'s first-run compile estimate: the CPU seconds numba spends compiling
each task's kernels, and the run's start (state, energy sums, first history row and VTU frame),
from an empty kernel cache, on one thread.

Each explicit deck of inputs/ with particles is measured in a fresh process on an empty
NUMBA_CACHE_DIR of its own, with the compile helper off (MPMSIM_COMPILE_HELPER=0: one process
compiles everything): the CPU time of building the simulation and opening the run (`start`),
then of the first step, split over its tasks in proportion to their timers, less the same
task's time in the second (warm) step. Each task's compile cost is the median over the decks
that use it, the start's the median over all; written to mpmsim/task_costs.json under
"compile", with each deck's measured and estimated total.

    python bench/compile_costs.py [DECK ...] [--dry-run]     # every explicit particle deck by default
    python bench/compile_costs.py --one DECK --json OUT       # one deck, this process (its cache as given)
    python bench/compile_costs.py --from DIR [--dry-run]      # fit the OUT files of --one runs in DIR

A deck's cost differs by the kernels' forms (2D, 3D, shape function, materials), so the estimate
is the typical cost of the tasks a scene runs; the table printed says how close it comes.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def measure_one(deck: Path) -> dict | None:
    """This process's compile CPU seconds for `deck` (start, and per task of the first step)."""
    import numba

    from mpmsim.deck import load_deck
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation
    from mpmsim.stability import total_sums

    numba.set_num_threads(1)
    scene = build_scene(load_deck(deck))
    if scene.deck.integrator != "explicit" or not scene.has_particles:
        return None
    with tempfile.TemporaryDirectory(prefix="mpmsim-compile-costs-") as tmp:
        t0 = time.process_time()
        sim = Simulation(scene, out_dir=Path(tmp), threads=1)
        total_sums(sim.state, detail=True)  # what a run does before its first step
        sim._record()
        sim._write_frame()
        t1 = time.process_time()
        sim.reset_timers()
        sim.step()
        t2 = time.process_time()
        first = dict(sim.timers)
        sim.reset_timers()
        sim.step()
        warm = dict(sim.timers)
    first.pop("output", None)
    wall = sum(first.values()) or 1.0
    cpu = t2 - t1
    tasks = {k: max(v * cpu / wall - warm.get(k, 0.0), 0.0) for k, v in first.items()}
    plan = [name for name, _ in sim.integrator.plan]
    return {"deck": deck.stem, "start": t1 - t0, "tasks": tasks, "plan": plan, "first_step": cpu}


def fresh(deck: Path, out: Path) -> None:
    """measure_one in a new process on an empty kernel cache, helper off."""
    with tempfile.TemporaryDirectory(prefix="mpmsim-compile-cache-") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, MPMSIM_COMPILE_HELPER="0", NUMBA_NUM_THREADS="1",
                   PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
        subprocess.run([sys.executable, __file__, "--one", str(deck), "--json", str(out)], env=env, check=True)


def fit(records: list[dict]) -> dict:
    import numpy as np

    names = sorted({t for r in records for t in r["tasks"]})
    tasks = {t: round(float(np.median([r["tasks"][t] for r in records if t in r["tasks"]])), 2) for t in names}
    return {"start": round(float(np.median([r["start"] for r in records])), 2), "tasks": tasks}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("decks", nargs="*", type=Path)
    ap.add_argument("--one", type=Path)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--from", dest="source", type=Path)
    ap.add_argument("--dry-run", action="store_true", help="print, do not write mpmsim/task_costs.json")
    args = ap.parse_args()
    if args.one is not None:
        record = measure_one(args.one)
        if args.json is not None:
            args.json.write_text(json.dumps(record))
        return
    if args.source is not None:
        files = sorted(args.source.glob("*.json"))
    else:
        work = Path(tempfile.mkdtemp(prefix="mpmsim-compile-costs-"))
        files = []
        for deck in args.decks or sorted((ROOT / "inputs").glob("*.yaml")):
            files.append(work / f"{deck.stem}.json")
            fresh(deck, files[-1])
            print(f"measured {deck.stem}", flush=True)
    records = [r for r in (json.loads(f.read_text()) for f in files) if r]
    costs = fit(records)
    sys.path.insert(0, str(ROOT / "bench"))
    from machine import describe  # noqa: E402 (bench/machine.py)

    stamp = f"{describe()}, one thread, {len(records)} decks of inputs/, empty kernel cache, helper off"
    print(f"\n# {stamp}")
    print("| deck | measured CPU s | estimated | ratio |\n|---|---|---|---|")
    for r in records:
        meas = r["start"] + r["first_step"]
        est = costs["start"] + sum(costs["tasks"].get(t, 0.0) for t in r["plan"])
        print(f"| {r['deck']} | {meas:.1f} | {est:.1f} | {est / meas:.2f} |")
    if not args.dry_run:
        from mpmsim.cost import COSTS

        data = json.loads(COSTS.read_text())
        data["compile"] = {"measured": stamp, **costs}
        COSTS.write_text(json.dumps(data, indent=1) + "\n")
        print(f"wrote {COSTS}")


if __name__ == "__main__":
    main()
