"""Imperfect interfaces (2013 paper): the sweeps behind docs/interfaces.md and its charts.

    python bench/interfaces.py two_layer   # Figs. 5/8: interfacial energy vs Dt, 3 cell sizes, 2D and 3D
    python bench/interfaces.py dls         # Figs. 7/9: DLS stiffness vs 1/Dt; tilted on dy = 2 dx cells
    python bench/interfaces.py sphere      # Figs. 12/13: bulk modulus vs D = Dn = Dt, by energy and pressure
    python bench/interfaces.py cost        # particle-steps/s: one body, stick, interface (3 schemes)
    python bench/interfaces.py chart       # redraw the charts from the saved results
    python bench/interfaces.py inclusion   # a cohesive sphere debonding: docs/figures/cohesive_inclusion.png

Every run is saved as it finishes (results/bench_interfaces/*.json), so an interrupted sweep
resumes. Runs are single-threaded; `--workers N` runs N at once.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
FIGURES = ROOT / "docs" / "figures"
RESULTS = ROOT / "results" / "bench_interfaces"
E0, SIDE = 0.005, 1.0  # sphere: applied strain, cube side (mm)


def two_layer_jobs():
    jobs = []
    for cell in (0.5, 0.25, 0.1):
        for Dt in (0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0):
            jobs.append(("two_layer", {"cell": cell, "Dt": Dt}))
    for Dt in (0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0):
        jobs.append(("two_layer_3d", {"cell": 0.5, "Dt": Dt, "z_rollers": True}))
        jobs.append(("two_layer_3d", {"cell": 0.5, "Dt": Dt}))
    return jobs


def dls_jobs():
    jobs = [("dls", {"degrees": 0.0, "cell": 0.25, "Dt": Dt}) for Dt in ("perfect", 10.0, 5.0, 3.0, 2.0, 1.5, 1.0)]
    for deg in (0.0, 15.0, 30.0, 45.0, 60.0, 90.0):
        for hp in (True, False):
            jobs.append(("dls", {"degrees": deg, "cell": [0.25, 0.5], "Dt": 5.0, "h_perp": hp}))
    # Fig. 9 at half the cells: 30 degrees on 0.125 x 0.25 against the untilted 0.125 mm
    jobs.append(("dls", {"degrees": 0.0, "cell": 0.125, "Dt": 5.0}))
    for hp in (True, False):
        jobs.append(("dls", {"degrees": 30.0, "cell": [0.125, 0.25], "Dt": 5.0, "h_perp": hp}))
    return jobs


def sphere_jobs():
    return [("sphere", {"cell": cell, "D": D}) for cell in (0.1, 0.05)
            for D in (1e3, 1e4, 3e4, 1e5, 3e5, 1e6, 1e7, 1e9)]


def deck_for(kind, p):
    from mpmsim.deck.overrides import with_overrides
    from tests.validation.specimens import dls_tilted, shipped, two_layer, two_layer_3d

    if kind == "two_layer":
        return two_layer(p["cell"], p["Dt"])
    if kind == "two_layer_3d":
        return two_layer_3d(p["cell"], p["Dt"], p.get("z_rollers", False))
    if kind == "dls":
        return dls_tilted(p["degrees"], p["cell"], p["Dt"], **{"contact.h_perp": p.get("h_perp", True)})
    return with_overrides(shipped("sphere_composite"), {"grid.cell_size": p["cell"], "time.end": 0.01,
                                                       "contact.default.Dn": p["D"], "contact.default.Dt": p["D"]})


def run_job(job):
    kind, p = job
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    from mpmsim.errors import InstabilityError
    from tests.conftest import ROOT as TROOT, simulate

    deck = deck_for(kind, p)
    t0 = time.perf_counter()
    try:
        sim = simulate(deck, TROOT / "inputs")
    except InstabilityError as e:
        return {"kind": kind, **p, "status": f"unstable: {e}"}
    h = sim.recorder
    tail = max(1, len(h.rows) // 5)
    mean = lambda c: float(h.column(c)[-tail:].mean())  # noqa: E731
    out = {"kind": kind, **p, "status": "ok", "wall": time.perf_counter() - t0, "particles": sim.state.particles.n,
           "strain_energy": mean("strain_energy"), "interface_energy": mean("interface_energy")}
    if kind == "sphere":
        out["pressure"] = float(((h.column("sxx") + h.column("syy") + h.column("szz")) / 3)[-tail:].mean())
    return out


def key(job):
    return hashlib.sha1(json.dumps(job, sort_keys=True).encode()).hexdigest()[:12]


def run_all(jobs, workers):
    RESULTS.mkdir(parents=True, exist_ok=True)
    todo = [j for j in jobs if not (RESULTS / f"{key(j)}.json").exists()]
    print(f"{len(jobs) - len(todo)} of {len(jobs)} runs already done")
    with ProcessPoolExecutor(workers) as pool:
        for job, res in zip(todo, pool.map(run_job, todo)):
            tmp = RESULTS / f"{key(job)}.tmp"
            tmp.write_text(json.dumps(res))
            tmp.replace(RESULTS / f"{key(job)}.json")
            print(json.dumps(res), flush=True)


def load(jobs):
    out = []
    for j in jobs:
        f = RESULTS / f"{key(j)}.json"
        if f.exists():
            out.append(json.loads(f.read_text()))
    return out


def chart():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mpmsim.sweep.metrics import csa_bulk_modulus, cube_bulk_modulus

    FIGURES.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    rows = load(two_layer_jobs())
    ax = axes[0]
    for kind, cell, rollers, style, label in [
            ("two_layer", 0.5, False, "s-", "2D 0.5 mm"), ("two_layer", 0.25, False, "^-", "2D 0.25 mm"),
            ("two_layer", 0.1, False, "o-", "2D 0.1 mm"), ("two_layer_3d", 0.5, True, "x:", "3D 0.5 mm, z rollers"),
            ("two_layer_3d", 0.5, False, "D--", "3D 0.5 mm, free z faces")]:
        r = sorted((x for x in rows if x["kind"] == kind and x["cell"] == cell and x["status"] == "ok"
                    and x.get("z_rollers", False) == rollers), key=lambda x: x["Dt"])
        if r:
            vol = 8.0 * 20.0 * 4.0
            ax.plot([1 / x["Dt"] for x in r], [x["interface_energy"] / vol * 1e6 for x in r], style, label=label)
    ax.set(xlabel="1/Dt (mm/MPa)", ylabel="interfacial energy density (J/m^3)", title="Two-layer specimen (Fig. 5)")
    ax.legend()
    ax = axes[1]
    rows = load(dls_jobs())
    r = sorted((x for x in rows if x["degrees"] == 0.0 and x["cell"] == 0.25 and x["status"] == "ok"),
               key=lambda x: 0 if x["Dt"] == "perfect" else 1 / x["Dt"])
    if r:
        ax.plot([0 if x["Dt"] == "perfect" else 1 / x["Dt"] for x in r],
                [4.0 / (2 * (x["strain_energy"] + x["interface_energy"])) for x in r], "o-", label="MPM, 0.25 mm")
    ax.set(xlabel="1/Dt (mm/MPa)", ylabel="stiffness k = P^2/2U (N/mm)", title="DLS specimen (Fig. 7)")
    ax.legend()
    ax = axes[2]
    rows = load(sphere_jobs())
    for cell, style in ((0.1, "s"), (0.05, "o")):
        r = sorted((x for x in rows if x["cell"] == cell and x["status"] == "ok"), key=lambda x: x["D"])
        if r:
            inv = [1 / x["D"] for x in r]
            K = [cube_bulk_modulus(x["strain_energy"] + x["interface_energy"], x["pressure"], SIDE, E0) for x in r]
            ax.semilogx(inv, [k[0] for k in K], style + "-", label=f"energy, {cell * 1000:g} um")
            ax.semilogx(inv, [k[1] for k in K], style + "--", mfc="none", label=f"pressure, {cell * 1000:g} um")
    inv = [10**e for e in range(-10, -2)]
    inv = [x * f for x in inv for f in (1, 2, 5)]
    csa = [csa_bulk_modulus(2400.0, 0.33, 70000.0, 0.25, math.pi * 0.7**3 / 6 / SIDE**3, 1 / x, 0.7) for x in inv]
    ax.semilogx(inv, csa, "k:", lw=1, label="CSA, imperfect interface (Hashin 1991)")
    ax.set(xlabel="1/D (mm/MPa), D = Dn = Dt", ylabel="bulk modulus K (MPa)", title="Glass spheres in polymer (Figs. 12-13)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(FIGURES / "interfaces.png", dpi=110)
    print(f"wrote {FIGURES / 'interfaces.png'}")


def cost(steps: int = 300):
    """Two-layer specimen at 0.25 mm cells (5120 particles), one thread, `steps` steps each:
    what the interface costs over one body and over bonded contact."""
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation
    from tests.conftest import ROOT as TROOT, deck_from
    from tests.validation.specimens import two_layer

    variants = {"one body (law none)": {"contact.default.law": "none"},
                "bonded (law stick)": {"contact.default.law": "stick"},
                "interface, backward Euler (default)": {},
                "interface, opening at the node": {"contact.interface_opening": "node"},
                "interface, trapezoidal": {"contact.interface_integration": "trapezoidal"},
                "interface, oscillator": {"contact.interface_integration": "oscillator"},
                "interface, force_limit": {"contact.interface_integration": "force_limit"},
                "interface, Dn = Dt, LR normals": {"contact.default.Dn": 5.0, "contact.normal": "logistic_regression"},
                "mid-plane, consistent bond": {"mid": True},
                "mid-plane, node-wise bond": {"mid": True, "contact.interface_bond": "nodal"}}
    print(f"{'variant':38s} {'M particle-steps/s':>18s} {'contact tasks':>14s}")
    for label, over in variants.items():
        sim = Simulation(build_scene(deck_from(two_layer(0.25, 5.0, **over), TROOT / "inputs")))
        for _ in range(20):  # compile and warm up
            sim.step()
        sim.reset_timers()
        for _ in range(steps):
            sim.step()
        total = sum(sim.timers.values())
        contact = sum(v for k, v in sim.timers.items() if k.startswith(("contact", "material fields")))
        print(f"{label:38s} {steps * sim.state.particles.n / total / 1e6:18.3f} {contact / total:14.1%}")


def cohesive_cost(steps: int = 300, rounds: int = 5):
    """A step of the two-layer specimen (0.25 mm cells, one thread) with a cohesive law against
    the same step with the elastic interface of the same stiffnesses (Dn = Dt = 5 MPa/mm; the
    cohesive peak, 10 MPa, is never reached under the 0.5 MPa load, so both runs are the same
    mechanics), alternated `rounds` times: the median time per step of each and their ratio."""
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    import statistics

    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation
    from tests.conftest import ROOT as TROOT, deck_from
    from tests.validation.specimens import two_layer

    elastic = {"contact.default.Dn": 5.0}
    cohesive = {"contact.default.Dn": 5.0, "contact.default.law": "cohesive",
                "contact.default.cohesive": {"peak_traction": 10.0, "G_Ic": 100.0}}
    sims = {k: Simulation(build_scene(deck_from(two_layer(0.25, 5.0, **o), TROOT / "inputs")))
            for k, o in (("elastic", elastic), ("cohesive", cohesive))}
    for sim in sims.values():
        for _ in range(20):  # compile and warm up
            sim.step()
    per_step = {k: [] for k in sims}
    for _ in range(rounds):
        for k, sim in sims.items():
            t0 = time.perf_counter()
            for _ in range(steps):
                sim.step()
            per_step[k].append((time.perf_counter() - t0) / steps)
    med = {k: statistics.median(v) for k, v in per_step.items()}
    n = sims["elastic"].state.particles.n
    print(f"two-layer specimen, {n} particles, 1 thread, {rounds} alternated rounds of {steps} steps")
    for k, v in med.items():
        print(f"{k:9s} {1e3 * v:8.3f} ms/step")
    print(f"cohesive / elastic: {med['cohesive'] / med['elastic']:.3f}")


def inclusion():
    """The debonding sphere of tests/validation/cohesive_inclusion.py (its defaults: R/h = 10,
    loaded to 9 MPa): the sphere's interface damage against the polar angle at six far-field
    stresses, with Goodier's bonded tractions, in docs/figures/cohesive_inclusion.png."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from tests.validation.cohesive_inclusion import Inclusion, run_inclusion

    spec = Inclusion()
    run = run_inclusion(spec)
    print(f"onset {run.onset:.3f} MPa = {run.onset / spec.onset_stress:.4f} of Goodier's {spec.onset_stress:.3f}; "
          f"most damage before it {run.early:.3f}")
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4))
    order = np.argsort(run.theta)
    for s in (6.0, 6.5, 7.0, 7.5, 8.0, 8.5):
        k = np.argmin(np.abs(run.stress - s))
        ax.plot(run.theta[order], run.damage[k][order], ".-", ms=3, label=f"{run.stress[k]:.1f} MPa")
    ax.set_xlabel("polar angle from the loading axis (degrees)")
    ax.set_ylabel("interface damage (sphere side)")
    ax.set_title(f"debond onset at {run.onset:.2f} MPa (Goodier: {spec.onset_stress:.2f})")
    ax.legend(title="far-field stress")
    theta = np.linspace(0.0, 90.0, 91)
    tn, tt = spec.tractions(np.radians(theta))
    bx.plot(theta, tn, label="normal")
    bx.plot(theta, tt, label="shear")
    bx.plot(theta, np.hypot(np.maximum(tn, 0.0), tt), "k--", label="onset measure (quadratic)")
    bx.set_xlabel("polar angle (degrees)")
    bx.set_ylabel("interface traction / applied stress")
    bx.set_title("Goodier's bonded sphere")
    bx.legend()
    fig.tight_layout()
    FIGURES.mkdir(parents=True, exist_ok=True)
    fig.savefig(FIGURES / "cohesive_inclusion.png", dpi=110)
    print(FIGURES / "cohesive_inclusion.png")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["two_layer", "dls", "sphere", "all", "chart", "cost", "cohesive_cost",
                                           "inclusion"])
    ap.add_argument("--workers", type=int, default=1)
    a = ap.parse_args()
    if a.what == "cost":
        return cost()
    if a.what == "cohesive_cost":
        return cohesive_cost()
    if a.what == "inclusion":
        return inclusion()
    sets = {"two_layer": two_layer_jobs, "dls": dls_jobs, "sphere": sphere_jobs}
    for name in (sets if a.what == "all" else [a.what] if a.what != "chart" else []):
        run_all(sets[name](), a.workers)
    chart()


if __name__ == "__main__":
    main()
