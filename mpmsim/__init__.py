"""mpmsim: material point method simulator for multimaterial contact mechanics."""

import os
from importlib.metadata import PackageNotFoundError, version

# mpmsim's threads are numba's: BLAS threads on top of them (numpy's eigh/solve in the implicit
# step's small dense problems) oversubscribe the cores and slowed a 3D contact test 20x. A
# user's own setting wins; numpy imported before mpmsim keeps whatever it loaded with.
for _blas in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_blas, "1")
# Threads that wait at the end of a parallel region sleep instead of spinning. With numba's
# OpenMP layer (libgomp) spinning is the default: a waiting thread keeps its core, and when
# other processes want the cores the spinning thread steals time from the thread the region
# waits for. Measured on the 2-core bench machine (bench/contention.py): --threads 2 ran 2.4x
# (one busy neighbour) to 12x (three) slower than --threads 1 while spinning, and no slower
# than --threads 1 while sleeping (docs/performance.md). libgomp reads this when it loads
# (numba's first threaded kernel), so it must be set before; OMP_WAIT_POLICY=ACTIVE restores
# spinning.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

try:
    __version__ = version("mpmsim")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"

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
