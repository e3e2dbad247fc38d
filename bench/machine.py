"""One line naming the machine a benchmark ran on, for every figure the benches print: the date,
the CPU model (/proc/cpuinfo, else platform), the CPU numba compiles for (LLVM's host CPU name,
or NUMBA_CPU_NAME when set) and which vector features that target has: SSE4.2, AVX2, FMA,
AVX-512F (an AVX-512 machine whose target lacks avx512f runs 256-bit code at best)."""

from __future__ import annotations

import datetime
import platform
from pathlib import Path

WATCHED = ("sse4.2", "avx2", "fma", "avx512f", "avx512vl")


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def numba_target() -> str:
    """'znver3 (avx2 fma sse4.2; no avx512f avx512vl)': the CPU name numba hands LLVM and the
    watched features on (+) and off (-) for it."""
    import llvmlite.binding as ll
    from numba.core import config

    name = config.CPU_NAME or ll.get_host_cpu_name()
    if config.CPU_FEATURES:
        flags = dict((f[1:], f[0] == "+") for f in config.CPU_FEATURES.split(","))
    else:
        flags = {k: bool(v) for k, v in ll.get_host_cpu_features().items()}
    on = [f for f in WATCHED if flags.get(f)]
    off = [f for f in WATCHED if not flags.get(f)]
    return f"{name} ({' '.join(on) or 'none of ' + ' '.join(WATCHED)}" + (f"; no {' '.join(off)})" if off else ")")


def describe(threads: int | None = None) -> str:
    line = f"{datetime.date.today()}  {cpu_model()}  numba target {numba_target()}"
    return line + (f"  threads {threads}" if threads is not None else "")


if __name__ == "__main__":
    print(describe())


def seconds_per_step(deck, steps: int, threads: int) -> tuple[float, int]:
    """(seconds per step over `steps` steps after a first, compiling one; deformable particles) of
    a validated deck run in this process (the benches' shared timing loop)."""
    import time

    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation

    from mpmsim.stability import total_sums

    sim = Simulation(build_scene(deck), out_dir=None, threads=threads)
    total_sums(sim.state)  # (the energy check's kernel, as a run's start: not compiled inside the timing)
    sim.step()  # (compiles on the first call)
    t0 = time.perf_counter()
    for _ in range(steps):
        sim.step()
    return (time.perf_counter() - t0) / steps, sim.state.particles.n


def steps_wall(sim, steps: int, warmup: int) -> float:
    """Wall seconds of `steps` steps after `warmup` ones (the timers zeroed after the warm-up).
    The energy sums are taken once first, as a run does at its start: the stability check's
    kernel (every stability.check_every steps) is then loaded, or compiled, outside the timing."""
    import time

    from mpmsim.stability import total_sums

    total_sums(sim.state)
    for _ in range(warmup):
        sim.step()
    sim.reset_timers()
    t0 = time.perf_counter()
    for _ in range(steps):
        sim.step()
    return time.perf_counter() - t0
