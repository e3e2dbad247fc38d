"""The run loop: step an integrator to time.end, schedule history and output, check stability
after every step, time everything, stop cleanly.

    sim = Simulation.from_deck("inputs/disks.yaml")
    result = sim.run()

Data flows one way: deck -> scene (mpmsim/scene: bodies, grid, materials, contact) -> state
(mpmsim/state.py: plain arrays) -> integrator (mpmsim/integrators: how a step advances the
state) -> output (mpmsim/output). The loop knows the integrator only through `stable_dt`,
`advance` and `timers`; any integrator runs with the same history, output, checks and
messages.
"""

from __future__ import annotations

import math

import time as wallclock
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from .deck import LoadedDeck, load_deck
from .errors import InstabilityError
from .integrators import Integrator, make_integrator
from .output.history import History
from .output.vtu import VtuSeries
from .scene import Scene, build_scene
from .bodies import KINETIC
from .stability import StabilityCheck, total_sums
from .state import State, StepFlags

CHECK = "check stability"
OUTPUT = "output"


@dataclass
class RunResult:
    steps: int
    wall_time: float
    particle_steps: int
    timers: dict[str, float]
    files: list[Path] = field(default_factory=list)
    history_path: Path | None = None
    pvd_path: Path | None = None
    timed_steps: int = 0  # steps in the timers and the rate (all but the first, compiling one)

    @property
    def rate(self) -> float:
        """Particle-steps (plus element-steps of FEM bodies) per second over the stepping (output excluded)."""
        stepping = sum(v for k, v in self.timers.items() if k != OUTPUT)
        return self.particle_steps / stepping if stepping > 0 else 0.0


def default_output_dir(loaded: LoadedDeck) -> Path:
    out = loaded.deck.output.directory
    if out is None:
        return Path.cwd() / "results" / loaded.stem
    p = Path(out)
    return p if p.is_absolute() else loaded.base_dir / p


def next_time(current: float, interval: float, now: float) -> float:
    """The first time of the series current + k interval (k >= 1) after `now`; one jump, so an
    interval far below the time step cannot stall the run (it then records every step)."""
    if current + interval > now:
        return current + interval
    k = math.floor((now - current) / interval) + 1
    nxt = current + k * interval
    return nxt if nxt > now else now + interval


class StopRequested(KeyboardInterrupt):
    """Raised between steps (Simulation.run's `between_steps`) when the run was asked to stop,
    e.g. by a signal: the state is whole, so the run writes it before stopping."""


class Simulation:
    def __init__(self, scene: Scene, out_dir: Path | None = None, threads: int | None = None,
                 integrator: Integrator | None = None, max_steps: float | None = None,
                 max_frames: float | None = None):
        """`out_dir=None` keeps the history in memory and writes no files (tests, sweeps).
        `integrator=None`: the deck's (make_integrator). `max_steps`, `max_frames`: refuse (a
        DeckError, before any file is touched) a run whose estimated step count (time.end over
        the first stable step) or output count exceeds them."""
        self.scene = scene
        deck = scene.deck
        self.end = deck.time.end
        self.vtu_interval = deck.output.vtu_interval or self.end / 20
        self.history_interval = deck.output.history_interval or self.end / 200
        self.state = State.from_scene(scene, threads)
        self.integrator = integrator if integrator is not None else make_integrator(scene)
        self.check = StabilityCheck(scene)
        self.loop_timers = {CHECK: 0.0, OUTPUT: 0.0}
        self.check_budget(max_steps, max_frames)
        self.out_dir = Path(out_dir) if out_dir is not None else None
        stem = scene.loaded.stem
        if self.out_dir is not None:
            self.out_dir.mkdir(parents=True, exist_ok=True)
        self.history = History(scene, self.state, self.out_dir / f"{stem}_history.csv" if self.out_dir else None)
        self.vtu = VtuSeries(self.out_dir, stem) if self.out_dir is not None else None
        self.files: list[Path] = []
        self.first_step_seconds = 0.0  # wall time of the first step of run() (compiling)

    def check_budget(self, max_steps: float | None, max_frames: float | None) -> None:
        deck = self.scene.deck
        problems = []
        if max_steps is not None:
            dt = deck.time.dt or self.integrator.stable_dt(self.state)
            steps = self.end / dt if dt > 0 else math.inf
            if not steps <= max_steps:
                problems.append((("time", "end"), f"about {steps:.3g} steps (stable dt {dt:.3g} for time.end "
                                 f"{self.end:g}); more than the {max_steps:.3g} allowed: check the densities and "
                                 "moduli, or run with --max-steps N"))
        if max_frames is not None:
            for key, interval in (("vtu_interval", self.vtu_interval), ("history_interval", self.history_interval)):
                frames = self.end / interval
                if not frames <= max_frames:
                    problems.append((("output", key), f"about {frames:.3g} outputs to time.end {self.end:g}; more "
                                     f"than the {max_frames:.3g} allowed: raise output.{key}, or run with "
                                     "--max-frames N"))
        if problems:
            from .deck.loader import raise_at

            raise_at(problems, self.scene.loaded)

    @classmethod
    def from_deck(cls, deck_path, out_dir: Path | None = None, threads: int | None = None) -> "Simulation":
        return cls(build_scene(load_deck(deck_path)), out_dir=out_dir, threads=threads)

    @property
    def timers(self) -> dict[str, float]:
        """Seconds per part of the run: the integrator's, then the stability check and output."""
        return {**self.integrator.timers, **self.loop_timers}

    def reset_timers(self) -> None:
        """Zero every timer (benchmarks: measure after a first, compiling step)."""
        for timers in (self.integrator.timers, self.loop_timers):
            for k in timers:
                timers[k] = 0.0

    def step(self) -> None:
        """One step of the integrator, then the stability check; advances the clock."""
        st, end = self.state, self.end
        if st.t >= end * (1.0 - 1e-9):
            raise RuntimeError(f"the run has reached time.end = {end:g}; nothing left to step")
        rule = self.integrator.stable_dt(st)
        st.dt_rule = rule
        st.dt = min(rule, end - st.t)
        st.flags = StepFlags()
        taken = self.integrator.advance(st, st.dt)
        st.dt = taken
        t0 = wallclock.perf_counter()
        self.check(st)
        self.loop_timers[CHECK] += wallclock.perf_counter() - t0
        st.t += st.dt
        st.step += 1

    def _write_output(self, vtu: bool) -> None:
        t0 = wallclock.perf_counter()
        if vtu and self.vtu is not None:
            self.files += self.vtu.write(self.state)
        self.history.flush()
        self.loop_timers[OUTPUT] += wallclock.perf_counter() - t0

    def _write_last(self, recorded_at: float, written_at: float) -> None:
        """The current state as the history's last row and the series' last frame, unless
        they already are (recorded or written at this time)."""
        if recorded_at != self.state.t:
            self.history.record(self.state)
        self._write_output(vtu=written_at != self.state.t)

    def run(self, progress: Callable[[State], None] | None = None,
            first_step: Callable[[float], None] | None = None,
            between_steps: Callable[[], None] | None = None) -> RunResult:
        """Step to time.end with history and output on their schedules. The first step (where
        numba compiles whatever the cache lacks) is kept out of the timers and the rate;
        `first_step(seconds)` is called after it. `between_steps()` is called after each step's
        output, where the state is whole: a StopRequested it raises ends the run with the
        history and a last VTU frame of that state written (a KeyboardInterrupt raised anywhere
        else writes the history only)."""
        st, end = self.state, self.end
        vtu_dt, hist_dt = self.vtu_interval, self.history_interval
        eps = 1e-9 * end
        start = wallclock.perf_counter()
        timed_from = None
        if st.step == 0:  # the energy balance starts from the state as the caller left it
            sums = total_sums(st)
            st.energy0 = float(sums[KINETIC]) if sums is not None else 0.0
        self.history.record(st)
        self._write_output(vtu=True)
        next_vtu, next_hist = vtu_dt, hist_dt
        recorded_at, written_at = st.t, st.t
        try:
            while st.t < end - eps:
                self.step()
                if timed_from is None:
                    self.first_step_seconds = wallclock.perf_counter() - start
                    self.reset_timers()
                    timed_from = st.step
                    if first_step is not None:
                        first_step(self.first_step_seconds)
                if st.t >= next_hist - eps:
                    self.history.record(st)
                    recorded_at = st.t
                    next_hist = next_time(next_hist, hist_dt, st.t + eps)
                if st.t >= next_vtu - eps:
                    self._write_output(vtu=True)
                    written_at = st.t
                    next_vtu = next_time(next_vtu, vtu_dt, st.t + eps)
                if progress is not None:
                    progress(st)
                if between_steps is not None:
                    between_steps()
        except StopRequested:
            self._write_last(recorded_at, written_at)
            raise
        except InstabilityError:
            # keep the failing state: advance the clock to the failing step, then write it
            st.t += st.dt
            st.step += 1
            self.history.record(st)
            self._write_output(vtu=True)
            raise
        except KeyboardInterrupt:
            self._write_output(vtu=False)
            raise
        self._write_last(recorded_at, written_at)
        wall = wallclock.perf_counter() - start
        n_cells = len(st.fem.cells) if st.fem is not None else 0  # points stepped: particles + elements
        timed = st.step - (timed_from if timed_from is not None else st.step)
        return RunResult(st.step, wall, timed * (st.particles.n + n_cells), self.timers, list(self.files),
                         self.history.path, self.vtu.pvd_path if self.vtu else None, timed)
