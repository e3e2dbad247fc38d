"""The implicit step with barrier contact: cost per step (`make bench`).

    python bench/implicit.py [--h 0.025] [--rings-end 0.1] [--threads 1 2]
    python bench/implicit.py --column       # MPM column settling on an FEM floor: refinement

inputs/implicit_blocks_2d.yaml (FEM on FEM) at element size h, and inputs/implicit_rings_2d.yaml
(an MPM ring against an FEM ring), on 1 and 2 threads: DOFs, Newton iterations per step and the time per
step split into assembly, sparse solve, CCD and line search, after a first (compiling) step.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numba
import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mpmsim.deck import load_deck_text  # noqa: E402
from mpmsim.scene import build_scene  # noqa: E402
from mpmsim.solver import Simulation  # noqa: E402


def measure(name: str, d: dict, threads: int = 1) -> None:
    numba.set_num_threads(threads)
    sim = Simulation(build_scene(load_deck_text(yaml.safe_dump(d), ROOT / "inputs" / "bench.yaml")), threads=threads)
    sim.step()
    sim.reset_timers()
    first = len(sim.integrator.stats)
    t0 = time.perf_counter()
    while sim.state.t < sim.end * (1 - 1e-9):
        sim.step()
    wall = time.perf_counter() - t0
    stats = sim.integrator.stats[first:]
    steps = len(stats)
    st = sim.state
    its = sum(s[0] for s in stats)
    parts = []
    dofs = 0
    if st.fem is not None:
        parts.append(f"{len(st.fem.cells)} triangles")
        dofs += st.fem.x.size - int(st.fem.held.sum())
    if sim.integrator.grid is not None:
        grid = sim.integrator.grid
        parts.append(f"{st.particles.n} particles on {grid.n} active grid nodes")
        dofs += grid.X.size
    print(f"{name}: {', '.join(parts)}, {dofs} free DOFs (last step), {steps} steps, {its / steps:.2f} Newton "
          f"iterations per step, {wall / steps * 1e3:.1f} ms per step ({wall / its * 1e3:.1f} ms per Newton "
          f"iteration), {threads} thread(s)")
    for part, sec in sim.integrator.timers.items():
        print(f"  {part:12s} {sec / steps * 1e3:8.2f} ms/step  {100 * sec / wall:5.1f}%")


def column_deck(h: float, per_direction: int, steps: int = 12, E: float = 1e6, contact: str = "corners",
                shift: float = 0.0, tolerance: float = 1e-7) -> dict:
    """A 0.2 x 1 MPM column (nu = 0, E, rho 1000, g 10) 3 mm above a stiff FEM floor, backward
    Euler with dt = 1 s: a few steps reach the static state. `contact`: implicit.particle_contact;
    `shift`: the grid moved up by this fraction of a cell (0: the column's ends on grid lines)."""
    return {
        "title": "column", "units": "SI", "analysis": "plane_strain",
        "grid": {"cell_size": h, "domain": {"min": [-0.4, -0.2 + shift * h], "max": [0.4, 1.4 + shift * h]}},
        "shape_function": "bspline2", "update": {"scheme": "apic"}, "particles_per_direction": per_direction,
        "materials": {"column": {"type": "compressible_neo_hookean", "E": E, "nu": 0.0, "density": 1000.0},
                      "floor": {"type": "compressible_neo_hookean", "E": 1e10, "nu": 0.3, "density": 1000.0}},
        "bodies": [{"name": "floor", "shape": "rectangle", "min": [-0.3, -0.1], "max": [0.3, -0.003],
                    "material": "floor", "discretization": "fem", "element_size": 0.05,
                    "constraints": [{"region": {"min": [-1.0, -0.2], "max": [1.0, -0.09]}}]},
                   {"name": "column", "shape": "rectangle", "min": [-0.1, 0.0], "max": [0.1, 1.0],
                    "material": "column"}],
        "gravity": [0.0, -10.0], "integrator": "implicit",
        "implicit": {"scheme": "backward_euler", "dhat": 1e-3, "kappa": 1e8, "newton_tolerance": tolerance,
                     "particle_contact": contact},
        "time": {"end": float(steps), "dt": 1.0},
    }


def column_exact(Y, H=1.0, rho=1000.0, g=10.0, E=1e6):
    """Static height of the material point at reference height Y in the nu = 0 neo-Hookean
    column (Y = 0 at the bottom): lambda = 0, so P_yy = mu (F - 1/F) = -rho g (H - Y), F_xx = 1."""
    mu = 0.5 * E
    Ys = np.linspace(0.0, H, 20001)
    s = -rho * g * (H - Ys) / mu
    F = 0.5 * (s + np.sqrt(s * s + 4.0))
    y = np.concatenate([[0.0], np.cumsum(0.5 * (F[1:] + F[:-1]) * np.diff(Ys))])
    return np.interp(Y, Ys, y)


def column_errors(h: float, per_direction: int, **options) -> dict:
    """Settlement of the top particle row and centre of mass, both relative to the bottom row
    (the barrier's gap drops out), against column_exact; `options` go to column_deck."""
    d = column_deck(h, per_direction, **options)
    E = d["materials"]["column"]["E"]
    sim = Simulation(build_scene(load_deck_text(yaml.safe_dump(d), ROOT / "inputs" / "column.yaml")), threads=1)
    P = sim.state.particles
    Y = P.x[:, 1].copy()
    sim.run()
    bottom, top = np.isclose(Y, Y.min()), np.isclose(Y, Y.max())
    y_bottom = P.x[bottom, 1].mean()
    exact_top = column_exact(Y.max(), E=E) - column_exact(Y.min(), E=E)
    exact_com = (column_exact(Y, E=E) - column_exact(Y.min(), E=E)).mean()
    settlement = (Y.max() - Y.min()) - (P.x[top, 1].mean() - y_bottom)
    exact_settlement = (Y.max() - Y.min()) - exact_top
    return {"h": h, "per_direction": per_direction, "particles": P.n, "settlement": settlement,
            "exact_settlement": exact_settlement, "settlement_error": settlement - exact_settlement,
            "com_error": (P.x[:, 1] - y_bottom).mean() - exact_com}


def column_study() -> None:
    """Errors and orders for 4/9/16 particles per cell at h = 0.1, 0.05, 0.025: particle
    contact at the centres and at the corners, E = 1e7 and 1e6 (settlement 0.5 and 5 mm), the
    column's ends on grid lines and half a cell off them."""
    cases = [(1e7, "centres", 0.0), (1e7, "corners", 0.0), (1e7, "corners", 0.5), (1e6, "corners", 0.0)]
    for E, contact, shift in cases:
        print(f"MPM column on an FEM floor, E = {E:g} (rho g H^2 / 2E = {5e3 / E * 1e3:g} mm), particle contact at "
              f"the {contact}, grid shifted by {shift:g} h: errors against the exact static column")
        for per_direction in (2, 3, 4):
            rows = [column_errors(h, per_direction, E=E, contact=contact, shift=shift) for h in (0.1, 0.05, 0.025)]
            for a, b in zip(rows, rows[1:] + [None]):
                order = "" if b is None else \
                    f"  order to next: settlement {np.log2(abs(a['settlement_error'] / b['settlement_error'])):.2f}, " \
                    f"com {np.log2(abs(a['com_error'] / b['com_error'])):.2f}"
                print(f"  {per_direction ** 2:2d} per cell, h = {a['h']:<6g}: settlement {a['settlement'] * 1e3:.4f} mm "
                      f"(exact {a['exact_settlement'] * 1e3:.4f}), error {a['settlement_error'] * 1e6:+.3f} um, "
                      f"centre of mass {a['com_error'] * 1e6:+.3f} um{order}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--h", type=float, default=0.025, help="element size of the blocks (default 0.025)")
    ap.add_argument("--rings-end", type=float, default=0.1, help="end time of the rings run (default 0.1 s)")
    ap.add_argument("--column", action="store_true", help="the column refinement study instead")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2], help="thread counts (default 1 2)")
    args = ap.parse_args()
    numba.set_num_threads(1)
    if args.column:
        column_study()
        return
    d = yaml.safe_load((ROOT / "inputs" / "implicit_blocks_2d.yaml").read_text())
    for b in d["bodies"]:
        b["element_size"] = args.h
    d["output"] = {"history_interval": d["time"]["end"]}
    rings = yaml.safe_load((ROOT / "inputs" / "implicit_rings_2d.yaml").read_text())
    rings["time"]["end"] = args.rings_end
    rings["output"] = {"history_interval": args.rings_end}
    for threads in args.threads:
        measure(f"implicit blocks, h = {args.h:g}", d, threads)
        measure("implicit rings (MPM ring against FEM ring)", rings, threads)


if __name__ == "__main__":
    main()
