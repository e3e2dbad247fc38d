"""The BFEMP paper's 3D twist (section 6.7), reduced: inputs/implicit_twist_3d.yaml for three
friction coefficients; the twist angle of the cube's top centre against the shell's angle.

    python bench/twist.py [--mu 0 0.1 0.5] [--jobs 2]

Each run writes results/twist/mu<mu>.json (per step: time, shell angle, top-centre angle, the
top centre's height, Newton iterations, particles inside a shell tetrahedron); the chart goes
to docs/figures/twist_angles.png. The shell's angle is the least-squares rotation about z of its
held rim, the top centre's that of the top layer of particles within 25 mm of the axis (12 of
512), both measured from the positions (atan2 of sum x0 x x over sum x0 . x).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mpmsim.deck import load_deck_text  # noqa: E402
from mpmsim.scene import build_scene  # noqa: E402
from mpmsim.solver import Simulation  # noqa: E402

OUT = ROOT / "results" / "twist"
TOP_RADIUS = 0.025


def z_angle(x0: np.ndarray, x: np.ndarray) -> float:
    """Least-squares rotation angle (degrees) about the z axis taking the points x0 to x."""
    return float(np.degrees(np.arctan2(np.sum(x0[:, 0] * x[:, 1] - x0[:, 1] * x[:, 0]),
                                       np.sum(x0[:, 0] * x[:, 0] + x0[:, 1] * x[:, 1]))))


def inside_count(points: np.ndarray, x: np.ndarray, cells: np.ndarray) -> int:
    """Points strictly inside some tetrahedron: the four sub-volumes (point, face) share the
    tetrahedron's sign (vectorised over the points, one tetrahedron at a time)."""
    def vol(a, b, c, d):
        return np.einsum("...i,...i->...", np.cross(b - a, c - a), d - a)

    inside = np.zeros(len(points), bool)
    lo, hi = x[cells].min(axis=1), x[cells].max(axis=1)
    for e in np.flatnonzero(np.all(hi >= points.min(axis=0), axis=1) & np.all(lo <= points.max(axis=0), axis=1)):
        a, b, c, d = x[cells[e]]
        s = np.sign(vol(a, b, c, d))
        inside |= ((s * vol(points, b, c, d) > 0) & (s * vol(a, points, c, d) > 0)
                   & (s * vol(a, b, points, d) > 0) & (s * vol(a, b, c, points) > 0))
    return int(inside.sum())


def twist_deck(mu: float, dt: float | None = None, end: float | None = None) -> dict:
    d = yaml.safe_load((ROOT / "inputs" / "implicit_twist_3d.yaml").read_text())
    if mu:
        d["contact"] = {"default": {"law": "coulomb", "friction": mu}}
    else:
        d.pop("contact", None)
    if dt is not None:
        d["time"]["dt"] = dt
    if end is not None:
        d["time"]["end"] = end
    return d


def run(mu: float, dt: float | None = None, end: float | None = None, check_inside: bool = True) -> dict:
    d = twist_deck(mu, dt, end)
    deck = load_deck_text(yaml.safe_dump(d), ROOT / "inputs" / "implicit_twist_3d.yaml")
    sim = Simulation(build_scene(deck), threads=1)
    P, f = sim.state.particles, sim.state.fem
    X0 = P.x.copy()
    top = (X0[:, 2] > X0[:, 2].max() - 1e-9) & (np.hypot(X0[:, 0], X0[:, 1]) < TOP_RADIUS)
    rim = f.held.all(axis=1)
    rows = []
    t0 = time.perf_counter()
    while sim.state.t < sim.end * (1 - 1e-12):
        sim.step()
        rows.append({"t": sim.state.t, "shell": z_angle(f.X[rim], f.x[rim]), "top": z_angle(X0[top], P.x[top]),
                     "top_z": float(P.x[top, 2].mean()), "newton": int(sim.integrator.stats[-1][0]),
                     "inside": inside_count(P.x, f.x, f.cells) if check_inside else -1})
    return {"mu": mu, "dt": sim.integrator.dt, "particles": int(P.n), "top_particles": int(top.sum()),
            "tets": int(len(f.cells)), "wall_s": time.perf_counter() - t0, "steps": rows}


def save(mu: float) -> dict:
    res = run(mu)
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / f"mu{mu:g}.json").write_text(json.dumps(res, indent=1))
    s = res["steps"][-1]
    print(f"mu {mu:g}: shell {s['shell']:.2f} deg, top centre {s['top']:.2f} deg, "
          f"max inside {max(r['inside'] for r in res['steps'])}, {res['wall_s']:.0f} s", flush=True)
    return res


def chart(results: list[dict]) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.5, 4.0))
    top = 0.0
    for res in results:
        st = res["steps"]
        shell = np.array([s["shell"] for s in st])
        ax.plot(shell, [s["top"] for s in st], marker=".", label=f"mu = {res['mu']:g}")
        top = max(top, shell.max())
    ax.plot([0, top], [0, top], "k:", lw=0.8, label="no slip")
    ax.set_xlabel("shell angle (degrees)")
    ax.set_ylabel("cube top-centre angle (degrees)")
    ax.set_title("3D twist: FEM shell cap on an MPM cube")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(ROOT / "docs" / "figures" / "twist_angles.png", dpi=110)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mu", type=float, nargs="+", default=[0.0, 0.1, 0.5])
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--chart-only", action="store_true", help="redraw the chart from results/twist")
    a = ap.parse_args()
    if a.chart_only:
        results = [json.loads((OUT / f"mu{mu:g}.json").read_text()) for mu in a.mu]
    else:
        with ProcessPoolExecutor(a.jobs) as pool:
            results = list(pool.map(save, a.mu))
    chart(results)


if __name__ == "__main__":
    main()
