"""APIC augury contact between FEM bodies (2D): the studies behind docs/fem-contact.md.

    python bench/fem_contact.py blocks      # two blocks: conservation, sticking gap, energy vs refinement
    python bench/fem_contact.py stability   # where contact fails: impact speed x mesh, chart
    python bench/fem_contact.py ramp        # block on a 30 degree ramp against the analytic slide
    python bench/fem_contact.py speed       # element-steps/s of the FEM update, augury cost per node
    python bench/fem_contact.py sliding     # loss of sliding speed per step between two long node rows
    python bench/fem_contact.py all

Every run is one thread; results go to results/fem_contact/*.json and the charts to
docs/figures/fem_contact_*.png.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mpmsim.deck import load_deck_text  # noqa: E402
from mpmsim.errors import InstabilityError  # noqa: E402
from mpmsim.fem.probes import boundary_gap  # noqa: E402
from mpmsim.scene import build_scene  # noqa: E402
from mpmsim.solver import Simulation  # noqa: E402

OUT = ROOT / "results" / "fem_contact"
FIG = ROOT / "docs" / "figures"
LEVELS = (0.5, 0.25, 0.125)


def deck(name: str, h: float, *, transfer="apic", iterations=1, end=0.04, hc=None, speed=1.0, shift=None,
         mu=None, dt=None) -> dict:
    """inputs/<name>.yaml at element size h (grid and time step follow the paper's ratios)."""
    d = yaml.safe_load((ROOT / "inputs" / f"{name}.yaml").read_text())
    ramp = name.startswith("fem_ramp")
    for b in d["bodies"]:
        b["element_size"] = h
        if "velocity" in b:
            b["velocity"] = [speed * float(c) for c in b["velocity"]]
    if shift is not None:
        d["bodies"][1]["transform"][0] = {"translate": [0.0, shift]}
    d["contact"]["augury"].update(cell_size=hc or (0.5 * h if ramp else 2.0 * h), transfer=transfer,
                                  iterations=iterations)
    if mu is not None:
        d["contact"]["default"] = {"law": "coulomb", "friction": mu} if mu > 0 else {"law": "frictionless"}
    d["time"] = {"end": end, "dt": dt or (2.5e-5 if ramp else 1e-4) * h}
    d["output"] = {"history_interval": end / 200}
    return d


def simulation(d: dict) -> Simulation:
    text = yaml.safe_dump(json.loads(json.dumps(d)), sort_keys=False)
    return Simulation(build_scene(load_deck_text(text, ROOT / "inputs" / "study.yaml")), out_dir=None, threads=1)


def run_sampled(d: dict, every: float, probe) -> tuple[Simulation, list, str | None]:
    """Step the deck, calling probe(state) every `every` seconds; (sim, samples, failure)."""
    sim = simulation(d)
    st, end = sim.state, sim.end
    samples, failure = [], None
    try:
        nxt = every
        while st.t < end * (1 - 1e-9):
            sim.step()
            sim.recorder.record(st)
            if st.t >= nxt * (1 - 1e-9) or st.t >= end * (1 - 1e-9):
                samples.append((st.t, *probe(st)))
                nxt += every
    except InstabilityError as exc:
        failure = str(exc)
    return sim, samples, failure


def columns(sim: Simulation, *names: str) -> list[np.ndarray]:
    rows = np.array(sim.recorder.rows, dtype=float)
    return [rows[:, sim.recorder.names.index(n)] for n in names]


# ------------------------------------------------------------------------------------ blocks
def blocks_case(h: float, transfer: str, iterations: int, end: float, shift=None, speed=1.0) -> dict:
    d = deck("fem_blocks_2d", h, transfer=transfer, iterations=iterations, end=end, shift=shift, speed=speed)
    hc = d["contact"]["augury"]["cell_size"]
    t0 = time.perf_counter()
    sim, samples, failure = run_sampled(d, end / 40, lambda st: (boundary_gap(st.fem.x, st.fem.facets,
                                                                              st.fem.node_body, 0, 1),))
    wall = time.perf_counter() - t0
    px, py, L, ke, se = columns(sim, "px", "py", "L", "kinetic_energy", "strain_energy")
    p0 = np.hypot(px[0], py[0])
    f = sim.state.fem
    scale = float(np.sum(f.mass * np.linalg.norm(f.x, axis=1) * np.linalg.norm(f.v, axis=1)))
    E = ke + se
    gaps = np.array([s[1] for s in samples])
    return {"h": h, "hc": hc, "transfer": transfer, "N": iterations, "end": end, "shift": shift, "speed": speed,
            "dP": float(max(np.abs(px - px[0]).max(), np.abs(py - py[0]).max()) / p0),
            "dL": float(np.abs(L - L[0]).max() / abs(L[0])), "dL_scale": float(np.abs(L - L[0]).max() / scale),
            "energy_end": float(E[-1] / E[0]), "gap_min": float(gaps.min()), "gap_end": float(gaps[-1]),
            "failure": failure, "wall_s": wall, "steps": sim.state.step}


def blocks() -> list[dict]:
    rows = []
    for transfer in ("apic", "pic"):
        for h in LEVELS:
            rows.append(blocks_case(h, transfer, 1, 0.1))
            rows.append(blocks_case(h, transfer, 0, 0.08, shift=6.0))
            r, s = rows[-2], rows[-1]
            print(f"{transfer} h={h}: dP {r['dP']:.1e} dL {r['dL']:.1e}  N=1 E(0.1)/E0 {r['energy_end']:.3f} "
                  f"gap end {r['gap_end']:.3f} | N=0 (shift 6) min gap/hc {s['gap_min'] / s['hc']:.3f} "
                  f"{'FAILED ' + s['failure'][:60] if s['failure'] or r['failure'] else ''}", flush=True)
    return rows


# ------------------------------------------------------------------------------------ stability
SPEEDS = (0.5, 1.0, 2.0, 4.0)
STAB_LEVELS = (0.5, 0.25, 0.125, 0.0625)


def stability() -> list[dict]:
    rows = []
    for transfer in ("apic", "pic"):
        for h in STAB_LEVELS:
            for s in SPEEDS:
                r = blocks_case(h, transfer, 1, 0.06 / s, speed=s)
                rows.append(r)
                print(f"{transfer} h={h} speed x{s}: {'FAILS: ' + r['failure'][:90] if r['failure'] else 'ok'}",
                      flush=True)
    return rows


def stability_chart(rows: list[dict]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6), sharey=True)
    for ax, transfer in zip(axes, ("apic", "pic")):
        for r in rows:
            if r["transfer"] != transfer:
                continue
            ok = r["failure"] is None
            ax.scatter(r["hc"], 71.6 * r["speed"], marker="o" if ok else "x", c="tab:green" if ok else "tab:red",
                       s=60)
        ax.set_xscale("log", base=2)
        ax.set_yscale("log", base=2)
        ax.set_yticks([71.6 * s for s in SPEEDS], [f"{71.6 * s:.0f}" for s in SPEEDS])
        ax.set_xticks([2.0 * h for h in STAB_LEVELS], [f"{2.0 * h:g}" for h in STAB_LEVELS])
        ax.minorticks_off()
        ax.set_xlabel("augury grid h_c (= 2 h)")
        ax.set_title(f"{transfer.upper()}, N = 1: o held, x interpenetrated")
    axes[0].set_ylabel("relative impact speed (m/s)")
    fig.tight_layout()
    FIG.mkdir(parents=True, exist_ok=True)
    fig.savefig(FIG / "fem_contact_stability.png", dpi=120)


# ------------------------------------------------------------------------------------ ramp
def ramp_case(h: float, transfer: str, mu: float, end: float, iterations: int = 1) -> dict:
    d = deck("fem_ramp_2d", h, transfer=transfer, iterations=iterations, end=end, mu=mu)
    t0 = time.perf_counter()
    sim, samples, failure = run_sampled(d, end / 20, lambda st: ())
    t, cx = columns(sim, "time", "cx_block")
    th = np.radians(30.0)
    analytic = 0.5 * 100.0 * max(np.sin(th) - mu * np.cos(th), 0.0) * np.cos(th) * t[-1] ** 2
    frictionless = 0.5 * 100.0 * np.sin(th) * np.cos(th) * t[-1] ** 2
    return {"h": h, "transfer": transfer, "mu": mu, "N": iterations, "t": float(t[-1]), "x": float(cx[-1] - cx[0]),
            "analytic": float(analytic), "ratio_to_frictionless": float((cx[-1] - cx[0]) / frictionless),
            "failure": failure, "wall_s": time.perf_counter() - t0}


def ramp() -> list[dict]:
    rows = []
    for transfer in ("apic", "pic"):
        for h in (0.5, 0.25):
            for mu in (0.0, 0.2, 0.7):
                r = ramp_case(h, transfer, mu, 0.1)
                rows.append(r)
                print(f"ramp {transfer} h={h} mu={mu}: x {r['x']:.4f} analytic {r['analytic']:.4f} "
                      f"({r['x'] / r['analytic'] if r['analytic'] else float('nan'):.3f})"
                      f"{' FAILED ' + r['failure'][:60] if r['failure'] else ''}", flush=True)
    return rows


# ------------------------------------------------------------------------------------ sliding
def sliding_loss(offset: float, apic: bool, iterations: int, h: float = 0.5) -> float:
    """Fraction of the relative tangential speed one augury correction (tau = dt) removes
    between two long rows of boundary nodes in contact (spacing h, augury cell h / 2 as in the
    ramp test, equal masses, frictionless), the upper row shifted by `offset` and sliding at
    unit speed over the lower; measured on the middle half of the rows."""
    from mpmsim.contact.augury.transfers import BSPLINE2, AuguryGrid, augury_correction

    s = np.arange(-20, 21) * h
    k = len(s)
    x = np.r_[np.c_[s + offset, np.zeros(k)], np.c_[s, np.zeros(k)]]
    v = np.zeros((2 * k, 2))
    v[:k, 0] = 1.0
    normal = np.zeros((2 * k, 2))
    normal[:k, 1], normal[k:, 1] = -1.0, 1.0
    acc, _ = augury_correction(x, np.ones(2 * k), v, np.zeros((2 * k, 2, 2)), normal, np.zeros(2 * k),
                               AuguryGrid(0.5 * h, BSPLINE2, apic), iterations, 1.0)
    mid = slice(k // 4, k - k // 4)
    return float(1.0 - ((1.0 + acc[:k][mid, 0]) - acc[k:][mid, 0]).mean())


def sliding() -> list[dict]:
    rows = []
    for transfer in ("pic", "apic"):
        for n in (1, 2, 4, 8):
            loss = [sliding_loss(f * 0.5, transfer == "apic", n) for f in (0.0, 0.1, 0.2, 0.3, 0.4, 0.5)]
            rows.append({"transfer": transfer, "N": n, "offset_over_h": [0.0, 0.1, 0.2, 0.3, 0.4, 0.5], "loss": loss})
            print(f"{transfer:4s} N={n}: " + " ".join(f"{v:.4f}" for v in loss), flush=True)
    return rows


# ------------------------------------------------------------------------------------ speed
def speed() -> dict:
    """Per-task cost of the 2D blocks at h = 0.0625 (9216 triangles) after a compiling step."""
    d = deck("fem_blocks_2d", 0.0625, end=0.002)
    sim = simulation(d)
    sim.step()
    sim.reset_timers()
    t0 = time.perf_counter()
    while sim.state.t < sim.end * (1 - 1e-9):
        sim.step()
    wall = time.perf_counter() - t0
    f = sim.state.fem
    steps = sim.state.step - 1
    tm = sim.timers
    fem_s = tm["fem kick-drift"] + tm["fem forces"] + tm["fem kick"]
    out = {"elements": len(f.cells), "nodes": f.n, "boundary_nodes": int(f.boundary.size), "steps": steps,
           "element_steps_per_s_fem_update": len(f.cells) * steps / fem_s,
           "augury_us_per_boundary_node_step": 1e6 * tm["augury contact"] / (steps * f.boundary.size),
           "element_steps_per_s_whole_step": len(f.cells) * steps / wall, "timers": tm}
    print(json.dumps({k: v for k, v in out.items() if k != "timers"}, indent=1))
    return out


def save(name: str, data) -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / f"{name}.json").write_text(json.dumps(data, indent=1))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["blocks", "stability", "ramp", "speed", "sliding", "all"])
    what = ap.parse_args().what
    import numba

    numba.set_num_threads(1)
    if what in ("speed", "all"):
        save("speed", speed())
    if what in ("blocks", "all"):
        save("blocks", blocks())
    if what in ("ramp", "all"):
        save("ramp", ramp())
    if what in ("sliding", "all"):
        save("sliding", sliding())
    if what in ("stability", "all"):
        rows = stability()
        save("stability", rows)
        stability_chart(rows)


if __name__ == "__main__":
    main()
