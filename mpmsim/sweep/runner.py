"""Run a sweep's matrix in worker processes; one JSON per finished run, so a killed sweep
resumes where it stopped; then the CSV table and the chart.

Layout of the results directory:
    runs/<id>.json    one per finished run (ok, unstable or error), written atomically
    <name>.csv        every run, assembled from runs/ once all are there
    <name>.png        error against cost (chart.py)

Cost, per run, on one thread, from the end of the first step to the end (the first step also
loads or compiles the numba kernels, which is not the method's cost): `cpu_s` is the worker's
CPU time (the chart's cost: on a shared machine it hardly depends on what else runs), `run_s`
the elapsed time; `wall_s` is the whole run, first step and scene building included. `peak_mem_mb` is ru_maxrss of the
worker process; each worker runs exactly one run (max_tasks_per_child=1), so it is that
run's peak, interpreter, numpy and numba included (about 150-200 MB of it is that baseline).
"""

from __future__ import annotations

import contextlib
import json
import multiprocessing
import os
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import yaml

from ..errors import DeckError
from ..output.atomic import write_text
from .matrix import Run, expand
from .spec import LoadedSweep


def deck_of(run: Run):
    """The run's deck, validated (raises DeckError naming the key)."""
    from ..deck import load_deck_text
    from ..deck.overrides import with_overrides

    data = with_overrides(yaml.safe_load(run.deck.read_text()), run.overrides)
    return load_deck_text(yaml.safe_dump(data, sort_keys=False), run.deck)


def execute(run: Run) -> dict:
    """Run one deck to its end in this process, history in memory; the record for runs/<id>.json.
    An unstable stop is a result (status 'unstable', with the time it stopped)."""
    import resource

    import numba

    from ..errors import InstabilityError
    from ..scene import build_scene
    from ..solver import Simulation

    numba.set_num_threads(1)
    t0 = time.perf_counter()
    sim = Simulation(build_scene(deck_of(run)), out_dir=None, threads=1)
    first = []  # (time, step) after the first step: the kernels are loaded by then

    def after_step(state):
        if not first:
            first.append((time.perf_counter(), time.process_time(), state.step))

    status, message, stopped_at = "ok", "", None
    try:
        sim.run(after_step)
    except InstabilityError as exc:
        status, message, stopped_at = "unstable", str(exc).splitlines()[0], exc.time
    end, end_cpu = time.perf_counter(), time.process_time()
    st = sim.state
    n = st.particles.n
    t1, c1, s1 = first[0] if first else (end, end_cpu, st.step)
    run_s, cpu_s = end - t1, end_cpu - c1
    timed_steps = st.step - s1
    return {
        "id": run.id, "deck": str(run.deck), "overrides": run.overrides, "values": run.values, "method": run.method,
        "role": run.role, "reference": run.reference, "status": status, "message": message, "stopped_at": stopped_at,
        "steps": st.step, "particles": n, "particle_steps": st.step * n, "wall_s": end - t0, "run_s": run_s,
        "cpu_s": cpu_s, "particle_steps_per_s": timed_steps * n / cpu_s if cpu_s > 0 else float("nan"),
        "peak_mem_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "history": {name: sim.history.column(name).tolist() for name in sim.history.names},
    }


@contextlib.contextmanager
def one_numba_thread_in_children():
    """NUMBA_NUM_THREADS=1 for the worker processes spawned meanwhile (they inherit the
    environment and read it when they import numba), restored afterwards: numba re-reads the
    variable at every compile in this process, and a value other than the running thread
    pool's stops it ("Cannot set NUMBA_NUM_THREADS ... once the threads have been launched")."""
    old = os.environ.get("NUMBA_NUM_THREADS")
    os.environ["NUMBA_NUM_THREADS"] = "1"
    try:
        yield
    finally:
        if old is None:
            del os.environ["NUMBA_NUM_THREADS"]
        else:
            os.environ["NUMBA_NUM_THREADS"] = old


def _worker(run: Run, runs_dir: str) -> str:
    try:
        record = execute(run)
    except Exception as exc:  # noqa: BLE001 - a crashing combination is recorded, the sweep goes on
        record = {"id": run.id, "deck": str(run.deck), "overrides": run.overrides, "values": run.values,
                  "method": run.method, "role": run.role, "reference": run.reference, "status": "error",
                  "message": f"{type(exc).__name__}: {exc}".splitlines()[0], "history": {}}
    write_text(Path(runs_dir) / f"{run.id}.json", json.dumps(record, default=float))
    return run.id


@dataclass
class SweepResult:
    runs: list[Run]
    references: list[Run]
    executed: list[str] = field(default_factory=list)  # ids run by this call
    skipped: list[str] = field(default_factory=list)  # ids already in runs/
    complete: bool = False
    csv: Path | None = None
    png: Path | None = None


def validate(runs: list[Run], source: str) -> None:
    """Every combination must be a valid deck before anything runs."""
    problems = []
    for run in runs:
        try:
            deck_of(run)
        except DeckError as exc:
            what = ", ".join(f"{k}={v}" for k, v in run.overrides.items())
            problems.append(f"with {what}:\n  " + exc.format().replace("\n", "\n  "))
    if problems:
        raise DeckError((("axes",), "some combinations are not valid decks\n" + "\n".join(problems[:5])),
                        source=source)


def run_sweep(loaded: LoadedSweep, jobs: int = 1, limit: int | None = None, out_dir: Path | None = None,
              progress: Callable[[Run, dict, int, int], None] | None = None) -> SweepResult:
    """Run what is missing (at most `limit` runs), then assemble the CSV and charts (runs not
    done yet are 'pending'). jobs = 0 runs in this process (tests, debugging; peak memory is
    then this process's). `progress(run, record, k, n)` is called as each run finishes."""
    from .report import assemble

    runs, refs = expand(loaded)
    out = Path(out_dir) if out_dir is not None else loaded.out_dir()
    runs_dir = out / "runs"
    runs_dir.mkdir(parents=True, exist_ok=True)
    todo_all = refs + runs  # references first: their failures show early
    validate(todo_all, str(loaded.path))
    result = SweepResult(runs, refs)
    done = {p.stem for p in runs_dir.glob("*.json")}
    todo = [r for r in todo_all if r.id not in done]
    result.skipped = [r.id for r in todo_all if r.id in done]
    if limit is not None:
        todo = todo[:limit]
    total = len(todo)
    by_id = {r.id: r for r in todo}

    def finished(run_id: str) -> None:
        result.executed.append(run_id)
        if progress:
            progress(by_id[run_id], load_record(runs_dir, run_id), len(result.executed), total)

    if jobs <= 0:
        for r in todo:
            finished(_worker(r, str(runs_dir)))
    elif todo:
        ctx = multiprocessing.get_context("spawn")  # max_tasks_per_child needs spawn
        with one_numba_thread_in_children(), \
                ProcessPoolExecutor(max_workers=jobs, mp_context=ctx, max_tasks_per_child=1) as pool:
            pending = {pool.submit(_worker, r, str(runs_dir)) for r in todo}
            try:
                while pending:
                    ready, pending = wait(pending, return_when=FIRST_COMPLETED)
                    for f in ready:
                        finished(f.result())
            except BaseException:
                for f in pending:
                    f.cancel()
                raise
    done = {p.stem for p in runs_dir.glob("*.json")}
    result.complete = all(r.id in done for r in todo_all)
    if done & {r.id for r in todo_all}:
        result.csv, result.png = assemble(loaded, runs, refs, runs_dir, out)
    return result


def load_record(runs_dir: Path, run_id: str) -> dict:
    return json.loads((runs_dir / f"{run_id}.json").read_text())


def history_arrays(record: dict) -> dict:
    return {k: np.asarray(v, dtype=float) for k, v in record.get("history", {}).items()}
