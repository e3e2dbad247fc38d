"""Cost of a checkpoint: file size, time to write and to restore, beside the time of one step.

    python bench/checkpoint.py [DECK ...]   # default: bench/column.yaml, inputs/two_blocks.yaml,
                                            # inputs/implicit_rings_2d.yaml

One thread; each deck is built, stepped twice (compiling), checkpointed three times (the best
write counts) and restored into a freshly built run three times (the best restore counts);
then 20 steps are timed.
"""

from __future__ import annotations

import os
import platform
import sys
import tempfile
import time
from datetime import date
from pathlib import Path

import numba

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mpmsim.deck import load_deck  # noqa: E402
from mpmsim.output.checkpoint import restore_checkpoint  # noqa: E402
from mpmsim.scene import build_scene  # noqa: E402
from mpmsim.solver import Simulation  # noqa: E402

DEFAULT = [ROOT / "bench" / "column.yaml", ROOT / "inputs" / "two_blocks.yaml", ROOT / "inputs" / "implicit_rings_2d.yaml"]


def best(f, n: int = 3) -> float:
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    numba.set_num_threads(1)
    decks = [Path(d) for d in sys.argv[1:]] or DEFAULT
    print(f"{date.today()}, {platform.node()}, {os.cpu_count()} cores, one thread")
    print("| deck | particles | FEM nodes | checkpoint (MB) | write (ms) | restore (ms) | one step (ms) |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for deck in decks:
        with tempfile.TemporaryDirectory() as out:
            sim = Simulation(build_scene(load_deck(deck)), out_dir=Path(out), threads=1)
            sim.step()
            sim.step()
            write = best(sim.write_checkpoint)
            fresh = Simulation(build_scene(load_deck(deck)), out_dir=Path(out), threads=1, resume=True)
            restore = best(lambda: restore_checkpoint(sim.checkpoint_path, {"simulation": fresh}))
            size = sim.checkpoint_path.stat().st_size / 1e6
            step = best(lambda: [sim.step() for _ in range(20)], 1) / 20
            fem = sim.state.fem.n if sim.state.fem is not None else 0
            print(f"| {deck.stem} | {sim.state.particles.n} | {fem} | {size:.2f} | {write * 1e3:.0f} | "
                  f"{restore * 1e3:.0f} | {step * 1e3:.1f} |", flush=True)


if __name__ == "__main__":
    main()
