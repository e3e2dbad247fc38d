"""Run a scene: walk the task list each step, time each task, schedule output, stop cleanly.

    sim = Simulation.from_deck("inputs/disks.yaml")
    result = sim.run()
"""

from __future__ import annotations

import time as wallclock
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from .deck import LoadedDeck, load_deck
from .errors import InstabilityError
from .output.history import History
from .output.vtu import VtuSeries
from .scene import Scene, build_scene
from .state import State, StepFlags
from .tasks import build_task_list


@dataclass
class RunResult:
    steps: int
    wall_time: float
    particle_steps: int
    timers: dict[str, float]
    files: list[Path] = field(default_factory=list)
    history_path: Path | None = None
    pvd_path: Path | None = None

    @property
    def rate(self) -> float:
        """Particle-steps per second over the stepping (output excluded)."""
        stepping = sum(v for k, v in self.timers.items() if k != "output")
        return self.particle_steps / stepping if stepping > 0 else 0.0


def default_output_dir(loaded: LoadedDeck) -> Path:
    out = loaded.deck.output.directory
    if out is None:
        return Path.cwd() / "results" / loaded.stem
    p = Path(out)
    return p if p.is_absolute() else loaded.base_dir / p


class Simulation:
    def __init__(self, scene: Scene, out_dir: Path | None = None, threads: int | None = None):
        """`out_dir=None` keeps the history in memory and writes no files (tests, sweeps)."""
        self.scene = scene
        self.state = State.from_scene(scene, threads)
        self.tasks = build_task_list(scene)
        self.timers = {t.name: 0.0 for t in self.tasks}
        self.timers["output"] = 0.0
        self.out_dir = Path(out_dir) if out_dir is not None else None
        stem = scene.loaded.stem
        if self.out_dir is not None:
            self.out_dir.mkdir(parents=True, exist_ok=True)
        self.history = History(self.state, self.out_dir / f"{stem}_history.csv" if self.out_dir else None)
        self.vtu = VtuSeries(self.out_dir, stem) if self.out_dir is not None else None
        self.files: list[Path] = []

    @classmethod
    def from_deck(cls, deck_path, out_dir: Path | None = None, threads: int | None = None) -> "Simulation":
        return cls(build_scene(load_deck(deck_path)), out_dir=out_dir, threads=threads)

    def step(self) -> None:
        st = self.state
        if st.t >= self.scene.deck.time.end * (1.0 - 1e-9):
            raise RuntimeError(f"the run has reached time.end = {self.scene.deck.time.end:g}; nothing left to step")
        st.flags = StepFlags()
        for task in self.tasks:
            t0 = wallclock.perf_counter()
            task.run(st)
            self.timers[task.name] += wallclock.perf_counter() - t0
        st.t += st.dt
        st.step += 1

    def _write_output(self, vtu: bool) -> None:
        t0 = wallclock.perf_counter()
        if vtu and self.vtu is not None:
            self.files.append(self.vtu.write(self.state))
        self.history.flush()
        self.timers["output"] += wallclock.perf_counter() - t0

    def run(self, progress: Callable[[State], None] | None = None) -> RunResult:
        st, deck = self.state, self.scene.deck
        end = deck.time.end
        vtu_dt = deck.output.vtu_interval or end / 20
        hist_dt = deck.output.history_interval or end / 200
        eps = 1e-9 * end
        start = wallclock.perf_counter()
        if st.step == 0:  # the energy balance starts from the state as the caller left it
            st.energy0 = 0.5 * float((st.particles.mass[:, None] * st.particles.v**2).sum())
        self.history.record(st)
        self._write_output(vtu=True)
        next_vtu, next_hist = vtu_dt, hist_dt
        recorded_at, written_at = st.t, st.t
        try:
            while st.t < end - eps:
                self.step()
                if st.t >= next_hist - eps:
                    self.history.record(st)
                    recorded_at = st.t
                    while next_hist <= st.t + eps:
                        next_hist += hist_dt
                if st.t >= next_vtu - eps:
                    self._write_output(vtu=True)
                    written_at = st.t
                    while next_vtu <= st.t + eps:
                        next_vtu += vtu_dt
                if progress is not None:
                    progress(st)
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
        if recorded_at != st.t:
            self.history.record(st)
        self._write_output(vtu=written_at != st.t)
        wall = wallclock.perf_counter() - start
        return RunResult(st.step, wall, st.step * st.particles.n, dict(self.timers), list(self.files),
                         self.history.path, self.vtu.pvd_path if self.vtu else None)
