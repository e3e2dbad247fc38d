"""Explicit integration: one step is the task list of mpmsim/tasks, built once from the scene
(the MPM step for particle bodies, velocity Verlet with augury contact for FEM bodies); each
task is timed for the run's table. After the tasks, the step's reactions (walls, rigid
materials) are added to their impulses since t = 0.

With `device="cuda"` the same task list runs on the GPU (mpmsim/gpu/step.py): each task is
the device version of the CPU task of that name, the state stays on the device, and
`to_host` brings the host state up to date when the run loop reads it."""

from __future__ import annotations

import functools
import time as wallclock

import numpy as np

from ..tasks import plan_tasks
from ..tasks.setup import cfl_rule
from .base import Integrator


class ExplicitMPM(Integrator):
    name = "explicit"
    device = None  # the GPU step (mpmsim/gpu/step.py) when the run is on a device

    def __init__(self, scene, device: str = "cpu"):
        super().__init__()
        time = scene.settings.time
        self.tasks, self.skipped = plan_tasks(scene)
        if device == "cuda":  # (a CPU integrator has no attribute: its checkpoint restarts on either)
            from ..gpu.step import DeviceStep
            from ..tasks import Task

            self.device = DeviceStep(scene)
            runs = self.device.tasks(self.tasks)
            self.tasks = [Task(t.name, runs[t.name], t.why) for t in self.tasks]
        self.plan = [(t.name, t.why) for t in self.tasks]
        self.timers = {t.name: 0.0 for t in self.tasks}
        self.cfl = time.cfl if time.cfl is not None else 0.5
        self.fixed = time.dt
        self._rule = cfl_rule(time.dt, self.cfl, float(scene.grid.h.min())) if scene.has_particles else None

    def stable_dt(self, state) -> float:
        """The deck's dt, or the smaller of the MPM CFL step and cfl x the smallest FEM
        element's h / c (at the current positions)."""
        t0 = wallclock.perf_counter()
        dt = self._rule(state) if self._rule is not None else np.inf
        if self.fixed is None:
            for bodies in state.bodies:
                dt = min(dt, bodies.stable_dt(state, self.cfl))
        self.timers[self.tasks[0].name] += wallclock.perf_counter() - t0
        return self.fixed if self.fixed is not None else dt

    def advance(self, state, dt: float) -> float:
        timers = self.timers
        if self.device is not None:
            from ..gpu.step import timed_step

            timed_step(self.device, self.tasks, timers, state)
        else:
            for task in self.tasks:
                t0 = wallclock.perf_counter()
                task.run(state)
                timers[task.name] += wallclock.perf_counter() - t0
        state.impulse += state.reaction * dt  # the walls' and rigid materials' impulse since t = 0
        return dt

    def dry_parts(self, state) -> list:
        """One part per task (a task stopped by a dry kernel's missing result ends alone)."""
        if self.device is not None:
            return []
        return [functools.partial(task.run, state) for task in self.tasks]

    def to_host(self, state) -> None:
        if self.device is not None:
            self.device.to_host(state)

    def host_changed(self, state) -> None:
        if self.device is not None:
            self.device.state = None  # copied to the device again at the next step
