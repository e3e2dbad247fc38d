"""Benchmark: mpmsim beside the reference code (NairnMPM) on the benchmark column and the LR
two-block column, one thread, runs alternated in one sitting.

Each round runs, for every scene, NairnMPM on the input bench/nairnmpm/make_inputs.py writes
for that cell size and step count, then mpmsim on the same deck (`bench/<scene>.yaml` at that
cell size), then, with `--old DIR`, the mpmsim of another checkout (an earlier commit, to
measure a speed-up beside the reference in the same sitting). Every run is a fresh process on
one thread. Rates are particle-steps per second of the 16 000 (or 256 000) deformable particles:
NairnMPM's from the sum of its per-task elapsed times per step (its listing's `Task #k` lines:
the step without setup and archives); mpmsim's from the wall time of `steps` steps after a
warm-up of three (kernels loaded or compiled before the timing, as bench/column.py does).
Medians over the rounds, the ratios of the medians.

    python bench/reference.py --nairnmpm /path/to/NairnMPM [--old /path/to/other/checkout]
                              [--rounds 3] [--scenes column:1 two_blocks:1 column:0.25 two_blocks:0.25]
                              [--json out.json]

Scene `name:cell` (mm); steps: 400 at 1 mm, 30 at 0.25 mm (`--steps` sets one count for all).
Build the reference code as bench/nairnmpm/README.md says. The two-block deck keeps mpmsim's
default third contact pass (`persist`, which recomputes the contact geometry as NairnMPM's
re-test after the re-extrapolation does); the remaining differences are in that README.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from machine import cpu_model  # (bench/machine.py: run as python bench/reference.py)

ROOT = Path(__file__).resolve().parents[1]
STEPS = {1.0: 400, 0.25: 30}

MPMSIM = r"""
import json, sys, time
from pathlib import Path
import numba, yaml
numba.set_num_threads(1)
from mpmsim.deck import load_deck_text
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation
from mpmsim.stability import total_sums
deck, cell, steps = sys.argv[1], float(sys.argv[2]), int(sys.argv[3])
data = yaml.safe_load(open(deck).read())
data["grid"]["cell_size"] = cell
sim = Simulation(build_scene(load_deck_text(yaml.safe_dump(data), Path(deck))), out_dir=None, threads=1)
total_sums(sim.state)
for _ in range(3):
    sim.step()
t0 = time.perf_counter()
for _ in range(steps):
    sim.step()
wall = time.perf_counter() - t0
print(json.dumps({"particles": int(sim.state.particles.n), "wall": wall}))
"""


def nairnmpm_rate(binary: str, scene: str, cell: float, steps: int) -> tuple[float, int]:
    """(particle-steps/s of the deformable particles, their number) of one NairnMPM run."""
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, str(ROOT / "bench" / "nairnmpm" / "make_inputs.py"), "--cell", str(cell),
                        "--steps", str(steps), "--scene", scene, "--out", tmp], check=True, capture_output=True)
        xml = next(Path(tmp).glob(f"{scene}_h*.xml"))
        (Path(tmp) / "NairnMPM.dtd").write_text((ROOT / "bench" / "nairnmpm" / "NairnMPM.dtd").read_text())
        run = subprocess.run([binary, "-np", "1", "-w", xml.name], cwd=tmp, capture_output=True, text=True,
                             timeout=3600)
        if run.returncode != 0:
            raise SystemExit(f"NairnMPM failed on {xml.name}: {run.stderr[-500:] or run.stdout[-500:]}")
        listing = run.stdout
    per_step_ms = sum(float(m.group(1)) for m in re.finditer(
        r"Task #\d+: .*?: [\d.eE+-]+ CPU_ms/step \([^)]*\), ([\d.eE+-]+) ms/step", listing))
    if per_step_ms <= 0:
        raise SystemExit("NairnMPM printed no per-task times (`Task #k:` lines) in its listing")
    particles = deformable_particles(listing)
    return particles / (per_step_ms * 1e-3), particles


def deformable_particles(listing: str) -> int:
    """The listing's count of non-rigid particles (its line `Nonrigid:N Rigid contact:.. Rigid BC:..`)."""
    m = re.search(r"Nonrigid:\s*(\d+)", listing)
    if not m:
        raise SystemExit("no particle count (`Nonrigid:`) in NairnMPM's listing")
    return int(m.group(1))


def mpmsim_rate(tree: Path, scene: str, cell: float, steps: int) -> tuple[float, int]:
    env = {**os.environ, "PYTHONPATH": str(tree), "NUMBA_NUM_THREADS": "1"}
    run = subprocess.run([sys.executable, "-c", MPMSIM, str(ROOT / "bench" / f"{scene}.yaml"), str(cell), str(steps)],
                         capture_output=True, text=True, env=env, timeout=3600, cwd=str(tree))
    if run.returncode != 0:
        raise SystemExit(f"mpmsim ({tree}) failed on {scene}: {run.stderr[-800:]}")
    out = json.loads(run.stdout.splitlines()[-1])
    return out["particles"] * steps / out["wall"], out["particles"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nairnmpm", required=True, help="the NairnMPM binary")
    ap.add_argument("--old", type=Path, help="another mpmsim checkout to time in the same rounds")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--scenes", nargs="+", default=["column:1", "two_blocks:1", "column:0.25", "two_blocks:0.25"])
    ap.add_argument("--steps", type=int, help="steps per run (default: 400 at 1 mm, 30 at 0.25 mm)")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    codes = {"NairnMPM": None, "mpmsim": ROOT}
    if args.old:
        codes["mpmsim (old)"] = args.old.resolve()
    scenes = [(s.split(":")[0], float(s.split(":")[1])) for s in args.scenes]
    print(f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, {platform.node()}, "
          f"{cpu_model()}, 1 thread, {args.rounds} alternated rounds")
    rates: dict = {(sc, cell, code): [] for sc, cell in scenes for code in codes}
    for r in range(args.rounds):
        for sc, cell in scenes:
            steps = args.steps or STEPS.get(cell, 100)
            for code, tree in codes.items():
                rate, n = (nairnmpm_rate(args.nairnmpm, sc, cell, steps) if tree is None
                           else mpmsim_rate(tree, sc, cell, steps))
                rates[(sc, cell, code)].append(rate)
                print(f"round {r + 1}: {sc} {cell:g} mm ({n} particles, {steps} steps) {code}: {rate / 1e6:.3f} M/s",
                      flush=True)
    print("\n| scene | particles | " + " | ".join(f"{c}, M particle-steps/s (runs)" for c in codes)
          + " | mpmsim / NairnMPM" + (" | mpmsim / old" if args.old else "") + " |")
    print("|---" * (3 + len(codes) + (1 if args.old else 0)) + "|")
    summary = {}
    for sc, cell in scenes:
        med = {c: statistics.median(rates[(sc, cell, c)]) for c in codes}
        runs = " | ".join(f"**{med[c] / 1e6:.2f}** ({', '.join(f'{v / 1e6:.2f}' for v in rates[(sc, cell, c)])})"
                          for c in codes)
        ratio = f" | ×{med['mpmsim'] / med['NairnMPM']:.2f}"
        old = f" | ×{med['mpmsim'] / med['mpmsim (old)']:.2f}" if args.old else ""
        n = 16_000 * round(1.0 / cell) ** 2
        print(f"| {sc}, {cell:g} mm | {n} | {runs}{ratio}{old} |")
        summary[f"{sc}:{cell:g}"] = {c: rates[(sc, cell, c)] for c in codes}
    if args.json:
        args.json.write_text(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
