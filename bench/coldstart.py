"""First-run compile time: each deck's kernels compiled from an empty numba cache.

    python bench/coldstart.py [DECK ...]      # default: disks, two_blocks, stretch

For each deck, `mpmsim compile DECK` runs in a fresh process with NUMBA_CACHE_DIR pointing at
an empty folder (so nothing is loaded from an earlier run), on one thread; then the same
command again with that cache filled (the warm start). Prints the wall time of both, the CPU
time (user + system) of the cold one, the 1-minute load average before each deck (on a shared
machine the wall time grows with the load, the CPU time hardly), and the compile budget of a
first `make run` (20 s) and of two_blocks (40 s) beside them.
"""

from __future__ import annotations

import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from datetime import date
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ["disks", "two_blocks", "stretch"]
BUDGET = {"disks": 20.0, "two_blocks": 40.0}


def timed_compile(deck: Path, cache: Path) -> tuple[float, float]:
    """(wall seconds, CPU seconds) of `mpmsim compile DECK` in a fresh process."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), NUMBA_NUM_THREADS="1")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    run = subprocess.run([sys.executable, "-m", "mpmsim", "compile", str(deck)], env=env, capture_output=True,
                         text=True)
    if run.returncode != 0:
        raise SystemExit(f"{deck}: mpmsim compile failed:\n{run.stderr}")
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    decks = sys.argv[1:] or DEFAULT
    print(f"{date.today()}, {platform.node()}, {os.cpu_count()} cores, one thread, Python {platform.python_version()}")
    print("| deck | cold (s) | cold CPU (s) | warm (s) | load | budget (s) |\n|---|---:|---:|---:|---:|---:|")
    for name in decks:
        deck = ROOT / "inputs" / f"{name}.yaml" if not name.endswith(".yaml") else Path(name)
        load = os.getloadavg()[0]
        with tempfile.TemporaryDirectory() as cache:
            cold, cpu = timed_compile(deck, Path(cache))
            warm, _ = timed_compile(deck, Path(cache))
        budget = BUDGET.get(deck.stem)
        print(f"| {deck.stem} | {cold:.1f} | {cpu:.1f} | {warm:.1f} | {load:.1f} | {budget if budget else '-'} |",
              flush=True)


if __name__ == "__main__":
    main()
