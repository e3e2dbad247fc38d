"""Output: VTU files read back by VTK's own XML reader, the .pvd series, CSV history, atomic
writes, and the command line's files and exit codes."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import xml.etree.ElementTree as ET

from pathlib import Path

import numpy as np
import pytest
import vtk
from typer.testing import CliRunner
from vtk.util.numpy_support import vtk_to_numpy

from mpmsim.cli import app
from mpmsim.output.atomic import atomic_path
from mpmsim.output.history import read_history
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation

from ..conftest import ROOT, deck_from

DECK = {
    "title": "two blocks and a platen", "units": "mm-g-ms",
    "grid": {"cell_size": 1.0, "boundaries": {"ymin": "fixed"}},
    "materials": {"soft": {"type": "neo_hookean", "K": 100.0, "G": 30.0, "density": 0.001},
                  "hard": {"type": "linear_elastic", "E": 500.0, "nu": 0.3, "density": 0.002},
                  "platen": {"type": "rigid", "velocity": [0.0, -1.0]}},
    "bodies": [{"shape": "rectangle", "min": [0, 0], "max": [4, 3], "material": "soft"},
               {"shape": "rectangle", "min": [0, 3], "max": [4, 5], "material": "hard"},
               {"shape": "rectangle", "min": [0, 5], "max": [4, 6], "material": "platen"}],
    "time": {"end": 0.05},
    "output": {"vtu_interval": 0.01, "history_interval": 0.005},
}


def read_vtu(path):
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(str(path))
    reader.Update()
    grid = reader.GetOutput()
    pd = grid.GetPointData()
    arrays = {pd.GetArrayName(i): vtk_to_numpy(pd.GetArray(i)) for i in range(pd.GetNumberOfArrays())}
    return grid, vtk_to_numpy(grid.GetPoints().GetData()), arrays


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    sim = Simulation(build_scene(deck_from(DECK)), out_dir=out)
    result = sim.run()
    return sim, result, out


def test_every_vtu_reads_back_with_vtk(finished):
    sim, result, out = finished
    assert len(result.files) == 12  # t = 0 and every 0.01 to the end; deformable and rigid files
    P, R = sim.state.particles, sim.state.rigid
    deformable = [p for p in result.files if "_rigid_" not in p.name]
    rigid = [p for p in result.files if "_rigid_" in p.name]
    assert len(deformable) == len(rigid) == 6
    for paths, n in ((deformable, P.n), (rigid, R.n)):
        for path in paths:
            grid, points, arrays = read_vtu(path)
            assert grid.GetNumberOfPoints() == n and grid.GetNumberOfCells() == n
            assert grid.GetCellType(0) == vtk.VTK_VERTEX
            assert arrays["velocity"].shape == (n, 3)
            assert arrays["stress"].shape == (n, 6)
            assert arrays["deformation_gradient"].shape == (n, 9)
            for name in ("J", "material", "mass", "volume", "displacement", "body"):
                assert name in arrays
            names = vtk_to_numpy(grid.GetFieldData().GetArray("material_names")).tobytes()
            assert names == b"soft\0hard\0platen\0"  # VTK reads the field data meshio cannot write
    # the last files hold the final state
    grid, points, arrays = read_vtu(deformable[-1])
    np.testing.assert_allclose(points[:, :2], P.x)
    np.testing.assert_allclose(arrays["stress"], P.stress)
    np.testing.assert_allclose(arrays["velocity"][:, :2], P.v)
    np.testing.assert_allclose(arrays["J"], np.linalg.det(P.F))
    grid, points, rigid_arrays = read_vtu(rigid[-1])
    np.testing.assert_allclose(points[:, :2], R.x)
    # material ids are deck order: soft 0, hard 1, platen 2
    assert set(arrays["material"]) == {0, 1} and set(rigid_arrays["material"]) == {2}


def test_pvd_collection_lists_the_series(finished):
    sim, result, out = finished
    root = ET.parse(result.pvd_path).getroot()
    sets = root.find("Collection").findall("DataSet")
    times = [float(d.get("timestep")) for d in sets]
    assert [out / d.get("file") for d in sets] == [p for p in result.files if "_rigid_" not in p.name]
    assert times == sorted(times) and times[0] == 0.0 and times[-1] == pytest.approx(0.05)
    rigid = ET.parse(out / "deck_rigid.pvd").getroot().find("Collection").findall("DataSet")
    assert [out / d.get("file") for d in rigid] == [p for p in result.files if "_rigid_" in p.name]
    assert [float(d.get("timestep")) for d in rigid] == times
    # a ParaView-compatible collection that VTK's own reader accepts
    reader = vtk.vtkXMLUnstructuredGridReader()
    assert reader.CanReadFile(str(result.files[0]))


def test_history_csv_has_plain_names_every_row_and_a_units_sidecar(finished):
    sim, result, out = finished
    lines = result.history_path.read_text().splitlines()
    header = lines[0].split(",")
    assert header[:5] == ["time", "step", "dt", "wall_s", "sxx"]
    assert "kinetic_energy" in header and "F_ymin_y" in header
    assert "F_platen_y" in header and "u_platen_y" in header
    assert len(lines) == 1 + 11
    assert result.history_path.name == "deck_history.csv"
    meta = json.loads((out / "deck_history.json").read_text())
    assert meta["title"] == sim.scene.deck.title and list(meta["columns"]) == header
    assert meta["columns"]["time"] == "ms" and meta["columns"]["kinetic_energy"] == "mJ (= N mm)"
    assert meta["columns"]["F_platen_y"] == "N" and meta["columns"]["u_platen_y"] == "mm"
    cols = read_history(result.history_path)
    assert len(cols["time"]) == len(sim.recorder.rows) == 11
    np.testing.assert_allclose(cols["u_platen_y"][-1], -0.05, rtol=1e-6)
    assert cols["F_platen_y"][-1] < 0  # the platen pushes the material down


def test_no_temporary_files_are_left(finished):
    sim, result, out = finished
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]


def test_atomic_write_keeps_the_old_file_when_writing_fails(tmp_path):
    target = tmp_path / "data.csv"
    target.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half-written")
            raise RuntimeError("disk full")
    assert target.read_text() == "old"
    assert list(tmp_path.iterdir()) == [target]


def test_cli_run_writes_series_and_reports_paths(tmp_path):
    deck = tmp_path / "blocks.yaml"
    import yaml

    deck.write_text(yaml.safe_dump(DECK))
    result = CliRunner().invoke(app, ["run", str(deck), "--out", str(tmp_path / "o")])
    assert result.exit_code == 0, result.output
    assert "blocks.pvd" in result.output and "blocks_history.csv" in result.output
    assert "update stress first" in result.output  # the per-task timing table
    assert (tmp_path / "o" / "blocks.pvd").is_file()


def test_cli_unstable_run_exits_3_and_keeps_the_failing_state(tmp_path):
    import yaml

    bad = dict(DECK, time={"end": 1.0, "dt": 0.01})  # ~10 x the stable step
    deck = tmp_path / "unstable.yaml"
    deck.write_text(yaml.safe_dump(bad))
    out = tmp_path / "o"
    result = CliRunner().invoke(app, ["run", str(deck), "--out", str(out), "--quiet"])
    assert result.exit_code == 3, result.output
    assert "unstable at step" in result.output and "Traceback" not in result.output
    pvd = ET.parse(out / "unstable.pvd").getroot().find("Collection").findall("DataSet")
    last = out / pvd[-1].get("file")
    assert len(pvd) >= 2 and last.is_file()  # initial state and the failing state
    cols = read_history(out / "unstable_history.csv")
    assert cols["time"][-1] == pytest.approx(float(pvd[-1].get("timestep")))


def test_version_and_check(tmp_path):
    result = CliRunner().invoke(app, ["--version"])
    assert result.exit_code == 0 and result.output.startswith("mpmsim ")
    import yaml

    deck = tmp_path / "blocks.yaml"
    deck.write_text(yaml.safe_dump(DECK))
    result = CliRunner().invoke(app, ["check", str(deck)])
    assert result.exit_code == 0
    assert "soft: 48" in result.output and "hard: 32" in result.output and "16 rigid" in result.output
    assert "tasks per step" in result.output and "move rigid" in result.output


def test_stepping_past_the_end_is_refused(finished):
    sim, _, _ = finished
    with pytest.raises(RuntimeError, match="reached time.end"):
        sim.step()


def test_default_threads_take_every_core_unless_threads_spin(monkeypatch):
    """Threads that share out the work (TBB) or sleep while they wait (OpenMP with mpmsim's
    OMP_WAIT_POLICY=PASSIVE) share cores with busy neighbours without stalling, so the default
    is every core of the affinity; where the user makes OpenMP's threads spin, only the idle
    cores (a spinning thread sharing a core with a busy process stalls every parallel region),
    never below one."""
    import mpmsim
    from mpmsim.cli import default_threads

    two, eight = {0, 1}, set(range(8))
    monkeypatch.setattr(mpmsim, "TBB", False)
    monkeypatch.setenv("OMP_WAIT_POLICY", "PASSIVE")
    assert default_threads(two, busy=2.0) == (2, "2 cores")
    assert default_threads(eight, busy=2.6)[0] == 8
    monkeypatch.setenv("OMP_WAIT_POLICY", "active")
    monkeypatch.setattr(mpmsim, "TBB", True)
    assert default_threads(two, busy=2.0)[0] == 2
    monkeypatch.setattr(mpmsim, "TBB", False)
    assert default_threads(two, busy=0.1)[0] == 2
    assert default_threads(two, busy=0.6)[0] == 1  # a neighbour on one core and a bit
    assert default_threads(two, busy=2.0)[0] == 1
    assert default_threads(eight, busy=2.6)[0] == 5
    n, why = default_threads({0, 1, 2, 3}, busy=1.0)
    assert n == 3 and "1 kept busy" in why and "0.2 s" in why
    n, why = default_threads(two, load=1.2)  # no /proc/stat: the load average
    assert n == 1 and "load average" in why


def test_busy_cores_reads_proc_stat():
    """Busy = (total - idle - iowait) ticks over total, summed over the process's cores; other
    cores and the all-CPU line left out."""
    from mpmsim.cli import busy_cores

    samples = iter([
        "cpu  900 0 0 900 0 0 0 0 0 0\ncpu0 100 0 0 400 0 0 0 0 0 0\ncpu1 300 0 0 200 0 0 0 0 0 0\n"
        "cpu2 0 0 0 500 0 0 0 0 0 0\nintr 5\n",
        # cpu0: 75 user + 25 system of 100 -> 1.0; cpu1: 10 busy + 80 idle + 10 iowait -> 0.1; cpu2 busy, not ours
        "cpu  1200 0 0 1100 0 0 0 0 0 0\ncpu0 175 0 25 400 0 0 0 0 0 0\ncpu1 310 0 0 280 10 0 0 0 0 0\n"
        "cpu2 100 0 0 500 0 0 0 0 0 0\nintr 9\n"])
    assert busy_cores({0, 1}, window=0.0, stat=lambda: next(samples)) == pytest.approx(1.1)

    def missing():
        raise FileNotFoundError("/proc/stat")

    assert busy_cores({0}, window=0.0, stat=missing) is None


def test_busy_cores_sees_a_busy_neighbour():
    """A process spinning on one core of the set counts as about one core (measured over 0.5 s)."""
    import os
    import subprocess
    import sys

    from mpmsim.cli import busy_cores

    cpu = min(os.sched_getaffinity(0))
    hog = subprocess.Popen([sys.executable, "-c", f"import os; os.sched_setaffinity(0, {{{cpu}}})\nwhile True: pass"])
    try:
        import time

        time.sleep(0.5)
        assert busy_cores({cpu}, window=0.5) > 0.9
    finally:
        hog.kill()
        hog.wait()


def test_kernels_are_cached_in_the_users_cache_when_the_package_is_read_only(tmp_path):
    """A package another user installed is not writable: numba would fail with "cannot cache
    function"; mpmsim points the cache at $XDG_CACHE_HOME/mpmsim/numba instead. A user's
    NUMBA_CACHE_DIR wins; a writable package keeps numba's default."""
    from mpmsim.kernel_cache import choose

    home = {"HOME": str(tmp_path)}
    assert choose(home, tmp_path, writable=lambda p: False) == tmp_path / ".cache" / "mpmsim" / "numba"
    xdg = {"XDG_CACHE_HOME": str(tmp_path / "xdg")}
    assert choose(xdg, tmp_path, writable=lambda p: False) == tmp_path / "xdg" / "mpmsim" / "numba"
    assert choose({"NUMBA_CACHE_DIR": "/somewhere"}, tmp_path, writable=lambda p: False) == Path("/somewhere")
    assert choose(home, tmp_path, writable=lambda p: True) is None


def test_cached_kernels_are_dropped_when_the_package_modules_move(tmp_path):
    """A kernel cached by an earlier layout of the package names modules in its index that may
    no longer exist (numba then fails to load it instead of compiling again): the cache root
    carries a stamp of the module layout, and a root stamped otherwise loses its kernels once."""
    from mpmsim.kernel_cache import STAMP, drop_if_moved, layout

    pkg = tmp_path / "pkg"
    (pkg / "contact").mkdir(parents=True)
    (pkg / "contact" / "workspace.py").write_text("")
    root = tmp_path / "cache"
    (root / "sub").mkdir(parents=True)
    old = [root / "sub" / "k-1.py311.nbi", root / "sub" / "k-1.py311.1.nbc"]
    for f in old:
        f.write_bytes(b"stale")
    (root / STAMP).write_text(layout(pkg))
    assert not drop_if_moved(root, pkg) and all(f.exists() for f in old)  # same layout: kept
    (pkg / "contact" / "workspace.py").rename(pkg / "contact" / "fields.py")  # a module moved
    assert drop_if_moved(root, pkg) and not any(f.exists() for f in old)
    assert (root / STAMP).read_text() == layout(pkg)
    assert not drop_if_moved(root, pkg)
    old[0].write_bytes(b"stale")
    (pkg / "contact" / "fields.py").write_text("X = 1\n")  # a module's code changed (its callers' kernels too)
    assert drop_if_moved(root, pkg) and not old[0].exists() and (root / STAMP).read_text() == layout(pkg)


def test_a_kernel_is_compiled_again_when_a_helper_in_another_file_changes(tmp_path):
    """Numba checks a cached kernel against its own file only: f(x) = 2 g(x) cached with g
    from another file kept the old g after g's file changed. With the package's source stamp
    the change drops the cache and f compiles again (subprocesses: a fresh import each)."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text(
        "from pathlib import Path\nimport numba\nfrom mpmsim.kernel_cache import drop_if_moved\n"
        "numba.config.CACHE_DIR = str(Path(__file__).parent.parent / 'cache')\n"
        "drop_if_moved(Path(numba.config.CACHE_DIR), Path(__file__).parent)\n")
    (pkg / "b.py").write_text("from numba import njit\n\n@njit(cache=True)\ndef g(x):\n    return x + 1\n")
    (pkg / "a.py").write_text("from numba import njit\nfrom .b import g\n\n@njit(cache=True)\n"
                              "def f(x):\n    return 2 * g(x)\n")
    (tmp_path / "cache").mkdir()
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), str(ROOT)]))

    def f1():
        p = subprocess.run([sys.executable, "-c", "from pkg.a import f; print(f(1))"], env=env, cwd=tmp_path,
                           capture_output=True, text=True, timeout=120)
        assert p.returncode == 0, p.stderr
        return int(p.stdout.strip())

    assert f1() == 4 and f1() == 4  # compiled, then loaded from the cache
    assert list((tmp_path / "cache").rglob("*.nbi"))
    (pkg / "b.py").write_text("from numba import njit\n\n@njit(cache=True)\ndef g(x):\n    return x + 100\n")
    assert f1() == 202


def test_a_read_only_install_imports_with_the_cache_in_the_users_directory(tmp_path):
    """End to end: a copy of the package that the importing user cannot write (read-only files
    and folders; as root, os.access is made to answer as for an ordinary user), imported by a fresh
    process with no NUMBA_CACHE_DIR, caches its kernels in $XDG_CACHE_HOME/mpmsim/numba and
    compiles one there."""
    import os
    import shutil
    import stat
    import subprocess
    import sys

    site = tmp_path / "site"
    shutil.copytree(Path(__file__).resolve().parents[2] / "mpmsim", site / "mpmsim",
                    ignore=shutil.ignore_patterns("__pycache__"))
    read = stat.S_IRUSR | stat.S_IRGRP | stat.S_IROTH
    for d, _, files in os.walk(site):
        for f in files:
            os.chmod(os.path.join(d, f), read)
        os.chmod(d, read | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)
    cache = tmp_path / "cache"
    cache.mkdir()
    os.chmod(cache, 0o777)
    os.chmod(tmp_path, 0o755)
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(PYTHONPATH=str(site), XDG_CACHE_HOME=str(cache), HOME=str(cache))
    # root writes anywhere, read-only or not: there, os.access answers as an ordinary user would
    code = ("import os; real = os.access; site = " + repr(str(site)) + "\n"
            "os.access = lambda p, m, *a, **k: (False if os.getuid() == 0 and m == os.W_OK\n"
            "                                   and str(p).startswith(site) else real(p, m, *a, **k))\n"
            "import mpmsim, numpy as np\n"
            "from mpmsim.fem.elements import det_small\n"
            "det_small(np.eye(2))\n"
            "print(mpmsim.CACHE_DIR)")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, cwd=str(tmp_path))
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == str(cache / "mpmsim" / "numba")
    assert any((cache / "mpmsim" / "numba").rglob("*.nbi"))


def test_compile_command_prepares_decks_and_refuses_nothing_to_do(tmp_path, monkeypatch):
    deck = Path(__file__).resolve().parents[2] / "inputs" / "fem_blocks_2d.yaml"
    monkeypatch.chdir(tmp_path)  # a run would write results/ here; compile writes nothing
    result = CliRunner().invoke(app, ["compile", str(deck)])
    assert result.exit_code == 0, result.output
    assert "kernels ready" in result.output
    assert not any(tmp_path.iterdir())  # nothing written
    result = CliRunner().invoke(app, ["compile"])
    assert result.exit_code == 2


@pytest.mark.parametrize("how,code,word", [("SIGINT", 130, "interrupted"), ("SIGTERM", 143, "terminated")])
def test_ctrl_c_or_sigterm_stops_a_run_with_a_message_and_keeps_its_output(tmp_path, how, code, word):
    """SIGINT (Ctrl-C) or SIGTERM during `mpmsim run`: exit 130 / 143, one line naming the step,
    time and folder, and the files written so far complete (no .tmp left); the run stops at the
    end of a step, so the history's last row and the series' last frame are the same state."""
    import signal
    import subprocess
    import sys
    import time

    import yaml

    d = yaml.safe_load((Path(__file__).resolve().parents[2] / "inputs" / "fem_blocks_2d.yaml").read_text())
    d["time"] = {"end": 100.0, "dt": 2.5e-5}  # far longer than the test waits
    d["output"] = {"vtu_interval": 0.001, "history_interval": 0.001}
    deck = tmp_path / "long.yaml"
    deck.write_text(yaml.safe_dump(d))
    out = tmp_path / "o"
    p = subprocess.Popen([sys.executable, "-m", "mpmsim", "run", str(deck), "--out", str(out), "--threads", "1"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    t0 = time.time()
    while not list(out.glob("*_fem_000003.vtu")) and time.time() - t0 < 300:  # stepping (compiled)
        time.sleep(0.2)
    p.send_signal(signal.SIGINT if how == "SIGINT" else signal.SIGTERM)
    _, err = p.communicate(timeout=120)
    assert p.returncode == code, err
    assert f"{word} at step" in err and str(out) in " ".join(err.split())
    assert "Traceback" not in err
    assert not list(out.glob("*.tmp"))
    assert (out / "long.pvd").exists() and (out / "long_history.csv").exists()
    import re

    from mpmsim.output.history import read_history

    frames = [float(t) for t in re.findall(r'timestep="([^"]+)"', (out / "long.pvd").read_text())]
    last_row = read_history(out / "long_history.csv")["time"][-1]
    # the signal may land in the very step that wrote frame 3 (then that frame is the last one)
    assert frames[-1] == pytest.approx(last_row, rel=1e-9, abs=1e-12) and frames[-1] >= 0.003 * (1 - 1e-9)


def test_a_rerun_into_the_same_folder_leaves_no_stale_series_files(tmp_path):
    """A shorter rerun into the folder of a longer run: the older run's numbered VTU files of
    this deck are gone (the .pvd and the folder agree); other decks' files stay."""
    from mpmsim.output.vtu import VtuSeries

    for name in ("deck_000007.vtu", "deck_fem_000012.vtu", "deck_big_000001.vtu", "other_000001.vtu",
                 "deck_notes.txt", ".deck_000008.vtu.tmp"):
        (tmp_path / name).write_text("x")
    series = VtuSeries(tmp_path, "deck")
    assert series.removed == 3
    assert sorted(p.name for p in tmp_path.iterdir()) == ["deck_big_000001.vtu", "deck_notes.txt",
                                                          "other_000001.vtu"]


def test_an_output_interval_far_below_the_step_records_every_step_and_ends():
    """history_interval: 1e-300 once never advanced the next output time (a hang); now the
    series jumps past the current time at once, so every step is recorded and the run ends."""
    import yaml

    from mpmsim.solver import next_time
    from tests.conftest import simulate

    assert next_time(0.0, 0.1, 0.05) == 0.1
    assert next_time(0.0, 0.1, 0.35) == pytest.approx(0.4)
    assert next_time(0.2, 1e-300, 0.3) > 0.3 - 1e-12
    d = yaml.safe_load((Path(__file__).resolve().parents[2] / "inputs" / "fem_blocks_2d.yaml").read_text())
    d["time"] = {"end": 0.001, "dt": 2.5e-5}
    d["output"] = {"history_interval": 1e-300, "vtu_interval": 1e-300}
    sim = simulate(d)
    assert sim.state.step == 40
    assert len(sim.recorder.rows) == 41


@pytest.mark.parametrize("where", ["file in the way", "nul byte", "unwritable"])
def test_an_unusable_output_folder_is_a_one_line_error(tmp_path, where):
    import os

    deck = Path(__file__).resolve().parents[2] / "inputs" / "fem_blocks_2d.yaml"
    if where == "file in the way":
        out = tmp_path / "f"
        out.write_text("x")
    elif where == "nul byte":  # in the deck's output.directory (the command line refuses it itself)
        text = deck.read_text() + '\n  directory: "a\\0b"\n'
        text = text.replace("output: {vtu_interval: 0.002, history_interval: 0.0005}\n",
                            "output:\n  vtu_interval: 0.002\n")
        deck = tmp_path / "nul.yaml"
        deck.write_text(text)
        out = None
    else:  # a folder below a regular file cannot be made, by root or anyone
        (tmp_path / "plain").write_text("x")
        out = tmp_path / "plain" / "sub"
    args = ["run", str(deck), "--quiet"] + (["--out", str(out)] if out is not None else [])
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 4, result.output
    assert "cannot write the output folder" in result.output and "Traceback" not in result.output
    assert len(result.output.strip().splitlines()) <= 2
