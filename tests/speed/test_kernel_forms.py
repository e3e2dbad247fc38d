"""Kernels compiled per scene: the cold-start budgets, the cache across processes, and the
serial and parallel forms of the chunk kernels (mpmsim/parallel.py) agreeing bit for bit.

The compile times are the benchmark's (bench/coldstart.py); here they are asserted with a
margin of 1.5x the budgets (a shared CI machine is slower and noisier than the benchmark's),
which still fails for the one-kernel-for-everything build this replaced (42 s and 112 s)."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import numpy as np
import pytest

from mpmsim import parallel
from mpmsim.deck import load_deck
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation

from ..conftest import ROOT

pytestmark = pytest.mark.speed

BUDGET = {"disks": 20.0, "two_blocks": 40.0}
MARGIN = 1.5


def compile_seconds(deck: str, cache) -> float:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "NUMBA_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
    t0 = time.perf_counter()
    run = subprocess.run([sys.executable, "-m", "mpmsim", "compile", str(ROOT / "inputs" / f"{deck}.yaml")],
                         capture_output=True, text=True, timeout=900, env=env)
    assert run.returncode == 0, run.stderr[-2000:]
    return time.perf_counter() - t0


@pytest.mark.parametrize("deck", sorted(BUDGET))
def test_cold_compile_within_budget_and_cached_for_the_next_process(deck, tmp_path):
    cold = compile_seconds(deck, tmp_path)
    warm = compile_seconds(deck, tmp_path)
    print(f"{deck}: cold {cold:.1f} s, warm {warm:.1f} s (budget {BUDGET[deck]:.0f} s)")
    assert cold < MARGIN * BUDGET[deck]
    # every kernel, the per-model and per-method ones included, loads from the cache: a kernel
    # whose cache key changed between processes would compile again (seconds, not 1-3 s)
    assert warm < 0.25 * cold and warm < 6.0


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
