"""APIC augury contact and field contact between FEM bodies: the studies behind docs/fem-contact.md.

    python bench/fem_contact.py blocks      # two blocks: conservation, sticking gap, energy vs refinement
    python bench/fem_contact.py stability   # where contact fails: impact speed x mesh, chart
    python bench/fem_contact.py ramp        # block on a 30 degree ramp against the analytic slide (Fig. 11, 2D)
    python bench/fem_contact.py ramp3d      # the same in 3D (h = 0.5, 0.25)
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
         mu=None, dt=None, method="augury") -> dict:
    """inputs/<name>.yaml at element size h (grid and time step follow the paper's ratios),
    contact by `method` (augury or field)."""
    d = yaml.safe_load((ROOT / "inputs" / f"{name}.yaml").read_text())
    ramp = name.startswith("fem_ramp")
    for b in d["bodies"]:
        b["element_size"] = h
        if "velocity" in b:
            b["velocity"] = [speed * float(c) for c in b["velocity"]]
    if shift is not None:
        d["bodies"][1]["transform"][0] = {"translate": [0.0, shift]}
    d["contact"]["augury"].update(cell_size=hc or (0.5 * h if ramp else 2.0 * h), transfer=transfer,
                                  iterations=iterations, method=method)
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
def blocks_case(h: float, transfer: str, iterations: int, end: float, shift=None, speed=1.0, method="augury") -> dict:
    d = deck("fem_blocks_2d", h, transfer=transfer, iterations=iterations, end=end, shift=shift, speed=speed,
             method=method)
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
    return {"h": h, "hc": hc, "method": method, "transfer": transfer, "N": iterations, "end": end, "shift": shift,
            "speed": speed,
            "dP": float(max(np.abs(px - px[0]).max(), np.abs(py - py[0]).max()) / p0),
            "dL": float(np.abs(L - L[0]).max() / abs(L[0])), "dL_scale": float(np.abs(L - L[0]).max() / scale),
            "energy_end": float(E[-1] / E[0]), "gap_min": float(gaps.min()), "gap_end": float(gaps[-1]),
            "failure": failure, "wall_s": wall, "steps": sim.state.step}


METHODS = (("augury", "apic"), ("augury", "pic"), ("field", "apic"))  # (method, transfer); field: transfer unused


def label(method: str, transfer: str) -> str:
    return "field" if method == "field" else f"augury {transfer.upper()}"


def blocks() -> list[dict]:
    rows = []
    for method, transfer in METHODS:
        for h in LEVELS:
            rows.append(blocks_case(h, transfer, 1, 0.1, method=method))
            r = rows[-1]
            line = (f"{label(method, transfer)} h={h}: dP {r['dP']:.1e} dL {r['dL']:.1e} (of sum m|x||v| "
                    f"{r['dL_scale']:.1e}) E(0.1)/E0 {r['energy_end']:.3f} gap min {r['gap_min']:.3f} end "
                    f"{r['gap_end']:.3f}")
            if method == "augury":
                rows.append(blocks_case(h, transfer, 0, 0.08, shift=6.0))
                line += f" | N=0 (shift 6) min gap/hc {rows[-1]['gap_min'] / rows[-1]['hc']:.3f}"
            print(line + (" FAILED" if any(q["failure"] for q in rows[-2:]) else ""), flush=True)
    return rows


# ------------------------------------------------------------------------------------ stability
SPEEDS = (0.5, 1.0, 2.0, 4.0)
STAB_LEVELS = (0.5, 0.25, 0.125, 0.0625)


def stability() -> list[dict]:
    rows = []
    for method, transfer in METHODS:
        for h in STAB_LEVELS:
            for s in SPEEDS:
                r = blocks_case(h, transfer, 1, 0.06 / s, speed=s, method=method)
                rows.append(r)
                print(f"{label(method, transfer)} h={h} speed x{s}: energy kept {r['energy_end']:.3f}, "
                      f"{r['wall_s']:.1f} s, {'FAILS: ' + r['failure'][:90] if r['failure'] else 'ok'}", flush=True)
    return rows


def stability_chart(rows: list[dict]) -> None:
    """Where contact holds (impact speed x h_c), and the energy kept after the impact against
    the run's cost."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 4, figsize=(15, 3.6))
    for ax, (method, transfer) in zip(axes, METHODS):
        for r in rows:
            if (r.get("method", "augury"), r["transfer"]) != (method, transfer):
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
        ax.set_title(f"{label(method, transfer)}: o held, x failed", fontsize=9)
    axes[0].set_ylabel("relative impact speed (m/s)")
    ax = axes[3]
    for (method, transfer), colour in zip(METHODS, ("tab:blue", "tab:orange", "tab:green")):
        sel = [r for r in rows if (r.get("method", "augury"), r["transfer"]) == (method, transfer)
               and r["failure"] is None and r["speed"] == 1.0]
        ax.plot([r["wall_s"] for r in sel], [1.0 - r["energy_end"] for r in sel], "o-", c=colour,
                label=label(method, transfer))
        for r in sel:
            ax.annotate(f"{r['hc']:g}", (r["wall_s"], 1.0 - r["energy_end"]), fontsize=7)
    ax.set_xscale("log")
    ax.set_xlabel("CPU s per run (1 thread; labels: h_c)")
    ax.set_ylabel("energy lost by 0.06 s (impact x1)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    FIG.mkdir(parents=True, exist_ok=True)
    fig.savefig(FIG / "fem_contact_stability.png", dpi=120)


# ------------------------------------------------------------------------------------ ramp
RAMP_H = (0.5, 0.33, 0.25)
RAMP_MU = (0.0, 0.2, 0.7)
RAMP_T = (0.05, 0.1)


def ramp_analytic(mu: float, t: float) -> float:
    """The rigid block's horizontal slide, 1/2 g (sin 30 - mu cos 30) cos 30 t^2 (0 above tan 30)."""
    th = np.radians(30.0)
    return 0.5 * 100.0 * max(np.sin(th) - mu * np.cos(th), 0.0) * np.cos(th) * t * t


def ramp_case(h: float, method: str, transfer: str, mu: float, dim: int = 2, end: float = 0.1) -> dict:
    """The block's horizontal slide (its centre of mass) at RAMP_T on the 2D or 3D ramp deck."""
    d = deck("fem_ramp_2d" if dim == 2 else "fem_ramp", h, transfer=transfer, end=end, mu=mu, method=method)
    t0 = time.perf_counter()
    sim, samples, failure = run_sampled(d, end / 20, lambda st: ())
    t, cx = columns(sim, "time", "cx_block")
    x = {f"x({T:g})": float(np.interp(T, t, cx - cx[0])) if T <= t[-1] * (1 + 1e-9) else float("nan")
         for T in RAMP_T}  # (nan: the run stopped before T)
    return {"dim": dim, "h": h, "method": method, "transfer": transfer, "mu": mu, **x,
            **{f"analytic({T:g})": ramp_analytic(mu, T) for T in RAMP_T}, "failure": failure,
            "wall_s": time.perf_counter() - t0}


def ramp(dim: int = 2, levels=RAMP_H) -> list[dict]:
    """The paper's Fig. 11 in numbers (augury, PIC and APIC, 4-node kernel) and the field method."""
    rows = []
    for method, transfer in METHODS:
        for h in levels:
            for mu in RAMP_MU:
                r = ramp_case(h, method, transfer, mu, dim)
                rows.append(r)
                ratios = " ".join(f"{r[f'x({T:g})'] / (r[f'analytic({T:g})'] or ramp_analytic(0.0, T)):.3f}"
                                  for T in RAMP_T)
                print(f"{dim}D ramp {label(method, transfer)} h={h} mu={mu}: x/analytic (mu 0.7: x/frictionless) at "
                      f"0.05, 0.1 s {ratios}{' FAILED ' + r['failure'][:60] if r['failure'] else ''} "
                      f"({r['wall_s']:.0f} s)", flush=True)
    return rows


def ramp_chart(rows: list[dict], name: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(RAMP_MU), figsize=(12, 3.6))
    for ax, mu in zip(axes, RAMP_MU):
        for (method, transfer), colour in zip(METHODS, ("tab:blue", "tab:orange", "tab:green")):
            for T, style in zip(RAMP_T, ("--", "-")):
                sel = sorted((r for r in rows if r["mu"] == mu and (r["method"], r["transfer"]) == (method, transfer)),
                             key=lambda r: r["h"])
                ref = [r[f"analytic({T:g})"] or ramp_analytic(0.0, T) for r in sel]
                ax.plot([r["h"] for r in sel], [r[f"x({T:g})"] / a for r, a in zip(sel, ref)], style, marker="o",
                        c=colour, label=f"{label(method, transfer)}, t = {T:g} s")
        ax.axhline(1.0 if mu < 0.5 else 0.0, c="k", lw=0.8)
        ax.set_xlabel("element size h (h_c = h / 2)")
        ax.set_title(f"mu = {mu:g}" + (": x / x(mu = 0, rigid)" if mu >= 0.5 else ": x / analytic"), fontsize=9)
        ax.invert_xaxis()
    axes[0].set_ylabel("block's slide")
    axes[0].legend(fontsize=6)
    fig.tight_layout()
    FIG.mkdir(parents=True, exist_ok=True)
    fig.savefig(FIG / f"{name}.png", dpi=120)


# ------------------------------------------------------------------------------------ sliding
def sliding_loss(offset: float, apic: bool, iterations: int, kernel: str = "four_node", ratio: float = 1.0,
                 h: float = 0.5) -> float:
    """Largest fraction of the relative tangential speed one augury correction (tau = dt)
    removes between two long rows of boundary nodes in contact, spacing h = 2 h_c (the ramp
    test's), frictionless, the upper row `ratio` times as heavy, shifted by `offset` x h and
    sliding at unit speed over the lower; over the middle half of the rows."""
    from mpmsim.contact.augury.transfers import KERNELS, AuguryGrid, augury_correction

    s = np.arange(-20, 21) * h
    k = len(s)
    x = np.r_[np.c_[s + offset * h, np.zeros(k)], np.c_[s, np.zeros(k)]]
    v = np.zeros((2 * k, 2))
    v[:k, 0] = 1.0
    m = np.r_[np.full(k, ratio), np.ones(k)]
    normal = np.zeros((2 * k, 2))
    normal[:k, 1], normal[k:, 1] = -1.0, 1.0
    acc, _ = augury_correction(x, m, v, np.zeros((2 * k, 2, 2)), normal, np.zeros(2 * k),
                               AuguryGrid(0.5 * h, KERNELS[kernel], apic), iterations, 1.0)
    mid = slice(k // 4, k - k // 4)
    rel = (1.0 + acc[:k][mid, 0]) - acc[k:][mid, 0]
    return float(np.abs(1.0 - rel).max())


OFFSETS = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5)


def sliding() -> list[dict]:
    rows = []
    for kernel in ("four_node", "bspline2"):
        for transfer in ("pic", "apic"):
            for n in (1, 2, 4, 8) if kernel == "bspline2" else (1,):
                for ratio in (1.0, 3.0):
                    loss = [sliding_loss(f, transfer == "apic", n, kernel, ratio) for f in OFFSETS]
                    rows.append({"kernel": kernel, "transfer": transfer, "N": n, "mass_ratio": ratio,
                                 "offset_over_h": list(OFFSETS), "loss": loss})
                    print(f"{kernel:9s} {transfer:4s} N={n} mass ratio {ratio:g}: "
                          + " ".join(f"{v:.2g}" for v in loss), flush=True)
    return rows


# ------------------------------------------------------------------------------------ speed
def speed() -> dict:
    """Per-task cost of the 2D blocks at h = 0.0625 (9216 triangles) after a compiling step,
    augury (APIC, N = 1) and field contact."""
    out = {}
    for method in ("augury", "field"):
        d = deck("fem_blocks_2d", 0.0625, end=0.002, method=method)
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
        out[method] = {"elements": len(f.cells), "nodes": f.n, "boundary_nodes": int(f.boundary.size), "steps": steps,
                       "element_steps_per_s_fem_update": len(f.cells) * steps / fem_s,
                       "contact_us_per_boundary_node_step": 1e6 * tm["augury contact"] / (steps * f.boundary.size),
                       "element_steps_per_s_whole_step": len(f.cells) * steps / wall, "timers": tm}
        print(method, json.dumps({k: v for k, v in out[method].items() if k != "timers"}), flush=True)
    return out


def save(name: str, data) -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / f"{name}.json").write_text(json.dumps(data, indent=1))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["blocks", "stability", "ramp", "ramp3d", "speed", "sliding", "all"])
    what = ap.parse_args().what
    import numba

    numba.set_num_threads(1)
    if what in ("speed", "all"):
        save("speed", speed())
    if what in ("blocks", "all"):
        save("blocks", blocks())
    if what in ("ramp", "all"):
        rows = ramp(2)
        save("ramp", rows)
        ramp_chart(rows, "fem_contact_ramp")
    if what in ("ramp3d", "all"):
        rows = ramp(3, (0.5, 0.25))
        save("ramp3d", rows)
        ramp_chart(rows, "fem_contact_ramp3d")
    if what in ("sliding", "all"):
        save("sliding", sliding())
    if what in ("stability", "all"):
        rows = stability()
        save("stability", rows)
        stability_chart(rows)


if __name__ == "__main__":
    main()
