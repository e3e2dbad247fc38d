"""Benchmark: the cost of a J2 plasticity step against a linear elastic one, per particle.

The Taylor bar (inputs/taylor_bar_3d.yaml, 0.8 mm cells, 4,212 particles; `--cell 0.4`: 32,886)
run for the first `--steps` steps after impact, where nearly every particle yields, once
with its j2_plasticity material and once with the same E and nu as linear_elastic; the two
runs alternate `--repeats` times in one process (kernels compiled before timing), and the
median seconds per step of each and their ratio are printed with
the date, the CPU and the thread count.

    python bench/plasticity.py [--threads 1] [--steps 200] [--repeats 5] [--cell 0.8]
"""

from __future__ import annotations

import argparse
import statistics
from pathlib import Path

import numba
import yaml

from mpmsim.deck import load_deck_text

from machine import describe, seconds_per_step  # (bench/machine.py: run as python bench/plasticity.py)

ROOT = Path(__file__).resolve().parents[1]
DECK = ROOT / "inputs" / "taylor_bar_3d.yaml"


def deck(material: str, cell: float):
    data = yaml.safe_load(DECK.read_text())
    data["grid"]["cell_size"] = cell
    data["output"] = {"history_interval": data["time"]["end"]}
    if material == "linear_elastic":
        m = data["materials"]["copper"]
        data["materials"]["copper"] = {"type": "linear_elastic", "E": m["E"], "nu": m["nu"], "density": m["density"]}
    return load_deck_text(yaml.safe_dump(data), DECK)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--cell", type=float, default=0.8)
    a = ap.parse_args()
    numba.set_num_threads(a.threads)
    times = {"linear_elastic": [], "j2_plasticity": []}
    n = 0
    for _ in range(a.repeats):
        for material in times:
            t, n = seconds_per_step(deck(material, a.cell), a.steps, a.threads)
            times[material].append(t)
    el, j2 = (statistics.median(times[m]) for m in times)
    print(f"{describe(a.threads)}  {n} particles, {a.steps} steps x {a.repeats} alternated runs")
    print(f"linear_elastic {el * 1e3:8.3f} ms/step  {n / el / 1e6:6.3f} M particle-steps/s")
    print(f"j2_plasticity  {j2 * 1e3:8.3f} ms/step  {n / j2 / 1e6:6.3f} M particle-steps/s")
    print(f"ratio j2 / elastic: {j2 / el:.3f}")


if __name__ == "__main__":
    main()
