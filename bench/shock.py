"""Shock example of the LR paper §4.3: numbers and figures for docs/shock.md.

    python bench/shock.py hugoniot   # Us and P vs the linear Hugoniot, 4 piston speeds (test bar)
    python bench/shock.py energy     # energy balance of the full deck, 0.25 mm and 0.125 mm cells
    python bench/shock.py fig7       # full decks: SMM, MM XPIC(5), uncorrected XPIC (Fig. 7)
    python bench/shock.py all

Figures go to docs/figures/shock_hugoniot.png and docs/figures/shock_fig7.png.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import yaml  # noqa: E402

from mpmsim.deck import load_deck_text  # noqa: E402
from mpmsim.deck.overrides import with_overrides  # noqa: E402
from mpmsim.scene import build_scene  # noqa: E402
from mpmsim.shock import columns, hugoniot, measure_front, run_with_profiles, shock_speed  # noqa: E402
from mpmsim.solver import Simulation  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
FIGS = ROOT / "docs" / "figures"
K, RHO0, S1 = 188000.0, 0.00887, 1.44
C0 = np.sqrt(K / RHO0)
SPACING = 0.125


def deck(name: str) -> dict:
    return yaml.safe_load((ROOT / "inputs" / f"{name}.yaml").read_text())


def simulation(data: dict) -> Simulation:
    plain = json.loads(json.dumps(data, default=float))  # numpy scalars -> plain floats
    return Simulation(build_scene(load_deck_text(yaml.safe_dump(plain, sort_keys=False), ROOT / "inputs" / "x.yaml")))


def hugoniot_table(length=20.0, height=0.75):
    rows = []
    for frac in (0.1, 0.2, 0.3, 0.4):
        up = frac * C0
        Us, P, _ = hugoniot(K, RHO0, S1, up)
        end = 0.7 * length / Us
        d = with_overrides(deck("nickel_shock"), {
            "bodies.0.max": [length, height], "bodies.1.min": [length, 0.0], "bodies.1.max": [length + 0.5, height],
            "materials.piston.velocity": [-up, 0.0], "time.end": end})
        times = end * np.arange(4, 11) / 10
        snaps = run_with_profiles(simulation(d), times, SPACING)
        last = measure_front(snaps[-1][1], length, 2.0)
        us, _ = shock_speed([t for t, _ in snaps], [p for _, p in snaps], last.plateau)
        rows.append((frac, up, Us, us, P, last.plateau, last.width))
    print("| up/C0 | up (m/s) | Us analytic | Us measured | error | P analytic (MPa) | P measured | error | front width (mm) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for frac, up, Us, us, P, pm, w in rows:
        print(f"| {frac:.1f} | {up:.1f} | {Us:.1f} | {us:.1f} | {100 * (us / Us - 1):+.2f}% | {P:.0f} | {pm:.0f} | "
              f"{100 * (pm / P - 1):+.2f}% | {w:.2f} |")
    up = np.linspace(0, 0.45 * C0, 50)
    fig, ax = plt.subplots(1, 2, figsize=(9, 3.6))
    ax[0].plot(up, C0 + S1 * up, "k-", label="Us = C0 + S1 up")
    ax[0].plot([r[1] for r in rows], [r[3] for r in rows], "ro", label="MPM")
    ax[0].set(xlabel="piston speed up (m/s)", ylabel="shock speed Us (m/s)")
    ax[1].plot(up, RHO0 * (C0 + S1 * up) * up / 1000, "k-", label="P = rho0 Us up")
    ax[1].plot([r[1] for r in rows], [r[5] / 1000 for r in rows], "ro", label="MPM plateau")
    ax[1].set(xlabel="piston speed up (m/s)", ylabel="pressure (GPa)")
    for a in ax:
        a.legend()
        a.grid(alpha=0.3)
    fig.suptitle("Nickel Mie–Grüneisen Hugoniot (20 x 0.75 mm bar, B2CPDI, XPIC(5))")
    fig.tight_layout()
    fig.savefig(FIGS / "shock_hugoniot.png", dpi=120)


def energy():
    for h in (0.25, 0.125):
        d = with_overrides(deck("nickel_shock"), {"grid.cell_size": h})
        t0 = time.perf_counter()
        sim = simulation(d)
        sim.run()
        hist = sim.recorder
        t = hist.column("time")
        total = hist.column("kinetic_energy") + hist.column("internal_energy") + hist.column("strain_energy")
        work = hist.column("external_work")
        i = np.searchsorted(t, 0.2 * t[-1])
        early = np.interp(0.3e-3, t, work - total)
        print(f"cells {h} mm: {sim.state.particles.n} particles, {sim.state.step} steps, "
              f"{time.perf_counter() - t0:.1f} s; at t = {t[-1]:.4g} ms work {work[-1]:.6g} mJ, "
              f"KE + U {total[-1]:.6g} mJ: balance {100 * (total[-1] - work[-1]) / work[-1]:+.2f}%; "
              f"start-up loss at 0.3 µs {early:.4g} mJ ({100 * early / work[-1]:.2f}% of the final work); "
              f"after 20% of the run: {100 * ((total[-1] - total[i]) - (work[-1] - work[i])) / (work[-1] - work[i]):+.2f}%; "
              f"bar momentum / piston impulse - 1: {hist.column('px')[-1] * d['materials']['piston']['velocity'][0] / work[-1] - 1:+.1e}")


def fig7(end):
    runs = {}
    variants = [("SMM", "nickel_shock", {}), ("MM XPIC", "nickel_shock_split", {}),
                ("Uncorrected XPIC", "nickel_shock_split", {"contact.xpic_contact_term": False})]
    for label, name, over in variants:
        t0 = time.perf_counter()
        sim = simulation(with_overrides(deck(name), {"time.end": end, **over}))
        sim.run()
        P = sim.state.particles
        order = np.lexsort((P.x0[:, 1], P.x0[:, 0]))
        runs[label] = (P.x0[order], P.x[order], P.stress[order, 0].copy(), P.pressure[order].copy())
        print(f"{label}: {P.n} particles, {sim.state.step} steps, {time.perf_counter() - t0:.1f} s")
    x0, x, s, p = runs["SMM"]
    prof = columns(x0, x, p, SPACING)
    front = measure_front(prof, 50.0, 2.0)
    interface = 25.0
    win = (x0[:, 0] > front.x0 + 0.5 * front.width) & (x0[:, 0] < interface + 3.0)
    print(f"front at x = {front.x:.3f} mm (x0 = {front.x0:.3f}), plateau {front.plateau:.0f} MPa, "
          f"width {front.width:.3f} mm; window x0 in ({front.x0 + 0.5 * front.width:.2f}, {interface + 3:.2f})")
    for label in ("MM XPIC", "Uncorrected XPIC"):
        d = np.abs(runs[label][2] - s)[win]
        print(f"{label}: max |sxx - sxx_SMM| = {d.max():.4g} MPa = {100 * d.max() / front.plateau:.3g}% of the plateau")
    fig, (ax, dax) = plt.subplots(2, 1, figsize=(7.5, 6.2), sharex=True, gridspec_kw={"height_ratios": [3, 1.3]})
    styles = {"SMM": ("k", "o", 5), "MM XPIC": ("tab:blue", "x", 4), "Uncorrected XPIC": ("tab:red", ".", 4)}
    lo, hi = front.x - 1.5, front.x + 6.0
    x_interface = runs["SMM"][1][np.argmin(np.abs(x0[:, 0] - interface)), 0]
    for label, (_, xx, ss, _) in runs.items():
        c, m, ms = styles[label]
        sel = (xx[:, 0] > lo) & (xx[:, 0] < hi)
        ax.plot(xx[sel, 0], -ss[sel] / 1000, m, color=c, ms=ms, ls="none", label=label)
        if label != "SMM":
            dax.plot(xx[sel, 0], 100 * (ss[sel] - s[sel]) / front.plateau, m, color=c, ms=ms, ls="none", label=label)
    for a in (ax, dax):
        a.axvline(x_interface, color="grey", ls=":", lw=1)
    ax.set(ylabel="axial stress -sxx (GPa)", xlim=(lo, hi),
           title=f"Nickel bar at t = {end * 1000:g} µs: shock front just past the interface (dotted)")
    ax.legend(loc="lower right")
    dax.set(xlabel="x (mm)", ylabel="sxx - sxx(SMM)\n(% of plateau)")
    dax.grid(alpha=0.3)
    inset = ax.inset_axes([0.33, 0.1, 0.3, 0.36])
    inset.plot(x[:, 0], -s / 1000, "k.", ms=1)
    inset.set_title("full wave", fontsize=8)
    inset.tick_params(labelsize=7)
    fig.tight_layout()
    fig.savefig(FIGS / "shock_fig7.png", dpi=120)


if __name__ == "__main__":
    what = sys.argv[1] if len(sys.argv) > 1 else "all"
    FIGS.mkdir(parents=True, exist_ok=True)
    if what in ("hugoniot", "all"):
        hugoniot_table()
    if what in ("energy", "all"):
        energy()
    if what in ("fig7", "all"):
        fig7(float(sys.argv[2]) if len(sys.argv) > 2 else 0.0037)
