"""Threads beside other processes: numba's TBB layer where the tbb wheel is installed (x86-64
Linux), else OpenMP whose waiting threads sleep; and the per-step sorts that feed
the threaded kernels (particles into slabs, contact point clouds) give the same order for any
chunking, as a serial sort would. Timings are bench/contention.py's and bench/scaling.py's."""

from __future__ import annotations

import os
import platform
import subprocess
import sys

import numpy as np
import pytest

from mpmsim import parallel
from mpmsim.gridops import bin_slabs

from ..conftest import ROOT

pytestmark = pytest.mark.speed


@pytest.mark.parametrize("given", [None, "ACTIVE"])
def test_importing_mpmsim_makes_waiting_threads_sleep_unless_the_user_says(given):
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    if given:
        env["OMP_WAIT_POLICY"] = given
    env["PYTHONPATH"] = str(ROOT)
    code = "import os, mpmsim; print(os.environ['OMP_WAIT_POLICY'])"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    assert out.stdout.strip() == (given or "PASSIVE")


def test_threaded_kernels_run_on_tbb_where_it_is_installed():
    """A fresh process: the threaded step's layer is TBB on x86-64 Linux (where the project
    installs the tbb wheel), OpenMP elsewhere; a layer the user names wins."""
    code = ("import mpmsim, numba\nfrom mpmsim.solver import Simulation\n"
            "numba.set_num_threads(2)\n"
            "sim = Simulation.from_deck(%r, threads=2)\nsim.step()\nprint(mpmsim.TBB, numba.threading_layer())"
            % str(ROOT / "bench" / "column.yaml"))
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_THREADING_LAYER"}
    env["PYTHONPATH"] = str(ROOT)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    tbb_here = sys.platform == "linux" and platform.machine() == "x86_64"
    assert out.stdout.split() == (["True", "tbb"] if tbb_here else ["False", "omp"])
    env["NUMBA_THREADING_LAYER"] = "omp"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    assert out.stdout.split() == ["False", "omp"]


@pytest.mark.parametrize("threaded", [False, True])
def test_slab_sort_is_stable_for_any_chunking(threaded):
    """Particles binned into slabs by their lowest node along an axis: the order a stable
    numpy argsort gives (each slab's particles in index order), whatever the chunks, in the
    serial and the parallel form."""
    rng = np.random.default_rng(7)
    n, width, lo = 5000, 3, 4
    lowest = rng.integers(0, 200, size=(n, 2))
    nslab = int(np.ceil((200 - lo) / width))
    slab = np.clip((lowest[:, 1] - lo) // width, 0, nslab - 1)
    expect_order = np.argsort(slab, kind="stable")
    expect_ptr = np.concatenate([[0], np.cumsum(np.bincount(slab, minlength=nslab))])
    was = parallel.threaded()
    parallel.use_threads(2 if threaded else 1)
    try:
        for nchunk in (1, 3, 8, 64):
            order, ptr = np.empty(n, dtype=np.int64), np.empty(nslab + 1, dtype=np.int64)
            bin_slabs(lowest, 1, lo, width, nslab, nchunk, order, ptr)
            assert np.array_equal(order, expect_order) and np.array_equal(ptr, expect_ptr)
    finally:
        parallel.use_threads(2 if was else 1)
