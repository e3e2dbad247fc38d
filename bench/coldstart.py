"""First-run compile time: each deck's kernels compiled from an empty numba cache.

    python bench/coldstart.py [DECK ...]      # default: disks, two_blocks, stretch

For each deck, `mpmsim compile DECK` runs in a fresh process with NUMBA_CACHE_DIR pointing at
an empty folder (so nothing is loaded from an earlier run), with the default thread count (the
decks here are small enough to run one thread: the serial kernel forms): first as a user runs
it, where a helper process compiles part of the first step's kernels (mpmsim/compile_ahead.py),
then in one process (MPMSIM_COMPILE_HELPER=0, an empty cache again), then once more with the
cache filled (the warm start). Prints the wall times, the CPU time (user + system, both
processes) of the cold ones, the 1-minute load average before each deck (on a shared machine
the wall time grows with the load, the CPU time hardly), and the compile budget of a first
`make run` (20 s) and of two_blocks (40 s) beside them.
"""

from __future__ import annotations

import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
from machine import describe  # noqa: E402 (bench/machine.py)
DEFAULT = ["disks", "two_blocks", "stretch"]
BUDGET = {"disks": 20.0, "two_blocks": 40.0}


def timed_compile(deck: Path, cache: Path, helper: bool = True) -> tuple[float, float]:
    """(wall seconds, CPU seconds) of `mpmsim compile DECK` in a fresh process."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), MPMSIM_COMPILE_HELPER="1" if helper else "0")
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
    print(f"{describe()}, default threads, Python {platform.python_version()}")
    print("| deck | cold (s) | cold CPU (s) | one process (s) | its CPU (s) | warm (s) | load | budget (s) |\n"
          "|---|---:|---:|---:|---:|---:|---:|---:|")
    for name in decks:
        deck = ROOT / "inputs" / f"{name}.yaml" if not name.endswith(".yaml") else Path(name)
        load = os.getloadavg()[0]
        with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as alone:
            cold, cpu = timed_compile(deck, Path(cache))
            one, one_cpu = timed_compile(deck, Path(alone), helper=False)
            warm, _ = timed_compile(deck, Path(cache))
        budget = BUDGET.get(deck.stem)
        print(f"| {deck.stem} | {cold:.1f} | {cpu:.1f} | {one:.1f} | {one_cpu:.1f} | {warm:.1f} | {load:.1f} | "
              f"{budget if budget else '-'} |", flush=True)


if __name__ == "__main__":
    main()
