"""The same impact run axisymmetric and in 3D: a steel sphere (R = 5 mm) strikes an aluminium disc
(radius 8 mm, 6 mm thick, fixed base) at 2 m/s, LR contact with the defaults, each body seeded as
its deck's default does (the r-z sphere in rings, the 3D one in shells; the discs on the lattice).

    python bench/sphere_impact.py [--law frictionless coulomb] [--cell 0.5] [--threads 1] [--only rz] [--quarter]

Decks: tests/validation/data/sphere_rz/sphere_impact_rz.yaml (r-z; its `seeding: lattice` and
`pass_3: recheck`, there to match the reference code's run, are dropped here) and
sphere_impact_3d.yaml (the 3D half model z >= 0; `--quarter` cuts it again at x = 0). `--cell`
sets both grids' cell size (R/h = 5 / cell). For each run: the whole body's peak contact force (the largest of the history's instantaneous
force, rows every 0.2 us, and of its mean over each 1 us), the contact duration (force above 1%
of the peak), the contact impulse, the sphere's rebound velocity (its axial momentum over its
mass) and the wall time after the first step; then r-z over 3D. Results as JSON under
results/bench_sphere_impact/.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numba
import numpy as np
import yaml

from machine import describe  # (bench/machine.py: run as python bench/sphere_impact.py)

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "validation" / "data" / "sphere_rz"
RESULTS = ROOT / "results" / "bench_sphere_impact"
ROW = 0.0002  # ms between history rows
V0 = 2.0


def deck(model: str, law: str, cell: float) -> dict:
    data = yaml.safe_load((DATA / f"sphere_impact_{'3d' if model == 'quarter' else model}.yaml").read_text())
    if model == "quarter":  # the half model cut again by x = 0 (a roller there too)
        data["grid"]["domain"]["min"][0] = 0.0
        data["grid"]["boundaries"]["xmin"] = "roller"
        for body in data["bodies"]:
            body["clip"]["min"][0] = 0.0
    data["grid"]["cell_size"] = cell
    data["contact"].pop("pass_3", None)
    for body in data["bodies"]:
        body.pop("seeding", None)
    if law == "coulomb":
        data["contact"]["default"] = {"law": "coulomb", "friction": 0.3}
    data["output"] = {"history_interval": ROW}
    return data


def run(model: str, law: str, cell: float, threads: int) -> dict:
    from mpmsim.deck.loader import as_loaded_deck
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation

    sim = Simulation(build_scene(as_loaded_deck(deck(model, law, cell), model, DATA)), out_dir=None, threads=threads)
    t0 = time.perf_counter()
    after_first = []  # (the first step compiles what the cache lacks: kept out of the wall time)
    sim.run(first_step=lambda seconds: after_first.append(time.perf_counter()))
    wall = time.perf_counter() - after_first[0]
    h = sim.history
    whole = "_whole" if model == "rz" else ""
    scale = {"rz": 1.0, "3d": 2.0, "quarter": 4.0}[model]  # (whole body: the 3D deck is a half model)
    t = h["time"].to_numpy()
    force = scale * h[f"contact_fy_steel_alu{whole}"].to_numpy()
    impulse = scale * h[f"contact_impulse_y_steel_alu{whole}"].to_numpy()
    p = scale * h[f"py_sphere{whole}"].to_numpy()
    mass = -p[0] / V0
    per_us = int(round(0.001 / ROW))
    mean_1us = np.diff(impulse[::per_us]) / (t[per_us] - t[0])
    peak = float(force.max())
    on = np.flatnonzero(force > 0.01 * peak)
    return {"model": model, "law": law, "cell": cell, "particles": int(sim.state.particles.n),
            "peak_force": peak, "peak_force_1us": float(mean_1us.max()),
            "contact_start": float(t[on[0]]), "contact_end": float(t[on[-1]]),
            "duration": float(t[on[-1]] - t[on[0]]), "impulse": float(impulse[-1]),
            "rebound": float(p[-1] / mass), "wall_s": wall, "threads": threads}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--law", nargs="+", default=["frictionless", "coulomb"], choices=["frictionless", "coulomb"])
    ap.add_argument("--cell", type=float, default=0.5)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--only", choices=["rz", "3d"])
    ap.add_argument("--quarter", action="store_true", help="the 3D run as a quarter model (x >= 0, z >= 0)")
    a = ap.parse_args()
    numba.set_num_threads(a.threads)
    RESULTS.mkdir(parents=True, exist_ok=True)
    print(describe(a.threads), f" R/h = {5.0 / a.cell:g}")
    keys = [("peak_force", "peak contact force (N)"), ("peak_force_1us", "peak, 1 us mean (N)"),
            ("duration", "contact duration (ms)"), ("impulse", "contact impulse (N ms)"),
            ("rebound", "rebound velocity (m/s)"), ("wall_s", "wall time (s)")]
    for law in a.law:
        res = {}
        for model in ("rz", "3d"):
            if a.only and model != a.only:
                continue
            res[model] = run("quarter" if model == "3d" and a.quarter else model, law, a.cell, a.threads)
            path = RESULTS / f"{res[model]['model']}_{law}_h{a.cell:g}.json"
            path.write_text(json.dumps(dict(res[model], machine=describe(a.threads)), indent=1))
        print(f"\n{law}: particles " + ", ".join(f"{m} {r['particles']}" for m, r in res.items()))
        for key, label in keys:
            row = "  ".join(f"{m} {r[key]:10.5g}" for m, r in res.items())
            if len(res) == 2:
                ratio = res["rz"][key] / res["3d"][key]
                row += f"   r-z / 3D {ratio:.4f}" if key == "wall_s" else f"   r-z / 3D - 1 {100 * (ratio - 1):+.2f}%"
            print(f"  {label:28s} {row}")


if __name__ == "__main__":
    main()
