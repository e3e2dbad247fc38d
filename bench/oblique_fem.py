"""The continuum of an oblique impact of a cylinder on a block (plane strain), converged.

Both bodies as finite elements, stepped implicitly, meeting through the barrier contact with
IPC's smoothed Coulomb friction (docs/bfemp.md), refined until the cylinder's rebound stops
moving.

    python bench/oblique_fem.py run [--levels 0 1 2 3] [--mu 0 0.3] [--gap 0.0005] [--lags 3] [--hmax 1]
                                    [--material linear_elastic|compressible_neo_hookean]
                                    [--radius 10] [--velocity 1 -1] [--x0 -8] [--end 0.05]
                                    [--cylinder E nu density] [--block E nu density] [--block-size 50 15]
    python bench/oblique_fem.py table       # results/bench_oblique_fem/*.json
    python bench/oblique_fem.py mpm [--rh 10 20] [--mu 0 0.3] [--contact KEY=VALUE ...] [--body KEY=VALUE ...]
                                    [--block-body KEY=VALUE ...] [the scene arguments]
    python bench/oblique_fem.py nodes [--rh 10] [--mu 0.3] [the same keys and scene arguments]

`mpm` runs the same scene as a plainly written MPM deck (`plain_deck`: the defaults, the cylinder
seeded to its surface, its centre R above the block: a touching start) and prints the rebound
beside the finest stored level of the continuum for that scene and mu, with the energy at the
end and what friction took (the ledger's friction_loss), both over the initial energy, and the
run's wall time; the continuum's friction share is 1 - E end / E0 (elastic bodies lose nothing
else). Its last column is the cylinder's angular momentum about the first touch point P at the
end over its start (`touch_momentum`): the continuum keeps it to 0.2%, and its shortfall is the
moment the MPM contact's forces took. `nodes` steps the plain deck and prints the impulse each
contact node gave the cylinder over the impact and where the normal impulse's centre lies from P
(docs/contact-methods.md, "Why the coarse rows miss"). `--contact KEY=VALUE` (repeatable; VALUE read as YAML) adds a key to the deck's `contact`
section, `--body KEY=VALUE` to the cylinder (e.g. `--body seeding=lattice`) and `--block-body KEY=VALUE`
to the block (a rectangle: it takes no `seeding`, its particles are always the lattice's).

The default scene is inputs/oblique_impact.yaml's: a steel disk (R = 10 mm, E = 200 GPa,
nu = 0.3, 7.85 g/cm^3) at (1, -1) m/s onto an aluminium block [-25, 25] x [0, 15] mm (E = 70 GPa,
nu = 0.33, 2.7 g/cm^3) held on y = 0. The arguments make any other (`Scene`): the disk's radius,
impact velocity and centre x, both materials (E in MPa, density in g/mm^3: the deck units
mm-g-ms) and the block's width and height (centred on x = 0, its bottom on y = 0); both
`linear_elastic` (small strain; the default cylinder turns by under 0.005 rad in the run) or,
with `--material`, `compressible_neo_hookean` of the same moduli. The disk starts `--gap` above
the block (0.5 um: a touching start, as the continuum has no other; a longer gap is only a longer
flight) and the run ends `--end` after it would touch (0.05 ms: the default cylinder's contact
lasts about 0.036 ms; choose it past the contact, which the run's `duration` reports).

Meshes: linear triangles, graded towards the first contact point (x0, top): element size
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
over the initial, the node counts and the wall time; JSON under results/bench_oblique_fem/ (a
scene other than the default adds its tag to the file name and its arguments to the record).
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from pathlib import Path
from typing import NamedTuple

import meshio
import numpy as np
from scipy.spatial import Delaunay

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results" / "bench_oblique_fem"
GRADE = 0.25
ROOT_CELL = 2.5  # the quadtrees' root cells (mm), at most


class Scene(NamedTuple):
    """A cylinder (disk) striking a block held on its bottom, plane strain, deck units mm-g-ms."""

    radius: float = 10.0
    velocity: tuple[float, float] = (1.0, -1.0)  # m/s (= mm/ms)
    x0: float = -8.0  # the disk centre's x
    cylinder: tuple[float, float, float] = (200000.0, 0.3, 0.00785)  # E (MPa), nu, density (g/mm^3)
    block: tuple[float, float, float] = (70000.0, 0.33, 0.0027)
    size: tuple[float, float] = (50.0, 15.0)  # the block's width (centred on x = 0) and height
    end: float = 0.05  # run time after the touch (ms)

    @property
    def top(self) -> float:
        return self.size[1]

    def tag(self) -> str:
        """'' for the default scene, else its arguments in a file name."""
        if self == Scene():
            return ""
        f = "_".join
        return ("_scene_R{:g}_v{}_x{:g}_cyl{}_blk{}_size{}_end{:g}".format(
            self.radius, f(f"{v:g}" for v in self.velocity), self.x0, f(f"{v:g}" for v in self.cylinder),
            f(f"{v:g}" for v in self.block), f(f"{v:g}" for v in self.size), self.end))


def sizing(p: np.ndarray, c: np.ndarray, hmin: float, hmax: float) -> np.ndarray:
    return np.minimum(hmax, hmin + GRADE * np.linalg.norm(p - c, axis=-1))


def quadtree_corners(lo, extent, c: np.ndarray, hmin: float, hmax: float) -> np.ndarray:
    """Corners of a quadtree over the box lo + [0, extent] (root cells of at most ROOT_CELL a
    side, as many as fit exactly), each leaf no larger than the element size at its point
    nearest c."""
    n = [max(1, math.ceil(e / ROOT_CELL - 1e-9)) for e in extent]
    sx, sy = extent[0] / n[0], extent[1] / n[1]
    cells = [(lo[0] + i * sx, lo[1] + j * sy, sx, sy) for i in range(n[0]) for j in range(n[1])]
    points = set()
    while cells:
        finer = []
        for x, y, a, b in cells:
            near = np.array([min(max(c[0], x), x + a), min(max(c[1], y), y + b)])
            if max(a, b) > 1.0001 * sizing(near, c, hmin, hmax):
                u, w = a / 2, b / 2
                finer += [(x, y, u, w), (x + u, y, u, w), (x, y + w, u, w), (x + u, y + w, u, w)]
            else:
                points.update((round(x + dx, 12), round(y + dy, 12)) for dx in (0.0, a) for dy in (0.0, b))
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


def disk_mesh(path: Path, scene: Scene, yc: float, hmin: float, hmax: float) -> int:
    R = scene.radius
    centre, c = np.array([scene.x0, yc]), np.array([scene.x0, yc - R])
    inner = quadtree_corners(centre - R, (2 * R, 2 * R), c, hmin, hmax)
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


def block_mesh(path: Path, scene: Scene, hmin: float, hmax: float) -> int:
    (x0, y0), (x1, y1) = (-scene.size[0] / 2, 0.0), (scene.size[0] / 2, scene.top)
    c = np.array([scene.x0, scene.top])
    points = quadtree_corners((x0, y0), scene.size, c, hmin, hmax)
    edge = np.isclose(points[:, 0], x0) | np.isclose(points[:, 0], x1) | np.isclose(points[:, 1], y0) \
        | np.isclose(points[:, 1], y1)
    return triangulate(points, ~edge, c, hmin, hmax, path)


def deck(folder: Path, level: int, mu: float, gap: float, lags: int, hmax: float = 1.0,
         material: str = "linear_elastic", scene: Scene = Scene()) -> tuple[dict, dict]:
    hmin, dt = 0.2 / 2**level, 5e-4 / 2**level
    yc = scene.top + scene.radius + gap
    nodes = {"disk": disk_mesh(folder / "disk.msh", scene, yc, hmin, hmax),
             "block": block_mesh(folder / "block.msh", scene, hmin, hmax)}
    (Ec, nuc, rhoc), (Eb, nub, rhob) = scene.cylinder, scene.block
    half = scene.size[0] / 2
    law = {"law": "frictionless"} if mu == 0.0 else {"law": "coulomb", "friction": mu}
    data = {
        "title": f"oblique impact, FEM level {level}",
        "units": "mm-g-ms",
        "analysis": "plane_strain",
        "materials": {
            "cylinder": {"type": material, "E": Ec, "nu": nuc, "density": rhoc},
            "block": {"type": material, "E": Eb, "nu": nub, "density": rhob},
        },
        "bodies": [
            {"name": "block", "shape": "mesh", "file": "block.msh", "material": "block", "discretization": "fem",
             "constraints": [{"region": {"min": [-half - 5.0, -0.1], "max": [half + 5.0, 0.1]}}]},
            {"name": "cylinder", "shape": "mesh", "file": "disk.msh", "material": "cylinder", "discretization": "fem",
             "velocity": list(scene.velocity)},
        ],
        "contact": {"default": law},
        "integrator": "implicit",
        "implicit": {"scheme": "newmark", "dhat": 1e-4, "friction_velocity": 1e-3, "friction_lags": lags},
        "time": {"end": gap + scene.end, "dt": dt},
        "output": {"vtu_interval": 1.0, "history_interval": dt},
    }
    return data, {"hmin": hmin, "hmax": hmax, "dt": dt, "material": material, "nodes": nodes}


def run(level: int, mu: float, gap: float = 5e-4, lags: int = 3, hmax: float = 1.0, material: str = "linear_elastic",
        threads: int = 1, scene: Scene = Scene()) -> dict:
    """One FEM run: the cylinder's rebound (vx, vy: its momentum over mass at the end, in m/s)
    and the run's figures."""
    from mpmsim.deck.loader import as_loaded_deck
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        data, info = deck(folder, level, mu, gap, lags, hmax, material, scene)
        sim = Simulation(build_scene(as_loaded_deck(data, "oblique_fem", folder)), out_dir=None, threads=threads)
        t0 = time.perf_counter()
        sim.run()
        wall = time.perf_counter() - t0
    col = sim.recorder.column
    px, py = col("px_cylinder"), col("py_cylinder")
    mass = float(np.hypot(px[0], py[0]) / np.hypot(*scene.velocity))  # (the default scene: px[0], vx = 1)
    energy = col("kinetic_energy") + col("strain_energy")
    moving = np.nonzero(np.abs(np.diff(py)) > 1e-6 * mass)[0]
    duration = float(col("time")[moving[-1] + 1] - col("time")[moving[0]]) if len(moving) else 0.0
    return {"level": level, "mu": mu, "gap": gap, "lags": lags, **info,
            "vx": float(px[-1] / mass), "vy": float(py[-1] / mass), "spin": float(col("spin_cylinder")[-1]),
            "duration": duration, "energy_ratio": float(energy[-1] / energy[0]), "wall_s": wall}


def plain_deck(scene: Scene, h: float, mu: float, contact: dict | None = None, body: dict | None = None,
               block_body: dict | None = None) -> dict:
    """The scene as a user writes it for MPM: particles with every default (the cylinder seeded
    to its surface), the cylinder's centre R above the block (its particle domains touching),
    cell size h, run to twice `end`; `contact`, `body` and `block_body` add keys to the contact
    section, the cylinder and the block."""
    w, top, r = scene.size[0], scene.top, scene.radius
    (Ec, nuc, rhoc), (Eb, nub, rhob) = scene.cylinder, scene.block
    law = {"law": "frictionless"} if mu == 0.0 else {"law": "coulomb", "friction": mu}
    return {"title": "oblique impact, plain MPM deck", "units": "mm-g-ms", "analysis": "plane_strain",
            "grid": {"cell_size": h, "domain": {"min": [-w / 2 - 2.0, 0.0], "max": [w / 2 + 2.0, top + 2 * r + 3.0]},
                     "boundaries": {"ymin": "fixed"}},
            "materials": {"cylinder": {"type": "linear_elastic", "E": Ec, "nu": nuc, "density": rhoc},
                          "block": {"type": "linear_elastic", "E": Eb, "nu": nub, "density": rhob}},
            "bodies": [{"name": "block", "shape": "rectangle", "min": [-w / 2, 0.0], "max": [w / 2, top],
                        "material": "block", **(block_body or {})},
                       {"name": "cylinder", "shape": "circle", "center": [scene.x0, top + r], "radius": r,
                        "material": "cylinder", "velocity": list(scene.velocity), **(body or {})}],
            "contact": {"default": law, **(contact or {})},
            "time": {"end": 2 * scene.end}, "output": {"energy_ledger": True}}


def run_mpm(scene: Scene, rh: float, mu: float, contact: dict | None = None, body: dict | None = None,
            block_body: dict | None = None) -> dict:
    """The plain MPM deck at R/h = rh: the cylinder's rebound, energy at the end and friction's
    share, the largest kinetic + strain energy at any history row (energy_max) and with friction's
    share added (booked_max), both over E0, the angular momentum about the touch point
    (touch_momentum), and the run's wall time (s)."""
    from mpmsim.deck.loader import as_loaded_deck
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation

    data = plain_deck(scene, scene.radius / rh, mu, contact, body, block_body)
    sim = Simulation(build_scene(as_loaded_deck(data, "oblique_mpm", ROOT)), out_dir=None, threads=1)
    t0 = time.perf_counter()
    sim.run()
    wall = time.perf_counter() - t0
    col = sim.recorder.column
    px, py = col("px_cylinder"), col("py_cylinder")
    mass = float(np.hypot(px[0], py[0]) / np.hypot(*scene.velocity))
    energy = col("kinetic_energy") + col("strain_energy")
    return {"vx": float(px[-1] / mass), "vy": float(py[-1] / mass), "energy_ratio": float(energy[-1] / energy[0]),
            "friction": float(col("friction_loss")[-1] / energy[0]),
            "energy_max": float(np.max(energy) / energy[0]),
            "booked_max": float(np.max(energy + col("friction_loss")) / energy[0]),
            "touch_L": touch_momentum(col("L_cylinder"), px, py, scene), "wall_s": wall}


def touch_momentum(L: np.ndarray, px: np.ndarray, py: np.ndarray, scene: Scene) -> float:
    """The cylinder's angular momentum about the first touch point P = (x0, top) at the end over
    its start (L about the origin less P x p). Contact forces act through P to within the
    patch's width and its drift (the continuum: 1.000), so 1 - this is the moment the contact
    forces took: the MPM contact's rolling resistance where the nodes carrying the force lie
    off the patch."""
    Lp = L - (scene.x0 * py - scene.top * px)
    return float(Lp[-1] / Lp[0])


def continuum_touch_momentum(record: dict, scene: Scene) -> float:
    """touch_momentum of a stored continuum run from its end velocity and spin (the centre's
    drift over the contact, under 0.04 mm, neglected: c - P = (0, R))."""
    mass = scene.cylinder[2] * math.pi * scene.radius ** 2
    vx0 = scene.velocity[0]
    return (record["vx"] - record["spin"] / (mass * scene.radius)) / vx0


def contact_nodes(scene: Scene, rh: float, mu: float, contact: dict | None = None, body: dict | None = None,
                  block_body: dict | None = None) -> None:
    """The plain deck at R/h = rh, stepped with output.contact_traction: the impulse each contact
    node gave the cylinder over the impact (pass 2's change, as the history's contact force sums
    it), by the node's offset from the first touch point P = (x0, top) in cells, and the offset
    of the normal impulse's centre from P along x. Nodes under 0.1% of the total are left out."""
    from mpmsim.contact.grid.traction import node_tractions
    from mpmsim.deck.loader import as_loaded_deck
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation

    data = plain_deck(scene, scene.radius / rh, mu, contact, body, block_body)
    data["output"]["contact_traction"] = True
    built = build_scene(as_loaded_deck(data, "oblique_mpm", ROOT))
    sim = Simulation(built, out_dir=None, threads=1)
    st, g = sim.state, sim.state.grid
    h = scene.radius / rh
    cylinder = int(st.contact.spec.mat_group[built.materials.names.index("cylinder")])
    impulse: dict[tuple[int, int], np.ndarray] = {}
    while st.t < sim.end * (1.0 - 1e-9):
        sim.step()
        nt = node_tractions(st.contact)
        if not len(nt.slot):
            continue
        # a target of the cylinder takes its force; one of the block gives the cylinder the opposite
        sign = np.where(nt.group == cylinder, 1.0, -1.0)[:, None]
        ij = np.stack([nt.node % g.shape[0], (nt.node // g.shape[0]) % g.shape[1]], 1)
        x = g.origin[:2] + ij * h
        for k in range(len(nt.slot)):
            key = (int(round((x[k, 0] - scene.x0) / h)), int(round((x[k, 1] - scene.top) / h)))
            impulse.setdefault(key, np.zeros(2))
            impulse[key] += sign[k] * nt.force[k] * st.dt
    total = sum(impulse.values())
    print(f"R/h = {rh:g}, mu = {mu:g}: the cylinder's impulse per contact node (m = cylinder mass, "
          f"J / m in m/s), node offset from P in cells (along x, y)")
    print("| node (x, y) | Jx / m | Jy / m | share of Jy |")
    print("|---|---|---|---|")
    mass = scene.cylinder[2] * math.pi * scene.radius ** 2
    for key in sorted(impulse):
        j = impulse[key]
        if abs(j[1]) >= 1e-3 * abs(total[1]):
            print(f"| ({key[0]:+d}, {key[1]:+d}) | {j[0] / mass:+.4f} | {j[1] / mass:+.4f} | {j[1] / total[1]:.3f} |")
    arm = sum(k[0] * h * j[1] for k, j in impulse.items()) / total[1]
    print(f"total J / m = ({total[0] / mass:+.4f}, {total[1] / mass:+.4f}); the normal impulse's centre "
          f"{arm:+.3f} mm ({arm / h:+.2f} cells) from P along x")


def mpm_table(scene: Scene, rhs: list[float], mus: list[float], contact: dict | None = None,
              body: dict | None = None, block_body: dict | None = None) -> None:
    rows = [r for r in continuum_runs() if Scene(**scene_args(r)) == scene
            and r.get("material", "linear_elastic") == "linear_elastic"]
    print("| mu | run | vx | vy | E end / E0 | friction / E0 | L about P, end / start | wall (s) |")
    print("|---|---|---|---|---|---|---|---|")
    for mu in mus:
        fem = [r for r in rows if r["mu"] == mu]
        if fem:
            f = max(fem, key=lambda r: r["level"])
            # (elastic bodies: all the continuum loses is friction's)
            print(f"| {mu:g} | continuum (level {f['level']}) | {f['vx']:.4f} | {f['vy']:.4f} | {f['energy_ratio']:.4f} "
                  f"| {1 - f['energy_ratio']:.4f} | {continuum_touch_momentum(f, scene):.4f} | |")
        for rh in rhs:
            m = run_mpm(scene, rh, mu, contact, body, block_body)
            cmp = (f" ({100 * (m['vx'] / f['vx'] - 1):+.1f}%)", f" ({100 * (m['vy'] / f['vy'] - 1):+.1f}%)") if fem \
                else ("", "")
            print(f"| {mu:g} | MPM, R/h = {rh:g} | {m['vx']:.4f}{cmp[0]} | {m['vy']:.4f}{cmp[1]} | "
                  f"{m['energy_ratio']:.4f} | {m['friction']:.4f} | {m['touch_L']:.4f} | {m['wall_s']:.0f} |", flush=True)


STORED = [ROOT / "tests" / "validation" / "data" / f for f in ("oblique_fem_reference.json", "oblique_fem_scene2.json")]


def continuum_runs() -> list[dict]:
    """The stored continua (tests/validation/data: the default scene and a second one), then
    this machine's results/bench_oblique_fem/*.json, each run with its scene."""
    runs = []
    for path in STORED:
        data = json.loads(path.read_text())
        runs += [{**r, "scene": data["scene"]} if "scene" in data else r for r in data["runs"]]
    return runs + [json.loads(p.read_text()) for p in sorted(RESULTS.glob("*.json"))]


def scene_args(record: dict) -> dict:
    """A result's Scene arguments (none for the default scene), tuples as Scene has them."""
    return {k: tuple(v) if isinstance(v, list) else v for k, v in record.get("scene", {}).items()}


def table() -> None:
    rows = [json.loads(p.read_text()) for p in sorted(RESULTS.glob("*.json"))]
    print("| scene | mu | level | hmin (mm) | hmax | lags | material | dt (us) | nodes | vx | vy | duration (ms) "
          "| E end / E0 | wall (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in sorted(rows, key=lambda r: (Scene(**scene_args(r)).tag(), r["mu"], r["lags"], -r["hmax"], r["level"])):
        print(f"| {Scene(**scene_args(r)).tag().removeprefix('_scene_') or 'default'} | {r['mu']:g} | {r['level']} | {r['hmin']:g} | {r['hmax']:g} | {r['lags']} | "
              f"{r.get('material', 'linear_elastic')} | {1e3 * r['dt']:g} | "
              f"{r['nodes']['disk'] + r['nodes']['block']} | {r['vx']:.4f} | {r['vy']:.4f} | "
              f"{r['duration']:.4f} | {r['energy_ratio']:.4f} | {r['wall_s']:.0f} |")


def key_values(parser: argparse.ArgumentParser, items: list[str], option: str) -> dict:
    """KEY=VALUE arguments as a dict, each VALUE read as YAML."""
    import yaml

    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            parser.error(f"{option} takes KEY=VALUE, not {item!r}")
        out[key.strip()] = yaml.safe_load(value)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("command", choices=["run", "table", "mpm", "nodes"])
    parser.add_argument("--rh", type=float, nargs="+", default=[10.0, 20.0], help="mpm: R/h of the MPM runs")
    parser.add_argument("--levels", type=int, nargs="+", default=[0, 1, 2, 3])
    parser.add_argument("--mu", type=float, nargs="+", default=[0.0, 0.3])
    parser.add_argument("--gap", type=float, default=5e-4)
    parser.add_argument("--lags", type=int, default=3)
    parser.add_argument("--hmax", type=float, default=1.0)
    parser.add_argument("--material", choices=["linear_elastic", "compressible_neo_hookean"], default="linear_elastic")
    d = Scene()
    parser.add_argument("--radius", type=float, default=d.radius, help="the cylinder's radius (mm)")
    parser.add_argument("--velocity", type=float, nargs=2, default=d.velocity, metavar=("VX", "VY"),
                        help="impact velocity (m/s)")
    parser.add_argument("--x0", type=float, default=d.x0, help="the cylinder centre's x (mm; the block spans -w/2..w/2)")
    parser.add_argument("--cylinder", type=float, nargs=3, default=d.cylinder, metavar=("E", "NU", "DENSITY"),
                        help="the cylinder's material (MPa, -, g/mm^3)")
    parser.add_argument("--block", type=float, nargs=3, default=d.block, metavar=("E", "NU", "DENSITY"),
                        help="the block's material (MPa, -, g/mm^3)")
    parser.add_argument("--block-size", type=float, nargs=2, default=d.size, metavar=("WIDTH", "HEIGHT"),
                        help="the block's width and height (mm)")
    parser.add_argument("--end", type=float, default=d.end, help="run time after the touch (ms), past the contact")
    parser.add_argument("--contact", action="append", default=[], metavar="KEY=VALUE",
                        help="mpm: a key of the deck's contact section (VALUE read as YAML); repeatable")
    parser.add_argument("--body", action="append", default=[], metavar="KEY=VALUE",
                        help="mpm: a key added to the cylinder (VALUE read as YAML), e.g. seeding=lattice; repeatable")
    parser.add_argument("--block-body", action="append", default=[], metavar="KEY=VALUE",
                        help="mpm: a key added to the block (VALUE read as YAML); repeatable")
    args = parser.parse_args()
    scene = Scene(args.radius, tuple(args.velocity), args.x0, tuple(args.cylinder), tuple(args.block),
                  tuple(args.block_size), args.end)
    if args.command == "table":
        table()
        return
    if args.command == "nodes":
        for rh in args.rh:
            for mu in args.mu:
                contact_nodes(scene, rh, mu, key_values(parser, args.contact, "--contact"),
                              key_values(parser, args.body, "--body"), key_values(parser, args.block_body, "--block-body"))
        return
    if args.command == "mpm":
        mpm_table(scene, args.rh, args.mu, key_values(parser, args.contact, "--contact"),
                  key_values(parser, args.body, "--body"), key_values(parser, args.block_body, "--block-body"))
        return
    RESULTS.mkdir(parents=True, exist_ok=True)
    for mu in args.mu:
        for level in args.levels:
            r = run(level, mu, args.gap, args.lags, args.hmax, args.material, scene=scene)
            if scene != Scene():
                r["scene"] = scene._asdict()
            tag = ("" if args.material == "linear_elastic" else "_" + args.material) + scene.tag()
            name = f"mu{mu:g}_level{level}_lags{args.lags}_hmax{args.hmax:g}{tag}.json"
            (RESULTS / name).write_text(json.dumps(r, indent=1))
            print(f"mu {mu:g} level {level}: vx {r['vx']:.4f} vy {r['vy']:.4f} duration {r['duration']:.4f} ms "
                  f"E/E0 {r['energy_ratio']:.4f} nodes {r['nodes']} wall {r['wall_s']:.0f} s", flush=True)


if __name__ == "__main__":
    main()
