"""Sweeps on Dask distributed: an 8-run sweep of the bar vibration on a cluster started here with
`dask scheduler` and two `dask worker` processes (through `mpmsim sweep --scheduler`), and on the
default LocalCluster (--jobs 2), give the in-process runner's numbers bit for bit; Ctrl-C stops
the runs in progress; a cluster without workers or an unreachable scheduler ends the sweep
with a message. Every server listens on 127.0.0.1 only."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numba
import psutil
import pytest
import yaml
from typer.testing import CliRunner

from mpmsim.cli import app
from mpmsim.sweep import load_sweep, run_sweep
from mpmsim.sweep.report import read_csv
from mpmsim.sweep.runner import SweepStopped

from ..conftest import ROOT

pytestmark = pytest.mark.ecosystem

BAR = ROOT / "inputs" / "bar_vibration.yaml"
# --no-dashboard leaves the health/metrics HTTP server on, by default on every interface
LOOPBACK_HTTP = ["--no-dashboard", "--dashboard-address", "127.0.0.1:0"]
TIMING = {"wall_s", "run_s", "cpu_s", "particle_steps_per_s", "peak_mem_mb", "start_mem_mb"}


def tiny8(directory: Path, **axes) -> Path:
    """2 shape functions x 2 updates x 2 cell sizes of the bar, a tenth of a millisecond each
    (56 and 111 steps), the finest cell size the reference."""
    data = {"title": "tiny8", "base": str(BAR),
            "axes": {"shape_function": ["linear", "gimp"],
                     "update": {"flip": {"update.scheme": "flip"}, "pic": {"update.scheme": "pic"}},
                     "grid.cell_size": [2.0, 1.0], "time.end": [0.15]},
            "method": ["shape_function", "update"], "reference": {"finest": "grid.cell_size"},
            "metrics": [{"name": "err", "type": "max_rel_error", "column": "px"},
                        {"name": "energy", "type": "energy_change"}]}
    data["axes"].update(axes)
    path = directory / "tiny8.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def records(out: Path) -> dict:
    return {p.stem: json.loads(p.read_text()) for p in (out / "runs").glob("*.json")}


def without_timing(record: dict) -> dict:
    """The record without its timing fields, and the history without its wall-clock column."""
    out = {k: v for k, v in record.items() if k not in TIMING}
    out["history"] = {k: v for k, v in record["history"].items() if k != "wall_s"}
    assert out["history"].keys() < record["history"].keys()  # (wall_s was there)
    return out


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    """The in-process runner's records and table (jobs 0)."""
    d = tmp_path_factory.mktemp("serial")
    res = run_sweep(load_sweep(tiny8(d)), jobs=0, out_dir=d / "out")
    assert res.complete and len(res.executed) == 8
    return records(d / "out"), read_csv(res.csv)


def assert_same_numbers(out: Path, csv: Path, serial) -> None:
    """Every record field but the timing ones (histories included) equal, the table's metric
    columns equal."""
    want, want_rows = serial
    got = records(out)
    assert sorted(got) == sorted(want) and len(got) == 8
    for run_id, record in want.items():
        assert record["status"] == "ok" and len(record["history"]["time"]) > 10
        assert without_timing(got[run_id]) == without_timing(record), run_id
    rows = read_csv(csv)
    assert [(r["id"], r["err"], r["energy"], r["particle_steps"]) for r in rows] == \
           [(r["id"], r["err"], r["energy"], r["particle_steps"]) for r in want_rows]
    assert sum(1 for r in rows if r["err"]) == 4  # the 2 mm runs against the 1 mm references


def listening_hosts(processes) -> set[str]:
    hosts = set()
    for p in processes:
        for c in p.net_connections(kind="inet"):
            if c.status == psutil.CONN_LISTEN:
                hosts.add(c.laddr.ip)
    return hosts


def with_children(pids) -> list[psutil.Process]:
    procs = [psutil.Process(pid) for pid in pids]
    return procs + [c for p in procs for c in p.children(recursive=True)]


def start(args: list[str], log: Path) -> subprocess.Popen:
    """`dask ...` in its own session (killed as a group), importing this checkout's mpmsim."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    with open(log, "w") as fh:
        return subprocess.Popen([sys.executable, "-m", "dask", *args], stdout=fh, stderr=subprocess.STDOUT,
                                env=env, start_new_session=True)


def stop_all(procs: list[subprocess.Popen]) -> None:
    for p in procs:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGTERM)
    for p in procs:
        try:
            p.wait(15)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait(5)


def start_scheduler(d: Path, procs: list) -> str:
    """A scheduler on 127.0.0.1, on a port the system picks; its address."""
    info = d / "scheduler.json"
    procs.append(start(["scheduler", "--host", "127.0.0.1", "--port", "0", *LOOPBACK_HTTP,
                        "--scheduler-file", str(info)], d / "scheduler.log"))
    deadline = time.monotonic() + 60
    while not info.exists():
        assert procs[-1].poll() is None and time.monotonic() < deadline, (d / "scheduler.log").read_text()
        time.sleep(0.2)
    return json.loads(info.read_text())["address"]


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """`dask scheduler` and two `dask worker --nthreads 1` processes; (address, processes)."""
    from distributed import Client

    d = tmp_path_factory.mktemp("dask")
    procs: list[subprocess.Popen] = []
    try:
        address = start_scheduler(d, procs)
        for i in range(2):
            procs.append(start(["worker", address, "--nthreads", "1", "--host", "127.0.0.1", *LOOPBACK_HTTP,
                                "--local-directory", str(d / f"worker{i}")], d / f"worker{i}.log"))
        with Client(address) as client:
            client.wait_for_workers(2, timeout=90)
        yield address, procs
    finally:
        stop_all(procs)


def test_existing_cluster_gives_the_serial_numbers(cluster, serial, tmp_path):
    from distributed import Client

    address, procs = cluster
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["sweep", str(tiny8(tmp_path)), "--scheduler", address, "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert f"on the Dask cluster at {address}" in res.output and "ran 8, already done 0" in res.output
    assert_same_numbers(out, out / "tiny8.csv", serial)
    with Client(address) as client:  # both workers ran runs, with this checkout's mpmsim and kernel cache
        ran = client.run(lambda: (sys.modules["mpmsim.sweep.runner"].__file__, numba.config.CACHE_DIR))
    assert len(ran) == 2
    assert set(ran.values()) == {(str(ROOT / "mpmsim" / "sweep" / "runner.py"), numba.config.CACHE_DIR)}
    assert listening_hosts(with_children(p.pid for p in procs)) == {"127.0.0.1"}
    again = CliRunner().invoke(app, ["sweep", str(tiny8(tmp_path)), "--scheduler", address, "--out", str(out)])
    assert again.exit_code == 0 and "ran 0, already done 8" in again.output  # resume: nothing re-run


def test_ctrl_c_stops_the_runs_on_the_cluster(cluster, tmp_path):
    """Interrupted after the first run: the pending run is cancelled and the ones going (each
    1300x longer than the first) stop within seconds; the finished run is kept."""
    from distributed import Client

    address, _ = cluster
    sweep = tiny8(tmp_path, shape_function=["linear"], update={"flip": {"update.scheme": "flip"}},
                  **{"grid.cell_size": [1.0], "time.end": [0.15, 200.0, 201.0, 202.0]})
    seen = []

    def interrupt(run, record, k, n):
        seen.append(record)
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep(load_sweep(sweep), scheduler=address, out_dir=tmp_path / "out", progress=interrupt)
    t0 = time.monotonic()
    assert [r["overrides"]["time.end"] for r in seen] == [0.15]
    assert sorted(records(tmp_path / "out")) == [seen[0]["id"]]
    with Client(address) as client:
        while True:
            busy = client.run(lambda dask_worker: dask_worker.state.executing_count)
            left = client.run_on_scheduler(lambda dask_scheduler: [k for k in dask_scheduler.tasks
                                                                   if str(k).startswith("mpmsim-run")])
            if sum(busy.values()) == 0 and not left:
                break
            assert time.monotonic() - t0 < 20, (busy, left)  # a long run takes minutes
            time.sleep(0.2)


def test_local_cluster_gives_the_serial_numbers(serial, tmp_path):
    """--jobs 2: a LocalCluster of two one-thread workers, listening on 127.0.0.1 only."""
    me = psutil.Process()
    hosts = []
    before = os.environ.get("NUMBA_NUM_THREADS")
    others = {c.pid for c in me.children(recursive=True)}  # (another test's cluster)

    def look(run, record, k, n):
        if k == 1:  # the cluster is up: the scheduler and nannies in this process, workers in children
            hosts.append(listening_hosts(with_children([me.pid])))

    res = run_sweep(load_sweep(tiny8(tmp_path)), jobs=2, out_dir=tmp_path / "out", progress=look)
    assert hosts == [{"127.0.0.1"}]
    assert os.environ.get("NUMBA_NUM_THREADS") == before  # the workers' setting stays theirs
    assert_same_numbers(tmp_path / "out", res.csv, serial)
    assert not [c for c in me.children(recursive=True)  # the workers are gone
                if c.pid not in others and "spawn_main" in " ".join(safe_cmdline(c))]


def safe_cmdline(p: psutil.Process) -> list[str]:
    try:
        return p.cmdline()
    except psutil.Error:  # gone meanwhile
        return []


def test_local_cluster_through_the_cli(serial, tmp_path):
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["sweep", str(tiny8(tmp_path)), "--jobs", "2", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "on a local Dask cluster of 2 worker(s)" in res.output and "ran 8, already done 0" in res.output
    assert_same_numbers(out, out / "tiny8.csv", serial)


def test_a_cluster_without_workers_stops_the_sweep(tmp_path):
    procs: list[subprocess.Popen] = []
    try:
        address = start_scheduler(tmp_path, procs)
        t0 = time.monotonic()
        with pytest.raises(SweepStopped, match=f"no Dask worker at {address} for 2 s"):
            run_sweep(load_sweep(tiny8(tmp_path)), scheduler=address, out_dir=tmp_path / "out", no_workers_s=2)
        assert time.monotonic() - t0 < 30
        assert records(tmp_path / "out") == {}
    finally:
        stop_all(procs)


def test_cli_scheduler_problems_exit_with_a_message(tmp_path):
    import dask

    sweep = str(tiny8(tmp_path))
    res = CliRunner().invoke(app, ["sweep", sweep, "--scheduler", "127.0.0.1"])
    assert res.exit_code == 2 and "cannot reach the Dask scheduler at 127.0.0.1: missing port number" in res.output
    with socket.socket() as s:  # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with dask.config.set({"distributed.comm.timeouts.connect": "2s"}):
        res = CliRunner().invoke(app, ["sweep", sweep, "--scheduler", f"tcp://127.0.0.1:{port}"])
    assert res.exit_code == 2 and f"cannot reach the Dask scheduler at tcp://127.0.0.1:{port}" in res.output
    res = CliRunner().invoke(app, ["sweep", sweep, "--scheduler", "tcp://127.0.0.1:1", "--jobs", "0"])
    assert res.exit_code == 2 and "cannot be combined with --scheduler" in res.output

