"""Energy of every explicit grid-contact deck in inputs/: does contact make energy anywhere?

Each deck whose scene has multimaterial grid contact (two or more velocity fields) runs to its
end (or to `--fraction` of it) on one thread, with its own settings, and the history gives the
total energy E = kinetic + strain + internal + interface - external work (walls, rigid bodies,
gravity, loads). Printed per deck: the largest rise of E over its initial value at any history
row, relative to the energy scale of the run (the largest of E(0), the largest kinetic + strain
energy and the largest |external work|), and the run's wall time. A positive rise is energy
the scheme made; dissipation (transfers, contact) makes E fall.

    python bench/contact_energy.py [--decks two_blocks oblique_impact ...] [--fraction 1.0]

Results in results/bench_contact_energy/<date and time>.json; docs/contact-methods.md quotes them. A
single-material deck (column, column_3d) may be given for comparison.
"""

from __future__ import annotations

import argparse
import json
import time
from datetime import datetime
from pathlib import Path

import numpy as np

from mpmsim.deck import load_deck
from mpmsim.deck.overrides import with_overrides
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation

from machine import describe  # (bench/machine.py: run as python bench/contact_energy.py)

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results" / "bench_contact_energy"


def contact_decks() -> list[str]:
    """The decks of inputs/ whose explicit run has grid contact (two or more velocity fields)."""
    names = []
    for path in sorted((ROOT / "inputs").glob("*.yaml")):
        deck = load_deck(path)
        if deck.deck.integrator != "explicit" or any(b.discretization == "fem" for b in deck.deck.bodies):
            continue  # (FEM bodies: the augury family; implicit: the barrier solver)
        scene = build_scene(deck)
        if scene.contact.grid is not None and scene.contact.grid.n_groups > 1:
            names.append(path.stem)
    return names


def total_energy(col, names) -> np.ndarray:
    energy = col("kinetic_energy") + col("strain_energy") - col("external_work")
    for name in ("internal_energy", "interface_energy"):
        if name in names:
            energy = energy + col(name)
    return energy


def run_deck(name: str, fraction: float) -> dict:
    path = ROOT / "inputs" / f"{name}.yaml"
    deck = load_deck(path)
    if fraction < 1.0:
        from mpmsim.deck import load_deck_text
        import yaml

        data = yaml.safe_load(path.read_text())
        data = with_overrides(data, {"time.end": fraction * float(data["time"]["end"])})
        deck = load_deck_text(yaml.safe_dump(data), path)
    sim = Simulation(build_scene(deck))
    t0 = time.perf_counter()
    sim.run()
    wall = time.perf_counter() - t0
    col = sim.recorder.column
    energy = total_energy(col, sim.recorder.names)
    scale = max(abs(energy[0]), float(np.max(col("kinetic_energy") + col("strain_energy"))),
                float(np.max(np.abs(col("external_work")))))
    rise = float(np.max(energy - energy[0])) / scale
    return {"deck": name, "rows": int(energy.size), "largest_rise": rise, "end_change": float(energy[-1] - energy[0]) / scale,
            "wall_s": wall}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--decks", nargs="*", help="deck names in inputs/ (default: every explicit grid-contact deck)")
    ap.add_argument("--fraction", type=float, default=1.0, help="run this fraction of each deck's end time")
    args = ap.parse_args()
    print(describe())
    decks = args.decks or contact_decks()
    rows = []
    for name in decks:
        r = run_deck(name, args.fraction)
        rows.append(r)
        print(f"{name:28s} rows {r['rows']:5d}  largest rise {100 * r['largest_rise']:+.3f}%  "
              f"end {100 * r['end_change']:+.2f}%  ({r['wall_s']:.0f} s)", flush=True)
    RESULTS.mkdir(parents=True, exist_ok=True)
    out = RESULTS / f"{datetime.now():%Y-%m-%dT%H%M%S}.json"
    out.write_text(json.dumps({"machine": describe(), "fraction": args.fraction, "rows": rows}, indent=1))
    print(f"wrote {out.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
