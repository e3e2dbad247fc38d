"""The gallery's pictures (docs/gallery.md) and the README's: shipped decks of inputs/ run as they
are, and frames of their VTU output drawn with matplotlib, one PNG per deck in docs/figures/.

    python bench/gallery.py              # every picture below (`make figure-gallery`)
    python bench/gallery.py disks taylor # some of them

Each run writes to results/gallery/<deck>/ and is reused when it ran to its end there (--rerun
runs it again). The decks run as shipped, on one thread: from under a minute (disks) to about
three (oblique_impact), the first compile included. Each particle is drawn as its deformed domain
(the parallelogram F maps its initial square to), coloured by a field of the VTU frame;
axisymmetric runs are mirrored about the axis r = 0 so the body of revolution is seen in section.
"""

from __future__ import annotations

import argparse
import re
import sys
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import meshio  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FIGURES = ROOT / "docs" / "figures"
RESULTS = ROOT / "results" / "gallery"


@dataclass
class Picture:
    deck: str  # a deck of inputs/
    out: str  # the PNG in docs/figures/
    times: list[float]  # output times to draw, one panel each (nearest frame)
    field: str  # "von_mises", "speed", "material" or a VTU point field
    label: str  # colour bar label
    mirror: bool = False  # an axisymmetric deck: draw r < 0 too
    scale: float = 1.0  # field scale (units in the label)
    window: tuple | None = None  # (xmin, xmax, ymin, ymax) of every panel, else the particles' extent
    cmap: str = "viridis"
    grow: float = 1.0  # domains drawn this much larger (bodies seeded in rings: their domains are not squares)


PICTURES = {
    # the deck `make run` runs: two elastic disks (Sulsky et al. 1994) before, at and after impact
    "disks": Picture("disks.yaml", "gallery_disks.png", [0.0, 2.1, 4.0], "von_mises", "von Mises stress (Pa)",
                     window=(0.0, 1.0, 0.0, 1.0)),
    # LR contact: a steel cylinder strikes an aluminium block at 45 degrees, frictionless
    "oblique": Picture("oblique_impact.yaml", "gallery_oblique.png", [0.0, 0.56], "von_mises",
                       "von Mises stress (MPa)", window=(-26.0, 26.0, 0.0, 36.0)),
    # J2 plasticity: the copper Taylor bar in r-z, start and end
    "taylor": Picture("taylor_bar_rz.yaml", "gallery_taylor.png", [0.0, 0.08], "plastic_strain",
                      "equivalent plastic strain", mirror=True),
    # FEM bodies with APIC augury contact: a block on a 30 degree ramp under gravity, at the end
    "fem_ramp": Picture("fem_ramp_2d.yaml", "gallery_fem_ramp.png", [0.1], "von_mises", "von Mises stress (kPa)",
                        scale=1e-3),
    # axisymmetric: a glass sphere in a polymer cylinder under end pressure (r-z), the stress at the end
    "sphere": Picture("sphere_composite_rz.yaml", "gallery_sphere_rz.png", [0.012], "von_mises",
                      "von Mises stress (MPa)", mirror=True, grow=1.35),
}


def frames(pvd: Path) -> list[tuple[float, list[Path]]]:
    """[(time, the files of that output: particles and FEM parts)] of a .pvd collection."""
    out: dict[float, list[Path]] = {}
    for t, f in re.findall(r'timestep="([^"]+)"[^>]*file="([^"]+)"', pvd.read_text()):
        out.setdefault(float(t), []).append(pvd.parent / f)
    return sorted(out.items())


def run(deck: Path, out: Path, rerun: bool) -> Path:
    pvd = out / f"{deck.stem}.pvd"
    done = out / ".gallery-complete"
    if done.exists() and pvd.exists() and not rerun:
        return pvd
    done.unlink(missing_ok=True)
    import mpmsim

    sim = mpmsim.Simulation.from_deck(str(deck), out_dir=str(out), threads=1)
    print(f"running {deck.relative_to(ROOT)} -> {out.relative_to(ROOT)}", flush=True)
    result = sim.run()
    print(f"  {result.steps} steps in {result.wall_time:.1f} s", flush=True)
    done.write_text(f"{result.steps} steps\n")
    return pvd


def von_mises(s: np.ndarray) -> np.ndarray:
    xx, yy, zz, xy, yz, xz = (s[:, k] for k in range(6))  # ParaView's order
    return np.sqrt(0.5 * ((xx - yy) ** 2 + (yy - zz) ** 2 + (zz - xx) ** 2) + 3.0 * (xy**2 + yz**2 + xz**2))


def values(mesh: meshio.Mesh, name: str) -> np.ndarray:
    """The field drawn, per particle, or per element of an FEM part."""
    if "triangle" in mesh.cells_dict:  # FEM: stresses per element, velocities per node
        cells = mesh.cells_dict["triangle"]
        if name == "von_mises":
            return von_mises(mesh.cell_data_dict["stress"]["triangle"])
        if name == "speed":
            return np.linalg.norm(mesh.point_data["velocity"], axis=1)[cells].mean(axis=1)
        return np.asarray(mesh.cell_data_dict[name]["triangle"], dtype=float)
    data = mesh.point_data
    if name == "von_mises":
        return von_mises(data["stress"])
    if name == "speed":
        return np.linalg.norm(data["velocity"], axis=1)
    if name not in data:
        raise SystemExit(f"no point field {name!r} in {sorted(data)}")
    return np.asarray(data[name], dtype=float)


def spacing(mesh: meshio.Mesh, axisymmetric: bool) -> np.ndarray:
    """(n,) the side of each particle's initial domain, taken square: the root of its area (its
    volume, per unit thickness in plane strain, per radian over r in r-z)."""
    vol = np.asarray(mesh.point_data["volume"], dtype=float)
    area = vol / np.maximum(mesh.points[:, 0], 1e-300) if axisymmetric else vol
    return np.sqrt(area)


def domains(mesh: meshio.Mesh, h: np.ndarray) -> np.ndarray:
    """(n, 4, 2) corners of each particle's deformed domain in the plane: x_p + F (h_p/2)(±1, ±1),
    h_p its initial spacing (the median spacing where the frame's particles are not the first's)."""
    F = mesh.point_data["deformation_gradient"].reshape(-1, 3, 3)[:, :2, :2]
    if len(h) != len(mesh.points):
        h = np.full(len(mesh.points), np.median(h))
    corners = 0.5 * np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    return mesh.points[:, None, :2] + h[:, None, None] * np.einsum("pij,kj->pki", F, corners)


def shapes(mesh: meshio.Mesh, h: np.ndarray) -> np.ndarray:
    """The polygons drawn: FEM triangles, or particle domains."""
    if "triangle" in mesh.cells_dict:
        return mesh.points[:, :2][mesh.cells_dict["triangle"]]
    return domains(mesh, h)


def draw(pic: Picture, pvd: Path) -> Path:
    series = frames(pvd)
    chosen = [min(series, key=lambda f: abs(f[0] - t)) for t in pic.times]
    parts = [(t, [meshio.read(p) for p in files]) for t, files in chosen]
    first = [m for m in (meshio.read(p) for p in series[0][1]) if "triangle" not in m.cells_dict]
    h = pic.grow * spacing(first[0], pic.mirror) if first else np.zeros(0)
    meshes = [(t, None) for t, _ in parts]
    ordered = [sorted(ms, key=lambda m: "triangle" in m.cells_dict) for _, ms in parts]  # particles first
    vals = [np.concatenate([values(m, pic.field) for m in ms]) * pic.scale for ms in ordered]
    polys = [np.concatenate([shapes(m, h) for m in ms if "triangle" not in m.cells_dict] or [np.zeros((0, 4, 2))])
             for _, ms in parts]
    tris = [[shapes(m, h) for m in ms if "triangle" in m.cells_dict] for _, ms in parts]
    polys = [list(q) + [tri for block in tr for tri in block] for q, tr in zip(polys, tris)]
    vmax = max(float(np.percentile(v, 99.5)) for v in vals) or 1.0
    if pic.mirror:
        polys = [q + [p * [-1.0, 1.0] for p in q] for q in polys]
        vals = [np.concatenate([v, v]) for v in vals]
    if pic.window:
        x0, x1, y0, y1 = pic.window
    else:
        allp = np.concatenate([np.asarray(p).reshape(-1, 2) for q in polys for p in q])
        pad = 0.02 * np.ptp(allp, axis=0).max()
        x0, y0 = allp.min(0) - pad
        x1, y1 = allp.max(0) + pad
    n = len(meshes)
    aspect = (y1 - y0) / (x1 - x0)
    panel = (3.2 if aspect < 1.6 else 2.0) * (1.5 if n == 1 else 1.0)
    fig, axes = plt.subplots(1, n, figsize=(panel * n + 0.9, panel * aspect + 0.5), squeeze=False)
    norm = matplotlib.colors.Normalize(0.0, vmax)
    for ax, (t, _), q, v in zip(axes[0], meshes, polys, vals):
        art = PolyCollection(q, array=v, cmap=pic.cmap, norm=norm, edgecolors="face", linewidths=0.2)
        ax.add_collection(art)
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal")
        ax.set_title(f"t = {t:.3g}", fontsize=9)
        ax.tick_params(labelsize=7)
    fig.colorbar(art, ax=axes[0].tolist(), shrink=0.85, pad=0.02).set_label(pic.label, fontsize=8)
    out = FIGURES / pic.out
    fig.savefig(out, dpi=110, bbox_inches="tight", pad_inches=0.05)
    plt.close(fig)
    print(f"wrote {out.relative_to(ROOT)}", flush=True)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("names", nargs="*", choices=[[], *PICTURES], help="pictures to make (default: all)")
    ap.add_argument("--rerun", action="store_true", help="run the decks again even where output exists")
    args = ap.parse_args(argv)
    for name in args.names or list(PICTURES):
        pic = PICTURES[name]
        deck = ROOT / "inputs" / pic.deck
        draw(pic, run(deck, RESULTS / deck.stem, args.rerun))
    return 0


if __name__ == "__main__":
    sys.exit(main())
