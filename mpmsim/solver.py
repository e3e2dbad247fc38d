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

from ._version import __version__
import numpy as np

from . import compile_ahead, linalg
from .deck import LoadedDeck, as_loaded_deck
from .deck.schema import wall_clock_seconds
from .errors import InstabilityError
from .output.checkpoint import CheckpointError, checkpoint_path, read_manifest, restore_checkpoint, \
    write_checkpoint
from .integrators import Integrator, make_integrator
from .output.history import History
from .output.vtu import VtuSeries
from .parallel import use_threads
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


def step_length(rule: float, remaining: float) -> float:
    """The step to take: the longest no longer than `rule` (the CFL bound or time.dt) that
    splits the `remaining` time into equal steps, so the run lands on time.end in steps of
    one length. Cutting only the last step short would end a resting contact on a sliver
    step whose contact decision (the separation advanced over the step) differs from the
    others': a sphere at rest on a flat then shows 24% less contact force in its final frame
    (docs/timestep.md, "The step length"). A rule that divides the remaining time to within
    1e-6 of a step is taken as it is (the clock's rounding over a long run is far below that,
    and would otherwise split the last step in two)."""
    tol = 1e-6
    if not (0.0 < rule < math.inf):
        return min(rule, remaining)
    if remaining <= rule * (1.0 + tol):
        return remaining
    steps = remaining / rule
    whole = math.ceil(steps - tol)
    return rule if steps >= whole - tol else remaining / whole


@dataclass
class Schedule:
    """Where the run loop is in its output schedules (saved in checkpoints)."""

    next_vtu: float
    next_hist: float
    next_checkpoint: float  # simulated time (inf: by wall clock or never)
    recorded_at: float  # time of the last history row
    written_at: float  # time of the last VTU frame


def check_device(scene: Scene, device: str, driver: bool = True) -> None:
    """Refuse a run on `device` (cuda) that the device cannot take: a DeckError naming each
    deck key the GPU step lacks, or (`driver`) mpmsim.gpu.DeviceError when CUDA is not there."""
    from . import gpu

    if device not in gpu.DEVICES:
        raise gpu.DeviceError(f"device {device!r}: one of {', '.join(gpu.DEVICES)}")
    problems = gpu.unsupported(scene)
    if problems:
        from .deck.loader import raise_at

        raise_at(problems, scene.loaded)
    if driver:
        gpu.require_cuda()


class StopRequested(KeyboardInterrupt):
    """Raised between steps (Simulation.run's `between_steps`) when the run was asked to stop,
    e.g. by a signal: the state is whole, so the run writes it (and a checkpoint) before stopping."""


class StepLimit(StopRequested):
    """The run took the number of steps it was asked for (`mpmsim run --steps N`)."""


class Simulation:
    def __init__(self, scene: Scene, out_dir: Path | None = None, threads: int | None = None,
                 integrator: Integrator | None = None, max_steps: float | None = None,
                 max_frames: float | None = None, resume: bool = False, device: str = "cpu"):
        """`out_dir=None` keeps the history in memory and writes no files (tests, sweeps).
        `integrator=None`: the deck's (make_integrator). `max_steps`, `max_frames`: refuse (a
        DeckError, before any file is touched) a run whose estimated step count (time.end over
        the first stable step) or output count exceeds them. `resume`: the folder holds a run
        to continue (call `resume()`); otherwise an earlier run's series files and checkpoint of
        this deck are removed. `device="cuda"`: the explicit MPM step on the GPU (mpmsim/gpu);
        what the deck asks for that is not there yet is refused (a DeckError naming the key),
        and a machine without CUDA raises mpmsim.gpu.DeviceError."""
        if device != "cpu":
            check_device(scene, device)
        self.scene = scene
        run = scene.settings
        self.end = run.time.end
        self.vtu_interval = run.output.vtu_interval or self.end / 20
        self.history_interval = run.output.history_interval or self.end / 200
        self.state = State.from_scene(scene, threads)
        self.integrator = integrator if integrator is not None else make_integrator(scene, device)
        self.check = StabilityCheck(scene)
        self.check.sync = lambda state: self.integrator.to_host(state)  # (its messages read the particles)
        self.loop_timers = {CHECK: 0.0, OUTPUT: 0.0}
        self.check_budget(max_steps, max_frames)
        self.out_dir = Path(out_dir) if out_dir is not None else None
        stem = scene.loaded.stem
        if self.out_dir is not None:
            self.out_dir.mkdir(parents=True, exist_ok=True)
        self.recorder = History(scene, self.state, self.out_dir / f"{stem}_history.csv" if self.out_dir else None)
        self.vtu = VtuSeries(self.out_dir, stem, clear=not resume) if self.out_dir is not None else None
        self.files: list[Path] = []
        self.first_step_seconds = 0.0  # wall time of the first step of run() (compiling)
        self.compile_helper = False  # run()'s first step with a helper compiling kernels (mpmsim run sets it)
        self.compile_report: dict = {}  # what compile_ahead.first_step said about it
        self.schedule: Schedule | None = None  # set by the first run() (or a restored checkpoint)
        interval = run.output.checkpoint_interval
        self.checkpoint_every = interval if not isinstance(interval, str) else math.inf  # simulated time
        self.checkpoint_wall = wall_clock_seconds(interval) if isinstance(interval, str) else None
        self.checkpoint_path = checkpoint_path(self.out_dir, stem) if self.out_dir is not None else None
        if self.out_dir is not None:  # what a killed run of this deck may have left half-written
            for name in (f"{stem}_history.csv", f"{stem}_history.json", f"{stem}.pvd", self.checkpoint_path.name):
                (self.out_dir / f".{name}.tmp").unlink(missing_ok=True)
            if not resume:
                self.checkpoint_path.unlink(missing_ok=True)

    def check_budget(self, max_steps: float | None, max_frames: float | None) -> None:
        run = self.scene.settings
        problems = []
        if max_steps is not None:
            dt = run.time.dt or self.integrator.stable_dt(self.state)
            steps = self.end / dt if dt > 0 else math.inf
            if not steps <= max_steps:
                problems.append((("time", "end"), f"about {steps:.3g} steps (stable dt {dt:.3g} for time.end "
                                 f"{self.end:g}); more than the {max_steps:.3g} allowed: check the densities and "
                                 "moduli, or run with --max-steps N"))
        if max_frames is not None:
            every = run.output.checkpoint_interval
            sim_every = [("checkpoint_interval", every)] if not isinstance(every, str) else []
            for key, interval in [("vtu_interval", self.vtu_interval), ("history_interval", self.history_interval)] \
                    + sim_every:
                frames = self.end / interval
                if not frames <= max_frames:
                    problems.append((("output", key), f"about {frames:.3g} outputs to time.end {self.end:g}; more "
                                     f"than the {max_frames:.3g} allowed: raise output.{key}, or run with "
                                     "--max-frames N"))
        if problems:
            from .deck.loader import raise_at

            raise_at(problems, self.scene.loaded)

    @classmethod
    def from_deck(cls, deck, out_dir: Path | str | None = None, threads: int | None = None, name: str = "deck",
                  base_dir: Path | str | None = None, **options) -> "Simulation":
        """A simulation of a deck given as a YAML file's path, a mapping (the YAML's content,
        e.g. a file's data with a key changed) or a `Deck` model; the last two are validated as
        a file would be, and named `name` (output files <name>_...; relative file names in the
        deck are read from `base_dir`, default the current folder). A bad deck raises DeckError
        naming the key. `out_dir=None` writes no files (history in memory); `options`: those
        of Simulation()."""
        return cls(build_scene(as_loaded_deck(deck, name, base_dir)), out_dir=out_dir, threads=threads, **options)

    @property
    def history(self):
        """The history recorded so far, as a pandas DataFrame (one row per history time; the
        columns of the history CSV). Built anew at each access; `recorder` is the History."""
        return self.recorder.frame()

    @property
    def particles(self) -> dict[str, np.ndarray]:
        """The deformable particles now, as arrays (copies): x, v (n, dim), stress (n, 6: xx yy zz
        xy yz xz), F (n, dim, dim), J, mass, volume (n,), material (names), body (indices)."""
        self.integrator.to_host(self.state)
        P = self.state.particles
        names = np.array(self.state.materials.deformable, dtype=object)
        return {"x": P.x.copy(), "v": P.v.copy(), "stress": P.stress.copy(), "F": P.F.copy(),
                "J": linalg.det(P.F), "mass": P.mass.copy(), "volume": P.vol.copy(),
                "material": names[P.mat] if P.n else np.array([], dtype=object), "body": P.body.copy()}

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
        self._begin_step()
        self._finish_step()

    def first_step(self, helper: bool = True, before: Callable[[], None] | None = None) -> dict:
        """step(), with a helper process compiling part of the kernels the cache lacks where it
        can (mpmsim/compile_ahead.py; helper=False: this process alone). `before()`: what a new
        run does first with the state at its start (the energy sums, the first history row and
        frame), run inside the same window so that its kernels compile beside the helper's; it
        sees the state as it was before the step began (its dt too). Returns the report."""
        st = self.state
        dt0 = st.dt
        self._begin_step()
        step, parts = self._finish_step, [*self.integrator.dry_parts(st), lambda: self.check(st)]
        if before is not None:
            def step() -> None:
                dt, st.dt = st.dt, dt0
                before()
                st.dt = dt
                self._finish_step()
            parts.insert(0, lambda: total_sums(st, detail=True))  # (the helper runs no output)
        on_cpu = getattr(self.integrator, "device", None) is None
        return compile_ahead.first_step(step, parts, enabled=helper and on_cpu)

    def _begin_step(self) -> None:
        """The step's time step and flags, the kernels' form."""
        st, end = self.state, self.end
        if st.t >= end * (1.0 - 1e-9):
            raise RuntimeError(f"the run has reached time.end = {end:g}; nothing left to step")
        rule = self.integrator.stable_dt(st)
        st.dt_rule = rule
        st.dt = step_length(rule, end - st.t)
        st.flags = StepFlags()
        use_threads(st.threads)  # this state's kernel form (another simulation may have switched it)

    def _finish_step(self) -> None:
        """The integrator's advance over the step's dt, the stability check, the clock."""
        st = self.state
        taken = self.integrator.advance(st, st.dt)
        st.dt = taken
        t0 = wallclock.perf_counter()
        self.check(st)
        self.loop_timers[CHECK] += wallclock.perf_counter() - t0
        st.t += st.dt
        st.step += 1

    def _write_frame(self) -> None:
        """A VTU frame of the state (the history appends its rows to the CSV as they are recorded)."""
        t0 = wallclock.perf_counter()
        if self.vtu is not None:
            self.integrator.to_host(self.state)
            self.files += self.vtu.write(self.state)
        self.loop_timers[OUTPUT] += wallclock.perf_counter() - t0

    def _record(self) -> None:
        """A history row of the state now."""
        self.integrator.to_host(self.state)
        self.recorder.record(self.state)

    def _write_last(self, recorded_at: float, written_at: float) -> None:
        """The current state as the history's last row and the series' last frame, unless
        they already are (recorded or written at this time)."""
        if recorded_at != self.state.t:
            self._record()
        if written_at != self.state.t:
            self._write_frame()

    # ------------------------------------------------------------------------ checkpoints
    def _checkpoint_root(self) -> dict:
        return {"simulation": self}

    def write_checkpoint(self) -> Path | None:
        """Save the whole run (state, integrator, history rows, frames, schedule) to the
        output folder's checkpoint, replacing the previous one atomically."""
        if self.checkpoint_path is None:
            return None
        t0 = wallclock.perf_counter()
        self.integrator.to_host(self.state)
        meta = {"mpmsim": __version__, "deck": self.scene.digest, "t": self.state.t,
                "step": self.state.step, "threads": self.state.threads}
        write_checkpoint(self.checkpoint_path, self._checkpoint_root(), meta)
        self.loop_timers[OUTPUT] += wallclock.perf_counter() - t0
        return self.checkpoint_path

    def resume(self, path: Path | None = None) -> dict:
        """Continue the run saved in the checkpoint `path` (default: this output folder's):
        refused (CheckpointError) when it is from another deck or mpmsim version. The folder is
        brought back to the checkpoint: frames written after it are removed, the .pvd and the
        history CSV (written anew from the checkpoint's rows) list exactly what the checkpoint
        holds."""
        path = Path(path) if path is not None else self.checkpoint_path
        if path is None:
            raise CheckpointError("a restart needs an output folder")
        manifest = read_manifest(path)
        if manifest.get("mpmsim") != __version__:
            raise CheckpointError(f"{str(path)!r} was written by mpmsim {manifest.get('mpmsim')}, this is "
                                  f"{__version__}; rerun from the start")
        if manifest.get("deck") != self.scene.digest:
            raise CheckpointError(f"{str(path)!r} was written for a different deck (or one changed since); "
                                  "rerun from the start, or restore the deck as it was")
        restore_checkpoint(path, self._checkpoint_root(), manifest)
        self.integrator.host_changed(self.state)
        if self.vtu is not None:
            self.vtu.resumed()
            self.files = [self.vtu.directory / f for _, _, f in self.vtu.entries]
        self.recorder.rewrite()
        return manifest

    def run(self, progress: Callable[[State], None] | bool | None = None,
            first_step: Callable[[float], None] | None = None,
            between_steps: Callable[[], None] | None = None) -> RunResult:
        """Step to time.end with history and output on their schedules. `progress`: True draws
        a progress bar (terminal or notebook), a function is called with the state after every
        step. The first step (where numba compiles whatever the cache lacks) is kept out of the
        timers and the rate; `first_step(seconds)` is called after it. `between_steps()` is
        called after each step's output, where the state is whole: a StopRequested it raises
        ends the run with the history and a last VTU frame of that state written (a
        KeyboardInterrupt raised anywhere else leaves the rows recorded so far and the frames
        written)."""
        if progress is True:
            from .deck.units import unit_system
            from .output.progress import progress_bar

            with progress_bar(self.scene.loaded.stem, self.end, unit_system(self.scene.settings.units).time) as report:
                return self.run(report, first_step, between_steps)
        progress = progress or None
        st, end = self.state, self.end
        vtu_dt, hist_dt = self.vtu_interval, self.history_interval
        eps = 1e-9 * end
        start = wallclock.perf_counter()
        timed_from = None

        def open_run() -> None:  # a new run (a restored one continues its schedule)
            if st.step == 0:  # the energy balance starts from the state as the caller left it
                sums = total_sums(st)
                st.energy0 = float(sums[KINETIC]) if sums is not None else 0.0
            self._record()
            self._write_frame()
            self.schedule = Schedule(st.t + vtu_dt, st.t + hist_dt, st.t + self.checkpoint_every, st.t, st.t)

        if self.schedule is None and not st.t < end - eps:
            open_run()
        sc = self.schedule
        saved_at = wallclock.perf_counter()
        try:
            while st.t < end - eps:
                if timed_from is None:  # (a new run's start inside it: its kernels compile beside the helper's)
                    self.compile_report = self.first_step(self.compile_helper, open_run if sc is None else None)
                    sc = self.schedule
                else:
                    self.step()
                if timed_from is None:
                    self.first_step_seconds = wallclock.perf_counter() - start
                    self.reset_timers()
                    timed_from = st.step
                    if first_step is not None:
                        first_step(self.first_step_seconds)
                if st.t >= sc.next_hist - eps:
                    self._record()
                    sc.recorded_at = st.t
                    sc.next_hist = next_time(sc.next_hist, hist_dt, st.t + eps)
                if st.t >= sc.next_vtu - eps:
                    self._write_frame()
                    sc.written_at = st.t
                    sc.next_vtu = next_time(sc.next_vtu, vtu_dt, st.t + eps)
                by_time = st.t >= sc.next_checkpoint - eps
                every_s = self.checkpoint_wall
                by_clock = every_s is not None and wallclock.perf_counter() - saved_at >= every_s
                if (by_time or by_clock) and st.t < end - eps:  # (none at the end: the run is complete)
                    if by_time:
                        sc.next_checkpoint = next_time(sc.next_checkpoint, self.checkpoint_every, st.t + eps)
                    self.write_checkpoint()
                    saved_at = wallclock.perf_counter()
                if progress is not None:
                    progress(st)
                if between_steps is not None:
                    between_steps()
        except StopRequested:
            # the checkpoint first: it holds the schedule as it is, so a restart continues as the
            # uninterrupted run would; then the stopping state as the last row and frame
            self.write_checkpoint()
            self._write_last(sc.recorded_at, sc.written_at)
            raise
        except InstabilityError:
            # keep the failing state: advance the clock to the failing step, then write it
            st.t += st.dt
            st.step += 1
            self._record()
            self._write_frame()
            raise
        self._write_last(sc.recorded_at, sc.written_at)
        if self.checkpoint_path is not None:  # the run is complete: nothing to continue
            self.checkpoint_path.unlink(missing_ok=True)
        wall = wallclock.perf_counter() - start
        timed = st.step - (timed_from if timed_from is not None else st.step)
        stepped = sum(bodies.stepped for bodies in st.bodies)  # particles and elements
        return RunResult(st.step, wall, timed * stepped, self.timers, list(self.files),
                         self.recorder.path, self.vtu.pvd_path if self.vtu else None, timed)
