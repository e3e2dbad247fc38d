"""Scenes of the GPU tests (tests/gpu): small decks, one per option group, and the comparison
of a CUDA run (numba's simulator in CI) with the CPU run of the same deck.

Run as a module in a subprocess with NUMBA_ENABLE_CUDASIM=1 (tests/gpu/test_gpu.py): it
prints one JSON line {case: {quantity: largest relative difference}}, so numba.cuda is never
imported into the test process.
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np

STEPS = 3


def deck(dim: int = 2, shape: str = "gimp", scheme: str = "flip", stress: str = "usavg", material: str = "neo_hookean",
         reextrapolate: bool = True, position: str = "midpoint", boundaries: dict | None = None,
         gravity: bool = False, platen: bool = True, damping: float = 0.0) -> dict:
    """A block of 4 x 4 (3D: 2 x 2 x 2) cells of 2 mm, 2 particles per cell and direction, on a fixed
    floor, pressed by a rigid platen (or free) and pulled by gravity if asked; fixed dt."""
    mat = ({"type": "neo_hookean", "K": 2450.0, "G": 940.0, "density": 0.001} if material == "neo_hookean"
           else {"type": "linear_elastic", "E": 2000.0, "nu": 0.3, "density": 0.001})
    lo, hi = [0.0] * dim, [8.0, 8.0] if dim == 2 else [4.0, 4.0, 4.0]
    up = dim - 1  # the vertical axis
    top = list(lo)
    top[up] = hi[up]
    top_hi = list(hi)
    top_hi[up] = hi[up] + 1.0
    v = [0.0] * dim
    v[up] = -0.9622
    bodies = [{"shape": "rectangle" if dim == 2 else "box", "min": lo, "max": hi, "material": "block",
               "velocity": [0.3] + [0.0] * (dim - 1)}]
    materials = {"block": mat}
    if platen:
        materials["platen"] = {"type": "rigid", "velocity": v}
        bodies.append({"shape": "rectangle" if dim == 2 else "box", "min": top, "max": top_hi, "material": "platen"})
    d = {
        "title": "GPU test block", "units": "mm-g-ms", "analysis": "plane_strain" if dim == 2 else "3d",
        "grid": {"cell_size": 2.0, "boundaries": boundaries if boundaries is not None else {("ymin" if dim == 2 else "zmin"): "fixed"},
                 "domain": {"min": [-4.0] * dim, "max": [12.0, 12.0]} if dim == 2 else {"min": [-2.0] * 3, "max": [6.0] * 3}},
        "shape_function": shape, "particles_per_direction": 2, "materials": materials, "bodies": bodies,
        "time": {"end": 1.0, "dt": 2e-4},
        "update": {"scheme": scheme, "stress": stress, "reextrapolate": reextrapolate, "position": position},
        "output": {"history_interval": 2e-4},
        "stability": {"check_every": 1},  # (the energy check every step: on a GPU, from the device)
    }
    if gravity:
        d["gravity"] = [0.0] * (dim - 1) + [-9.81e-3]
    if damping:
        d["damping"] = {"grid": damping}
    return d


CASES = {
    "gimp-flip-usavg-neohookean-rigid": deck(),
    "linear-pic-usl-elastic-gravity-roller-damped": deck(shape="linear", scheme="pic", stress="usl",
                                                         material="linear_elastic", gravity=True, platen=False,
                                                         damping=50.0,  # 1% of the momentum per step
                                                         boundaries={"ymin": "roller", "xmin": "roller",
                                                                     "xmax": "roller"}),
    "bspline2-apic-usf-elastic-walls": deck(shape="bspline2", scheme="apic", stress="usf", material="linear_elastic",
                                            boundaries={"ymin": "fixed", "xmin": "fixed", "xmax": "roller"}),
    "bspline2-flip-usavg-minus-updated": deck(shape="bspline2", reextrapolate=False, position="updated"),
    "gimp-apic-usl-plus-elastic": deck(scheme="apic", stress="usl", material="linear_elastic"),
    "3d-gimp-flip-usavg-neohookean-rigid": deck(dim=3),
    "3d-bspline2-apic-usl-elastic-walls-gravity": deck(dim=3, shape="bspline2", scheme="apic", stress="usl",
                                                       material="linear_elastic", gravity=True,
                                                       boundaries={"zmin": "fixed", "xmin": "roller", "ymax": "fixed"}),
}


def two_blocks(contact: dict, dim: int = 2, split: str = "y", walls: bool = False, **kw) -> dict:
    """deck(**kw) with the block cut in two materials on a grid line (y = 4 mm, 3D: z = 2 mm;
    split "x": x = 2 mm, beside the xmin face), the second block sliding over the first at
    0.5 mm/ms (and 0.3 mm/ms into it), in contact by `contact`. walls: the domain starts at
    the block (x, y >= 0), so material slots sit on wall nodes and ghost slots mirror them."""
    d = deck(dim=dim, **kw)
    d["materials"]["upper"] = dict(d["materials"]["block"])
    body = d["bodies"][0]
    axis = {"x": 0, "y": 1}[split] if dim == 2 else 2
    cut = 2.0 if split == "x" else (4.0 if dim == 2 else 2.0)
    lower, upper = dict(body, max=list(body["max"]), velocity=[0.0] * dim), dict(body, min=list(body["min"]))
    lower["max"][axis] = cut
    upper["min"][axis] = cut
    upper["material"] = "upper"
    v = [0.0] * dim
    v[0 if axis != 0 else 1] = 0.5  # sliding along the interface ...
    v[axis] = -0.3  # ... and pressed onto it
    upper["velocity"] = v
    d["bodies"] = [lower, upper] + d["bodies"][1:]
    d["contact"] = contact
    if walls:
        d["grid"]["domain"]["min"] = [0.0] * dim
    return d


CONTACT = {
    "contact-lr-coulomb-gimp-flip-usavg": two_blocks({"normal": "logistic_regression",
                                                      "default": {"law": "coulomb", "friction": 0.2}}),
    "contact-specified-frictionless-displacement-linear-pic-usl": two_blocks(
        {"normal": "specified", "normal_vector": [0.0, 1.0], "separation": "displacement",
         "default": {"law": "frictionless"}}, shape="linear", scheme="pic", stress="usl", material="linear_elastic"),
    "contact-gradient-stick-recheck-bspline2-apic-updated-walls": two_blocks(
        {"normal": "average_gradient", "separation": "cutoff", "pass_3": "recheck",
         "default": {"law": "coulomb", "friction": 0.4}, "pairs": [{"between": ["block", "upper"], "law": "stick"}]},
        split="x", walls=True, shape="bspline2", scheme="apic", stress="usl", position="updated",
        boundaries={"xmin": "fixed", "ymin": "roller"}),
    "contact-lr-fit-coulomb-static-gimp-flip-usavg-one-pass": two_blocks(
        {"normal": "logistic_regression", "separation": "fit", "passes": 1,
         "default": {"law": "coulomb", "friction": 0.3, "static_friction": 0.5}}),
    "3d-contact-lr-coulomb-gimp-flip-usavg": two_blocks({"normal": "logistic_regression",
                                                         "default": {"law": "coulomb", "friction": 0.2}}, dim=3),
}
CASES.update(CONTACT)

SORTED = {"gimp-flip-usavg-neohookean-rigid-sorted-scatter": "gimp-flip-usavg-neohookean-rigid",
          "contact-lr-coulomb-gimp-flip-usavg-sorted-scatter": "contact-lr-coulomb-gimp-flip-usavg"}
CASES.update({name: CASES[base] for name, base in SORTED.items()})  # the same scenes, scatter="sorted"


def relative(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    scale = np.max(np.abs(a)) if a.size else 0.0
    return float(np.max(np.abs(a - b)) / scale) if scale > 0 else float(np.max(np.abs(a - b), initial=0.0))


def compare(d: dict, steps: int = STEPS, scatter: str = "atomic") -> dict:
    """Largest relative difference (array-wise: max |cpu - gpu| / max |cpu|) of positions,
    velocities, stresses, F and every history column after `steps` steps."""
    from mpmsim.solver import Simulation

    out = {}
    runs = {}
    for device in ("cpu", "cuda"):
        sim = Simulation.from_deck(d, threads=1, name="block", device=device)
        if device == "cuda":  # (sorted: grouped by cell again every 2 steps)
            sim.integrator.device.scatter, sim.integrator.device.sort_every = scatter, 2
        sim.recorder.record(sim.state)
        for _ in range(steps):
            sim.step()
            sim._record()
        runs[device] = sim
    cpu, gpu = runs["cpu"], runs["cuda"]
    a, b = cpu.particles, gpu.particles
    for k in ("x", "v", "stress", "F"):
        out[k] = relative(a[k], b[k])
    ha, hb = cpu.history, gpu.history
    # a column's scale is the largest of its group (F_platen_x, _y, _z): a component that is zero
    # but for round-off (the platen's sideways force) is compared on the group's scale
    group = lambda c: c.rsplit("_", 1)[0]  # noqa: E731
    scale = {}
    for c in ha.columns:
        scale[group(c)] = max(scale.get(group(c), 0.0), float(np.max(np.abs(ha[c]))))
    out["history"] = max(float(np.max(np.abs(ha[c] - hb[c]))) / (scale[group(c)] or 1.0)
                         for c in ha.columns if c != "wall_s")
    out["history_columns"] = list(ha.columns) == list(hb.columns)
    out["timers"] = list(cpu.integrator.timers) == list(gpu.integrator.timers)
    from mpmsim.bodies import KINETIC, STRAIN

    sc, sg = cpu.state.particles.sums(cpu.state, False), gpu.state.particles.device_sums(gpu.state)
    out["energy"] = max(abs(sc.total[i] - sg.total[i]) / abs(sc.total[i]) for i in (KINETIC, STRAIN))
    out["moved"] = relative(a["x"], np.asarray(cpu.state.particles.x0)) if hasattr(cpu.state.particles, "x0") else 0
    if cpu.state.contact is not None:  # contact acted: contact nodes and a force between the materials
        cs = cpu.state.contact
        out["contact_nodes"] = int(cs.n_cn)
        out["contact_force"] = float(np.abs(cs.pair_force).max())
        gpu.integrator.to_host(gpu.state)  # each node's last contact step (a checkpoint's)
        out["contact_step"] = bool(np.array_equal(cs.contact_step, gpu.state.contact.contact_step))
    return out


def faults(speed: float, max_steps: int = 40) -> dict:
    """The message each device stops with when the platen is driven into the block at `speed`
    (mm/ms): the first step whose check fails, and what it says."""
    from mpmsim.errors import InstabilityError
    from mpmsim.solver import Simulation

    d = deck(material="linear_elastic")
    d["materials"]["platen"]["velocity"] = [0.0, -speed]
    out = {}
    for device in ("cpu", "cuda"):
        sim = Simulation.from_deck(d, threads=1, name="block", device=device)
        try:
            for _ in range(max_steps):
                sim.step()
            out[device] = "no stop"
        except InstabilityError as exc:
            out[device] = str(exc)
    return out


def penetration() -> dict:
    """The rigid-penetration watch (bodies/rigid.py) on each device: after a step, particle 5 is
    put at the centre of a platen three particles thick; the stability check's message."""
    from mpmsim.errors import InstabilityError
    from mpmsim.solver import Simulation

    d = deck()
    d["bodies"][1]["max"][1] = 11.0
    out = {}
    for device in ("cpu", "cuda"):
        sim = Simulation.from_deck(d, threads=1, name="block", device=device)
        sim.step()
        st = sim.state
        sim.integrator.to_host(st)
        st.particles.x[5] = st.rigid.x.mean(axis=0)
        if device == "cuda":
            sim.integrator.device.d["x"].copy_to_device(st.particles.x)
        try:
            sim.check(st)
            out[device] = "no stop"
        except InstabilityError as exc:
            out[device] = str(exc)
    return out


def cli(*args: str) -> int:
    """`mpmsim ARGS` in this process (the simulator's environment); its exit code."""
    from typer.testing import CliRunner

    from mpmsim.cli import app

    return CliRunner().invoke(app, list(args)).exit_code


def files(folder: str) -> dict:
    """The column-like block run to the end on the CPU and on the device, and run 3 (4) steps on
    the device (`--steps`: a checkpoint, as Ctrl-C leaves) then restarted on the CPU (on the
    device): exit codes,
    the files each folder holds, and the largest relative difference of the history and the
    final particles from the CPU run."""
    from pathlib import Path

    import pandas as pd
    import yaml

    from mpmsim.output.checkpoint import checkpoint_path

    root = Path(folder)
    d = deck()
    d["time"]["end"] = 6 * d["time"]["dt"]
    d["output"]["vtu_interval"] = 2 * d["time"]["dt"]
    path = root / "block.yaml"
    path.write_text(yaml.safe_dump(d))
    out = {"exit": [cli("run", str(path), "--out", str(root / "cpu"), "-q", "--threads", "1"),
                    cli("run", str(path), "--out", str(root / "gpu"), "-q", "--threads", "1", "--device", "cuda"),
                    cli("run", str(path), "--out", str(root / "stop"), "-q", "--threads", "1", "--device", "cuda",
                        "--steps", "3")]}
    out["exit"].append(cli("run", str(path), "--out", str(root / "stop_gpu"), "-q", "--threads", "1", "--device",
                           "cuda", "--steps", "4"))
    out["checkpoint"] = all(checkpoint_path(root / k, "block").exists() for k in ("stop", "stop_gpu"))
    out["exit"].append(cli("run", str(path), "--restart", str(root / "stop"), "-q", "--threads", "1"))
    out["exit"].append(cli("run", str(path), "--restart", str(root / "stop_gpu"), "-q", "--threads", "1", "--device",
                           "cuda"))
    runs = ("cpu", "gpu", "stop", "stop_gpu")
    out["files"] = {k: sorted(f.name for f in (root / k).iterdir()) for k in runs}
    hist = {k: pd.read_csv(root / k / "block_history.csv") for k in runs}
    cols = [c for c in hist["cpu"].columns if not c.startswith("wall")]
    for k in runs[1:]:
        out[f"history_{k}"] = max(relative(hist["cpu"][c], hist[k][c]) for c in cols if hist["cpu"][c].abs().max() > 0)
        out[f"rows_{k}"] = len(hist[k])
    out["rows_cpu"] = len(hist["cpu"])
    out["vtu_sizes"] = {k: sorted((f.name, f.stat().st_size) for f in (root / k).glob("*.vtu")) for k in ("cpu", "gpu")}
    out["log_gpu"] = "device: cuda" in (root / "gpu" / "block_run.log").read_text()
    return out


if __name__ == "__main__":
    if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1":
        from tests.gpu.simulator import run_single_thread_blocks

        run_single_thread_blocks()
    if sys.argv[1:2] == ["--files"]:
        print(json.dumps(files(sys.argv[2])))
    elif sys.argv[1:2] == ["--penetration"]:
        print(json.dumps(penetration()))
    elif sys.argv[1:2] == ["--faults"]:
        print(json.dumps({speed: faults(float(speed)) for speed in sys.argv[2:]}))
    else:
        names = sys.argv[1:] or list(CASES)
        print(json.dumps({n: compare(CASES[n], scatter="sorted" if n in SORTED else "atomic") for n in names}))
