"""Run a sweep's matrix on Dask workers (or in this process); one JSON per finished run, so a
killed sweep resumes where it stopped; then the CSV table and the chart.

Layout of the results directory:
    runs/<id>.json    one per finished run (ok, unstable or error), written atomically
    <name>.csv        every run, assembled from runs/ once all are there
    <name>.png        error against cost (chart.py)

Where runs go (`run_sweep(jobs=, scheduler=)`): jobs = 0 in this process, one after the other;
otherwise to Dask distributed, either a LocalCluster this call starts (`jobs` worker processes,
one thread each) or the existing cluster whose scheduler is at `scheduler`. A task carries the
run and its deck's text and returns the record; this process writes runs/<id>.json, so workers
need no access to the results directory.

Cost, per run, on one thread, from the end of the first step to the end (the first step also
loads or compiles the numba kernels, which is not the method's cost): `cpu_s` is the worker's
CPU time (the chart's cost: on a shared machine it hardly depends on what else runs), `run_s`
the elapsed time; `wall_s` is the whole run, first step and scene building included.
`peak_mem_mb` is the worker process's peak resident memory during the run (Linux: the high-water
mark is reset when the run starts), `start_mem_mb` its resident memory when the run started: a
worker process runs many runs, so the difference is what the run added; the start includes the
interpreter, numpy, numba, the Dask worker and the kernels earlier runs loaded.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import yaml

from ..errors import DeckError
from .matrix import Run, expand
from .records import save_record
from .spec import LoadedSweep

STOP_CHECK_S = 1.0  # how often (wall seconds) a run on a Dask worker asks whether the sweep was stopped
NO_WORKERS_S = 120.0  # a sweep on a cluster without any worker for this long stops (SweepStopped)


class SweepStopped(RuntimeError):
    """The sweep cannot go on (no worker for NO_WORKERS_S, or a worker that cannot run the
    task); finished runs are kept."""


class SchedulerUnreachable(SweepStopped):
    """No Dask scheduler answers at the address given (a command-line mistake, as a bad path)."""


class Cancelled(Exception):
    """Raised inside a run whose sweep was stopped (Ctrl-C on the client)."""


def deck_of(run: Run, text: str | None = None):
    """The run's deck, validated (raises DeckError naming the key). `text`: the deck file's
    text, when the caller has it (a worker without the file); files the deck names (images,
    meshes) are still looked up relative to run.deck."""
    from ..deck import load_deck_text
    from ..deck.overrides import with_overrides

    data = with_overrides(yaml.safe_load(run.deck.read_text() if text is None else text), run.overrides)
    return load_deck_text(yaml.safe_dump(data, sort_keys=False), run.deck)


def _status_mb(field_name: str) -> float | None:
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith(field_name + ":"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return None


def _reset_peak_memory() -> float | None:
    """Reset this process's resident-memory high-water mark to its current size (Linux
    /proc/self/clear_refs); returns that size in MB, None where this is not possible."""
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
    except OSError:
        return None
    return _status_mb("VmRSS")


def _peak_memory(reset: bool) -> float:
    """Peak resident memory (MB) since the reset, or of the process's whole life without one."""
    import resource

    hwm = _status_mb("VmHWM") if reset else None
    return hwm if hwm is not None else resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def execute(run: Run, deck_text: str | None = None, should_stop: Callable[[], bool] | None = None) -> dict:
    """Run one deck to its end in this process, history in memory; the record for runs/<id>.json.
    An unstable stop is a result (status 'unstable', with the time it stopped). `should_stop()`,
    asked every STOP_CHECK_S, ends the run early with Cancelled."""
    import numba

    from ..errors import InstabilityError
    from ..scene import build_scene
    from ..solver import Simulation

    numba.set_num_threads(1)
    start_mem = _reset_peak_memory()
    t0 = time.perf_counter()
    sim = Simulation(build_scene(deck_of(run, deck_text)), out_dir=None, threads=1)
    first = []  # (time, step) after the first step: the kernels are loaded by then
    asked = [t0]

    def after_step(state):
        if not first:
            first.append((time.perf_counter(), time.process_time(), state.step))
        if should_stop is not None and time.perf_counter() - asked[0] >= STOP_CHECK_S:
            asked[0] = time.perf_counter()
            if should_stop():
                raise Cancelled(run.id)

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
        "peak_mem_mb": _peak_memory(start_mem is not None), "start_mem_mb": start_mem,
        "history": {name: sim.recorder.column(name).tolist() for name in sim.recorder.names},
    }


def error_record(run: Run, message: str) -> dict:
    return {"id": run.id, "deck": str(run.deck), "overrides": run.overrides, "values": run.values,
            "method": run.method, "role": run.role, "reference": run.reference, "status": "error",
            "message": message.splitlines()[0] if message else "", "history": {}}


_ONE_RUN_AT_A_TIME = threading.Lock()  # a worker with several threads still runs one deck at a time


def run_one(run: Run, deck_text: str | None = None, stop_event: str | None = None) -> dict | None:
    """The record of one run; a run that raises is recorded as status 'error' (a crashing
    combination is a result, the sweep goes on). On a Dask worker `stop_event` names the
    distributed.Event the client sets when the sweep is stopped: the run then ends early and
    None is returned (the client has dropped the task)."""
    should_stop = None
    if stop_event is not None:
        from distributed import Event

        event = Event(stop_event)
        should_stop = event.is_set
    with _ONE_RUN_AT_A_TIME:
        if should_stop is not None and should_stop():
            return None
        try:
            return execute(run, deck_text, should_stop)
        except Cancelled:
            return None
        except Exception as exc:  # noqa: BLE001 - a crashing combination is recorded, the sweep goes on
            return error_record(run, f"{type(exc).__name__}: {exc}")




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
              progress: Callable[[Run, dict, int, int], None] | None = None, scheduler: str | None = None,
              no_workers_s: float = NO_WORKERS_S) -> SweepResult:
    """Run what is missing (at most `limit` runs), then assemble the CSV and charts (runs not
    done yet are 'pending'). jobs = 0 runs in this process (tests, debugging); jobs > 0 on a
    Dask LocalCluster of that many one-thread worker processes; `scheduler` (an address such as
    tcp://host:8786) on that existing cluster instead. `progress(run, record, k, n)` is called
    as each run finishes. Raises SweepStopped when the cluster cannot run the sweep."""
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
    texts = {deck: deck.read_text() for deck in {r.deck for r in todo}}  # shipped with each task

    def finished(run: Run, record: dict) -> None:
        save_record(runs_dir, record)  # here, not on the worker: workers need no shared filesystem
        result.executed.append(run.id)
        if progress:
            progress(run, record, len(result.executed), total)

    if todo and scheduler is None and jobs <= 0:
        for r in todo:
            finished(r, run_one(r, texts[r.deck]))
    elif todo:
        _run_on_dask(todo, texts, finished, jobs, scheduler, no_workers_s)
    done = {p.stem for p in runs_dir.glob("*.json")}
    result.complete = all(r.id in done for r in todo_all)
    if done & {r.id for r in todo_all}:
        result.csv, result.png = assemble(loaded, runs, refs, runs_dir, out)
    return result


def _run_on_dask(todo: list[Run], texts: dict, finished: Callable[[Run, dict], None], jobs: int,
                 scheduler: str | None, no_workers_s: float) -> None:
    """Submit every run, hand each record to `finished` as it arrives. On any exception here
    (Ctrl-C included) the runs still going are told to stop, the pending ones cancelled, and a
    LocalCluster this started is closed."""
    from distributed import Client, Event, KilledWorker, LocalCluster, as_completed

    with contextlib.ExitStack() as stack:
        if scheduler is None:
            cluster = stack.enter_context(LocalCluster(
                n_workers=jobs, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None,
                memory_limit=0,  # no memory manager: a big run is not paused or restarted by the nanny
                env={"NUMBA_NUM_THREADS": "1"},  # set in each worker process before numba is imported
                preload=[__name__],  # dask_setup below
                silence_logs=logging.ERROR))
            client = stack.enter_context(Client(cluster))
        else:
            try:
                client = stack.enter_context(Client(scheduler))  # (distributed.comm.timeouts.connect)
            except (OSError, ValueError, TypeError) as exc:
                raise SchedulerUnreachable(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
        token = uuid.uuid4().hex[:10]
        stop = f"mpmsim-sweep-stop-{token}"
        futures = {client.submit(run_one, r, texts[r.deck], stop, key=f"mpmsim-run-{r.id}-{token}", pure=False): r
                   for r in todo}
        ac = as_completed(futures)
        try:
            seen_worker, next_look = time.monotonic(), 0.0
            while not ac.is_empty():
                batch = ac.next_batch(block=False)
                for fut in batch:
                    run = futures.pop(fut)  # dropped once handled: the worker frees the record
                    if fut.status == "finished":
                        finished(run, fut.result())
                    elif fut.status == "error" and isinstance(fut.exception(), KilledWorker):
                        finished(run, error_record(run, "KilledWorker: the Dask workers running it died (out of "
                                                        f"memory, a crash) each time it was tried: {fut.exception()}"))
                    elif fut.status == "error":  # not the run's fault: e.g. a worker without mpmsim
                        exc = fut.exception()
                        raise SweepStopped(f"a Dask worker could not run {run.id}: {type(exc).__name__}: {exc}"
                                           .splitlines()[0])
                    else:
                        raise SweepStopped(f"run {run.id} was cancelled on the cluster (the connection to the "
                                           "scheduler was lost, or the cluster was restarted)")
                if batch:
                    continue
                now = time.monotonic()
                if now >= next_look:  # a cluster whose workers are all gone would wait forever
                    next_look = now + 2.0
                    try:
                        workers = client.nthreads()
                    except Exception:  # noqa: BLE001 - the scheduler not answering: no worker either
                        workers = {}
                    if workers:
                        seen_worker = now
                    elif now - seen_worker > no_workers_s:
                        raise SweepStopped(f"no Dask worker at {client.scheduler.address} for {no_workers_s:g} s")
                time.sleep(0.1)
        except BaseException:
            with contextlib.suppress(Exception):
                Event(stop, client=client).set()  # runs in progress end at their next check
                client.cancel(list(futures))
            raise


def dask_setup(worker) -> None:
    """Preload hook of the LocalCluster's workers. Ctrl-C in a terminal reaches every process of
    the foreground group: the workers ignore it (no traceback from each) and are closed by the
    client, which stops the sweep."""
    import signal

    with contextlib.suppress(ValueError):  # (only possible in the main thread)
        signal.signal(signal.SIGINT, signal.SIG_IGN)


