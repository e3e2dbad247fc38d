"""numba's CUDA simulator, made quicker for the GPU tests' one-thread blocks.

Under the simulator mpmsim launches one thread per block (mpmsim/gpu/kernels.py: TPB), and
the simulator runs every block by starting a Python thread for each of its threads and
polling them until they end. With one thread per block there is nothing to interleave: the
polling only competes with the kernel for the interpreter (measured: two thirds of a case's
time went to starting, polling and joining threads). `run_single_thread_blocks()` runs such a
block in the calling thread instead, which the simulator's `cuda.threadIdx`/`cuda.blockIdx`
read from; blocks of more threads keep the simulator's own path. The kernels see the same
indices in the same order, so results are unchanged (the tests compare them with the CPU's
to 1e-10, and here to the last bit)."""

from __future__ import annotations

import threading

_KEYS = ("blockIdx", "threadIdx", "thread_id", "syncthreads", "syncthreads_count", "syncthreads_and",
         "syncthreads_or")


def run_single_thread_blocks() -> None:
    from numba.cuda.simulator import kernel as sim

    original = sim.BlockManager.run
    if getattr(original, "single_thread_blocks", False):
        return

    def run(self, grid_point, *args):
        if any(d != 1 for d in self._block_dim):
            return original(self, grid_point, *args)
        me = threading.current_thread()
        saved = {k: me.__dict__[k] for k in _KEYS if k in me.__dict__}
        me.blockIdx, me.threadIdx, me.thread_id = sim.Dim3(*grid_point), sim.Dim3(0, 0, 0), 0
        me.syncthreads = lambda: None  # the block's only thread is always at the barrier
        me.syncthreads_count = me.syncthreads_and = me.syncthreads_or = lambda value: 1 if value else 0
        try:
            self._f(*args)
        finally:
            for k in _KEYS:
                me.__dict__.pop(k, None)
            me.__dict__.update(saved)

    run.single_thread_blocks = True
    sim.BlockManager.run = run
