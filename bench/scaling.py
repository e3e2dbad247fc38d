"""Benchmark: thread scaling of the explicit step, whole and per task.

Each scene runs with 1, 2, 4, ... threads up to this process's cores (or `--threads`), every
count in a fresh process: the deck is built, one step compiles or loads the kernels, three
steps warm up, then `--rounds` rounds of `--steps` steps are timed (wall clock) with the
per-task timers. Reported: M particle-steps/s (median round), speed-up and efficiency over
one thread, the first round against the median of the later ones (a fresh process's first
threaded steps), and each task's speed-up.

Scenes, `name:particles` (the cell size is set to reach about that many particles):
  column      bench/column.yaml: the 40 x 100 mm neo-Hookean column, 4 particles per cell
  two_blocks  bench/two_blocks.yaml: the same column as two blocks in LR contact
  column3d    inputs/column_3d.yaml: the 20 x 100 x 20 mm column, 8 particles per cell

    python bench/scaling.py [--scenes column:1024000 two_blocks:256000 column3d:640000]
                            [--threads 1 2 4 8 16] [--steps 20] [--rounds 3] [--json out.json]
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENES = {  # deck, particles per unit cell volume^-1 (particles at 1 mm cells), dimension
    "column": (ROOT / "bench" / "column.yaml", 16_000, 2),
    "two_blocks": (ROOT / "bench" / "two_blocks.yaml", 16_000, 2),
    "column3d": (ROOT / "inputs" / "column_3d.yaml", 320_000, 3),
}
DEFAULT_SCENES = ["column:1024000", "column:256000", "column:16000", "two_blocks:256000", "column3d:640000"]
WARMUP = 3


def cell_for(scene: str, particles: int) -> float:
    """The cell size (mm) that gives the scene about `particles` particles."""
    _, at_1mm, dim = SCENES[scene]
    return (at_1mm / particles) ** (1.0 / dim)


def worker(scene: str, particles: int, threads: int, steps: int, rounds: int) -> dict:
    """Runs in its own process: one scene at one thread count."""
    import numba
    import yaml

    from mpmsim.deck import load_deck_text
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation
    from mpmsim.stability import total_sums

    deck, _, _ = SCENES[scene]
    data = yaml.safe_load(deck.read_text())
    data["grid"]["cell_size"] = round(cell_for(scene, particles), 6)
    numba.set_num_threads(threads)
    t0 = time.perf_counter()
    sim = Simulation(build_scene(load_deck_text(yaml.safe_dump(data), deck)), out_dir=None, threads=threads)
    build = time.perf_counter() - t0
    t0 = time.perf_counter()
    total_sums(sim.state)  # compiles or loads the kernels: the energy check's (as a run's start), a step's
    sim.step()
    first_step = time.perf_counter() - t0
    for _ in range(WARMUP):
        sim.step()
    n = sim.state.particles.n
    out = []
    for _ in range(rounds):
        sim.reset_timers()
        t0 = time.perf_counter()
        for _ in range(steps):
            sim.step()
        wall = time.perf_counter() - t0
        out.append({"rate": n * steps / wall / 1e6, "wall": wall,
                    "tasks": {k: v for k, v in sim.timers.items() if k != "output"}})
    return {"scene": scene, "particles": n, "cell": data["grid"]["cell_size"], "threads": threads,
            "layer": numba.threading_layer(), "build_s": build, "first_step_s": first_step, "rounds": out}


def run_one(scene: str, particles: int, threads: int, steps: int, rounds: int) -> dict:
    code = ("import json, sys; sys.path.insert(0, %r); from scaling import worker; "
            "print(json.dumps(worker(%r, %d, %d, %d, %d)))" % (str(Path(__file__).parent), scene, particles,
                                                                threads, steps, rounds))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{scene}:{particles} at {threads} threads failed: {done.stderr.strip()[-400:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def summarise(result: dict) -> dict:
    rates = [r["rate"] for r in result["rounds"]]
    later = rates[1:] or rates
    tasks = {}
    for name in result["rounds"][0]["tasks"]:
        tasks[name] = statistics.median(r["tasks"][name] for r in result["rounds"])
    return {"rate": statistics.median(rates), "first_vs_later": rates[0] / statistics.median(later), "tasks": tasks}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", default=DEFAULT_SCENES, help="name:particles")
    cores = len(os.sched_getaffinity(0))
    counts = sorted({2 ** k for k in range(int(math.log2(cores)) + 1)} | {cores})
    ap.add_argument("--threads", type=int, nargs="+", default=counts)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    threads = sorted(set(args.threads) | {1})
    stamp = f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC"
    print(f"# {stamp}, {platform.node()} ({platform.processor() or platform.machine()}), {cores} cores; "
          f"{args.steps} steps x {args.rounds} rounds after {WARMUP} warm-up steps, a fresh process per count")
    results = []
    for spec in args.scenes:
        name, _, count = spec.partition(":")
        if name not in SCENES or not count.isdigit():
            raise SystemExit(f"--scenes: {spec!r} is not name:particles with name one of {', '.join(SCENES)}")
        for th in threads:
            res = run_one(name, int(count), th, args.steps, args.rounds)
            res["summary"] = summarise(res)
            results.append(res)
            s = res["summary"]
            print(f"  {name}:{res['particles']} {th:3d} threads: {s['rate']:7.2f} M/s, first round "
                  f"{s['first_vs_later']:.2f} of later, layer {res['layer']}", flush=True)
    print("\n| scene | particles | threads | M particle-steps/s | speed-up | efficiency | first round / later |")
    print("|---|---|---|---|---|---|---|")
    for res in results:
        base = next(r for r in results if r["scene"] == res["scene"] and r["particles"] == res["particles"]
                    and r["threads"] == 1)
        s, b = res["summary"], base["summary"]
        up = s["rate"] / b["rate"]
        res["summary"].update(speedup=up, efficiency=up / res["threads"])
        print(f"| {res['scene']} | {res['particles']} | {res['threads']} | {s['rate']:.2f} | {up:.2f} | "
              f"{up / res['threads']:.0%} | {s['first_vs_later']:.2f} |")
    for key in dict.fromkeys((r["scene"], r["particles"]) for r in results):
        group = [r for r in results if (r["scene"], r["particles"]) == key]
        base = group[0]["summary"]["tasks"]
        print(f"\nPer-task speed-up over 1 thread, {key[0]} ({key[1]} particles); "
              f"share of the 1-thread step in brackets:")
        print("| task | " + " | ".join(f"{r['threads']}" for r in group) + " |")
        print("|---|" + "---|" * len(group))
        total = sum(base.values())
        for task, t1 in base.items():
            cells = [f"{t1 / r['summary']['tasks'][task]:.2f}" if r["summary"]["tasks"][task] > 0 else "-"
                     for r in group]
            print(f"| {task} ({100 * t1 / total:.0f}%) | " + " | ".join(cells) + " |")
    if args.json:
        args.json.write_text(json.dumps({"date": stamp, "machine": platform.node(), "cores": cores,
                                         "results": results}, indent=1))


if __name__ == "__main__":
    main()
