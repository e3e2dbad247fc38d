"""Command line: `mpmsim run DECK`, `mpmsim compile DECK`, `mpmsim check DECK`, `mpmsim sweep SWEEP`,
`mpmsim plot CSV...`, `mpmsim paraview RESULTS`, `mpmsim --version`.

Exit codes: 0 ok, 1 a sweep stopped by its Dask cluster (no workers, a lost scheduler), 2 bad
deck, bad command line, unusable checkpoint or results folder, 3 run stopped as unstable, 4
output could not be written (folder, disk), 130 / 143 stopped by Ctrl-C / SIGTERM
(docs/reliability.md).
"""

from __future__ import annotations

import contextlib
import inspect
import io
import os
import signal
import sys
import time
import warnings
from contextlib import contextmanager
from pathlib import Path
from typing import Optional

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table
from rich.text import Text

from . import kernel_cache
from ._version import __version__
from .errors import DeckError, InstabilityError

EXIT_BAD_DECK = 2
EXIT_UNSTABLE = 3
EXIT_IO = 4

# rich_markup_mode None: help texts are shown as written (brackets such as mpmsim[cuda] are not
# markup); each command's docstring opens with a one-line summary, the command list's entry
app = typer.Typer(add_completion=False, pretty_exceptions_enable=False, no_args_is_help=True, rich_markup_mode=None,
                  help="Material point method simulator for multimaterial contact mechanics.")
out = Console(soft_wrap=True)  # never break file paths across lines
err = Console(stderr=True, soft_wrap=True)


def _version(value: bool) -> None:
    if value:
        print(f"mpmsim {__version__}")
        raise typer.Exit(0)


@app.callback()
def _root(version: Optional[bool] = typer.Option(None, "--version", callback=_version, is_eager=True,
                                                 help="Print the version and exit.")) -> None:
    """mpmsim: one YAML deck in; VTU time series and CSV histories out."""


@contextmanager
def _deck_errors():
    """A DeckError raised inside (by the loader, the scene, an integrator's checks) or a
    checkpoint that cannot be used ends the command with its message and exit 2."""
    from .output.checkpoint import CheckpointError

    try:
        yield
    except DeckError as exc:
        err.print(f"[bold red]mpmsim: bad deck[/]\n{escape(exc.format())}", highlight=False, soft_wrap=True)
        raise typer.Exit(EXIT_BAD_DECK) from None
    except CheckpointError as exc:
        err.print(f"mpmsim: cannot restart: {escape(str(exc))}", highlight=False, soft_wrap=True)
        raise typer.Exit(EXIT_BAD_DECK) from None


def _load_scene(deck: Path):
    from .deck import load_deck
    from .scene import build_scene

    with _deck_errors():
        return build_scene(load_deck(deck))


def _command(function):
    """A command whose entry in the command list is its docstring's first line, whole."""
    return app.command(short_help=inspect.getdoc(function).splitlines()[0])(function)


@_command
def run(
    ctx: typer.Context,
    deck: Path = typer.Argument(..., help="Problem deck (YAML)."),
    out_dir: Optional[Path] = typer.Option(None, "--out", help="Output directory (overrides the deck)."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar, timing table or file list."),
    threads: Optional[int] = typer.Option(
        None, "--threads", help="Worker threads (default: the cores other processes leave idle)."),
    max_steps: int = typer.Option(100_000_000, "--max-steps", min=1,
                                  help="Refuse a run estimated to take more steps."),
    max_frames: int = typer.Option(100_000, "--max-frames", min=1, help="Refuse more VTU frames or history rows."),
    restart: Optional[Path] = typer.Option(
        None, "--restart", help="Continue the run whose output folder (and checkpoint) this is."),
    steps: Optional[int] = typer.Option(
        None, "--steps", min=1, help="Stop after this many steps (a checkpoint is written: --restart continues)."),
    device: str = typer.Option("cpu", "--device", help="cpu, or cuda: the explicit MPM step on an NVIDIA GPU "
                               "(pip install 'mpmsim[cuda]'; what the GPU lacks is refused, naming the key)."),
) -> None:
    """Run a deck: VTU series (+ .pvd for ParaView) and a CSV history."""
    import numba

    from .output.checkpoint import checkpoint_path, read_manifest
    from .output.progress import progress_bar
    from .output.runlog import RunLog
    from .parallel import auto_threads
    from .solver import Simulation, StepLimit, StopRequested, default_output_dir

    cold = kernel_cache.is_empty()  # before the scene's own kernels fill it
    scene = _load_scene(deck)
    _check_device(scene, device)
    manifest = None
    if restart is not None:
        with _deck_errors():
            manifest = read_manifest(checkpoint_path(restart, scene.loaded.stem))
    if threads is not None:
        chosen, why = threads, "--threads"
    elif manifest is not None:  # the checkpoint's count: the run continues bit for bit
        chosen, why = int(manifest.get("threads", 1)), "as the checkpointed run"
    else:
        chosen, why = default_threads()
        small, reason = auto_threads(chosen, len(scene.deformable.x))
        if reason:
            chosen, why = small, reason
    numba.set_num_threads(max(1, min(chosen, numba.config.NUMBA_NUM_THREADS)))
    thread_line = f"threads: {numba.get_num_threads()} ({why}; --threads N to choose)"
    if not quiet and threads is None:
        out.print(thread_line, highlight=False)
    directory = restart if restart is not None else out_dir if out_dir is not None else default_output_dir(scene.loaded)
    try:
        with _deck_errors():
            sim = Simulation(scene, out_dir=directory, threads=numba.get_num_threads(), max_steps=max_steps,
                             max_frames=max_frames, resume=restart is not None, device=device)
            sim.compile_helper = True  # the first step's kernels compile in two processes (compile_ahead)
            if restart is not None:
                sim.resume()
            log = RunLog(Path(directory) / f"{scene.loaded.stem}_run.log", _command_line(ctx), scene.loaded,
                         numba.get_num_threads())
            log.note(thread_line)
            if device != "cpu":
                log.note(f"device: {device} (the explicit MPM step on the GPU: docs/performance.md#gpu)")
            for notice in scene.notices:  # (also with --quiet: a warning is not progress)
                log.note(f"warning: {notice}")
                err.print(f"[yellow]warning:[/] {escape(notice)}", highlight=False, soft_wrap=True)
            if restart is not None:
                restarted = (f"restarting from the checkpoint at step {sim.state.step}, t = {sim.state.t:.6g} "
                             f"{_units(scene).time}")
                log.note(restarted)
                if not quiet:
                    out.print(restarted, highlight=False)
    except (OSError, ValueError) as exc:  # the folder: not creatable, a file in the way, a NUL in the path
        err.print(f"mpmsim: cannot write the output folder {escape(repr(str(directory)))}: {escape(_reason(exc))}",
                  highlight=False, soft_wrap=True)
        raise typer.Exit(EXIT_IO) from None

    def stop(message: str, reason: str, code: int) -> typer.Exit:
        """Say why the run stopped (stderr and the log); the exit to raise."""
        err.print(message, highlight=False, soft_wrap=True)
        log.note(Text.from_markup(message).plain)
        with contextlib.suppress(OSError):  # (a full disk may refuse the log too)
            log.finish(f"{reason} (exit {code})")
        return typer.Exit(code)

    st, end = sim.state, scene.deck.time.end
    tu = _units(scene).time

    if not quiet and cold:
        out.print("compiling kernels for this scene (first run only)...", highlight=False)

    def compiled(seconds: float) -> None:
        if cold or seconds > 2.0:
            said = f"first step: {seconds:.1f} s (numba compiled the kernels the cache lacked; later runs load them)"
            report = sim.compile_report
            if report.get("helper") and report.get("waited"):
                said += f"; a helper process compiled {report['waited']} of them alongside"
            log.note(said)
            if not quiet:
                out.print(said, highlight=False)

    # Ctrl-C (SIGINT) and SIGTERM ask the run to stop at the end of the current step, where the
    # state is whole and is written; a second signal stops it at once (history kept)
    received: list[int] = []

    def request_stop(signum, frame):
        if received:
            raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()
        received.append(signum)
        os.write(2, b"\nmpmsim: stopping at the end of this step (signal again to stop now)\n")  # no locks

    last_step = None if steps is None else sim.state.step + steps

    def between_steps() -> None:
        if received:
            raise StopRequested()
        if last_step is not None and st.step >= last_step:
            raise StepLimit()

    previous = {s: signal.signal(s, request_stop) for s in (signal.SIGINT, signal.SIGTERM)}
    show = warnings.showwarning

    def note_warning(message, category, filename, lineno, file=None, line=None):
        """A warning the run gives goes to the log as well (as it happens: a failing run's too)."""
        log.note(f"warning: {category.__name__}: {message} ({Path(filename).name}:{lineno})")
        show(message, category, filename, lineno, file, line)

    warnings.showwarning = note_warning
    try:
        if not quiet:
            with progress_bar(scene.loaded.stem, end, tu, out) as report:
                result = sim.run(report, compiled, between_steps)
        else:
            result = sim.run(first_step=compiled, between_steps=between_steps)
    except InstabilityError as exc:
        raise stop(f"[bold red]mpmsim: run stopped[/]: {escape(str(exc))}\noutput so far (including the failing "
                   f"state) is in {directory}", f"unstable at step {st.step}, t = {st.t:.6g} {tu}",
                   EXIT_UNSTABLE) from None
    except OSError as exc:  # a write failed mid-run (disk full, folder removed): earlier files are whole
        raise stop(f"mpmsim: output failed at step {st.step}, t = {st.t:.6g} {tu}: {escape(_reason(exc))}; the files "
                   f"written before are whole, in {directory}", "output failed", EXIT_IO) from None
    except StepLimit:
        stop(f"mpmsim: stopped after {steps} steps (--steps) at t = {st.t:.6g} {tu}; results in {directory}; "
             f"continue with mpmsim run {deck} --restart {directory}",
             f"stopped after {steps} steps (--steps), checkpoint written", 0)
        return
    except KeyboardInterrupt as exc:  # caught here: the command-line framework would swallow it
        term = (received[0] == signal.SIGTERM) if received else isinstance(exc, Terminated)
        what, code = ("terminated", 143) if term else ("interrupted", 130)
        resume = f"mpmsim run {deck} --restart {directory}"
        if isinstance(exc, StopRequested):  # stopped at the end of a step: checkpoint written
            raise stop(f"mpmsim: {what} at step {st.step}, t = {st.t:.6g} {tu}; results in {directory}; resume "
                       f"with {resume}", f"{what} at the end of step {st.step}, checkpoint written", code) from None
        # stopped mid-step (a second signal): the last periodic checkpoint, if any, is kept
        ckpt = checkpoint_path(directory, scene.loaded.stem)
        where = f"; resume from the last checkpoint with {resume}" if ckpt.exists() else ""
        raise stop(f"mpmsim: {what} in step {st.step + 1}; the history and the VTU files written so far are in "
                   f"{directory}{where}", f"{what} in step {st.step + 1}", code) from None
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        warnings.showwarning = show
    table = _timing_table(result, sim)
    report_lines = list(getattr(sim.integrator, "report", lambda: [])())
    if st.ledger is not None:
        from .tasks.ledger import ledger_summary
        report_lines.append(ledger_summary(st, _units(scene).energy))
    for line in report_lines:
        log.note(line)
    with contextlib.suppress(OSError):
        log.finish(f"completed at t = {st.t:.6g} {tu}, step {st.step} (exit 0)", _plain(table))
    if quiet:
        return
    out.print(table)
    for line in report_lines:
        out.print(line, highlight=False)
    out.print(f"[bold]run log[/]:    {log.path}", highlight=False)
    out.print(f"[bold]VTU series[/]: {result.pvd_path}  ({len(result.files)} files)", highlight=False)
    out.print(f"[bold]history[/]:    {result.history_path}", highlight=False)
    out.print(_time_split(result, sim), highlight=False)


def _time_split(result, sim) -> str:
    """The run's closing line: its wall time as compiling plus stepping. Compiling (or, with
    the kernel cache filled, loading the kernels) is the first step's time less a warm step's
    (the mean of the others); stepping is the rest, output included."""
    first = min(sim.first_step_seconds, result.wall_time)
    rest = result.wall_time - first
    warm = rest / result.timed_steps if result.timed_steps else 0.0
    compiling = max(first - warm, 0.0)
    return (f"[bold]time[/]:       {result.wall_time:.2f} s wall = {compiling:.2f} s compiling or loading kernels "
            f"(the first step less a warm one) + {result.wall_time - compiling:.2f} s stepping ({result.steps} steps, "
            "output included)")


def _reason(exc: BaseException) -> str:
    """An OS error in a few words (no traceback, no errno number)."""
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror + (f" ({exc.filename})" if exc.filename else "")
    return str(exc)


class Terminated(KeyboardInterrupt):
    """A second SIGTERM, raised where the run is so it stops as Ctrl-C does (output kept whole)."""


def default_threads(cpus: set[int] | None = None, busy: float | None = None,
                    load: float | None = None) -> tuple[int, str]:
    """(threads, why): every core this process may run on (its affinity). Threads share out a
    region's work as they go (TBB) or sleep while they wait (OpenMP with OMP_WAIT_POLICY=PASSIVE,
    mpmsim's default), so a busy neighbour takes its share of the cores and no more: on the
    2-core bench machine two threads ran at least as fast as one beside one or three busy
    processes, started before or during the run (bench/contention.py, docs/performance.md).
    Where the user makes OpenMP's waiting threads spin (OMP_WAIT_POLICY=ACTIVE, without TBB) a
    thread sharing a core with a busy process stalls every region (2-12x slower measured), so
    then only the cores other processes leave idle are taken: `busy` is how many cores' worth
    of CPU they used over the last 0.2 s (/proc/stat; rounded); without /proc, the 1-minute
    load average (`load`)."""
    from . import TBB

    if cpus is None:
        cpus = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else set(range(os.cpu_count() or 1))
    n_cpus = len(cpus)
    if TBB or os.environ.get("OMP_WAIT_POLICY", "").strip().upper() != "ACTIVE":
        return n_cpus, f"{n_cpus} cores"
    how = "over the last 0.2 s"
    if busy is None and load is None:
        busy = busy_cores(cpus)
    if busy is None:
        if load is None:
            try:
                load = os.getloadavg()[0]
            except (OSError, AttributeError):
                load = 0.0
        busy, how = load, "1-minute load average"
    taken = min(n_cpus, max(0, int(busy + 0.5)))
    n = max(1, n_cpus - taken)
    return n, (f"{n_cpus} cores, all idle, spinning waits" if taken == 0 else
               f"{n_cpus} cores, {taken} kept busy by other processes ({busy:.1f} cores' worth, {how}), "
               f"spinning waits")


def busy_cores(cpus: set[int], window: float = 0.2, stat=lambda: Path("/proc/stat").read_text()) -> float | None:
    """Cores' worth of CPU time spent on `cpus` over `window` seconds while this process sleeps
    (so all of it is other processes'), from /proc/stat (`stat()` reads it); None where that
    file is not there."""
    def sample() -> dict[int, tuple[int, int]]:
        ticks = {}
        for line in stat().splitlines():
            name, *values = line.split()
            if name.startswith("cpu") and name != "cpu" and int(name[3:]) in cpus:
                v = [int(x) for x in values[:8]]
                ticks[int(name[3:])] = (sum(v), v[3] + v[4])  # total, idle + iowait
        return ticks

    try:
        first = sample()
        time.sleep(window)
        second = sample()
    except (OSError, ValueError, IndexError):
        return None
    busy = 0.0
    for cpu, (total, idle) in second.items():
        if cpu in first:
            d_total, d_idle = total - first[cpu][0], idle - first[cpu][1]
            busy += (d_total - d_idle) / d_total if d_total > 0 else 0.0
    return busy


def _units(scene):
    from .deck.units import unit_system

    return unit_system(scene.deck.units)


def _command_line(ctx: typer.Context) -> list[str]:
    """The running command as it could be typed again: the arguments given, options with values
    other than their defaults (the same whether it came from the shell or from Python)."""
    words = ["mpmsim"] + ctx.command_path.split()[1:]
    for param in ctx.command.params:
        value = ctx.params.get(param.name)
        if param.param_type_name == "argument":
            words.append(str(value))
        elif value != param.default and value is not None:
            flag = max(param.opts, key=len)
            words += [flag] if param.is_flag else [flag, str(value)]
    return words


def _plain(renderable) -> str:
    """A rich table as plain text (the run log)."""
    console = Console(file=io.StringIO(), width=120, color_system=None)
    console.print(renderable)
    return console.file.getvalue()


def _timing_table(result, sim) -> Table:
    n_p = sim.state.particles.n
    n_e = len(sim.state.fem.cells) if sim.state.fem is not None else 0
    n = n_p + n_e
    what = "particle+element" if n_p and n_e else ("element" if n_e else "particle")
    counts = ", ".join(s for s in (f"{n_p} particles" if n_p or not n_e else "", f"{n_e} elements" if n_e else "") if s)
    steps = max(result.timed_steps, 1)
    first = min(sim.first_step_seconds, result.wall_time)
    table = Table(title=f"{result.steps} steps (timed: all but the first), {counts}, {result.wall_time:.2f} s wall: "
                        f"{first:.2f} s first step (with compiling), {result.wall_time - first:.2f} s the rest; "
                        f"{result.rate / 1e6:.2f} M {what}-steps/s")
    for col in ("task", "time (s)", "%", "us/step", f"M {what}-steps/s"):
        table.add_column(col, justify="left" if col == "task" else "right")
    total = sum(result.timers.values()) or 1.0
    for name, sec in result.timers.items():
        rate = f"{n * steps / sec / 1e6:.1f}" if sec > 0 and name != "output" else "-"
        table.add_row(name, f"{sec:.3f}", f"{100 * sec / total:.1f}", f"{sec / steps * 1e6:.1f}", rate)
    return table


@_command
def compile(
    decks: list[Path] = typer.Argument(None, help="Decks whose kernels to compile."),
    all_decks: bool = typer.Option(False, "--all", help="Every deck in the inputs/ folder next to the package."),
) -> None:
    """Fill numba's kernel cache for decks, so later runs compile nothing.

    Builds each deck's scene and starts its run as `mpmsim run` does (the energy sums, the
    first history row and VTU frame, the first step) in a temporary folder."""
    import tempfile

    from .parallel import auto_threads
    from .solver import Simulation, StopRequested

    paths = list(decks or [])
    if all_decks:
        paths += sorted((kernel_cache.PACKAGE_DIR.parent / "inputs").glob("*.yaml"))
    if not paths:
        err.print("mpmsim compile: name a deck or give --all", highlight=False)
        raise typer.Exit(EXIT_BAD_DECK)
    for path in paths:
        out.print(f"{path}: compiling the kernels it uses (numba; cached ones load at once)...", highlight=False)
        t0 = time.perf_counter()
        scene = _load_scene(path)
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
        threads, _ = auto_threads(cores, len(scene.deformable.x))  # the kernels a default run uses
        def after_first() -> None:
            raise StopRequested()

        with _deck_errors(), tempfile.TemporaryDirectory(prefix="mpmsim-compile-") as tmp:
            sim = Simulation(scene, out_dir=Path(tmp), threads=threads)  # its output kernels too
            sim.compile_helper = True
            with contextlib.suppress(StopRequested):
                sim.run(between_steps=after_first)  # the first step: a helper compiles part (compile_ahead)
        out.print(f"{path}: kernels ready ({time.perf_counter() - t0:.1f} s)", highlight=False)


@_command
def check(
    deck: Path = typer.Argument(..., help="Problem deck (YAML)."),
    probe: bool = typer.Option(True, "--probe/--no-probe", help="FEM and implicit scenes: estimate the cost by "
                               "running the first steps (up to 5 s, and compiling on a first run)."),
    device: str = typer.Option("cpu", "--device", help="cuda: also refuse (exit 2, naming the key) what the GPU "
                               "step does not do yet (no GPU needed to check)."),
) -> None:
    """Validate a deck; print the scene, time step, cost and task list.

    The scene: particles, grid, FEM bodies, contact; the cost: an estimate of the run's time on
    one thread and of a first run's compiling; warnings where the deck pairs methods measured to
    go wrong in its setting."""
    scene = _load_scene(deck)
    _check_device(scene, device, driver=False)
    with _deck_errors():
        _check(scene, probe)
    if device != "cpu":
        out.print(f"device {device}: everything this deck asks for runs on the GPU step", highlight=False)


def _check_device(scene, device: str, driver: bool = True) -> None:
    """`--device cuda`: refuse (exit 2, one line naming the key) what the GPU step lacks, and
    (`driver`: run) a machine where CUDA cannot run."""
    if device == "cpu":
        return
    from .gpu import DeviceError
    from .solver import check_device

    with _deck_errors():
        try:
            check_device(scene, device, driver)
        except DeviceError as exc:
            err.print(f"mpmsim: {escape(str(exc))}", highlight=False, soft_wrap=True)
            raise typer.Exit(EXIT_BAD_DECK) from None


def _check(scene, want_probe: bool = True) -> list[str]:
    """Print what `mpmsim check` says of a scene; returns the warnings among it."""
    from .integrators import make_integrator
    from .state import State

    d, u = scene.deck, _units(scene)
    state = State.from_scene(scene, threads=1)
    out.print(f"[bold]{scene.loaded.path}[/]: {d.title}", highlight=False)
    out.print(f"analysis {d.analysis}, units {u.name} (length {u.length}, time {u.time}, stress {u.stress})",
              highlight=False)
    if scene.has_particles:
        _describe_particles(scene, state, u)
    if state.fem is not None:
        _describe_fem(scene, state, u)
    integrator = make_integrator(scene)
    dt = integrator.stable_dt(state)
    if d.time.dt is not None:
        how = "fixed"
    else:
        cfl = d.time.cfl if d.time.cfl is not None else 0.5
        speed = state.wave_max
        if state.n_rigid_materials:
            speed = max(speed, float(np.abs(state.rigid.v_start).max()))
        how = f"CFL {cfl:g}" + (f", max wave speed + |v| = {speed:.4g} {u.velocity}" if scene.has_particles else
                                ", smallest FEM element over its wave speed")
    steps = int(np.ceil(d.time.end / dt))
    out.print(f"time step: {dt:.4g} {u.time} ({how}); end {d.time.end:g} {u.time} -> about {steps} steps",
              highlight=False)
    warned = list(scene.notices)
    if scene.has_particles:
        from .stability import compaction_warnings

        warned += compaction_warnings(scene, state.particles.x)
    for warning in warned:
        out.print(f"[yellow]warning:[/] {escape(warning)}", highlight=False)
    P = state.particles
    if (d.integrator == "implicit" or state.fem is not None) and not want_probe:
        out.print("cost: not estimated (--no-probe)", highlight=False)
    elif d.integrator == "implicit" or state.fem is not None:
        from .cost import probe

        out.print("cost: probing the first steps on one thread (the first compiles what the kernel cache lacks)...",
                  highlight=False)
        implicit = d.integrator == "implicit"
        found = probe(scene) if implicit else probe(scene, max_steps=200, seconds=1.0)
        if found.failed:
            warned.append(f"the probe stopped at its step {found.steps + 1}: {found.failed}")
            out.print(f"[yellow]warning:[/] {escape(warned[-1])}", highlight=False, soft_wrap=True)
        seconds = found.run_seconds(steps) if found.steps >= 2 else 0.0
        if found.steps < 2:
            out.print("cost: no estimate (the probe needs two steps)", highlight=False)
        elif implicit:
            unknowns = " and ".join(s for s in (f"{state.fem.n} FEM nodes" if state.fem is not None else "",
                                               f"{P.n} particles' grid nodes" if scene.has_particles else "") if s)
            made = sum(found.contact)
            phase = f"the later half of its {made} steps in contact" if made else "its later half (no contact yet)"
            out.print(f"cost: the probe ran {found.steps} steps of about {steps}, {sum(found.iterations)} Newton "
                      f"iterations (first step {found.seconds[0]:.3g} s, compiling included); {found.per_step:.3g} "
                      f"iterations per step and {found.per_iteration * 1e3:.3g} ms per iteration ({unknowns}, one "
                      f"thread) over {phase} -> about {seconds:.3g} s for the run (CPU time on one thread, the "
                      "wall time on an idle core; plus JIT compile on a first run; the iterations per step can "
                      "change as contact develops)", highlight=False)
        else:
            out.print(f"cost: the probe ran {found.steps} steps of about {steps} (first step {found.seconds[0]:.3g} s, "
                      f"compiling included); about {found.per_iteration * 1e3:.3g} ms per step on one thread (the "
                      f"later half of the probe) -> about {seconds:.3g} s for the run (CPU time on one thread, the "
                      "wall time on an idle core; plus JIT compile on a first run)", highlight=False)
    else:
        from .cost import compile_seconds, step_microseconds

        tasks = [name for name, _ in integrator.plan]
        us, missing = step_microseconds(tasks, P.n, int(state.entries.nodes.shape[1]))
        lacking = f"; no cost measured for {', '.join(missing)}" if missing else ""
        first = compile_seconds(tasks)
        compiling = (f"; a first run from an empty kernel cache adds about {first:.0f} s of compiling (CPU time; "
                     "later runs load the kernels)" if first is not None else "; plus compiling on a first run")
        out.print(f"cost: {steps * P.n:.3g} particle-steps, about {us / 1e3:.3g} ms per step on one thread -> "
                  f"{steps * us * 1e-6:.3g} s{compiling}{lacking}", highlight=False)
    if scene.has_particles and d.integrator != "implicit":
        out.print(f"kernels: {kernel_dimension(state)}", highlight=False)
    out.print(f"[bold]tasks per step[/] ({integrator.name} integrator; only what this scene needs):")
    for i, (name, why) in enumerate(integrator.plan, 1):
        out.print(f"  {i:2d}. {name:22s} {why}", highlight=False)
    if integrator.skipped:
        out.print("[bold]left out[/] (not needed by this scene):")
        for name, why in integrator.skipped:
            out.print(f"      {name:22s} {why}", highlight=False)
    return warned


def _describe_particles(scene, state, u) -> None:
    d, g = scene.deck, scene.grid
    cells = g.cells
    dims = " x ".join(str(c) for c in cells)
    sizes = " x ".join(f"{h:g}" for h in g.h)
    box = " x ".join(f"[{a:g}, {b:g}]" for a, b in zip(g.domain_lo, g.domain_hi))
    named = {0: "free", 1: "fixed", 2: "roller"}  # (the grid's: an axisymmetric axis face is a roller)
    faces = ", ".join(f"{f}={named[int(g.face_type[k])]}" + (" (the axis r = 0)" if k == 0 and scene.settings.axisymmetric
                                                            and int(g.face_type[0]) and g.domain_lo[0] == 0 else "")
                      for k, f in enumerate(("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")[: 2 * g.dim]))
    out.print(f"grid: {dims} cells of {sizes} {u.length}; domain {box}; "
              f"{g.n_nodes} nodes with {g.ghost} ghost layer(s); faces {faces}", highlight=False)
    P = state.particles
    occupied = np.unique(np.floor((P.x - g.domain_lo) / g.h).astype(np.int64), axis=0)
    out.print(f"active cells: {len(occupied)} of {int(np.prod(cells))} hold particles", highlight=False)
    per = ", ".join(f"{m}: {int(np.sum(P.mat == i))}" for i, m in enumerate(scene.materials.deformable)
                    if np.any(P.mat == i))
    rig = ", ".join(f"{m}: {int(np.sum(state.rigid.mat == i))}" for i, m in enumerate(scene.materials.rigid))
    out.print(f"particles: {P.n} deformable ({per})" + (f"; {state.rigid.n} rigid ({rig})" if rig else ""),
              highlight=False)
    for line in _seeding_lines(scene):
        out.print(line, highlight=False)


def _seeding_lines(scene) -> list[str]:
    """How each round particle body (circle, annulus, sphere) is seeded and why. On the lattice
    in a scene with grid contact: that its surface is a staircase whose corners carry the contact
    load (docs/contact.md, "The staircase is the error"; "Friction from a touching start" for
    the impact's rebound against the continuum), and why the default did not follow the
    surface (a body laid over others, `overwrites`, cannot)."""
    contact = scene.contact.grid is not None
    lines = []
    for i, body in enumerate(scene.deck.bodies):
        shape = getattr(body, "shape", None)
        if shape not in ("circle", "annulus", "sphere") or getattr(body, "discretization", "particles") != "particles":
            continue
        who = f"body '{body.name}'" if body.name else f"bodies.{i}"
        seeding = scene.seedings[i]
        why = f" ({seeding.why})" if seeding.why else ""
        if seeding.how != "lattice":
            lines.append(f"{who} ({shape}): seeded in {seeding.how} that follow its surface{why}")
        elif contact:
            lines.append(f"{who} ({shape}): seeded on the lattice{why}, its surface a staircase whose corners carry "
                         "the contact load (Hertz cylinder: centre pressure -29% at R/h = 20; oblique impact with "
                         "friction: normal rebound off by up to 36% at R/h = 10-20; docs/contact.md)")
    return lines


def _describe_fem(scene, state, u) -> None:
    fem = state.fem
    kind = "triangles" if scene.dim == 2 else "tetrahedra"
    for row, info in enumerate(fem.infos):
        nodes = int(np.sum(fem.node_body == row))
        cells = int(np.sum(fem.cell_body == row))
        held = int(np.sum(fem.held[fem.node_body == row].any(axis=1)))
        out.print(f"FEM body '{info.name}': {nodes} nodes, {cells} {kind}" + (f", {held} held nodes" if held else ""),
                  highlight=False)
    role = "barrier contact points" if scene.settings.integrator == "implicit" else "augury particles"
    out.print(f"FEM boundary nodes ({role}): {len(fem.boundary)}", highlight=False)
    a = scene.contact.augury
    if a is not None:
        how = ("field contact" if a.method == "field" else
               f"augury contact: {a.transfer.upper()}, {a.iterations} iteration(s)")
        out.print(f"{how}, grid {a.cell_size:g} {u.length}, {a.kernel}, tau = "
                  + (f"{a.tau:g} {u.time}" if a.tau else "the time step"), highlight=False)


def kernel_dimension(state) -> str:
    """What the dimension-parameterised kernels run on: in 2D, two-component arrays, dim^2 nodes
    per particle and one node layer in z (no 3D work)."""
    dim, K = state.dim, state.sd.S.shape[1]
    if state.shape.axisymmetric:
        return (f"axisymmetric (x = r, y = z): 2-component vectors, 3x3 F (hoop stretch F_tt), {K} nodes per "
                f"particle ({state.shape.name}, r-weighted, with the hoop function), masses and forces per radian")
    return (f"{dim}D: {state.particles.x.shape[1]}-component vectors, {dim}x{dim} F, {K} nodes per particle "
            f"({state.shape.name}), {state.grid.shape[2]} node layer(s) in z")


@_command
def sweep(
    sweep_file: Path = typer.Argument(..., help="Sweep file (YAML): base deck, axes, reference, metrics."),
    jobs: int = typer.Option(1, "--jobs", "-j", min=0, help="Worker processes of a local Dask cluster, one numba "
                             "thread each; 0: every run in this process, one after the other (debugging)."),
    scheduler: Optional[str] = typer.Option(
        None, "--scheduler", help="Run on this existing Dask cluster (e.g. tcp://127.0.0.1:8786) instead of a "
        "local one; its workers need mpmsim (docs/sweep.md)."),
    out_dir: Optional[Path] = typer.Option(None, "--out", help="Results directory (overrides the sweep file)."),
    limit: Optional[int] = typer.Option(None, "--limit", help="Run at most this many of the missing runs."),
) -> None:
    """Run a matrix of deck variants: error and cost per run, and a chart.

    Writes a CSV of the error and the cost of every run and a chart of error against cost.

    Finished runs are kept in OUT/runs/, so a re-run resumes where a killed sweep stopped."""
    from .sweep import load_sweep, run_sweep
    from .sweep.matrix import expand
    from .sweep.runner import SchedulerUnreachable, SweepStopped

    if scheduler is not None and jobs == 0:
        err.print("mpmsim sweep: --jobs 0 runs in this process; it cannot be combined with --scheduler",
                  highlight=False)
        raise typer.Exit(EXIT_BAD_DECK)
    where = (f"on the Dask cluster at {scheduler}" if scheduler is not None else
             "in this process" if jobs == 0 else f"on a local Dask cluster of {jobs} worker(s)")
    done: list[str] = []

    def progress(run, record, k: int, n: int) -> None:
        done.append(run.id)
        _sweep_progress(run, record, k, n)

    try:
        loaded = load_sweep(sweep_file)
        runs, refs = expand(loaded)
        out.print(f"[bold]{sweep_file}[/]: {len(runs)} runs + {len(refs)} reference runs, {where}", highlight=False)
        result = run_sweep(loaded, jobs=jobs, limit=limit, out_dir=out_dir, progress=progress, scheduler=scheduler)
    except DeckError as exc:
        err.print(f"[bold red]mpmsim: bad sweep[/]\n{escape(exc.format())}", highlight=False, soft_wrap=True)
        raise typer.Exit(EXIT_BAD_DECK) from None
    except SweepStopped as exc:  # an unreachable scheduler, no workers, workers that cannot run mpmsim
        err.print(f"mpmsim sweep: {escape(str(exc))}; {len(done)} run(s) finished here are kept; the same command "
                  "again continues", highlight=False, soft_wrap=True)
        raise typer.Exit(EXIT_BAD_DECK if isinstance(exc, SchedulerUnreachable) else 1) from None
    except KeyboardInterrupt:  # caught here: the command-line framework would swallow it
        err.print(f"mpmsim sweep: interrupted; pending runs cancelled, {len(done)} run(s) finished here are kept; "
                  "the same command again continues", highlight=False, soft_wrap=True)
        raise typer.Exit(130) from None
    out.print(f"ran {len(result.executed)}, already done {len(result.skipped)}", highlight=False)
    if not result.complete:
        out.print("sweep not complete (--limit): runs not done yet are 'pending' in the table; "
                  "the same command again continues", highlight=False)
    if result.csv is not None:
        out.print(f"[bold]table[/]: {result.csv}\n[bold]chart[/]: {result.png}", highlight=False)


def _sweep_progress(run, record, k: int, n: int) -> None:
    what = ", ".join(f"{a}={v}" for a, v in run.values.items())
    cost = f"{record['cpu_s']:.1f} s" if "cpu_s" in record else ""
    out.print(f"  {k}/{n} {run.id} {record['status']:8s} {cost:>9s}  {what}", highlight=False)


@_command
def plot(
    histories: list[Path] = typer.Argument(..., help="History CSV files (mpmsim run output)."),
    x: str = typer.Option("time", "--x", help="Column (or expression of columns) on the x axis."),
    y: list[str] = typer.Option(..., "--y", help="Column(s) on the y axis (repeat --y for more)."),
    output: Path = typer.Option(Path("plot.png"), "--out", "-o", help="PNG file to write."),
    xlabel: Optional[str] = typer.Option(None, "--xlabel", help="x axis label (default: the column and its unit)."),
    ylabel: Optional[str] = typer.Option(None, "--ylabel", help="y axis label (default: the columns and units)."),
) -> None:
    """Overlay history columns of one or more runs in a PNG.

    Each run's curves are labelled by its deck's title."""
    from .plotting import PlotError, plot_histories

    try:
        plot_histories(histories, x, y, output, xlabel, ylabel)
    except PlotError as exc:
        err.print(f"mpmsim plot: {exc}", highlight=False, soft_wrap=True, markup=False)
        raise typer.Exit(EXIT_BAD_DECK) from None
    out.print(f"wrote {output}", highlight=False)


@_command
def paraview(
    results: Path = typer.Argument(..., help="Results folder of a run (or the .pvd in it)."),
    stress: str = typer.Option("yy", "--stress", help="Stress component of the second view: xx yy zz xy yz xz."),
) -> None:
    """Write a ParaView script, <name>_paraview.py, beside a run's series.

    The script opens the series coloured by material, with a stress view and colour bar
    (paraview --script=FILE, or pvbatch FILE --screenshot out.png)."""
    from .output.paraview import COMPONENTS, ResultsError, write_script

    if stress not in COMPONENTS:
        err.print(f"mpmsim paraview: --stress must be one of {' '.join(COMPONENTS)}, not {stress!r}",
                  highlight=False, soft_wrap=True)
        raise typer.Exit(EXIT_BAD_DECK)
    try:
        script = write_script(results, stress)
    except (OSError, ResultsError) as exc:
        err.print(f"mpmsim paraview: {escape(str(exc))}", highlight=False, soft_wrap=True)
        raise typer.Exit(EXIT_BAD_DECK) from None
    out.print(f"wrote {script}\n  open:   paraview --script={script}\n"
              f"  render: pvbatch {script} --screenshot {script.with_suffix('.png')}", highlight=False)


def main() -> None:
    """The console entry point. Click's usage errors (a missing argument, a value an option does
    not take, a command that does not exist) end in one line naming the command, as the deck
    errors do, not in click's three (Usage, Try, Error)."""
    # the classes of the click that typer runs on (recent typer vendors its own): typer exports
    # BadParameter, a UsageError, a ClickException
    usage_error, click_error = (next(c for c in typer.BadParameter.__mro__ if c.__name__ == name)
                                for name in ("UsageError", "ClickException"))
    try:
        code = app(standalone_mode=False)
    except usage_error as exc:
        where = exc.ctx.command_path if exc.ctx is not None else "mpmsim"
        if type(exc).__name__ == "NoArgsIsHelpError":  # `mpmsim` alone: its help, as click prints it
            print(exc.format_message(), file=sys.stderr)
        else:
            print(f"{where}: {exc.format_message()} ('{where} --help' shows the usage)", file=sys.stderr)
        sys.exit(exc.exit_code)
    except click_error as exc:
        print(f"mpmsim: {exc.format_message()}", file=sys.stderr)
        sys.exit(exc.exit_code)
    except (KeyboardInterrupt, typer.Abort) as exc:
        if isinstance(exc, KeyboardInterrupt) or isinstance(exc.__cause__, KeyboardInterrupt):
            print("interrupted; output written so far is kept", file=sys.stderr)
            sys.exit(130)
        print("mpmsim: aborted", file=sys.stderr)
        sys.exit(1)
    sys.exit(code if isinstance(code, int) else 0)


if __name__ == "__main__":
    main()
