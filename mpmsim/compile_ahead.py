"""A first step whose kernels compile in two processes.

A scene's first step compiles every kernel it calls that numba's cache lacks, one after the
other (two_blocks: 29 kernels, about a minute of CPU, the contact geometry alone 40% of it).
The kernels are independent compilations, so on a machine with a second core a helper process
compiles part of them while this process compiles the rest; both write numba's kernel cache,
and each loads what the other wrote:

1. The helper is forked at the start of the first step and runs that step's tasks *dry*: every
   call of a compiled kernel from Python is recorded with its argument types and returns at
   once (nothing runs: only the types of the arguments are needed, and the state's arrays fix
   them). A task that stumbles over a kernel's missing result (an index array it did not
   compute) ends there and the next task goes on, so the dry step records most of the step's
   kernels and all of the large ones (two_blocks: 22 of 29; the seven it misses are small).
   Then it compiles the recorded kernels largest first (by the bytecode of the kernel and the
   compiled functions it calls, which ranks two_blocks' kernels as their measured compile
   times do), so that a kernel as large as the contact geometry (40% of two_blocks' compile)
   starts at once.
2. This process runs the step as usual, the first kernel first. Each kernel is claimed by one
   process only (a lock file created exclusively, named by the kernel and its argument types):
   a kernel this process claims it compiles itself; for one the helper claimed it waits, and
   while it waits it compiles the next unclaimed kernels of the helper's recorded list (the
   step's order), then loads the helper's kernel from the cache.
3. At the end of the step the helper is stopped (anything it still compiles, this process did
   not need).

The helper never computes anything this process uses except a cached kernel, and numba checks
those as for any cached kernel (same source, same types): the step's results are the same to
the last bit as with one process. If the helper fails or dies, this process compiles what is
left itself. Used where it can help: Linux (fork), at least two cores this process may use, the
CPU step; `MPMSIM_COMPILE_HELPER=0` turns it off. Measured in docs/performance.md ("Cold start").
"""

from __future__ import annotations

import ctypes
import gc
import hashlib
import os
import pickle
import shutil
import signal
import sys
import tempfile
import time
import types
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path

DRY_CALL_LIMIT = 20_000  # a dry step calling more kernels than this is cut short (a loop on dummy results)
DRY_SECONDS = 10.0  # and one running longer
_WAIT = 0.02  # seconds between looks at a lock the other process holds


def available() -> bool:
    """Whether a helper can run here: fork, two usable cores, not turned off."""
    if os.environ.get("MPMSIM_COMPILE_HELPER", "1") == "0":
        return False
    if not hasattr(os, "fork") or sys.platform != "linux":
        return False
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    return cores >= 2


class _Unknown:
    """What a kernel returns in the dry step: zero-like, false, and itself under arithmetic;
    iterating over it ends the dry step."""

    def __bool__(self):
        return False

    def __int__(self):
        return 0

    __index__ = __int__

    def __float__(self):
        return 0.0

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        return self

    def __getitem__(self, key):
        return self

    def __iter__(self):
        raise TypeError("a dry kernel's result was unpacked")  # ends this part only

    def _same(self, *other):
        return self

    __add__ = __radd__ = __sub__ = __rsub__ = __mul__ = __rmul__ = __truediv__ = __rtruediv__ = _same
    __floordiv__ = __rfloordiv__ = __neg__ = __abs__ = __pow__ = __rpow__ = __mod__ = _same

    def __lt__(self, other):
        return False

    __le__ = __gt__ = __ge__ = __lt__


class _DryEnd(Exception):
    """The dry step stops here (its recorded kernels stand)."""


def _key(dispatcher, sig: tuple) -> str:
    fn = dispatcher.py_func
    text = f"{fn.__module__}.{fn.__qualname__}|{sig}"
    return hashlib.sha1(text.encode()).hexdigest()[:20]


def _signature(dispatcher, args: tuple) -> tuple | None:
    try:
        return tuple(dispatcher.typeof_pyval(a) for a in args)
    except Exception:  # noqa: BLE001 (an argument numba cannot type: not recorded)
        return None


def code_size(fn, seen: set | None = None) -> int:
    """Bytes of bytecode of `fn`, its nested functions and the compiled functions it calls
    (module globals it names: dispatchers, chunk kernels), each counted once: a proxy for
    its compile time."""
    seen = set() if seen is None else seen
    if id(fn) in seen or not isinstance(fn, types.FunctionType):
        return 0
    seen.add(id(fn))
    code = fn.__code__
    size = len(code.co_code) + sum(len(c.co_code) for c in code.co_consts if isinstance(c, types.CodeType))
    for name in code.co_names:
        size += code_size(getattr(fn.__globals__.get(name), "py_func", None), seen)
    return size


def _claim(locks: Path, key: str) -> bool:
    try:
        os.close(os.open(locks / f"{key}.lock", os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        return True
    except FileExistsError:
        return False


def _done(locks: Path, key: str) -> None:
    (locks / f"{key}.done").touch()


def _name(dispatcher) -> tuple[str, str, bool]:
    fn = dispatcher.py_func
    return fn.__module__, fn.__qualname__, bool(dispatcher.targetoptions.get("parallel"))


def _write_plan(locks: Path, recorded: dict) -> None:
    """The recorded kernels in the step's order (key, name, types), for the parent: it
    compiles from them while it waits for one of the helper's."""
    plan = [(key, _name(dispatcher), sig) for key, (dispatcher, sig) in recorded.items()]
    try:
        data = pickle.dumps(plan)
    except Exception:  # noqa: BLE001 (types that do not pickle: no plan, the parent only waits)
        return
    tmp = locks / "plan.tmp"
    tmp.write_bytes(data)
    os.replace(tmp, locks / "plan")


def _dispatchers() -> dict:
    """This process's CPU kernels by name (module, qualname, parallel): the chunk kernels' two
    forms (made here if not yet) and every other live dispatcher; a name two differ by maps
    to None."""
    from numba.core.registry import CPUDispatcher

    from .parallel import ChunkKernel

    found: dict = {}

    def add(name, dispatcher):
        found[name] = dispatcher if found.get(name, dispatcher) is dispatcher else None

    for kernel in list(ChunkKernel.made):
        add((kernel.__module__, kernel.__qualname__ + "_serial", False), kernel.serial)
        add((kernel.__module__, kernel.__qualname__, True), kernel.parallel)
    for obj in gc.get_objects():
        if isinstance(obj, CPUDispatcher):
            add(_name(obj), obj)
    return found


@contextmanager
def _dispatcher_calls(call):
    """Within: a Python call of any CPU kernel goes through `call(dispatcher, args, original)`."""
    from numba.core.registry import CPUDispatcher

    original = CPUDispatcher.__call__

    def patched(self, *args, **kwargs):
        if kwargs:
            return original(self, *args, **kwargs)
        return call(self, args, original)

    CPUDispatcher.__call__ = patched
    try:
        yield
    finally:
        CPUDispatcher.__call__ = original


def dry_run(parts: list[Callable[[], object]]) -> dict:
    """Run `parts` dry (each alone; module text): {key: (dispatcher, argument types)} of the
    kernels they call from Python that this process has not compiled for those types, in the
    order of their first call. Only in a process whose state may be spoiled (the helper):
    the parts' Python code runs on placeholders."""
    recorded: dict[str, tuple] = {}
    start = time.perf_counter()

    def dry(dispatcher, args, original):
        if len(recorded) > DRY_CALL_LIMIT or time.perf_counter() - start > DRY_SECONDS:
            raise _DryEnd("dry step cut short")
        sig = _signature(dispatcher, args)
        if sig is not None and sig not in dispatcher.overloads:
            recorded.setdefault(_key(dispatcher, sig), (dispatcher, sig))
        return _Unknown()

    with _dispatcher_calls(dry):
        for part in parts:
            try:
                part()
            except _DryEnd:
                break
            except BaseException:  # noqa: BLE001 (a part ends wherever a dummy result stops it)
                continue
    return recorded


def _helper(parts: list[Callable[[], object]], locks: Path, parent: int) -> None:
    """The forked helper: the dry step (each part alone), then the recorded kernels compiled
    largest first, each claimed first (the parent may have)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:  # killed with the parent (Linux's parent-death signal), whatever kills it
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:  # the parent died before the signal was set
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)
    os.dup2(devnull, 2)
    start = time.perf_counter()
    where = os.environ.get("MPMSIM_COMPILE_HELPER_LOG")

    def log(line: str) -> None:
        if where:
            with open(where, "a") as f:
                print(f"{time.perf_counter() - start:7.2f} s  {line}", file=f)

    recorded = dry_run(parts)
    log(f"dry step: {len(recorded)} kernels to compile")
    _write_plan(locks, recorded)
    compiled = 0
    order = sorted(recorded.items(), key=lambda item: -code_size(item[1][0].py_func))
    for key, (dispatcher, sig) in order:
        if os.getppid() != parent:
            break
        if not _claim(locks, key):
            log(f"{dispatcher.py_func.__qualname__}: claimed by the parent")
            continue
        t0 = time.perf_counter()
        try:
            dispatcher.compile(sig)
            compiled += 1
            said = "compiled"
        except BaseException as exc:  # noqa: BLE001 (the parent compiles it and reports the error)
            said = f"failed ({type(exc).__name__}: {str(exc)[:200]})"
        finally:
            _done(locks, key)
        log(f"{dispatcher.py_func.__qualname__}: {said} in {time.perf_counter() - t0:.1f} s")
    (locks / f"helper-{compiled}.end").touch()


def first_step(step: Callable[[], None], parts: list[Callable[[], object]], enabled: bool = True) -> dict:
    """Run `step()` (a scene's first step) with a helper compiling part of its kernels (see the
    module's text), which runs `parts` (the step's tasks, each a call) dry; without one where
    `available()` says no or `enabled` is false. Returns {"helper": whether one ran,
    "compiled_here": kernels this process compiled where the step called them,
    "compiled_ahead": those it compiled from the helper's list while waiting, "waited": kernels
    it waited for and loaded from the helper, "compiled_helper": the helper's count (None if it
    was stopped before it finished)}."""
    report = {"helper": False, "compiled_here": 0, "waited": 0, "compiled_ahead": 0}
    if not (enabled and available()):
        step()
        return report
    try:
        locks = Path(tempfile.mkdtemp(prefix="mpmsim-compile-"))
    except OSError:  # no temporary folder: one process
        step()
        return report
    parent = os.getpid()
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:  # the helper
        try:
            _helper(parts, locks, parent)
        finally:
            os._exit(0)
    report["helper"] = True
    alive = [True]

    def helper_alive() -> bool:
        if alive[0]:
            done, _ = os.waitpid(pid, os.WNOHANG)
            alive[0] = done == 0
        return alive[0]

    plan: list = []
    named: dict = {}

    def compile_ahead_of(waiting: str) -> bool:
        """While the helper compiles `waiting`: claim and compile the first kernel of its plan
        (the step's order) that neither process has claimed. Whether one was compiled."""
        if not named:  # the helper's plan, read once (with this process's kernels by name)
            if not (locks / "plan").exists():
                return False
            plan.extend(pickle.loads((locks / "plan").read_bytes()))
            named.update(_dispatchers())
            named[None] = None  # (read: an empty plan is not read again)
        for key, name, sig in plan:
            dispatcher = named.get(name)
            if key == waiting or dispatcher is None or sig in dispatcher.overloads or not _claim(locks, key):
                continue
            report["compiled_ahead"] += 1
            try:
                dispatcher.compile(sig)
            except Exception:  # noqa: BLE001 (compiled again, and reported, where the step calls it)
                pass
            finally:
                _done(locks, key)
            return True
        return False

    def shared(dispatcher, args, original):
        sig = _signature(dispatcher, args)
        if sig is None or sig in dispatcher.overloads:
            return original(dispatcher, *args)
        key = _key(dispatcher, sig)
        if _claim(locks, key):
            report["compiled_here"] += 1
            try:
                return original(dispatcher, *args)
            finally:
                _done(locks, key)
        while not (locks / f"{key}.done").exists() and helper_alive():
            if not compile_ahead_of(key):
                time.sleep(_WAIT)
        if (locks / f"{key}.done").exists():
            report["waited"] += 1
        return original(dispatcher, *args)  # loads the helper's kernel from the cache (or compiles it)

    try:
        with _dispatcher_calls(shared):
            step()
    finally:
        if helper_alive():
            os.kill(pid, signal.SIGTERM)
            os.waitpid(pid, 0)
        ends = list(locks.glob("helper-*.end"))
        report["compiled_helper"] = int(ends[0].stem.split("-")[1]) if ends else None
        shutil.rmtree(locks, ignore_errors=True)
    return report
