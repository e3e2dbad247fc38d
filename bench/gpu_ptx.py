"""Compile every kernel of the GPU step to PTX without a GPU: the check that the kernels the
simulator runs (as Python) also compile for a device.

numba's CUDA simulator runs kernels as Python, so it accepts code the CUDA compiler would
reject (an array allocated in a kernel, a CPU-only NumPy call in a shared helper). This
script steps the device tasks of small scenes with the launches replaced by compilation for a
chosen compute capability (default 9.0, H100): every kernel, with the argument types of a real
run, goes through numba-cuda's compiler and NVVM, and nothing runs.

    pip install 'numba-cuda[cu13]'     # (or [cu12]) NVVM and the CUDA runtime headers
    python bench/gpu_ptx.py [--cc 9 0]

Prints one line per kernel (name, signature's first types, PTX size) and exits 1 on a failure.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


class HostArray(np.ndarray):
    """A numpy array with the device-array methods the step calls."""

    def copy_to_device(self, a):
        self[...] = a

    def copy_to_host(self, out=None):
        if out is None:
            return np.array(self)
        out[...] = self
        return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cc", type=int, nargs=2, default=(9, 0))
    args = ap.parse_args()
    if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1":
        raise SystemExit("bench/gpu_ptx.py compiles for a device: run it without NUMBA_ENABLE_CUDASIM")
    import numba
    from numba import cuda
    import numba.cuda.dispatcher as dispatcher

    cc = tuple(args.cc)

    class Device:  # the compute capability device functions are compiled for
        compute_capability = cc

    dispatcher.get_current_device = lambda: Device()
    host = lambda a: np.ascontiguousarray(a).view(HostArray)  # noqa: E731
    cuda.to_device = lambda a, *x, **k: host(np.array(a))
    cuda.device_array = lambda shape, dtype=np.float64, *x, **k: host(np.zeros(shape, dtype=dtype))
    cuda.synchronize = lambda: None
    done: dict = {}
    failed = []

    def launch(self, config):
        def call(*a):
            sig = tuple(numba.typeof(x) for x in a)
            key = (self.py_func.__qualname__, id(self), sig)
            if key in done:
                return
            try:
                ptx, _ = cuda.compile_ptx(self.py_func, sig, cc=cc)
                done[key] = len(ptx)
                print(f"ok   {self.py_func.__qualname__:<36} {len(ptx):>8} bytes PTX")
            except Exception as exc:  # report every kernel, then fail
                done[key] = -1
                failed.append(self.py_func.__qualname__)
                print(f"FAIL {self.py_func.__qualname__}: {type(exc).__name__}: {str(exc).splitlines()[0][:300]}")
        return call

    dispatcher.CUDADispatcher.__getitem__ = launch

    from mpmsim.gpu import step as gpu_step
    from mpmsim.solver import Simulation
    from tests.gpu.cases import CASES

    for name, d in CASES.items():
        sim = Simulation.from_deck(d, threads=1, name="block")
        dev = gpu_step.DeviceStep(sim.scene)
        dev.bind(sim.state)
        st = sim.state
        st.dt = d["time"]["dt"]
        c = dev.contact
        for task in ("shape_functions", "material_fields", "extrapolate", "geometry", "pass_1", "stress_first",
                     "forces", "grid_update", "pass_2", "particle_update", "move_rigid", "reextrapolate_task",
                     "pass_3", "stress_last"):
            if hasattr(dev, task):
                getattr(dev, task)(st)
            elif c is not None:  # a contact task; nothing ran, so say there is a contact node to plan
                getattr(c, task)(st)
                c.n_cn = c.n_slots = 1
        dev.scatter, dev.since_sort = "sorted", dev.sort_every  # the scatters with the particles grouped by cell
        for task in ("shape_functions", "extrapolate", "forces"):
            getattr(dev, task)(st)
        dev.energy_sums(st)  # the energy check's sums
        ints = np.zeros(3, dtype=np.int64)  # the rigid-penetration watch (its lattices: int arrays)
        gpu_step.K.inside_rigid[1, 1](st.particles.x, st.grid.origin, st.grid.h, ints, ints, ints, ints, ints)
        print(f"-- {name}: {len(done)} kernels compiled so far")
    if failed:
        raise SystemExit(f"{len(failed)} kernel(s) failed to compile: {', '.join(sorted(set(failed)))}")
    print(f"all {len(done)} kernel specialisations compile for compute capability {cc[0]}.{cc[1]}")


if __name__ == "__main__":
    main()
