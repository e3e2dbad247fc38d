"""Benchmark: the explicit MPM step on one GPU (--device cuda) beside all CPU cores, same scenes.

Scenes (issue 40): the 2D column (bench/column.yaml: neo-Hookean, uGIMP, FLIP, USAVG, rigid
platen, fixed floor) at 1M and 4M particles, the LR two-block column (bench/two_blocks.yaml) at
1M, the 3D column (inputs/column_3d.yaml) at 1M. Particle counts are reached by the cell size
(2 particles per cell and direction).

For each scene: particle-steps/s and per-task seconds on the GPU, once per scatter method
(atomic adds in the particles' storage order, or with the particles grouped by cell; each
task ends with a device synchronisation, so its timer is its GPU time) and on the CPU with
all cores; after the same steps, the largest relative difference of positions, velocities
and stresses (max |gpu - cpu| / max |cpu|, target 1e-10; for the LR scene the CPU also runs on
half its threads, and that run's difference is the CPU's own spread, the yardstick where
contact decisions turn on round-off: docs/performance.md); an estimate of the bytes each particle-step moves (the
particle arrays each kernel reads and writes, atomic adds as read-modify-write of 8 bytes,
grid arrays not counted) and the fraction of the card's bandwidth it implies.

    python bench/gpu.py                       # the issue's sizes, 100 steps (a device machine;
                                              # a few minutes: scene builds, kernel compiles, CPU runs)
    python bench/gpu.py --tiny                # 2 000 particles, 3 steps: checks the script runs
    NUMBA_ENABLE_CUDASIM=1 python bench/gpu.py --tiny   # the same without a GPU (simulator)
    options: --steps N --sizes 1e6 4e6 --size3d 1e6 --bandwidth 3.35e12 --json FILE --scatter atomic sorted

Output: a table on stdout and a JSON document (--json, default bench/gpu.json).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from datetime import datetime, timezone
from pathlib import Path

import numba
import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
H100_BANDWIDTH = 3.35e12  # bytes/s, H100 SXM HBM3


def column_deck(n: float, dim: int, steps: int, src: str | None = None) -> dict:
    """The benchmark column (2D: bench/column.yaml; 3D: inputs/column_3d.yaml; or the deck
    `src`, its last body the platen) with the cell size that gives about n particles; fixed dt
    (the CFL step of the undeformed column) so the GPU and CPU runs take the same steps."""
    src = ROOT / (src or ("bench/column.yaml" if dim == 2 else "inputs/column_3d.yaml"))
    d = yaml.safe_load(src.read_text())
    d["title"] = f"{d['title']} ({n:.3g} particles)"
    h0 = float(d["grid"]["cell_size"])
    per = d.get("particles_per_direction", 2) ** dim
    n0 = sum(per * np.prod((np.array(b["max"], float) - np.array(b["min"], float)) / h0) for b in d["bodies"][:-1])
    h = h0 * (n0 / n) ** (1.0 / dim)
    d["grid"]["cell_size"] = float(h)
    c = 1924.4  # dilatational wave speed of the column's neo-Hookean polymer, mm/ms
    dt = 0.5 * h / c
    d["time"] = {"end": float((steps + 10) * dt), "dt": float(dt)}  # (the platen travel sizes the grid)
    d["output"] = {"history_interval": 1e8, "vtu_interval": 1e8}
    platen = d["bodies"][-1]  # as thick as two cells of the new grid
    platen["max"][dim - 1] = float(platen["min"][dim - 1] + 2 * h)
    return d


def simulation(scene, device: str, threads: int):
    from mpmsim.solver import Simulation

    numba.set_num_threads(threads)
    return Simulation(scene, threads=threads, device=device)


def per_particle_bytes(sim) -> float:
    """Bytes of particle data the device step reads and writes per particle (an estimate: see
    the module docstring)."""
    st = sim.state
    dim = st.dim
    K = st.sd.S.shape[1]
    f = 8
    entries = K * (8 + 8 + dim * 8)  # nodes, S, G of one particle
    x, v, F, s, vol = dim * f, dim * f, dim * dim * f, 6 * f, f
    affine = st.particles.affine
    upd = sim.scene.settings.update
    stress_passes = 2 if upd.stress == "usavg" else 1
    scatter = K * (1 + dim) * 2 * f  # atomic mass + momentum: read-modify-write
    total = x + entries + 3 * f  # shape functions: read x, write entries and lowest
    total += f + v + K * 16 + scatter + (2 * dim * dim * f if affine else 0)  # extrapolate
    total += stress_passes * (K * (8 + dim * 8 + dim * 8) + v + 2 * F + 2 * s + 2 * vol + f + 4)  # stress
    total += K * (8 + 8 + dim * 8 + dim * 2 * f) + s + vol + f  # forces
    total += K * (8 + 8 + 3 * dim * 8) + 2 * x + 2 * v + f  # particle update (reads 3 grid fields per entry)
    if upd.stress in ("usl", "usavg") and upd.reextrapolate:
        total += f + v + K * 16 + K * dim * 2 * f  # re-extrapolate
    return float(total)


def run_scene(name: str, d: dict, steps: int, warmup: int, threads: int, bandwidth: float,
              scatters: list[str], spread: bool = False) -> dict:
    """The scene on the GPU (once per scatter method) and on the CPU's threads: rates, per-task
    seconds, bytes per particle-step, and each GPU run's agreement with the CPU run. spread:
    the CPU again on half its threads, whose difference from the first CPU run is the CPU's own
    spread (the summation order alone; with LR contact it exceeds 1e-10, docs/performance.md)."""
    from mpmsim.deck import as_loaded_deck
    from mpmsim.errors import DeckError
    from mpmsim.gpu import unsupported
    from mpmsim.scene import build_scene

    scene = build_scene(as_loaded_deck(d, "bench", ROOT))
    missing = unsupported(scene)
    out = {"scene": name, "particles": int(len(scene.deformable.x)), "steps": steps, "runs": {}}
    if missing:
        out["gpu"] = "not supported: " + "; ".join(f"{'.'.join(map(str, k))}: {m}" for k, m in missing)
        return out
    results = {}
    runs = [(f"gpu {s}", "cuda", 1, s) for s in scatters] + [("cpu", "cpu", threads, None)]
    if spread:
        runs.append((f"cpu {max(threads // 2, 1)}", "cpu", max(threads // 2, 1), None))
    for label, device, nthreads, scatter in runs:
        try:
            t0 = time.perf_counter()
            sim = simulation(scene, device, nthreads)
            if scatter is not None:
                sim.integrator.device.scatter = scatter
            sim.step()  # (compiles the kernels; timed apart)
            first = time.perf_counter() - t0
        except DeckError as exc:
            out["gpu"] = f"refused: {exc}"
            return out
        for _ in range(warmup - 1):
            sim.step()
        sim.reset_timers()
        t0 = time.perf_counter()
        for _ in range(steps):
            sim.step()
        if device == "cuda":
            sim.integrator.device.cuda.synchronize()
        wall = time.perf_counter() - t0
        n = sim.state.particles.n
        results[label] = sim.particles
        r = out["runs"][label] = {"threads": nthreads, "seconds": wall, "particle_steps_per_s": n * steps / wall,
                                  "first_step_s": first, "tasks_s": dict(sim.timers)}
        if device == "cuda":
            b = per_particle_bytes(sim)
            r["bytes_per_particle_step"] = b
            r["bandwidth_fraction"] = b * n * steps / wall / bandwidth
        del sim
    a = results["cpu"]
    for label in results:
        if label != "cpu":  # (another CPU run: the CPU's own spread)
            g = results[label]
            agree = {k: float(np.max(np.abs(a[k] - g[k])) / max(np.max(np.abs(a[k])), 1e-300))
                     for k in ("x", "v", "stress")}
            out["runs"][label]["agreement"] = agree
            out["runs"][label]["agree_1e-10"] = all(v <= 1e-10 for v in agree.values())
    return out


def table(rows: list[dict]) -> str:
    lines = [f"{'scene':<22} {'run':<11} {'particles':>10} {'Mp-s/s':>8} {'x CPU':>6} {'B/p-step':>9} {'of BW':>6}"
             "  max rel. diff from CPU (x, v, stress)"]
    for r in rows:
        if "gpu" in r:
            lines.append(f"{r['scene']:<22} {'gpu':<11} {r['particles']:>10} {r['gpu']}")
            continue
        cpu = r["runs"]["cpu"]["particle_steps_per_s"]
        for label, g in r["runs"].items():
            rate = g["particle_steps_per_s"]
            row = f"{r['scene']:<22} {label:<11} {r['particles']:>10} {rate / 1e6:>8.2f} {rate / cpu:>6.1f}"
            if "agreement" in g:
                ag = g["agreement"]
                if "bytes_per_particle_step" in g:
                    row += f" {g['bytes_per_particle_step']:>9.0f} {100 * g['bandwidth_fraction']:>5.1f}%  "
                else:
                    row += f" {'':>9} {'':>6}  "
                row += f"{ag['x']:.1e} {ag['v']:.1e} {ag['stress']:.1e}"
            lines.append(row)
    for r in rows:
        if "gpu" in r:
            continue
        labels = list(r["runs"])
        lines.append(f"\n{r['scene']}: seconds per task over {r['steps']} steps ({' | '.join(labels)}; CPU "
                     f"{r['runs']['cpu']['threads']} threads)")
        for k in r["runs"]["cpu"]["tasks_s"]:
            lines.append(f"  {k:<22} " + " | ".join(f"{r['runs'][lab]['tasks_s'].get(k, 0.0):>9.4f}" for lab in labels))
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--warmup", type=int, default=2)
    ap.add_argument("--sizes", type=float, nargs="+", default=[1e6, 4e6], help="2D column particle counts")
    ap.add_argument("--size3d", type=float, default=1e6)
    ap.add_argument("--tiny", action="store_true", help="2 000 particles, 3 steps (checks the script runs)")
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--bandwidth", type=float, default=H100_BANDWIDTH, help="card bandwidth, bytes/s")
    ap.add_argument("--scatter", nargs="+", default=["atomic", "sorted"], choices=["atomic", "sorted"],
                    help="particle-to-grid scatter methods to run (float64 atomic adds in storage order, or with "
                    "the particles grouped by cell)")
    ap.add_argument("--size-lr", type=float, default=1e6, help="LR two-block column particle count")
    ap.add_argument("--json", type=Path, default=ROOT / "bench" / "gpu.json")
    args = ap.parse_args()
    if args.tiny:
        args.sizes, args.size3d, args.size_lr, args.steps, args.warmup = [2000.0], 1000.0, 2000.0, 3, 1
    from mpmsim.gpu import DeviceError, require_cuda

    try:
        require_cuda()
    except DeviceError as exc:
        raise SystemExit(f"bench/gpu.py: {exc}") from None
    from numba import cuda
    from numba.cuda.core import config as cuda_config

    device = "numba CUDA simulator" if cuda_config.ENABLE_CUDASIM else cuda.get_current_device().name
    device = device.decode() if isinstance(device, bytes) else device
    total = args.steps + args.warmup
    scenes = [(f"column 2D {n:.0e}", column_deck(n, 2, total), False) for n in args.sizes]
    scenes.append((f"two blocks LR {args.size_lr:.0e}", column_deck(args.size_lr, 2, total, "bench/two_blocks.yaml"),
                   True))
    scenes.append((f"column 3D {args.size3d:.0e}", column_deck(args.size3d, 3, total), False))
    rows = []
    for name, d, spread in scenes:
        rows.append(run_scene(name, d, args.steps, args.warmup, args.threads, args.bandwidth, args.scatter, spread))
        print(f"{name}: done", flush=True)
    doc = {"date": datetime.now(timezone.utc).isoformat(timespec="seconds"), "device": str(device),
           "cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(), "threads": args.threads,
           "steps": args.steps, "scatter": args.scatter, "bandwidth": args.bandwidth, "scenes": rows}
    args.json.write_text(json.dumps(doc, indent=1))
    print(table(rows))
    print(f"\n{doc['device']}, {doc['cores']} cores, {doc['date']}; JSON: {args.json}")


if __name__ == "__main__":
    main()
