"""Contact methods: accuracy and cost on the same problems (LR paper Figs. 5 and 6).

    python bench/contact.py accuracy   # Fig. 5: every method to 20% strain on the 5 mm column
    python bench/contact.py cost       # particle-steps/s: 1 mm column, full-size ellipse box
    python bench/contact.py all        # both, then the accuracy-against-cost chart
    python bench/contact.py ellipses   # Fig. 6 at full size: LR, DF, CP to 75% compression
    python bench/contact.py chart      # redraw both charts from the saved results
    python bench/contact.py ledger     # cost of output.energy_ledger on the 1/20 mm ellipse box
    python bench/contact.py pass3      # cost of pass 3's geometry: persist (default) against keep

Accuracy: the two-block column (inputs/two_blocks.yaml) against one block (inputs/column.yaml),
max |MM - SMM| / SMM of the mean axial stress from 0.2% strain on; writes
docs/figures/contact_column_error.png and prints the table in docs/contact-methods.md.
Cost: one thread, per contact task; 200 steps of the column at 1 mm cells (16 000
particles), and whole runs of the ellipse box at 1/20 mm cells (DF, CP, LR cold and warm
start). `ellipses` runs Fig. 6 at the paper's 1/70 mm cells (about half an hour per method). Runs go in parallel
processes (one numba thread each), so use `--workers 1` for undisturbed timings.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import yaml

from mpmsim.errors import InstabilityError
from mpmsim.stability import total_sums
from mpmsim.sweep.metrics import relative_error_curve

ROOT = Path(__file__).resolve().parents[1]
FIGURES = ROOT / "docs" / "figures"
RESULTS = ROOT / "results" / "bench_contact"

AVG = {"contact.normal": "average_gradient"}
XPIC5 = {"update.scheme": "xpic", "update.order": 5}
# Fig. 5 methods: label -> (multimaterial overrides, single-material overrides of the reference)
METHODS = {
    "LR": ({}, {}),
    "LR once": ({"contact.passes": 1}, {}),
    "LR-XPIC(5)": (XPIC5, XPIC5),
    "LR-XPIC(5) uncorrected": ({**XPIC5, "contact.xpic_contact_term": False}, XPIC5),
    "AVG (displacement)": (AVG, {}),
    "CP=0.8": ({**AVG, "contact.separation": "cutoff", "contact.cutoff": 0.8}, {}),
    "Δv<0": ({**AVG, "contact.separation": "velocity"}, {}),
    "DF": ({**AVG, "contact.separation": "fit"}, {}),
    "DF+SN": ({"contact.normal": "specified", "contact.normal_vector": [0.0, 1.0], "contact.separation": "fit"}, {}),
}
ELLIPSE_METHODS = {
    "LR": {},
    "LR warm start": {"contact.warm_start": True},
    "DF": {**AVG, "contact.separation": "fit"},
    "CP=0.8": {**AVG, "contact.separation": "cutoff", "contact.cutoff": 0.8},
}


def deck(name: str, overrides: dict):
    from mpmsim.deck import load_deck_text
    from mpmsim.deck.overrides import with_overrides

    path = ROOT / "inputs" / f"{name}.yaml"
    data = with_overrides(yaml.safe_load(path.read_text()), overrides)
    return load_deck_text(yaml.safe_dump(data, sort_keys=False), path)


def simulation(name: str, overrides: dict):
    import numba

    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation

    numba.set_num_threads(1)
    return Simulation(build_scene(deck(name, overrides)), out_dir=None, threads=1)


def run_to_end(job):
    """Worker: run a deck to its end; the history columns the error needs, and the cost."""
    name, overrides = job
    sim = simulation(name, overrides)
    t0 = time.perf_counter()
    stopped = ""
    try:
        sim.run()
    except InstabilityError as exc:  # an unstable method is a result, not a crash of the study
        stopped = str(exc).splitlines()[0]
    wall = time.perf_counter() - t0
    h = sim.recorder
    return {"strain": (-h.column("u_platen_y") / 100.0).tolist(), "syy": h.column("syy").tolist(),
            "wall": wall, "steps": sim.state.step, "particles": sim.state.particles.n, "stopped": stopped}


def accuracy(workers: int) -> dict:
    jobs = {("column", json.dumps(smm, sort_keys=True)) for _, smm in METHODS.values()}
    jobs = [(name, json.loads(o)) for name, o in sorted(jobs)]
    jobs += [("two_blocks", mm) for mm, _ in METHODS.values()]
    with ProcessPoolExecutor(workers) as pool:
        out = list(pool.map(run_to_end, jobs))
    done = {(name, json.dumps(o, sort_keys=True)): r for (name, o), r in zip(jobs, out)}
    curves = {}
    for label, (mm, smm) in METHODS.items():
        a = done[("two_blocks", json.dumps(mm, sort_keys=True))]
        b = done[("column", json.dumps(smm, sort_keys=True))]
        # the Fig. 5 metric, as the sweeps compute it (mpmsim.sweep.metrics), from 0.2% strain on
        eps, err = relative_error_curve(np.array(a["strain"]), np.array(a["syy"]), np.array(b["strain"]),
                                        np.array(b["syy"]), 0.002)
        curves[label] = {"strain": eps.tolist(), "error": err.tolist(), "wall": a["wall"],
                         "steps": a["steps"], "stopped": a["stopped"]}
    print("\nFig. 5 (5 mm cells, CFL 0.25): max |MM - SMM| / SMM of the mean axial stress")
    print("| method | max error | at strain | final strain | wall (1 thread) |")
    print("|---|---|---|---|---|")
    for label, c in curves.items():
        e = np.abs(c["error"])
        i = int(np.argmax(e))
        note = f" (stopped: {c['stopped']})" if c["stopped"] else ""
        print(f"| {label} | {100 * e[i]:.3g}% | {100 * c['strain'][i]:.1f}% | {100 * c['strain'][-1]:.1f}%{note} "
              f"| {c['wall']:.1f} s |")
    plot_errors(curves)
    return curves


def plot_errors(curves: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    for ax, limit in zip(axes, (None, 1.0)):
        for label, c in curves.items():
            ax.plot(100 * np.array(c["strain"]), 100 * np.array(c["error"]), label=label, lw=1.2)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_xlabel("compression strain (%)")
        ax.set_ylabel("(MM - SMM) / SMM (%)")
        if limit:
            ax.set_ylim(-limit, limit)
            ax.set_title("B. zoomed to ±1%")
        else:
            ax.set_title("A. all methods")
    axes[0].legend(fontsize=8)
    fig.suptitle("Two identical blocks vs one block (LR paper Fig. 5), 5 mm cells, GIMP, CFL 0.25")
    fig.tight_layout()
    FIGURES.mkdir(parents=True, exist_ok=True)
    fig.savefig(FIGURES / "contact_column_error.png", dpi=110)
    print(f"wrote {FIGURES / 'contact_column_error.png'}")


def time_steps(job):
    """Worker: particle-steps/s and the contact tasks' us/step, over `steps` steps after a
    warm-up (None: the whole run, averaging over every stage of contact)."""
    name, overrides, steps = job
    sim = simulation(name, overrides)
    total_sums(sim.state)  # (the energy check's kernel, as a run's start: loaded before the timing)
    for _ in range(3):
        sim.step()
    sim.reset_timers()
    first = sim.state.step
    t0 = time.perf_counter()
    if steps is None:
        sim.run()
    else:
        for _ in range(steps):
            sim.step()
    wall = time.perf_counter() - t0
    steps = sim.state.step - first
    n = sim.state.particles.n
    contact = {k: v / steps * 1e6 for k, v in sim.timers.items() if "contact" in k or k == "material fields"}
    return {"rate": n * steps / wall, "us_step": wall / steps * 1e6, "contact_us": contact, "particles": n,
            "steps": steps}


COLUMN_1MM = {"grid.cell_size": 1.0, "time.cfl": 0.5}  # 16 000 particles, as bench/column.yaml
ELLIPSE_COARSE = {"grid.cell_size": 0.05, "bodies.1.max": [1.0, 2.1]}  # 3.5x coarser than the paper


def cost(workers: int, steps: int) -> dict:
    jobs = {"column: one material": ("column", COLUMN_1MM, steps),
            "column: one material XPIC(5)": ("column", {**COLUMN_1MM, **XPIC5}, steps)}
    jobs.update({f"column: {label}": ("two_blocks", {**COLUMN_1MM, **mm}, steps) for label, (mm, _) in METHODS.items()})
    jobs["column: LR warm start"] = ("two_blocks", {**COLUMN_1MM, "contact.warm_start": True}, steps)
    jobs.update({f"ellipses: {k}": ("ellipse_box", {**ELLIPSE_COARSE, **ELLIPSE_METHODS[k]}, None)
                 for k in ("DF", "CP=0.8", "LR", "LR warm start")})
    with ProcessPoolExecutor(workers) as pool:
        out = dict(zip(jobs, pool.map(time_steps, jobs.values())))
    print("\nCost (1 thread each): particle-steps/s and the contact tasks (us/step)")
    print("| problem: method | particles | steps | M particle-steps/s | time vs first | contact tasks, us/step |")
    print("|---|---|---|---|---|---|")
    base = {}
    for label, r in out.items():
        problem = label.split(":")[0]
        base.setdefault(problem, r["rate"])
        tasks = ", ".join(f"{k} {v:.0f}" for k, v in r["contact_us"].items())
        print(f"| {label} | {r['particles']} | {r['steps']} | {r['rate'] / 1e6:.3f} | "
              f"{100 * (base[problem] / r['rate'] - 1):+.0f}% | {tasks} |")
    return out


def plot_tradeoff(curves: dict, costs: dict) -> None:
    """Max Fig. 5 error against the cost of the same method on the 1 mm column."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    def cost(name: str) -> float:  # µs per particle-step
        return 1e6 / costs[name]["rate"]

    fig, ax = plt.subplots(figsize=(7.5, 5))
    for label, c in curves.items():
        r = cost(f"column: {label}")
        e = 100 * np.abs(c["error"]).max()
        ax.scatter(r, e)
        ax.annotate(label, (r, e), textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.axvline(cost("column: one material"), color="grey", ls="--", label="one material, FLIP")
    ax.axvline(cost("column: one material XPIC(5)"), color="grey", ls=":", label="one material, XPIC(5)")
    ax.set_yscale("log")
    ax.set_xlabel("cost: µs per particle-step, 1 mm column, 1 thread")
    ax.set_ylabel("max |MM - SMM| / SMM to 20% strain (%), 5 mm column")
    ax.legend()
    ax.set_title("Contact methods: Fig. 5 error against cost (XPIC runs pay for XPIC too)", fontsize=10)
    fig.tight_layout()
    fig.savefig(FIGURES / "contact_accuracy_vs_cost.png", dpi=110)
    print(f"wrote {FIGURES / 'contact_accuracy_vs_cost.png'}")


ENERGY = ("external_work", "kinetic_energy", "strain_energy", "transfer_loss", "contact_loss", "friction_loss",
          "condition_loss", "force_gap_loss", "energy_residual")


def ellipse_to_end(job):
    """Worker: the full-size ellipse box to its end; final stress, overlap and wall time."""
    from mpmsim.overlap import overlap_fraction

    label, overrides = job
    sim = simulation("ellipse_box", {**overrides, "output.energy_ledger": True})
    t0 = time.perf_counter()
    stopped = ""
    try:
        sim.run()
    except InstabilityError as exc:
        stopped = str(exc).splitlines()[0]
    wall = time.perf_counter() - t0
    P, h = sim.state.particles, sim.state.grid.h
    frac = overlap_fraction(P.x, P.F, P.mat, sim.scene.semi_size, float(h.min()) / 8)
    box = 1.0 * (2.0 - 100.0 * sim.state.t)  # the piston moves at 100 mm/ms
    return {"method": label, "syy": float(np.sum(P.stress[:, 1] * P.vol) / P.vol.sum()), "overlap": frac,
            "wall": wall, "steps": sim.state.step, "particles": P.n, "stopped": stopped,
            "stroke": 100.0 * sim.state.t / 2.0, "volumes": float(P.vol.sum() / box),
            "history": [sim.recorder.column("time").tolist(), sim.recorder.column("syy").tolist()],
            "energy": {c: float(sim.recorder.column(c)[-1]) for c in ENERGY}}


def ellipses(workers: int) -> list:
    """Fig. 6 at 1/70 mm with LR, DF and CP, and LR at 1/35 mm (convergence). A method stopped
    before the end is compared with LR at the stroke it reached."""
    jobs = [(k, ELLIPSE_METHODS[k]) for k in ("LR", "DF", "CP=0.8")]
    jobs.append(("LR, 1/35 mm", {"grid.cell_size": 1.0 / 35.0}))
    with ProcessPoolExecutor(workers) as pool:
        out = list(pool.map(ellipse_to_end, jobs))
    lr_t, lr_syy = out[0]["history"]
    print("\nFig. 6 (CPDI, PIC; 1/70 mm cells unless named); paper (XPIC(5)): LR 105, DF 84, CP 80 GPa")
    print("| method | final -syy (GPa) | LR / method there | overlap | stroke reached | sum J V0 / box | steps "
          "| wall (1 thread) |")
    print("|---|---|---|---|---|---|---|---|")
    for r in out:
        note = f" (stopped: {r['stopped']})" if r["stopped"] else ""
        t, syy = r["history"]
        ratio = float(np.interp(t[-1], lr_t, lr_syy)) / syy[-1]
        print(f"| {r['method']} | {-r['syy'] / 1000:.1f}{note} | {ratio:.3f} | {100 * r['overlap']:.1f}% "
              f"| {r['stroke']:.1%} | {r['volumes']:.4f} | {r['steps']} | {r['wall'] / 60:.1f} min |")
    print("\nEnergy ledger at the end, % of the piston work (external_work)")
    print("| method | " + " | ".join(ENERGY[1:]) + " |")
    print("|---|" + "---|" * (len(ENERGY) - 1))
    for r in out:
        e = r["energy"]
        print(f"| {r['method']} | " + " | ".join(f"{100 * e[c] / e[ENERGY[0]]:.2f}" for c in ENERGY[1:]) + " |")
    return out


def ledger_cost(steps: int) -> None:
    """The energy ledger's cost: the ellipse box at 1/20 mm (LR, PIC), `steps` timed steps
    after 50 warm ones, with the ledger off and on, alternated in one process, on 1 and 2
    threads; particle-steps/s of each and the ledger tasks' share of the step's task time."""
    import numba

    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation

    print("| threads | ledger | M particle-steps/s | ledger tasks' share |")
    print("|---|---|---|---|")
    for threads in (1, 2):
        numba.set_num_threads(threads)
        for on in (False, True, False, True):
            ov = {**ELLIPSE_COARSE, "output.energy_ledger": on}
            sim = Simulation(build_scene(deck("ellipse_box", ov)), out_dir=None, threads=threads)
            for _ in range(50):
                sim.step()
            sim.reset_timers()
            t0 = time.perf_counter()
            for _ in range(steps):
                sim.step()
            wall = time.perf_counter() - t0
            tasks = {k: v for k, v in sim.integrator.timers.items()}
            share = sum(v for k, v in tasks.items() if k.startswith("energy ledger")) / sum(tasks.values())
            rate = sim.state.particles.n * steps / wall / 1e6
            print(f"| {threads} | {'on' if on else 'off'} | {rate:.3f} | {100 * share:.1f}% |", flush=True)


def pass_3_cost(rounds: int, steps: int = 100) -> None:
    """The cost of `pass_3: persist` (pass 3 computes the contact geometry again) against `keep`:
    bench/two_blocks.yaml (16,000 particles, LR), both runs built in one process and stepped
    alternately (`steps` timed steps per round, after 60 warm ones; the order flips each round),
    on 1 and 2 threads; the median seconds per step of each, particle-steps/s and the ratio."""
    import statistics

    import numba

    from machine import describe  # (bench/machine.py: run as python bench/contact.py)

    from mpmsim.deck import load_deck_text
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation

    path = ROOT / "bench" / "two_blocks.yaml"
    print("| threads | keep (M particle-steps/s) | persist | persist / keep (time per step) |")
    print("|---|---|---|---|")
    for threads in (1, 2):
        numba.set_num_threads(threads)
        sims = {}
        for mode in ("keep", "persist"):
            data = yaml.safe_load(path.read_text())
            data["contact"]["pass_3"] = mode
            data["output"] = {"vtu_interval": 1e9, "history_interval": 1e9}
            sims[mode] = Simulation(build_scene(load_deck_text(yaml.safe_dump(data), path)), out_dir=None,
                                    threads=threads)
            for _ in range(60):
                sims[mode].step()
        times = {"keep": [], "persist": []}
        for r in range(rounds):
            for mode in ("keep", "persist") if r % 2 == 0 else ("persist", "keep"):
                t0 = time.perf_counter()
                for _ in range(steps):
                    sims[mode].step()
                times[mode].append((time.perf_counter() - t0) / steps)
        med = {m: statistics.median(t) for m, t in times.items()}
        n = sims["keep"].state.particles.n
        print(f"| {threads} | {n / med['keep'] / 1e6:.3f} | {n / med['persist'] / 1e6:.3f} | "
              f"{med['persist'] / med['keep']:.3f} |", flush=True)
    print(describe())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=["accuracy", "cost", "all", "ellipses", "chart", "ledger", "pass3"])
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--steps", type=int, default=200, help="timed steps on the 1 mm column")
    args = ap.parse_args()
    if args.what == "ledger":
        return ledger_cost(1000)
    if args.what == "pass3":
        return pass_3_cost(10)
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    RESULTS.mkdir(parents=True, exist_ok=True)
    curves = costs = None
    if args.what in ("accuracy", "all"):
        curves = accuracy(args.workers)
        (RESULTS / "accuracy.json").write_text(json.dumps(curves))
    if args.what in ("cost", "all"):
        costs = cost(args.workers, args.steps)
        (RESULTS / "cost.json").write_text(json.dumps(costs))
    if args.what == "chart":  # redraw from the saved results of earlier runs
        curves = json.loads((RESULTS / "accuracy.json").read_text())
        costs = json.loads((RESULTS / "cost.json").read_text())
        plot_errors(curves)
    if args.what == "ellipses":
        (RESULTS / "ellipses.json").write_text(json.dumps(ellipses(args.workers)))
    if curves is not None and costs is not None:
        plot_tradeoff(curves, costs)


if __name__ == "__main__":
    main()
