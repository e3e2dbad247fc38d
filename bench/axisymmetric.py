"""Benchmark: the cost of an axisymmetric step against a plane-strain one, per particle-step.

The same scene (the thick-walled sphere of inputs/sphere_pressure_rz.yaml: 3,769 particles,
linear elastic, gimp, PIC, USAVG; `--deck` another r-z deck) run as `analysis: axisymmetric`
and as `analysis: plane_strain` (the axis face a roller, as the r-z run has it): the two runs
alternate `--repeats` times in one process (kernels compiled before timing), and the median
seconds per step of each and their ratio are printed with the date, the CPU and the threads.
The r-z step does more per particle: the r-weighted radial factor (uGIMP: the integrals over
the domain), the hoop function T, the hoop rate and force, and the material's 3D update.

    python bench/axisymmetric.py [--threads 1] [--steps 300] [--repeats 5] [--deck inputs/x.yaml]
"""

from __future__ import annotations

import argparse
import statistics
from pathlib import Path

import numba
import yaml

from mpmsim.deck import load_deck_text

from machine import describe, seconds_per_step  # (bench/machine.py: run as python bench/axisymmetric.py)

ROOT = Path(__file__).resolve().parents[1]
DECK = ROOT / "inputs" / "sphere_pressure_rz.yaml"


def deck(path: Path, analysis: str):
    data = yaml.safe_load(path.read_text())
    data["analysis"] = analysis
    data["output"] = {"history_interval": data["time"]["end"]}
    if analysis == "plane_strain":
        data["grid"].setdefault("boundaries", {})["xmin"] = "roller"
    return load_deck_text(yaml.safe_dump(data), path)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--deck", type=Path, default=DECK)
    a = ap.parse_args()
    numba.set_num_threads(a.threads)
    times = {"plane_strain": [], "axisymmetric": []}
    n = {}
    for _ in range(a.repeats):
        for analysis in times:
            t, n[analysis] = seconds_per_step(deck(a.deck, analysis), a.steps, a.threads)
            times[analysis].append(t / n[analysis])
    ps, rz = (statistics.median(times[m]) for m in times)
    print(f"{describe(a.threads)}  {a.deck.name}: {n['axisymmetric']} particles, {a.steps} steps x {a.repeats} "
          "alternated runs")
    print(f"plane_strain  {ps * 1e6:7.3f} us per particle-step")
    print(f"axisymmetric  {rz * 1e6:7.3f} us per particle-step")
    print(f"ratio axisymmetric / plane strain: {rz / ps:.3f}")


if __name__ == "__main__":
    main()
