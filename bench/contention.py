"""Benchmark: the default thread count beside a busy neighbour.

`mpmsim run` on the benchmark column (bench/column.yaml: 16 000 particles, uGIMP, FLIP),
shortened to about 400 steps, with the default thread count and with `--threads 1`, first
on the idle machine, then with one competing process spinning on one core (pinned with
sched_setaffinity, started a second before). A parallel region waits for its slowest
thread, so a thread sharing a core with a busy process stalls every step; the default must
see the neighbour and stay within 1.3x of `--threads 1` (the forced `--threads N`, all cores,
shows the collapse it avoids). The rate is read from the run log's task table (the first,
compiling step left out).

    python bench/contention.py [--steps 400] [--rounds 2]
"""

from __future__ import annotations

import argparse
import datetime
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
DECK = ROOT / "bench" / "column.yaml"
LIMIT = 1.3


def short_deck(folder: Path, steps: int) -> Path:
    """The column deck cut to about `steps` steps (its time step is CFL-set: about 2.6e-4 ms)."""
    from mpmsim.deck import load_deck
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation

    sim = Simulation(build_scene(load_deck(DECK)), out_dir=None, threads=1)
    dt = sim.integrator.stable_dt(sim.state)
    data = yaml.safe_load(DECK.read_text())
    data["time"]["end"] = steps * dt
    data["output"] = {"vtu_interval": steps * dt, "history_interval": steps * dt / 10, "checkpoint_interval": "off"}
    path = folder / "column_short.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def run(deck: Path, out: Path, threads: int | None) -> tuple[float, int, str]:
    """(M particle-steps/s, threads used, the default's reason) of one `mpmsim run`."""
    cmd = [sys.executable, "-m", "mpmsim", "run", str(deck), "--out", str(out), "--quiet"]
    if threads is not None:
        cmd += ["--threads", str(threads)]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    log = (out / "column_short_run.log").read_text()
    rate = float(re.search(r"([\d.]+) M particle-steps/s", " ".join(log.split())).group(1))  # (title wraps)
    used = re.search(r"^threads: (\d+)$", log, re.M).group(1)
    why = re.search(r"^threads: \d+ \((.*); --threads N to choose\)$", log, re.M)
    return rate, int(used), why.group(1) if why else "given"


def hog(cpu: int) -> subprocess.Popen:
    code = f"import os\nos.sched_setaffinity(0, {{{cpu}}})\nwhile True:\n    pass\n"
    return subprocess.Popen([sys.executable, "-c", code])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--rounds", type=int, default=2)
    args = ap.parse_args()
    cpus = sorted(os.sched_getaffinity(0))
    print(f"# {datetime.date.today()}, {platform.node()} ({platform.processor() or platform.machine()}), "
          f"{len(cpus)} cores {cpus}; column deck, about {args.steps} steps, `mpmsim run --quiet`")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        deck = short_deck(folder, args.steps)
        run(deck, folder / "warm", 1)  # compile (and load) the kernels once
        rows = []
        for r in range(args.rounds):
            for neighbour in (False, True):
                spinner = hog(cpus[0]) if neighbour else None
                try:
                    if spinner:
                        time.sleep(1.0)
                    for label, threads in (("default", None), ("--threads 1", 1), (f"--threads {len(cpus)}", len(cpus))):
                        rate, used, why = run(deck, folder / f"r{r}", threads)
                        rows.append((r, neighbour, label, used, rate, why))
                finally:
                    if spinner:
                        spinner.kill()
                        spinner.wait()
    print("| round | neighbour on one core | threads | used | M particle-steps/s | default's reason |")
    print("|---|---|---|---|---|---|")
    for r, neighbour, label, used, rate, why in rows:
        print(f"| {r + 1} | {'yes' if neighbour else 'no'} | {label} | {used} | {rate:.2f} | {why} |")
    worst = 0.0
    for r in range(args.rounds):
        for neighbour in (False, True):
            by = {label: rate for rr, nb, label, _, rate, _ in rows if rr == r and nb == neighbour}
            slowdown = by["--threads 1"] / by["default"]
            worst = max(worst, slowdown)
            print(f"round {r + 1}, neighbour {'yes' if neighbour else 'no'}: --threads 1 / default = "
                  f"{slowdown:.2f} (time ratio: default takes {slowdown:.2f}x the time of --threads 1)")
    verdict = "ok" if worst <= LIMIT else "TOO SLOW"
    print(f"worst: default takes {worst:.2f}x the time of --threads 1 (limit {LIMIT}): {verdict}")
    sys.exit(0 if worst <= LIMIT else 1)


if __name__ == "__main__":
    main()
