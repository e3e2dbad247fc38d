"""Explicit MPM: one step is the task list of mpmsim/tasks, built once from the scene; each
task is timed for the run's table."""

from __future__ import annotations

import time as wallclock

from ..tasks import plan_tasks
from ..tasks.setup import cfl_rule
from . import Integrator


class ExplicitMPM(Integrator):
    name = "explicit"

    def __init__(self, scene):
        super().__init__()
        deck = scene.deck
        self.tasks, self.skipped = plan_tasks(scene)
        self.plan = [(t.name, t.why) for t in self.tasks]
        self.timers = {t.name: 0.0 for t in self.tasks}
        cfl = deck.time.cfl if deck.time.cfl is not None else 0.5
        self._rule = cfl_rule(deck.time.dt, cfl, float(scene.grid.h.min()))

    def stable_dt(self, state) -> float:
        t0 = wallclock.perf_counter()
        dt = self._rule(state)
        self.timers[self.tasks[0].name] += wallclock.perf_counter() - t0
        return dt

    def advance(self, state, dt: float) -> float:
        timers = self.timers
        for task in self.tasks:
            t0 = wallclock.perf_counter()
            task.run(state)
            timers[task.name] += wallclock.perf_counter() - t0
        return dt
