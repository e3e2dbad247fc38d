"""Serial or parallel kernels, compiled on demand.

A kernel whose outer loop runs over chunks (`for c in prange(nchunk)`) can be compiled two
ways: with numba's `parallel=True`, which turns the loop into a threaded region, or as a
plain loop. Compiling the threaded form costs 1.5-3x the time of the plain one (numba's
parfor passes and a second compiled body per kernel), and on a small scene it buys little:
a step of a few thousand particles gains under 20% from a second thread, or loses.
So every chunked kernel is decorated with `@chunk_kernel` instead of
`@njit(parallel=True, cache=True)`, and

- `kernel(*args)` runs the serial or the parallel form, as `use_threads(...)` last chose
  for this process (Simulation.step chooses before each step, from its State's thread
  count; State.from_scene before the first kernels);
- each form is compiled only when first used, and cached in its own file: the serial copy
  of the function gets the qualified name `<name>_serial`, which names numba's cache file.

Both forms run the same chunks in the same order and combine per-chunk results after the
loop, so they give the same numbers (bit for bit).

Kernels called from other compiled code cannot be switched this way (a compiled caller
binds one dispatcher); those stay plain `njit` functions.
"""

from __future__ import annotations

import types
import weakref

from numba import njit

_mode = {"parallel": False}

# Below this many particles a default run takes one thread (and so the serial kernels: a
# scene this small compiles in a fraction of the time and loses little; docs/performance.md).
PARALLEL_MIN_PARTICLES = 10_000


def auto_threads(available: int, n_particles: int) -> tuple[int, str]:
    """(threads, why) for a run that did not ask for a count: `available` idle cores, one
    thread for a scene of fewer than PARALLEL_MIN_PARTICLES particles."""
    if available > 1 and n_particles < PARALLEL_MIN_PARTICLES:
        return 1, f"{n_particles} particles: one thread below {PARALLEL_MIN_PARTICLES}"
    return available, ""


def chunks_for(threads: int) -> int:
    """The chunks a chunked kernel's loop runs over with `threads` threads (four each, so a
    thread that falls behind holds up a quarter of its share)."""
    return max(1, 4 * threads)


def use_threads(threads: int) -> None:
    """Run the parallel form of every chunk kernel when threads > 1, the serial one otherwise."""
    _mode["parallel"] = threads > 1


def threaded() -> bool:
    return _mode["parallel"]


class ChunkKernel:
    """A chunked kernel in its serial and parallel forms (each compiled when first called)."""

    made: "weakref.WeakSet[ChunkKernel]" = weakref.WeakSet()  # every chunk kernel (compile_ahead finds their forms)

    def __init__(self, fn):
        ChunkKernel.made.add(self)
        self.py_func = fn
        self.__name__ = fn.__name__
        self.__qualname__ = fn.__qualname__
        self.__doc__ = fn.__doc__
        self.__module__ = fn.__module__
        self._serial = None
        self._parallel = None

    @property
    def serial(self):
        if self._serial is None:
            fn = self.py_func
            copy = types.FunctionType(fn.__code__, fn.__globals__, fn.__name__, fn.__defaults__, fn.__closure__)
            copy.__qualname__ = fn.__qualname__ + "_serial"  # numba names the cache file after it
            copy.__module__ = fn.__module__
            copy.__doc__ = fn.__doc__
            # numpy's error model, as in the parallel form. numba's cache key does not hold the
            # options: after changing them here, rename the copy (or `make clean-cache`), or a
            # checkout whose kernel files did not change loads forms built with the old ones
            self._serial = njit(cache=True, error_model="numpy")(copy)
        return self._serial

    @property
    def parallel(self):
        if self._parallel is None:
            self._parallel = njit(parallel=True, cache=True)(self.py_func)
        return self._parallel

    def __call__(self, *args):
        return (self.parallel if _mode["parallel"] else self.serial)(*args)


def chunk_kernel(fn) -> ChunkKernel:
    """Decorator: `fn` as a ChunkKernel (see the module's text)."""
    return ChunkKernel(fn)


# numba options of a function called once per item (a contact node) inside a kernel's loop and
# working only on the arrays it is given: compiled without numba's reference counting (NRT).
# With it, numba keeps an NRT incref/decref call (an atomic add through a function pointer) for
# every array of every bundle bound in an inlined helper wherever the helper's branches stop
# its pruning: in the LR contact planner over a hundred per contact node. Without it the
# function borrows its arguments; numba refuses to compile an allocation there (a typing error
# at np.zeros), so the option cannot hide a leak, and the numbers are the same to the bit. On
# the two-block benchmark column: the contact geometry 2.5x, pass 2 1.8x faster
# (docs/performance.md). (`_nrt` is numba's target option for compiling without its runtime.)
BORROWING = {"_nrt": False}


def specialize(fn, tag: str, **bind):
    """A copy of the (not yet compiled) function `fn` whose module globals named in `bind`
    take the given values, named `<qualname>_<tag>`. numba reads globals as constants when it
    compiles, so bound method codes prune the branches of the other methods, and bound
    functions replace the ones it calls; the name gives the copy its own cache file, so `tag`
    must tell every binding apart. numba ties the cache entry to `fn`'s source file: a binding
    to a function of another file must show in `tag` too, and an edit of that function needs a
    new tag or `make clean-cache`. (A kernel made inside a factory could instead close over
    its constants, but a compiled function in a closure cell changes numba's cache key in
    every process; one bound as a global does not.)"""
    scope = dict(fn.__globals__)
    scope.update(bind)
    copy = types.FunctionType(fn.__code__, scope, fn.__name__, fn.__defaults__, fn.__closure__)
    copy.__qualname__ = f"{fn.__qualname__}_{tag}"
    copy.__module__ = fn.__module__
    copy.__doc__ = fn.__doc__
    return copy
