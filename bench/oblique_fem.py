"""A converged reference for the oblique impact (inputs/oblique_impact.yaml): the same steel
cylinder and aluminium block as finite elements, stepped implicitly, meeting through the barrier
contact with IPC's smoothed Coulomb friction (docs/bfemp.md), refined until the cylinder's
rebound stops moving.

    python bench/oblique_fem.py run [--levels 0 1 2 3] [--mu 0 0.3] [--gap 0.0005] [--lags 3] [--hmax 1]
                                    [--material linear_elastic|compressible_neo_hookean]
    python bench/oblique_fem.py table       # results/bench_oblique_fem/*.json

The scene is the MPM deck's: a steel disk (R = 10 mm, E = 200 GPa, nu = 0.3, 7.85 g/cm^3) at
(1, -1) m/s onto an aluminium block [-25, 25] x [0, 15] mm (E = 70 GPa, nu = 0.33, 2.7 g/cm^3)
held on y = 0, plane strain, both `linear_elastic` (small strain; the cylinder turns by under
0.005 rad in the run) or, with `--material`, `compressible_neo_hookean` of the same moduli. The
disk starts `--gap` above the block at x = -8 mm (0.5 um: a touching start, as the continuum has
no other; a longer gap is only a longer flight) and the run ends 0.05 ms after it would touch,
well after it has left (the contact lasts about 0.036 ms).

Meshes: linear triangles, graded towards the first contact point (-8, 15): element size
h(x) = min(hmax, hmin + 0.25 |x - c|), from a quadtree of the body's box refined until each cell
is no larger than h at its point nearest c; the quadtree's corners inside the body (the disk's
at least 0.6 h inside its circle) and points on its boundary h apart, triangulated by scipy's
Delaunay (both bodies are convex; the triangulation is taken with the inner points moved by up
to 1e-3 h, so that no four are cocircular). Level L: hmin = 0.2 / 2^L mm, hmax = 1 mm
(`--hmax`), time step 5e-4 / 2^L ms (midpoint Newmark: no numerical damping of the bodies'
ringing). Barrier distance dhat = 1e-4 mm (the contact's approach is
about 0.01 mm), friction velocity eps_v = 1e-3 m/s, `--lags` friction lags per step.

Measured per run: the cylinder's velocity (momentum over mass) and spin at the end, the contact
duration (rows where the cylinder's momentum changes), kinetic plus strain energy at the end
over the initial, the node counts and the wall time; JSON under results/bench_oblique_fem/.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import meshio
import numpy as np
from scipy.spatial import Delaunay

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results" / "bench_oblique_fem"
R, CX, TOP = 10.0, -8.0, 15.0  # disk radius, its centre's x, the block's top
BLOCK = ((-25.0, 0.0), (25.0, 15.0))
GRADE = 0.25


def sizing(p: np.ndarray, c: np.ndarray, hmin: float, hmax: float) -> np.ndarray:
    return np.minimum(hmax, hmin + GRADE * np.linalg.norm(p - c, axis=-1))


def quadtree_corners(lo, roots, size: float, c: np.ndarray, hmin: float, hmax: float) -> np.ndarray:
    """Corners of a quadtree over roots[0] x roots[1] square cells of `size` from `lo`, each
    leaf no larger than the element size at its point nearest c."""
    cells = [(lo[0] + i * size, lo[1] + j * size, size) for i in range(roots[0]) for j in range(roots[1])]
    points = set()
    while cells:
        finer = []
        for x, y, s in cells:
            near = np.array([min(max(c[0], x), x + s), min(max(c[1], y), y + s)])
            if s > 1.0001 * sizing(near, c, hmin, hmax):
                t = s / 2
                finer += [(x, y, t), (x + t, y, t), (x, y + t, t), (x + t, y + t, t)]
            else:
                points.update((round(x + dx, 12), round(y + dy, 12)) for dx in (0.0, s) for dy in (0.0, s))
        cells = finer
    return np.array(sorted(points))


def triangulate(points: np.ndarray, interior: np.ndarray, c: np.ndarray, hmin: float, hmax: float,
                path: Path) -> int:
    """Delaunay triangles of the points (interior ones jittered), counter-clockwise, to a Gmsh file."""
    p = points.copy()
    jitter = np.random.default_rng(1).uniform(-1.0, 1.0, (int(interior.sum()), 2))
    p[interior] += 1e-3 * sizing(p[interior], c, hmin, hmax)[:, None] * jitter
    tri = Delaunay(p).simplices
    a, b, d = p[tri[:, 0]], p[tri[:, 1]], p[tri[:, 2]]
    area = (b[:, 0] - a[:, 0]) * (d[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (d[:, 0] - a[:, 0])
    tri[area < 0] = tri[area < 0][:, [0, 2, 1]]
    points3 = np.column_stack([points, np.zeros(len(points))])
    tags = {"gmsh:physical": [np.ones(len(tri), int)], "gmsh:geometrical": [np.ones(len(tri), int)]}
    meshio.write(path, meshio.Mesh(points3, [("triangle", tri)], cell_data=tags), file_format="gmsh22", binary=False)
    return len(points)


def disk_mesh(path: Path, yc: float, hmin: float, hmax: float) -> int:
    centre, c = np.array([CX, yc]), np.array([CX, yc - R])
    inner = quadtree_corners(centre - R, (8, 8), 2.5, c, hmin, hmax)
    inner = inner[np.linalg.norm(inner - centre, axis=1) < R - 0.6 * sizing(inner, c, hmin, hmax)]
    rim, t = [], -np.pi / 2  # h apart round the circle from its lowest point
    while t < 1.5 * np.pi - 1e-12:
        q = centre + R * np.array([np.cos(t), np.sin(t)])
        rim.append(q)
        t += float(sizing(q, c, hmin, hmax)) / R
    if np.linalg.norm(rim[-1] - rim[0]) < 0.5 * hmin:
        rim.pop()
    points = np.vstack([np.array(rim), inner])
    interior = np.r_[np.zeros(len(rim), bool), np.ones(len(inner), bool)]
    return triangulate(points, interior, c, hmin, hmax, path)


def block_mesh(path: Path, hmin: float, hmax: float) -> int:
    (x0, y0), (x1, y1) = BLOCK
    c = np.array([CX, TOP])
    points = quadtree_corners((x0, y0), (20, 6), 2.5, c, hmin, hmax)
    edge = np.isclose(points[:, 0], x0) | np.isclose(points[:, 0], x1) | np.isclose(points[:, 1], y0) \
        | np.isclose(points[:, 1], y1)
    return triangulate(points, ~edge, c, hmin, hmax, path)


def deck(folder: Path, level: int, mu: float, gap: float, lags: int, hmax: float = 1.0,
         material: str = "linear_elastic") -> tuple[dict, dict]:
    hmin, dt = 0.2 / 2**level, 5e-4 / 2**level
    yc = TOP + R + gap
    nodes = {"disk": disk_mesh(folder / "disk.msh", yc, hmin, hmax),
             "block": block_mesh(folder / "block.msh", hmin, hmax)}
    law = {"law": "frictionless"} if mu == 0.0 else {"law": "coulomb", "friction": mu}
    data = {
        "title": f"oblique impact, FEM level {level}",
        "units": "mm-g-ms",
        "analysis": "plane_strain",
        "materials": {
            "steel": {"type": material, "E": 200000.0, "nu": 0.3, "density": 0.00785},
            "alu": {"type": material, "E": 70000.0, "nu": 0.33, "density": 0.0027},
        },
        "bodies": [
            {"name": "block", "shape": "mesh", "file": "block.msh", "material": "alu", "discretization": "fem",
             "constraints": [{"region": {"min": [-30.0, -0.1], "max": [30.0, 0.1]}}]},
            {"name": "cylinder", "shape": "mesh", "file": "disk.msh", "material": "steel", "discretization": "fem",
             "velocity": [1.0, -1.0]},
        ],
        "contact": {"default": law},
        "integrator": "implicit",
        "implicit": {"scheme": "newmark", "dhat": 1e-4, "friction_velocity": 1e-3, "friction_lags": lags},
        "time": {"end": gap + 0.05, "dt": dt},
        "output": {"vtu_interval": 1.0, "history_interval": dt},
    }
    return data, {"hmin": hmin, "hmax": hmax, "dt": dt, "material": material, "nodes": nodes}


def run(level: int, mu: float, gap: float = 5e-4, lags: int = 3, hmax: float = 1.0, material: str = "linear_elastic",
        threads: int = 1) -> dict:
    """One FEM run: the cylinder's rebound and the run's figures."""
    from mpmsim.deck.loader import as_loaded_deck
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        data, info = deck(folder, level, mu, gap, lags, hmax, material)
        sim = Simulation(build_scene(as_loaded_deck(data, "oblique_fem", folder)), out_dir=None, threads=threads)
        t0 = time.perf_counter()
        sim.run()
        wall = time.perf_counter() - t0
    col = sim.recorder.column
    px, py = col("px_cylinder"), col("py_cylinder")
    mass = px[0]
    energy = col("kinetic_energy") + col("strain_energy")
    moving = np.nonzero(np.abs(np.diff(py)) > 1e-6 * mass)[0]
    duration = float(col("time")[moving[-1] + 1] - col("time")[moving[0]]) if len(moving) else 0.0
    return {"level": level, "mu": mu, "gap": gap, "lags": lags, **info,
            "vx": float(px[-1] / mass), "vy": float(py[-1] / mass), "spin": float(col("spin_cylinder")[-1]),
            "duration": duration, "energy_ratio": float(energy[-1] / energy[0]), "wall_s": wall}


def table() -> None:
    rows = [json.loads(p.read_text()) for p in sorted(RESULTS.glob("*.json"))]
    print("| mu | level | hmin (mm) | hmax | lags | material | dt (us) | nodes | vx | vy | duration (ms) "
          "| E end / E0 | wall (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in sorted(rows, key=lambda r: (r["mu"], r["lags"], -r["hmax"], r["level"])):
        print(f"| {r['mu']:g} | {r['level']} | {r['hmin']:g} | {r['hmax']:g} | {r['lags']} | "
              f"{r.get('material', 'linear_elastic')} | {1e3 * r['dt']:g} | "
              f"{r['nodes']['disk'] + r['nodes']['block']} | {r['vx']:.4f} | {r['vy']:.4f} | "
              f"{r['duration']:.4f} | {r['energy_ratio']:.4f} | {r['wall_s']:.0f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("command", choices=["run", "table"])
    parser.add_argument("--levels", type=int, nargs="+", default=[0, 1, 2, 3])
    parser.add_argument("--mu", type=float, nargs="+", default=[0.0, 0.3])
    parser.add_argument("--gap", type=float, default=5e-4)
    parser.add_argument("--lags", type=int, default=3)
    parser.add_argument("--hmax", type=float, default=1.0)
    parser.add_argument("--material", choices=["linear_elastic", "compressible_neo_hookean"], default="linear_elastic")
    args = parser.parse_args()
    if args.command == "table":
        table()
        return
    RESULTS.mkdir(parents=True, exist_ok=True)
    for mu in args.mu:
        for level in args.levels:
            r = run(level, mu, args.gap, args.lags, args.hmax, args.material)
            tag = "" if args.material == "linear_elastic" else "_" + args.material
            name = f"mu{mu:g}_level{level}_lags{args.lags}_hmax{args.hmax:g}{tag}.json"
            (RESULTS / name).write_text(json.dumps(r, indent=1))
            print(f"mu {mu:g} level {level}: vx {r['vx']:.4f} vy {r['vy']:.4f} duration {r['duration']:.4f} ms "
                  f"E/E0 {r['energy_ratio']:.4f} nodes {r['nodes']} wall {r['wall_s']:.0f} s", flush=True)


if __name__ == "__main__":
    main()
