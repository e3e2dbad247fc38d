"""Kernels compiled per scene: only the scene's kernels, the cache across processes, and the
serial and parallel forms of the chunk kernels (mpmsim/parallel.py) agreeing bit for bit.

The compile times are a timing, measured against their budgets by bench/coldstart.py; here the
machine-independent part: the kernels a scene uses and that a second process loads them all."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from mpmsim import parallel
from mpmsim.deck import load_deck
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation

from ..conftest import ROOT

pytestmark = pytest.mark.speed

KERNELS = """
import gc, json, sys
from numba.core import event
from numba.core.registry import CPUDispatcher
from mpmsim.deck import load_deck
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation
with event.install_recorder("numba:compile") as rec:
    sim = Simulation(build_scene(load_deck(sys.argv[1])), out_dir=None, threads=1)
    sim.step()
used = sorted({f"{d.py_func.__module__}.{d.py_func.__qualname__}" for d in gc.get_objects()
               if isinstance(d, CPUDispatcher) and d.signatures and d.py_func.__module__.startswith("mpmsim")})
compiled = sorted({str(getattr(e.data.get("dispatcher"), "py_func", "?")) for _, e in rec.buffer
                   if isinstance(e.data, dict)})
print(json.dumps({"used": used, "compiled": compiled, "events": len(rec.buffer)}))
"""


def kernels(deck: str) -> dict:
    """The kernels of mpmsim a fresh process builds the deck's scene and takes a step with, and
    what it compiled (numba's compile events: a kernel loaded from the cache raises none)."""
    env = {**os.environ, "NUMBA_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
    run = subprocess.run([sys.executable, "-c", KERNELS, str(ROOT / "inputs" / f"{deck}.yaml")],
                         capture_output=True, text=True, timeout=900, env=env)
    assert run.returncode == 0, run.stderr[-2000:]
    return json.loads(run.stdout.splitlines()[-1])


@pytest.mark.parametrize("deck", ["disks", "two_blocks"])
def test_a_scene_compiles_only_its_kernels_and_the_next_process_loads_them_all(deck):
    """Machine-independent: which kernels a scene uses, and that a second process compiles
    none of them (a kernel whose cache key changed between processes would compile again).
    How long the first compile takes is a timing: bench/coldstart.py measures it against the
    budgets (20 s for disks, 40 s for two_blocks, docs/performance.md)."""
    first = kernels(deck)  # compiles what the suite's cache still lacks
    second = kernels(deck)
    assert second["events"] == 0, f"{deck}: the second process compiled {second['compiled']}"
    assert second["used"] == first["used"]
    used = second["used"]
    families = {f: [k for k in used if k.startswith(f"mpmsim.{f}")] for f in
                ("contact.grid", "contact.barrier", "contact.augury", "fem", "integrators.implicit", "gpu")}
    assert not any(families[f] for f in ("contact.barrier", "contact.augury", "fem", "integrators.implicit", "gpu")), \
        {f: k for f, k in families.items() if k}
    if deck == "disks":  # one material: no contact kernel at all
        assert not families["contact.grid"] and 5 <= len(used) <= 15, used
    else:  # LR contact: the material fields, geometry and passes, and the particle kernels
        assert len(families["contact.grid"]) >= 8 and len(used) <= 40, used


def test_small_scenes_take_one_thread_unless_asked():
    assert parallel.auto_threads(2, 1624) == (1, f"1624 particles: one thread below {parallel.PARALLEL_MIN_PARTICLES}")
    assert parallel.auto_threads(2, parallel.PARALLEL_MIN_PARTICLES) == (2, "")
    assert parallel.auto_threads(1, 10) == (1, "")
    sim = Simulation(build_scene(load_deck(ROOT / "inputs" / "disks.yaml")), out_dir=None)
    assert sim.state.threads == 1 and not parallel.threaded()
    sim = Simulation(build_scene(load_deck(ROOT / "inputs" / "disks.yaml")), out_dir=None, threads=2)
    assert sim.state.threads == 2 and parallel.threaded()


def test_serial_and_parallel_forms_agree_bit_for_bit(monkeypatch):
    """two_blocks (LR contact, rigid platen, USAVG): the same 30 steps with every chunk kernel
    in its parallel form and in its serial form, over the same 8 chunks."""
    import mpmsim.solver as solver

    def run(form_threads: int):
        monkeypatch.setattr(solver, "use_threads", lambda threads: parallel.use_threads(form_threads))
        sim = Simulation(build_scene(load_deck(ROOT / "inputs" / "two_blocks.yaml")), out_dir=None, threads=2)
        for _ in range(30):
            sim.step()
        P = sim.state.particles
        return P.x.copy(), P.v.copy(), P.stress.copy(), sim.state.t

    x2, v2, s2, t2 = run(2)
    x1, v1, s1, t1 = run(1)
    assert t1 == t2
    assert np.array_equal(x1, x2) and np.array_equal(v1, v2) and np.array_equal(s1, s2)
    assert np.abs(v1).max() > 0.0  # the platen has moved material


def test_the_grid_loops_take_no_array_reference_per_node_component():
    """The grid loops call bc.node_bc once per node component; numba keeps an NRT incref and
    decref per array argument of such an inlined helper wherever its branches stop the pruning
    (4.3x on the benchmark column's grid velocities, docs/performance.md). The grid view's node
    counts and faces are tuples for that. Read from the compiled code (a fresh, uncached
    compile: numba shows no LLVM for cached code): each array is referenced once, on entry.
    The same check sees the extra references when the faces are arrays."""
    import re

    from numba import njit

    from mpmsim.tasks.boundary import grid_velocity, held_by

    sim = Simulation(build_scene(load_deck(ROOT / "bench" / "column.yaml")), out_dir=None, threads=1)
    sim.step()
    st = sim.state
    view = st.grid.view
    assert all(isinstance(t, tuple) for t in (view.shape, view.face_type, view.wall_index))

    def references(grid) -> list[str]:
        fresh = njit(error_model="numpy")(grid_velocity.py_func)
        fresh(st.box.active(), grid, held_by(st, st.rigid.v_start), st.fields.mass, st.fields.mom, st.fields.vel)
        return re.findall(r"call void @NRT_incref\(ptr (?:nonnull )?(%[\w.]+)\)", fresh.inspect_llvm(fresh.signatures[0]))

    refs = references(view)
    assert refs and len(refs) == len(set(refs)), refs
    arrays = view._replace(face_type=np.array(view.face_type), wall_index=np.array(view.wall_index))
    refs = references(arrays)
    assert len(refs) > len(set(refs)), refs
