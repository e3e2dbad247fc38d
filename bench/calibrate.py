"""Calibrate `mpmsim check`'s run-time estimate: per-task costs a + b · n · K (µs, one thread).

Runs every explicit deck of inputs/ with particles for a few warm steps on one thread (its
first steps compile and are left out), reads the task timers, fits a and b per task by least
squares relative to each measurement, writes mpmsim/task_costs.json, and prints each deck's
measured and estimated time per step.

    python bench/calibrate.py [--steps 60] [--seconds 8] [--dry-run]
"""

from __future__ import annotations

import argparse
import datetime
import json
import platform
import time
from pathlib import Path

import numba
import numpy as np

from mpmsim.cost import CHECK, COSTS
from mpmsim.deck import load_deck
from mpmsim.scene import build_scene
from mpmsim.solver import OUTPUT, Simulation

ROOT = Path(__file__).resolve().parents[1]


def measure(deck: Path, steps: int, seconds: float) -> dict | None:
    scene = build_scene(load_deck(deck))
    if scene.deck.integrator != "explicit" or not scene.has_particles:
        return None
    sim = Simulation(scene, out_dir=None, threads=1)
    for _ in range(3):
        sim.step()
    sim.reset_timers()
    t0, n = time.perf_counter(), 0
    while n < steps and time.perf_counter() - t0 < seconds and sim.state.t < 0.999 * sim.end:
        sim.step()
        n += 1
    st = sim.state
    tasks = {k: 1e6 * v / n for k, v in sim.timers.items() if k != OUTPUT}
    return {"n": st.particles.n, "K": int(st.entries.nodes.shape[1]), "steps": n, "tasks": tasks,
            "plan": [name for name, _ in sim.integrator.plan]}


def fit(runs: dict) -> dict:
    names = sorted({t for r in runs.values() for t in r["tasks"]})
    costs = {}
    for t in names:
        rows = [(r["n"] * r["K"], r["tasks"][t]) for r in runs.values() if t in r["tasks"]]
        A = np.array([[1.0, nk] for nk, _ in rows])
        y = np.array([v for _, v in rows])
        # relative errors (small decks count as much as big ones), weighted by the fit's own
        # values: weights 1/measured would pull the fit below the measurements
        w = 1.0 / np.maximum(y, 1.0)
        for _ in range(5):
            (a, b), *_ = np.linalg.lstsq(A * w[:, None], y * w, rcond=None)
            w = 1.0 / np.maximum(A @ np.array([a, b]), 1.0)
        costs[t] = [round(max(float(a), 0.0), 3), float(f"{max(float(b), 0.0):.4g}")]
    return costs


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=60)
    ap.add_argument("--seconds", type=float, default=8.0)
    ap.add_argument("--dry-run", action="store_true", help="print, do not write mpmsim/task_costs.json")
    args = ap.parse_args()
    numba.set_num_threads(1)
    runs = {}
    for deck in sorted((ROOT / "inputs").glob("*.yaml")):
        r = measure(deck, args.steps, args.seconds)
        if r is not None:
            runs[deck.stem] = r
            print(f"measured {deck.stem}: {sum(r['tasks'].values()):.0f} us/step ({r['steps']} steps)", flush=True)
    costs = fit(runs)
    stamp = f"{datetime.date.today()}, {platform.node()} ({platform.machine()}), 1 thread, {len(runs)} decks of inputs/"
    print(f"\n# {stamp}\n| deck | particles | K | measured us/step | estimated | ratio |\n|---|---|---|---|---|---|")
    for name, r in runs.items():
        meas = sum(r["tasks"].values())
        est = sum(costs[t][0] + costs[t][1] * r["n"] * r["K"] for t in [*r["plan"], CHECK] if t in costs)
        print(f"| {name} | {r['n']} | {r['K']} | {meas:.0f} | {est:.0f} | {est / meas:.2f} |")
    if not args.dry_run:
        try:  # the file's other tables (bench/compile_costs.py's "compile") are kept
            kept = json.loads(COSTS.read_text())
        except (OSError, ValueError):
            kept = {}
        COSTS.write_text(json.dumps({**kept, "measured": stamp, "tasks": costs}, indent=1) + "\n")
        print(f"wrote {COSTS}")


if __name__ == "__main__":
    main()
