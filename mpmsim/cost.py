"""Run-time estimates for `mpmsim check`.

Explicit particle scenes: each task of a step costs a + b · n · K microseconds on one thread:
a fixed part (calling the kernel, the grid box, Python around it) and a part per
particle-node pair (n particles, K grid nodes in each particle's support: 9 for uGIMP in 2D,
27 in 3D, 16 for CPDI, 25 for B2CPDI), which is what the transfers and the stress update loop
over. The coefficients are fitted, per task, by `python bench/calibrate.py` (in `make bench`)
to the warm task timers of every explicit particle deck in inputs/ on one thread, and stored
in task_costs.json with the date and machine they were measured on (docs/performance.md says
how close the estimates come). A first run also compiles the scene's kernels (numba, when the
kernel cache lacks them): `compile_seconds` adds up a typical compile cost per task of the
step and one for the run's start (state, energy sums, output), CPU seconds from an empty
cache on one thread, measured by `python bench/compile_costs.py` and stored in the same file.

Scenes with FEM bodies, and implicit scenes: their cost does not follow one size (augury
contact goes with the boundary nodes, the augury grid and the kernel; the stability check with
the elements; an implicit step with its Newton iterations, which depend on contact, stiffness
and the step, not on the size), so `probe` measures it: it runs the scene's first steps on one
thread and records each step's CPU time and Newton iterations. An explicit run is then
steps × the mean warm step; an implicit one steps × iterations per step × time per iteration
(`Probe.run_seconds`).
"""

from __future__ import annotations

import json
import time
import warnings
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from .errors import InstabilityError
from .solver import CHECK  # the run loop's own task, after every step

COSTS = Path(__file__).with_name("task_costs.json")
PROBE_STEPS, PROBE_SECONDS = 40, 5.0  # probe: at most this many steps, this long after the first


@lru_cache(maxsize=1)
def task_costs() -> dict:
    """{"tasks": {name: [a_us, b_us]}, "measured": "..."} (empty tasks if the file is missing)."""
    try:
        return json.loads(COSTS.read_text())
    except (OSError, ValueError):
        return {"tasks": {}, "measured": "no calibration"}


def step_microseconds(tasks: list[str], n: int, K: int) -> tuple[float, list[str]]:
    """(estimated µs per step on one thread, the tasks without a calibrated cost)."""
    costs = task_costs()["tasks"]
    total, missing = 0.0, []
    for name in [*tasks, CHECK]:
        if name in costs:
            a, b = costs[name]
            total += a + b * n * K
        else:
            missing.append(name)
    return total, missing


def compile_seconds(tasks: list[str]) -> float | None:
    """Estimated CPU seconds of compiling a first run's kernels from an empty kernel cache: the
    run's start plus each task's typical compile cost (None where the file has none)."""
    costs = task_costs().get("compile")
    if not costs:
        return None
    return costs["start"] + sum(costs["tasks"].get(name, 0.0) for name in [*tasks, CHECK])


@dataclass
class Probe:
    """The first steps of a run, one entry per step: Newton iterations (1 for an explicit
    step), CPU time (the first step's includes compiling; on one thread and an idle core the
    wall time is the same), whether barrier contact was active at its end (False for an
    explicit step)."""
    iterations: list[int]
    seconds: list[float]
    contact: list[bool]
    failed: str | None = None  # why a step of the probe failed (None: none did)

    @property
    def steps(self) -> int:
        return len(self.iterations)

    def _phase(self) -> list[int]:
        """The steps the run is taken to go on like: the later half of the probe's contact
        steps (contact, once made, lasts in most scenes and its first steps are transients),
        or of all its steps when it made no contact."""
        steps = [i for i, c in enumerate(self.contact) if c] or list(range(self.steps))
        return steps[len(steps) // 2:]

    @property
    def per_step(self) -> float:
        """Newton iterations per step after the probe."""
        phase = self._phase()
        return sum(self.iterations[i] for i in phase) / len(phase)

    @property
    def per_iteration(self) -> float:
        """Seconds per Newton iteration: over the probe's phase steps after the first (compiling)
        one, or over every step after the first."""
        timed = [i for i in self._phase() if i > 0] or list(range(1, self.steps)) or [0]
        typical = float(np.median([self.seconds[i] / max(self.iterations[i], 1) for i in timed]))
        # a step that compiled (a kernel first needed mid-probe, as contact begins) is left out
        timed = [i for i in timed if self.seconds[i] / max(self.iterations[i], 1) < 20.0 * typical] or timed
        return sum(self.seconds[i] for i in timed) / max(sum(self.iterations[i] for i in timed), 1)

    def run_seconds(self, steps: int) -> float:
        """Estimated seconds of a run of `steps` steps (compiling left out): the probe's steps
        as measured (the first at `per_iteration`), the rest at `per_step` iterations of
        `per_iteration` each."""
        probed = self.iterations[0] * self.per_iteration + sum(self.seconds[1:])
        return probed + max(steps - self.steps, 0) * self.per_step * self.per_iteration


def probe(scene, max_steps: int = PROBE_STEPS, seconds: float = PROBE_SECONDS) -> Probe:
    """Run a scene's first steps on one thread (no output): up to max_steps, or fewer when the
    steps after the first take more than `seconds` together, or the run ends. A step that fails
    (an unstable scene) ends the probe, its reason in `failed`; warnings are left to the run."""
    import numba

    from .solver import Simulation

    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    found = Probe([], [], [])
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            sim = Simulation(scene, out_dir=None, threads=1)
            integ = sim.integrator
            newton = hasattr(integ, "stats")  # the implicit integrator's per-step Newton counts
            while found.steps < max(max_steps, 2) and sim.state.t < sim.end * (1.0 - 1e-9):
                t0 = time.process_time()  # CPU time: on a shared machine it hardly depends on the load
                sim.step()
                found.seconds.append(time.process_time() - t0)
                found.iterations.append(integ.stats[-1][0] if newton else 1)
                barrier = getattr(integ, "barrier_term", None)
                found.contact.append(bool(barrier is not None and barrier.in_contact))
                if found.steps >= 2 and sum(found.seconds[1:]) > seconds:
                    break
    except Exception as exc:  # noqa: BLE001 (the estimate is advice: `run` reports the failure itself)
        found.failed = f"{type(exc).__name__}: {exc}" if not isinstance(exc, InstabilityError) else str(exc)
    finally:
        numba.set_num_threads(threads)
    return found
