"""The explicit MPM step on a GPU (mpmsim/gpu) against the CPU path, under numba's CUDA
simulator (NUMBA_ENABLE_CUDASIM=1), in subprocesses: numba.cuda is never imported into this
process. Each option the GPU step supports is in one scene of tests/gpu/cases.py; after a few
steps positions, velocities, stresses, F, every history column and the energy check's sums
(computed on the device) agree with the CPU run to 1e-10 relative (the simulator runs the threads one after another, so here they agree to the
last bit; on a device the atomic adds change the summation order)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from .cases import CASES

pytestmark = pytest.mark.gpu
ROOT = Path(__file__).resolve().parents[2]
TOL = 1e-10


def simulate(*args: str, sim: bool = True) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    env.pop("NUMBA_ENABLE_CUDASIM", None)
    if sim:
        env["NUMBA_ENABLE_CUDASIM"] = "1"
    return subprocess.run([sys.executable, *args], cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)


def last_json(proc: subprocess.CompletedProcess) -> dict:
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def compared():
    return last_json(simulate("-m", "tests.gpu.cases"))


@pytest.mark.parametrize("case", list(CASES))
def test_device_step_matches_cpu(compared, case):
    r = compared[case]
    assert r["moved"] > 1e-6  # the scene did something in its steps
    for quantity in ("x", "v", "stress", "F", "history", "energy"):
        assert r[quantity] <= TOL, (quantity, r[quantity])
    assert r["history_columns"] and r["timers"]  # same history columns, same task names and timers
    if "contact_nodes" in r:  # contact acted, and each node's last contact step (persist) reaches the host
        assert r["contact_nodes"] > 0 and r["contact_force"] > 0.0 and r["contact_step"]


def test_files_and_checkpoint_restart_on_cpu(tmp_path):
    """A device run writes the CPU run's files (VTU, PVD, history CSV and JSON, run log); one
    stopped after 3 (4) steps (the path Ctrl-C takes: StopRequested) leaves a checkpoint that the
    CPU (the device) continues to the CPU run's end."""
    r = last_json(simulate("-m", "tests.gpu.cases", "--files", str(tmp_path)))
    assert r["exit"] == [0] * 6 and r["checkpoint"]
    assert r["files"]["gpu"] == r["files"]["cpu"] == r["files"]["stop"] == r["files"]["stop_gpu"]
    assert "block_run.log" in r["files"]["gpu"] and "block.pvd" in r["files"]["gpu"] and r["log_gpu"]
    assert r["rows_gpu"] == r["rows_stop"] == r["rows_stop_gpu"] == r["rows_cpu"] == 7
    assert max(r["history_gpu"], r["history_stop"], r["history_stop_gpu"]) <= TOL
    assert r["vtu_sizes"]["gpu"] == r["vtu_sizes"]["cpu"]


BAD = """title: t
units: mm-g-ms
analysis: plane_strain
grid: {cell_size: 5.0, boundaries: {ymin: fixed}}
shape_function: cpdi
materials:
  polymer: {type: neo_hookean, K: 2450.0, G: 940.0, density: 0.001}
bodies:
  - {shape: rectangle, min: [0.0, 0.0], max: [20.0, 20.0], material: polymer}
time: {end: 1.0}
update: {scheme: xpic, order: 2}
"""


def test_check_refuses_what_the_gpu_lacks_naming_the_key(tmp_path):
    deck = tmp_path / "bad.yaml"
    deck.write_text(BAD)
    for command in ("check", "run"):
        args = ("--out", str(tmp_path / "o")) if command == "run" else ()
        p = simulate("-m", "mpmsim", command, str(deck), "--device", "cuda", *args, sim=False)
        assert p.returncode == 2, p.stderr
        assert "Traceback" not in p.stderr
        lines = [ln for ln in p.stderr.splitlines() if "not on the GPU yet" in ln]
        assert [ln.split(": ")[1] for ln in lines] == ["shape_function", "update.scheme"]
        assert all(ln.startswith(f"{deck}, line ") for ln in lines)
        assert not (tmp_path / "o").exists()


CONTACT_BAD = """title: t
units: mm-g-ms
analysis: plane_strain
grid: {cell_size: 5.0, boundaries: {ymin: fixed}}
shape_function: gimp
materials:
  lower: {type: neo_hookean, K: 2450.0, G: 940.0, density: 0.001}
  upper: {type: neo_hookean, K: 2450.0, G: 940.0, density: 0.001}
  platen: {type: rigid, velocity: [0.0, -1.0], mode: contact}
bodies:
  - {shape: rectangle, min: [0.0, 0.0], max: [20.0, 20.0], material: lower}
  - {shape: rectangle, min: [0.0, 20.0], max: [20.0, 40.0], material: upper}
  - {shape: rectangle, min: [0.0, 40.0], max: [20.0, 45.0], material: platen}
contact:
  normal: logistic_regression
  warm_start: true
  default: {law: coulomb, friction: 0.2}
  pairs:
    - {between: [lower, upper], law: interface, Dn: 1.0e3, Dt: 1.0e3}
time: {end: 1.0}
"""


def test_check_refuses_the_contact_options_the_gpu_lacks(tmp_path):
    """Grid contact runs on the GPU (mpmsim/gpu/contact.py) except rigid contact materials,
    interface and plugin laws, warm-started regressions and the traction output: each is
    refused with one line naming its key; the rest of the contact deck passes."""
    deck = tmp_path / "bad.yaml"
    deck.write_text(CONTACT_BAD)
    p = simulate("-m", "mpmsim", "check", str(deck), "--device", "cuda", sim=False)
    assert p.returncode == 2 and "Traceback" not in p.stderr, p.stderr
    lines = [ln for ln in p.stderr.splitlines() if "not on the GPU yet" in ln]
    assert [ln.split(": ")[1] for ln in lines] == ["materials.platen.mode", "contact.pairs.0.law",
                                                   "contact.warm_start"]
    ok = CONTACT_BAD.replace(", mode: contact", "").replace("  warm_start: true\n", "").replace(
        "law: interface, Dn: 1.0e3, Dt: 1.0e3", "law: frictionless")
    deck.write_text(ok)
    p = simulate("-m", "mpmsim", "check", str(deck), "--device", "cuda", "--no-probe", sim=False)
    assert p.returncode == 0, p.stderr
    assert "device cuda: everything this deck asks for runs on the GPU step" in p.stdout


def test_check_of_a_supported_deck_needs_no_gpu():
    """`check --device cuda` answers where no GPU is (deck preparation): the column runs there."""
    p = simulate("-m", "mpmsim", "check", "inputs/column.yaml", "--device", "cuda", "--no-probe", sim=False)
    assert p.returncode == 0, p.stderr
    assert "device cuda: everything this deck asks for runs on the GPU step" in p.stdout


def test_no_cuda_driver_is_one_line(tmp_path):
    """Without a driver (this machine, outside the simulator) --device cuda stops with one line, exit 2."""
    p = simulate("-m", "mpmsim", "run", "inputs/column.yaml", "--device", "cuda", "-q", "--steps", "1",
                 "--out", str(tmp_path / "o"), sim=False)
    if p.returncode == 0:  # pragma: no cover - a machine with a GPU runs it
        return
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert [ln for ln in p.stderr.splitlines() if ln.strip()] == [
        "mpmsim: --device cuda: no CUDA driver or GPU found on this machine (numba.cuda.is_available() is false; "
        "NUMBA_ENABLE_CUDASIM=1 runs numba's CUDA simulator, slowly)"]


def test_faults_stop_the_run_with_the_cpu_message():
    """A platen driven into the block at 20 m/s inverts a particle in the first step, at 10 m/s
    pushes one out of the grid at step 7: each device stops at the same step with the same
    message (fault slots and the first flagged particle, mpmsim/gpu/kernels.py)."""
    r = last_json(simulate("-m", "tests.gpu.cases", "--faults", "20000", "10000"))
    assert "J = 0 <= 0: the particle inverted" in r["20000"]["cpu"]
    assert "the particle left the grid domain" in r["10000"]["cpu"]
    assert all(v["cpu"] == v["cuda"] for v in r.values())


def test_rigid_penetration_watch_on_the_device():
    """A particle moved inside a rigid body (on the device) is found by the device's lattice
    test and reported as the CPU reports it."""
    r = last_json(simulate("-m", "tests.gpu.cases", "--penetration"))
    assert "is inside rigid material 'platen'" in r["cpu"] and r["cuda"] == r["cpu"]


def test_the_cpu_path_does_not_import_cuda():
    """numba.cuda (seconds of import) is loaded only when a run asks for --device cuda."""
    code = ("import sys; from mpmsim.solver import Simulation; "
            "sim = Simulation.from_deck('inputs/column.yaml', threads=1); sim.step(); "
            "print(sorted(m for m in sys.modules if m.startswith(('numba.cuda', 'numba_cuda', 'mpmsim.gpu'))))")
    p = simulate("-c", code, sim=False)
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip().splitlines()[-1] == "[]"
