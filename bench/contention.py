"""Benchmark: threads beside busy neighbours.

`mpmsim run` on the benchmark decks (bench/column.yaml: 16 000 particles, one material;
bench/two_blocks.yaml: the same column as two blocks in LR contact), shortened to about 400
steps, with `--threads 1`, `--threads N` (all cores) and the default thread count, run one
after the other (alternated, so all three see the same machine), in five settings: the idle
machine; one and three busy neighbours (plain spinning processes, left to the scheduler)
started a second before the run; one and three started halfway through it. A parallel
region waits for its slowest thread, so threads that share cores with busy processes can
stall every step; `--threads N` must never take more than 1.3x the time of `--threads 1`.
Then the idle machine's speed-up of N threads on the 256 000-particle column (the same
column in 0.25 mm cells), which must stay at least 1.8x on 2 cores.

The rate is read from the run log's task table (the first, compiling step left out).

    python bench/contention.py [--steps 400] [--rounds 2] [--big-steps 30] [--json out.json]
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
DECKS = {"column": ROOT / "bench" / "column.yaml", "two_blocks": ROOT / "bench" / "two_blocks.yaml"}
LIMIT = 1.3  # --threads N over --threads 1, time
SPEEDUP = 1.8  # idle, 256k column, 2 cores
SETTINGS = [("idle", 0, None), ("1 busy before", 1, "before"), ("3 busy before", 3, "before"),
            ("1 busy from halfway", 1, "during"), ("3 busy from halfway", 3, "during")]


def short_deck(deck: Path, folder: Path, steps: int, cell: float | None = None) -> Path:
    """`deck` cut to about `steps` steps (its time step is CFL-set), optionally in cells of `cell`."""
    from mpmsim.deck import load_deck_text
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation

    data = yaml.safe_load(deck.read_text())
    if cell is not None:
        data["grid"]["cell_size"] = cell
    sim = Simulation(build_scene(load_deck_text(yaml.safe_dump(data), deck)), out_dir=None, threads=1)
    dt = sim.integrator.stable_dt(sim.state)
    data["time"]["end"] = steps * dt
    data["output"] = {"vtu_interval": steps * dt, "history_interval": steps * dt / 10, "checkpoint_interval": "off"}
    path = folder / f"{deck.stem}{'' if cell is None else '_big'}.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def hogs(n: int) -> list[subprocess.Popen]:
    return [subprocess.Popen([sys.executable, "-c", "while True:\n    pass\n"]) for _ in range(n)]


def stop(procs: list[subprocess.Popen]) -> None:
    for p in procs:
        p.kill()
        p.wait()


def run(deck: Path, out: Path, threads: int | None, busy: int = 0, at: float | None = None) -> dict:
    """One `mpmsim run`: M particle-steps/s, wall seconds, threads used and the default's reason;
    `busy` spinning processes started `at` seconds after it (None: none started here)."""
    cmd = [sys.executable, "-m", "mpmsim", "run", str(deck), "--out", str(out), "--quiet"]
    if threads is not None:
        cmd += ["--threads", str(threads)]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    started = []
    try:
        if at is not None:
            try:
                proc.wait(timeout=at)
            except subprocess.TimeoutExpired:
                started = hogs(busy)
        _, err = proc.communicate()
    finally:
        stop(started)
    if proc.returncode != 0:
        raise SystemExit(f"mpmsim run failed: {err.strip().splitlines()[-1] if err.strip() else proc.returncode}")
    log = (out / f"{deck.stem}_run.log").read_text()
    rate = float(re.search(r"([\d.]+) M particle-steps/s", " ".join(log.split())).group(1))  # (title wraps)
    used = int(re.search(r"^threads: (\d+)", log, re.M).group(1))
    why = re.search(r"^threads: \d+ \((.*); --threads N to choose\)$", log, re.M)
    return {"rate": rate, "wall": time.perf_counter() - t0, "used": used, "why": why.group(1) if why else "given"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--big-steps", type=int, default=30, help="steps of the 256k column (0: skip it)")
    ap.add_argument("--json", type=Path, help="write the rows here")
    args = ap.parse_args()
    cpus = sorted(os.sched_getaffinity(0))
    n = len(cpus)
    print(f"# {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, {platform.node()} "
          f"({platform.processor() or platform.machine()}), {n} cores {cpus}, "
          f"OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY', '(mpmsim: PASSIVE)')}; about {args.steps} steps, "
          f"`mpmsim run --quiet`, {args.rounds} rounds alternated")
    configs = [("--threads 1", 1), (f"--threads {n}", n), ("default", None)]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        decks = {name: short_deck(path, folder, args.steps) for name, path in DECKS.items()}
        for deck in decks.values():
            run(deck, folder / "warm", 1)  # compile (and load) the kernels once, both forms
            run(deck, folder / "warm", n)
        idle_wall = {name: run(deck, folder / "warm", 1)["wall"] for name, deck in decks.items()}
        for r in range(args.rounds):
            for setting, busy, when in SETTINGS:
                for name, deck in decks.items():
                    before = hogs(busy) if when == "before" else []
                    try:
                        if before:
                            time.sleep(1.0)
                        for label, threads in configs:
                            at = 0.5 * idle_wall[name] if when == "during" else None
                            row = run(deck, folder / f"r{r}", threads, busy, at)
                            row.update(round=r + 1, setting=setting, deck=name, threads=label)
                            rows.append(row)
                            print(f"  {setting:20s} {name:10s} {label:12s} {row['rate']:6.2f} M/s "
                                  f"({row['used']} used)", flush=True)
                    finally:
                        stop(before)
        big = []
        if args.big_steps > 0 and n > 1:
            deck = short_deck(DECKS["column"], folder, args.big_steps, cell=0.25)
            run(deck, folder / "warm", 1)
            run(deck, folder / "warm", n)
            for r in range(args.rounds):
                for threads in (1, n):
                    big.append({"round": r + 1, "threads": threads, **run(deck, folder / f"b{r}", threads)})
    print("\n| setting | deck | round | `--threads 1` | " f"`--threads {n}` | default (used) | "
          f"time `--threads {n}` / `--threads 1` |")
    print("|---|---|---|---|---|---|---|")
    worst = 0.0
    for r in range(1, args.rounds + 1):
        for setting, _, _ in SETTINGS:
            for name in decks:
                by = {row["threads"]: row for row in rows if row["round"] == r and row["setting"] == setting
                      and row["deck"] == name}
                ratio = by["--threads 1"]["rate"] / by[f"--threads {n}"]["rate"]
                worst = max(worst, ratio)
                d = by["default"]
                print(f"| {setting} | {name} | {r} | {by['--threads 1']['rate']:.2f} | "
                      f"{by[f'--threads {n}']['rate']:.2f} | {d['rate']:.2f} ({d['used']}) | {ratio:.2f} |")
    ok = worst <= LIMIT
    print(f"\nworst: --threads {n} takes {worst:.2f}x the time of --threads 1 (limit {LIMIT}): "
          f"{'ok' if ok else 'TOO SLOW'}")
    if big:
        one = [b["rate"] for b in big if b["threads"] == 1]
        many = [b["rate"] for b in big if b["threads"] == n]
        speedup = min(many) / max(one)
        ok_big = speedup >= SPEEDUP or n < 2
        print(f"256k column, idle: --threads 1 {', '.join(f'{x:.2f}' for x in one)}; --threads {n} "
              f"{', '.join(f'{x:.2f}' for x in many)} M/s: speed-up {speedup:.2f} (worst pairing; "
              f"at least {SPEEDUP}): {'ok' if ok_big else 'TOO LOW'}")
        ok = ok and ok_big
    if args.json:
        args.json.write_text(json.dumps({"cores": n, "rows": rows, "big": big}, indent=1))
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
