"""A progress bar for a run (the command line's, and `Simulation.run(progress=True)`)."""

from __future__ import annotations

import time
from contextlib import contextmanager

from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn


@contextmanager
def progress_bar(name: str, end: float, time_unit: str, console: Console | None = None):
    """Yield `report(state)`, to call after each step: simulated time, steps per second and
    time remaining, redrawn at most ten times a second."""
    progress = Progress(TextColumn("[bold]{task.description}"), BarColumn(),
                        TextColumn("t = {task.fields[t]} / {task.fields[end]} " + time_unit),
                        TextColumn("{task.fields[rate]} steps/s"), TimeRemainingColumn(),
                        console=console, transient=False)
    last = [0.0, 0, time.perf_counter(), 0.0]  # redrawn at, step then, clock then, t

    def report(state) -> None:
        last[3] = state.t
        now = time.perf_counter()
        if now - last[0] < 0.1:
            return
        rate = (state.step - last[1]) / max(now - last[2], 1e-9)
        last[:3] = [now, state.step, now]
        progress.update(bar, completed=state.t, t=f"{state.t:.4g}", rate=f"{rate:,.0f}")

    with progress:
        bar = progress.add_task(name, total=end, t="0", end=f"{end:g}", rate="-")
        yield report
        progress.update(bar, completed=last[3], t=f"{last[3]:.4g}")
