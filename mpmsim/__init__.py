"""mpmsim: material point method simulator for multimaterial contact mechanics."""

import os

# mpmsim's threads are numba's: BLAS threads on top of them (numpy's eigh/solve in the implicit
# step's small dense problems) oversubscribe the cores and slowed a 3D contact test 20x. A
# user's own setting wins; numpy imported before mpmsim keeps whatever it loaded with.
for _blas in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_blas, "1")


def _load_tbb() -> bool:
    """Make numba's TBB threading layer loadable: the `tbb` wheel (a dependency on x86-64
    Linux) puts libtbb in the environment's lib folder, where the dynamic loader does not look,
    so it is loaded here by path; numba's default layer (the first of tbb, omp, workqueue that
    loads) is then TBB. A NUMBA_THREADING_LAYER the user set wins."""
    if os.environ.get("NUMBA_THREADING_LAYER", "default") not in ("default", "tbb", ""):
        return False
    import ctypes
    import sys

    for name in ("libtbb.so.12", "libtbb.12.dylib"):
        path = os.path.join(sys.prefix, "lib", name)
        if os.path.exists(path):
            try:
                ctypes.CDLL(path, mode=ctypes.RTLD_GLOBAL)
                return True
            except OSError:
                return False
    return False


# Threads wait at the end of each parallel region (about 20 a step). TBB's workers share the
# region's chunks as they go and sleep soon after running out of work; numba's OpenMP layer
# (libgomp) hands each thread a fixed share and by default spins while it waits, so a thread
# sharing a core with a busy process stalls the region and the spinning one takes the time
# the stalled one needs. Measured on the 2-core bench machine (bench/contention.py,
# docs/performance.md): OpenMP with spinning waits ran --threads 2 2.4x (one busy neighbour)
# to 12x (three) slower than --threads 1; TBB, or OpenMP with sleeping waits, no slower than
# one thread, and TBB as fast as spinning OpenMP on the idle machine where sleeping OpenMP
# waits lose 35% on the 16 000-particle column. So: TBB where it is installed, else OpenMP
# with sleeping waits (libgomp reads this when it loads, at numba's first threaded kernel;
# OMP_WAIT_POLICY=ACTIVE restores spinning).
TBB = _load_tbb()
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

from ._version import __version__  # noqa: E402

from . import kernel_cache as _kernel_cache  # noqa: E402  (before any kernel is defined)

CACHE_DIR = _kernel_cache.configure()

__all__ = ["Simulation", "Deck", "DeckError", "InstabilityError", "__version__"]


def __getattr__(name: str):
    """`mpmsim.Simulation` and friends, imported when first used (so `mpmsim --version` and
    `import mpmsim` stay quick)."""
    if name == "Simulation":
        from .solver import Simulation

        return Simulation
    if name == "Deck":
        from .deck import Deck

        return Deck
    if name in ("DeckError", "InstabilityError"):
        from . import errors

        return getattr(errors, name)
    raise AttributeError(f"module 'mpmsim' has no attribute {name!r}")
