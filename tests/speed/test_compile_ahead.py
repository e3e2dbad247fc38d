"""A first step compiled in two processes (mpmsim/compile_ahead.py): the step's results are
those of one process, every kernel is compiled once by one of the two, a task the dry step
stumbles in ends alone, and a scene's first step through Simulation.first_step equals step().

How much faster the first step is, is a timing: bench/coldstart.py measures `mpmsim compile`
with and without the helper (docs/performance.md, "Cold start")."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from mpmsim import compile_ahead
from mpmsim.deck import load_deck
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation

from ..conftest import ROOT

pytestmark = [pytest.mark.speed,
              pytest.mark.skipif(not compile_ahead.available(), reason="needs fork and two cores")]

# Four kernels a toy step calls in three parts. Part one uses a kernel's result as an index
# array (the dry step stumbles there: that part ends, the next goes on); part three calls two.
KERNELS = '''
import numpy as np
from numba import njit

@njit(cache=True)
def nonzero_rows(a):
    return np.nonzero(a > 0.5)[0]

@njit(cache=True)
def scale(a, s):
    for i in range(a.size):
        a[i] = a[i] * s + np.sin(a[i]) * np.cos(a[i] * s)

@njit(cache=True)
def total(a):
    t = 0.0
    for i in range(a.size):
        t += np.exp(-a[i] * a[i]) + np.tanh(a[i])
    return t

@njit(cache=True)
def smooth(a, b):
    n = a.size
    for i in range(1, n - 1):
        b[i] = 0.25 * a[i - 1] + 0.5 * a[i] + 0.25 * a[i + 1]
    return b.sum()
'''

STEP = '''
import json, os, sys
import numpy as np
from numba.core import event
sys.path.insert(0, sys.argv[1])
import toykernels as k
from mpmsim import compile_ahead

a = np.linspace(0.0, 1.0, 101)
b = np.zeros_like(a)
out = {}

def part_index():
    rows = k.nonzero_rows(a)
    b[rows.astype(np.int64)] = 1.0  # in the dry step `rows` is no array: this part ends here

def part_scale():
    k.scale(a, 1.5)

def part_sums():
    out["total"] = k.total(a)
    out["smooth"] = k.smooth(a, b)

def step():
    for part in (part_index, part_scale, part_sums):
        part()

with event.install_recorder("numba:compile") as rec:
    report = compile_ahead.first_step(step, [part_index, part_scale, part_sums], enabled=sys.argv[2] == "1")
here = sorted({e.data["dispatcher"].py_func.__name__ for _, e in rec.buffer
               if e.is_start and e.data["dispatcher"].py_func.__module__ == "toykernels"})
print(json.dumps({"report": report, "here": here, "a": a.tolist(), "b": b.tolist(), **out}))
'''


def toy_step(tmp_path, helper: bool) -> dict:
    """The toy step in a fresh process on an empty kernel cache."""
    src = tmp_path / "src"
    src.mkdir(exist_ok=True)
    (src / "toykernels.py").write_text(KERNELS)
    cache = tmp_path / f"cache-{int(helper)}"
    log = tmp_path / f"helper-{int(helper)}.log"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(ROOT), "MPMSIM_COMPILE_HELPER": "1",
           "MPMSIM_COMPILE_HELPER_LOG": str(log)}
    run = subprocess.run([sys.executable, "-c", textwrap.dedent(STEP), str(src), "1" if helper else "0"],
                         capture_output=True, text=True, timeout=600, env=env)
    assert run.returncode == 0, run.stderr[-2000:]
    result = json.loads(run.stdout.splitlines()[-1])
    result["log"] = log.read_text() if log.exists() else ""
    return result


def test_two_processes_compile_each_kernel_once_and_give_one_process_results(tmp_path):
    alone = toy_step(tmp_path, helper=False)
    shared = toy_step(tmp_path, helper=True)
    assert not alone["report"]["helper"] and shared["report"]["helper"]
    for key in ("a", "b", "total", "smooth"):
        assert shared[key] == alone[key], key  # the same numbers, to the last bit
    kernels = {"nonzero_rows", "scale", "total", "smooth"}
    assert set(alone["here"]) == kernels
    # the helper's dry step recorded the three kernels after the stumbling part too (four in all)
    assert "dry step: 4 kernels to compile" in shared["log"], shared["log"]
    # each kernel compiled once, here or in the helper: what this process compiled and what the
    # helper said it compiled are disjoint and together the four
    by_helper = {line.split()[2].rstrip(":") for line in shared["log"].splitlines() if line.endswith(" s") and
                 "compiled in" in line}
    claimed = {line.split()[2].rstrip(":") for line in shared["log"].splitlines() if "claimed by the parent" in line}
    assert by_helper | claimed == kernels and not by_helper & claimed, shared["log"]  # none failed in the helper
    assert not by_helper & set(shared["here"]), (by_helper, shared["here"])
    assert by_helper | set(shared["here"]) == kernels, (by_helper, shared["here"])
    rep = shared["report"]
    assert rep["compiled_here"] + rep["compiled_ahead"] + rep["waited"] >= len(set(shared["here"]))


def test_dry_results_are_falsy_zeros_that_stop_an_unpacking_part():
    unknown = compile_ahead._Unknown()
    assert not unknown and int(unknown) == 0 and float(unknown) == 0.0
    assert unknown + 1 is unknown and 2 * unknown is unknown and unknown.anything is unknown
    with pytest.raises(TypeError):
        n, m = unknown


DRY = """
import json, sys
from mpmsim import compile_ahead
from mpmsim.deck import load_deck
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation
sim = Simulation(build_scene(load_deck(sys.argv[1])), out_dir=None, threads=1)
sim._begin_step()
recorded = compile_ahead.dry_run(sim.integrator.dry_parts(sim.state))
print(json.dumps(sorted({d.py_func.__name__ for d, _ in recorded.values()})))
"""


@pytest.mark.parametrize("deck, largest", [
    ("two_blocks", {"geometry_kernel", "pass_2_kernel", "exchange_pass", "tensor_shape_functions"}),
    ("implicit_blocks_2d", {"element_hessians", "internal_forces", "element_energies"})])
def test_the_dry_step_records_a_scene_s_largest_kernels(deck, largest):
    """What the helper learns from the dry step (a fresh process, where no kernel is loaded
    yet): the explicit step's tasks and the implicit step's energy terms each alone, so a task
    that stumbles does not hide the kernels of the next. The kernels named are the largest
    compiles of these scenes (docs/performance.md)."""
    env = {**os.environ, "NUMBA_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
    run = subprocess.run([sys.executable, "-c", DRY, str(ROOT / "inputs" / f"{deck}.yaml")], capture_output=True,
                         text=True, timeout=600, env=env)
    assert run.returncode == 0, run.stderr[-2000:]
    recorded = set(json.loads(run.stdout.splitlines()[-1]))
    assert largest <= recorded, (largest - recorded, recorded)


@pytest.mark.parametrize("deck", ["two_blocks", "implicit_blocks_2d"])
def test_a_scene_first_step_with_the_helper_equals_step(deck):
    """Simulation.first_step (the CLI's first step) against step(): the same state to the last
    bit (the kernels are loaded from the suite's cache here; the helper still runs its dry step
    and loads them). The implicit step's terms are made before the fork (dry_parts) and its
    a^0 in the step, as step() does them."""
    loaded = load_deck(ROOT / "inputs" / f"{deck}.yaml")
    plain = Simulation(build_scene(loaded), out_dir=None, threads=1)
    plain.step()
    helped = Simulation(build_scene(loaded), out_dir=None, threads=1)
    report = helped.first_step(helper=True)
    assert report["helper"]
    pairs = [(helped.state.particles, plain.state.particles, ("x", "v", "F", "stress"))]
    if plain.state.fem is not None:
        pairs.append((helped.state.fem, plain.state.fem, ("x", "v", "a")))
    for a, b, names in pairs:
        for name in names:
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert helped.state.t == plain.state.t and helped.state.step == plain.state.step == 1


# The kernels (name, signature) a process has ready after `mpmsim compile DECK`, or after
# running DECK for 12 steps with its output (past the first energy check, every 10 steps):
# loaded from the cache or compiled, whichever; so the comparison does not depend on the cache.
USED = '''
import json, sys, tempfile
from pathlib import Path
import numba
from numba.core.registry import CPUDispatcher
what, deck = sys.argv[1], sys.argv[2]
if what == "compile":
    from mpmsim.cli import app
    try:
        app(["compile", deck], standalone_mode=False)
    except SystemExit as exc:
        assert not exc.code, exc.code
else:
    from mpmsim.cli import _load_scene
    from mpmsim.parallel import auto_threads
    from mpmsim.solver import Simulation, StopRequested
    scene = _load_scene(Path(deck))
    threads, _ = auto_threads(2, len(scene.deformable.x))
    with tempfile.TemporaryDirectory() as tmp:
        sim = Simulation(scene, out_dir=Path(tmp), threads=threads)
        def stop():
            if sim.state.step >= 12:
                raise StopRequested()
        try:
            sim.run(between_steps=stop)
        except StopRequested:
            pass
import gc
ready = sorted({f"{d.py_func.__module__}.{d.py_func.__qualname__} {sig}"
                for d in gc.get_objects() if isinstance(d, CPUDispatcher) for sig in d.overloads})
print(json.dumps(ready))
'''


@pytest.mark.parametrize("deck", ["two_blocks", "disks"])
def test_mpmsim_compile_readies_every_kernel_a_run_calls(deck):
    """`mpmsim compile DECK` starts the run as `mpmsim run` does (energy sums, first history row
    and frame, first step), so a run afterwards compiles nothing: every kernel a 12-step run with
    its output calls, compile had ready (the energy check, the history and the VTU frame
    included)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPMSIM_COMPILE_HELPER": "0", "NUMBA_NUM_THREADS": "2"}
    path = str(ROOT / "inputs" / f"{deck}.yaml")
    ready = {}
    for what in ("compile", "run"):
        run = subprocess.run([sys.executable, "-c", USED, what, path], capture_output=True, text=True,
                             timeout=900, env=env)
        assert run.returncode == 0, run.stderr[-3000:]
        ready[what] = set(json.loads(run.stdout.strip().splitlines()[-1]))
    assert ready["run"], "the run called no kernel"
    missing = sorted(ready["run"] - ready["compile"])
    assert not missing, f"a run after mpmsim compile still compiles: {missing}"
