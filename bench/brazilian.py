"""The BFEMP paper's Brazilian disk (§6.3) against Hertz: the contact half-width a at the
bottom plate as the load P rises, for the plane Hertz relation of a cylinder on a flat,

    a = sqrt(4 P R / (pi E*)),   1/E* = (1 - nu_d^2)/E_d + (1 - nu_p^2)/E_p,

P the load per unit thickness. The half-width comes from the barrier's normal forces, not from
counting particles: for each contact point within dhat of the bottom plate, f = w (-b'(d)) (its
weight times the barrier's slope); Hertz's pressure p0 sqrt(1 - x^2/a^2) has the second moment
sum f x^2 / sum f = a^2 / 4 about its centre. Each particle's force stands for the pressure over
its stretch of the surface, one particle spacing s wide, whose own spread adds s^2 / 12 to the
variance (Sheppard's correction for binned data), so

    a = 2 sqrt(sum f (x - xbar)^2 / sum f + s^2 / 12),

a smooth function of the load whatever the particle spacing (the raw moment without the s^2/12 is
kept as a_raw). P = sum f / thickness. The disk is seeded in rings (`seeding: rings`): on the
grid lattice its lowest row is a flat facet about 2 sqrt(2 R delta) wide that touches all at once
(`--seeding lattice` shows it).

    python bench/brazilian.py [--cells 0.01 0.005 0.0025] [--material linear_elastic]
        [--speed 0.05 --dt 0.004 --end 0.26] [--save PREFIX] [--chart PNG]

The top plate moves down 0.2 mm a step (50 mm/s, dt = 4 ms, three times the disk's R/c = 1.3 ms,
c its P-wave speed: quasi-static) until a_H / R passes 0.2.

prints per step P, a, Hertz's a and their ratio, and the mean |a/a_H - 1| over the small-
deformation range (a/R in [0.05, 0.2]) per resolution; `--chart PNG` draws a against P.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mpmsim.contact.barrier.energy import BarrierContact  # noqa: E402
from mpmsim.contact.barrier.potential import barrier_normal_force  # noqa: E402
from mpmsim.deck import load_deck_text  # noqa: E402
from mpmsim.scene import build_scene  # noqa: E402
from mpmsim.solver import Simulation  # noqa: E402

DECK = ROOT / "inputs" / "implicit_brazilian_2d.yaml"
SMALL = (0.05, 0.2)  # a / R: the small-deformation range


def disk_deck(h: float, material: str = "compressible_neo_hookean", end: float = 0.3, dt: float = 0.01,
              dhat: float | None = None, seeding: str = "rings", speed: float = 0.005) -> dict:
    """The Brazilian deck at cell size h (particles 2 per direction, dhat = h / 20 unless
    given), the disk's material model and seeding (rings: following its surface; lattice:
    the grid-aligned staircase) chosen, the plates' element size h, the top plate moving down
    at `speed` (m/s)."""
    d = yaml.safe_load(DECK.read_text())
    d["grid"]["cell_size"] = h
    d["bodies"][0]["seeding"] = seeding
    d["materials"]["rock"]["type"] = material
    for body in d["bodies"][1:]:
        body["element_size"] = h
    d["bodies"][2]["constraints"][0]["velocity"] = [0.0, -speed]
    d["implicit"]["dhat"] = dhat = dhat if dhat is not None else h / 20.0
    # the plates' faces 2 dhat beyond the outermost particle centres (R - s/2, s = h / 2): the
    # barrier acts on particle centres, and the deck's +-0.0985 suits h = 0.01 only
    face = d["bodies"][0]["radius"] - h / 4.0 + 2.0 * dhat
    thick = d["bodies"][1]["max"][1] - d["bodies"][1]["min"][1]
    d["bodies"][1]["max"][1], d["bodies"][1]["min"][1] = -face, -face - thick
    d["bodies"][2]["min"][1], d["bodies"][2]["max"][1] = face, face + thick
    d["time"] = {"end": end, "dt": dt}
    d["output"] = {"vtu_interval": 10.0, "history_interval": 10.0}
    return d


def hertz_width(P: np.ndarray, d: dict) -> np.ndarray:
    """Plane Hertz half-width of the disk on the bottom plate under P per unit thickness."""
    rock, steel = d["materials"]["rock"], d["materials"]["steel"]
    inv = (1 - float(rock["nu"]) ** 2) / float(rock["E"]) + (1 - float(steel["nu"]) ** 2) / float(steel["E"])
    R = d["bodies"][0]["radius"]
    return np.sqrt(4.0 * P * R * inv / np.pi)


def bottom_forces(sim, plate_top: float) -> tuple[np.ndarray, np.ndarray]:
    """(x, f) of the particles within dhat of the bottom plate's top face: f = w (-b'(d))."""
    term = next(t for t in sim.integrator.terms if isinstance(t, BarrierContact))
    P = sim.state.particles
    w = term.particle_weights(P.vol0, np.arange(P.n), False)
    gap = P.x[:, 1] - plate_top
    near = (gap > 0.0) & (gap < term.dhat)
    f = w[near] * np.array([barrier_normal_force(g, term.dhat, term.kappa) for g in gap[near]])
    return P.x[near, 0], f


def half_width(x: np.ndarray, f: np.ndarray, s: float = 0.0) -> float:
    """2 sqrt(variance of the forces' positions + s^2 / 12) (0 without force)."""
    total = f.sum()
    if total <= 0.0:
        return 0.0
    xbar = float((f * x).sum() / total)
    return 2.0 * float(np.sqrt((f * (x - xbar) ** 2).sum() / total + s * s / 12.0))


def run(h: float, material: str, end: float, dt: float = 0.01, quiet: bool = False,
        seeding: str = "rings", speed: float = 0.005) -> np.ndarray:
    """Rows (t, P per unit thickness, a, a_Hertz, a_raw) after each step."""
    d = disk_deck(h, material, end, dt, seeding=seeding, speed=speed)
    scene = build_scene(load_deck_text(yaml.safe_dump(d, sort_keys=False), DECK))
    sim = Simulation(scene, out_dir=None, threads=1)
    plate_top = d["bodies"][1]["max"][1]
    s = h / int(d.get("particles_per_direction", 2))
    rows = []
    while sim.state.t < end * (1 - 1e-9):
        sim.step()
        x, f = bottom_forces(sim, plate_top)
        load = f.sum() / next(t for t in sim.integrator.terms if isinstance(t, BarrierContact)).thickness
        rows.append((sim.state.t, load, half_width(x, f, s), float(hertz_width(np.array([load]), d)[0]),
                     half_width(x, f)))
        if not quiet:
            t, P, a, aH, _ = rows[-1]
            print(f"h = {h:g} t = {t:.3f} P = {P:10.4g} a = {a:.5g} a_H = {aH:.5g} "
                  f"ratio = {a / aH if aH > 0 else float('nan'):.4f}", flush=True)
    return np.array(rows)


def small_range_error(rows: np.ndarray, R: float) -> tuple[float, float]:
    """(mean, max) |a / a_H - 1| over the steps whose a_H / R lies in the small-deformation range."""
    sel = (rows[:, 3] / R >= SMALL[0]) & (rows[:, 3] / R <= SMALL[1])
    if not sel.any():
        return float("nan"), float("nan")
    err = np.abs(rows[sel, 2] / rows[sel, 3] - 1.0)
    return float(err.mean()), float(err.max())


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cells", type=float, nargs="+", default=[0.01, 0.005, 0.0025])
    ap.add_argument("--material", default="compressible_neo_hookean",
                    choices=["compressible_neo_hookean", "linear_elastic", "neo_hookean"])
    ap.add_argument("--end", type=float, default=0.26)
    ap.add_argument("--dt", type=float, default=0.004)
    ap.add_argument("--speed", type=float, default=0.05, help="top plate's speed (m/s)")
    ap.add_argument("--seeding", default="rings", choices=["rings", "lattice"])
    ap.add_argument("--save", help="write each resolution's rows to SAVE_h<h>.txt")
    ap.add_argument("--chart", help="PNG of a against P, each resolution beside Hertz")
    ap.add_argument("--load", nargs="+", metavar="LABEL=FILE",
                    help="chart rows saved by --save instead of running (with --chart)")
    args = ap.parse_args(argv)
    if args.load:
        series = {k: np.loadtxt(v) for k, v in (item.rsplit("=", 1) for item in args.load)}
        chart(args.chart, series, "Brazilian disk against plane Hertz")
        return
    R = yaml.safe_load(DECK.read_text())["bodies"][0]["radius"]
    results = {}
    for h in args.cells:
        t0 = time.perf_counter()
        rows = run(h, args.material, args.end, args.dt, seeding=args.seeding, speed=args.speed)
        results[h] = rows
        if args.save:
            np.savetxt(f"{args.save}_h{h:g}.txt", rows, header="t P a a_hertz a_raw")
        mean, worst = small_range_error(rows, R)
        print(f"h = {h:g} {args.material} {args.seeding}: |a/a_H - 1| over a/R in {SMALL}: mean {mean:.4f} "
              f"max {worst:.4f} ({time.perf_counter() - t0:.0f} s)", flush=True)
    if args.chart:
        chart(args.chart, {f"h = {h * 1e3:g} mm": rows for h, rows in results.items()}, args.material)


def chart(path: str, series: dict, title: str) -> None:
    """a against P for each {label: rows}, beside plane Hertz (shaded: a/R outside [0.05, 0.2])."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d = disk_deck(0.01)
    R = d["bodies"][0]["radius"]
    fig, ax = plt.subplots(figsize=(6.4, 4.5))
    P = np.linspace(0.0, max(r[:, 1].max() for r in series.values()), 300)
    ax.plot(P, hertz_width(P, d) * 1e3, "k-", lw=2, label="plane Hertz")
    for (label, rows), style in zip(series.items(), ["o-", "s-", "^-", "d--", "v--", "x:"]):
        ax.plot(rows[:, 1], rows[:, 2] * 1e3, style, ms=3, lw=1, label=label)
    for lim in SMALL:
        ax.axhline(lim * R * 1e3, color="0.6", lw=0.8, ls=":")
    ax.set_xlabel("load P per unit thickness (N/m)")
    ax.set_ylabel("contact half-width a (mm)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)

if __name__ == "__main__":
    main()
