"""The sweep engine on a tiny deck: a 2 x 2 matrix of the bar vibration (seconds), resume after
an interruption, the CSV and chart, and bad sweep files named by key path and line."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
import yaml

from mpmsim.errors import DeckError
from mpmsim.sweep import load_sweep, run_sweep
from mpmsim.sweep.chart import pareto_front
from mpmsim.sweep.matrix import expand
from mpmsim.sweep.metrics import acceleration, max_rel_error, period
from mpmsim.sweep.report import read_csv

from ..conftest import ROOT

BAR = ROOT / "inputs" / "bar_vibration.yaml"
PERIOD = 0.272553  # 4 L / c, inputs/bar_vibration.yaml


def tiny(tmp_path, **extra) -> dict:
    """bar_vibration.yaml, 2 mm cells, two periods: 2 shape functions x 2 updates."""
    data = {"title": "tiny", "base": str(BAR),
            "axes": {"shape_function": ["linear", "gimp"],
                     "update": {"flip": {"update.scheme": "flip"}, "pic": {"update.scheme": "pic"}},
                     "grid.cell_size": [2.0], "time.end": [0.55]},
            "method": ["shape_function", "update"],
            "reference": {"analytic": {"values": {"period": PERIOD}}},
            "metrics": [{"name": "period_err", "type": "period_error", "column": "px", "expected": "period"},
                        {"name": "energy", "type": "energy_change"}]}
    data.update(extra)
    return data


def write(tmp_path, data, name="tiny.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def test_matrix_ids_are_stable_and_distinct(tmp_path):
    runs, refs = expand(load_sweep(write(tmp_path, tiny(tmp_path))))
    again, _ = expand(load_sweep(write(tmp_path, tiny(tmp_path), "copy.yaml")))
    assert len(runs) == 4 and refs == []
    assert len({r.id for r in runs}) == 4
    assert [r.id for r in runs] == [r.id for r in again]
    assert runs[1].overrides == {"shape_function": "linear", "update.scheme": "pic", "grid.cell_size": 2.0,
                                 "time.end": 0.55}
    assert runs[1].method == "shape_function=linear, pic"


def test_sweep_2x2_resumes_without_repeating_finished_runs(tmp_path):
    loaded = load_sweep(write(tmp_path, tiny(tmp_path)))
    out = tmp_path / "out"
    first = run_sweep(loaded, jobs=0, limit=3, out_dir=out)  # "killed" after three runs
    assert len(first.executed) == 3 and not first.complete
    assert [r["status"] for r in read_csv(first.csv)].count("pending") == 1  # a partial table
    second = run_sweep(loaded, jobs=0, out_dir=out)
    assert second.skipped == first.executed  # finished runs are not repeated
    assert len(second.executed) == 1 and second.complete
    rows = read_csv(second.csv)
    assert len(rows) == 4 and {r["status"] for r in rows} == {"ok"}
    assert second.png.stat().st_size > 10_000
    by = {(r["shape_function"], r["update"]): r for r in rows}
    for r in rows:
        assert int(r["particle_steps"]) == int(r["steps"]) * int(r["particles"]) > 0
        assert 0 < float(r["cpu_s"]) < 1.5 * float(r["run_s"]) and float(r["peak_mem_mb"]) > 50
        assert float(r["period_err"]) < 0.03  # two periods at 12.5 cells per bar
    assert float(by[("gimp", "flip")]["energy"]) < 0.01  # FLIP keeps the energy
    assert float(by[("gimp", "pic")]["energy"]) > 0.1  # PIC dissipates
    third = run_sweep(loaded, jobs=0, out_dir=out)
    assert third.executed == [] and third.complete


def test_worker_processes_record_each_run(tmp_path):
    """A LocalCluster of two one-thread workers runs both runs."""
    data = tiny(tmp_path)
    data["axes"]["shape_function"] = ["gimp"]
    data["axes"]["update"] = {"flip": {"update.scheme": "flip"}}
    data["axes"]["grid.cell_size"] = [2.0, 1.0]
    loaded = load_sweep(write(tmp_path, data))
    before = os.environ.get("NUMBA_NUM_THREADS")
    res = run_sweep(loaded, jobs=2, out_dir=tmp_path / "out")
    # the workers' one-thread setting must not leak: numba re-reads it at every later compile
    assert os.environ.get("NUMBA_NUM_THREADS") == before
    rows = read_csv(res.csv)
    assert len(res.executed) == 2 and [r["status"] for r in rows] == ["ok", "ok"]
    assert float(rows[1]["particle_steps"]) > 7 * float(rows[0]["particle_steps"])  # 4x particles, 2x steps


def test_single_material_and_finest_references(tmp_path):
    """Reference runs are shared by the runs they serve; the finest run is its own reference."""
    data = tiny(tmp_path)
    data["reference"] = {"single_material": {"overrides": {"update.scheme": "pic"}, "axes": ["grid.cell_size"]}}
    data["metrics"] = [{"name": "err", "type": "max_rel_error", "column": "kinetic_energy", "range": [0.0, 0.1]}]
    runs, refs = expand(load_sweep(write(tmp_path, data)))
    assert len(refs) == 1 and all(r.reference == refs[0].id for r in runs)
    data["reference"] = {"finest": "grid.cell_size"}
    data["axes"]["grid.cell_size"] = [2.0, 1.0]
    runs, refs = expand(load_sweep(write(tmp_path, data)))
    fine = {r.id for r in runs if r.values["grid.cell_size"] == "1"}
    assert refs == [] and {r.reference for r in runs} == fine


def test_unstable_runs_are_recorded_with_the_time_they_stopped(tmp_path):
    data = tiny(tmp_path)
    data["axes"] = {"step": {"CFL 0.37": {"time": {"end": 0.3, "dt": 0.002}},
                             "CFL 3.7": {"time": {"end": 0.3, "dt": 0.02}}}, "grid.cell_size": [2.0]}
    data.pop("method")
    res = run_sweep(load_sweep(write(tmp_path, data)), jobs=0, out_dir=tmp_path / "out")
    rows = read_csv(res.csv)
    assert [r["status"] for r in rows] == ["ok", "unstable"]
    assert 0.0 < float(rows[1]["stopped_at"]) < 0.3
    assert res.png.exists()


def test_metric_helpers():
    x = np.linspace(0, 1, 11)
    assert max_rel_error(x, 1.02 * (1 + x), x, 1 + x, 0.0, 0.5) == pytest.approx(0.02)
    assert math.isnan(max_rel_error(x, x, x + 5, x, 0.0, 1.0))
    t = np.linspace(0, 2, 2001)
    assert period(t, np.cos(2 * np.pi * t / 0.7)) == pytest.approx(0.7, rel=1e-4)
    assert pareto_front([(1, 5), (2, 1), (3, 3), (4, 0.5)]) == [(1, 5), (2, 1), (4, 0.5)]
    # acceleration from a position (parabola) or a velocity (line) in a time window
    t = np.linspace(0.0, 1.0, 101)
    x = 0.3 + 2.0 * t + 0.5 * 4.0 * t**2 + np.where(t < 0.2, 1.0, 0.0)  # a jump outside the window
    assert acceleration(t, x, (0.3, 1.0)) == pytest.approx(4.0, rel=1e-10)
    assert acceleration(t, 2.0 + 4.0 * t, None, velocity=True) == pytest.approx(4.0, rel=1e-10)
    assert math.isnan(acceleration(t, x, (2.0, 3.0)))


@pytest.mark.parametrize("change, where", [
    ({"axes": {"shape_function": []}}, "tiny.yaml, line 4: axes.shape_function"),
    ({"metrics": [{"name": "e", "type": "max_rel_eror", "column": "syy"}]}, "metrics.0.type"),
    ({"metrics": [{"name": "e", "type": "period_error", "colum": "px", "expected": 1.0}]}, "unknown key 'colum'"),
    ({"reference": {"finest": "cells"}}, "'cells' is not an axis"),
    ({"axes": {"status": [1, 2]}}, "axes.status: the name of a table column"),
    ({"base": "nowhere.yaml"}, "base: no deck at"),
])
def test_bad_sweep_files_name_the_key(tmp_path, change, where):
    data = tiny(tmp_path)
    data.update(change)
    with pytest.raises(DeckError) as exc:
        load_sweep(write(tmp_path, data))
    assert where in exc.value.format()


def test_bad_axis_value_is_reported_before_anything_runs(tmp_path):
    data = tiny(tmp_path)
    data["axes"]["shape_function"] = ["gimp", "quadratic"]
    with pytest.raises(DeckError, match="shape_function"):
        run_sweep(load_sweep(write(tmp_path, data)), jobs=0, out_dir=tmp_path / "out")
    assert not list((tmp_path / "out" / "runs").glob("*.json"))


def test_column_submatrix_lr_below_1_percent_cp08_above_4(tmp_path):
    """Must-show 1 on a sub-matrix of inputs/sweeps/column.yaml: 10 mm cells, to 5% strain,
    LR (two passes) and CP = 0.8 against one material (measured 0.094% and 11.0%)."""
    column = yaml.safe_load((ROOT / "inputs" / "sweeps" / "column.yaml").read_text())
    data = {"base": str(ROOT / "inputs" / "two_blocks.yaml"),
            "axes": {"contact": {"LR": column["axes"]["normal"]["LR"],
                                "CP=0.8": {**column["axes"]["normal"]["AVG"], **column["axes"]["detection"]["CP=0.8"]}},
                     "grid.cell_size": [10.0], "time.end": [5.2]},
            "method": ["contact"], "reference": column["reference"] | {"single_material": {
                "overrides": {"contact.default": {"law": "none"}}, "axes": ["grid.cell_size", "time.end"]}},
            "metrics": [column["metrics"][1]]}
    res = run_sweep(load_sweep(write(tmp_path, data)), jobs=0, out_dir=tmp_path / "out")
    rows = {r["method"]: r for r in read_csv(res.csv)}
    assert rows["single material"]["role"] == "reference"
    assert float(rows["LR"]["err_5pct"]) < 0.01
    assert float(rows["CP=0.8"]["err_5pct"]) > 0.04


def test_cli_bad_sweep_exits_2_with_the_key_path(tmp_path):
    from typer.testing import CliRunner

    from mpmsim.cli import app

    data = tiny(tmp_path)
    data["metrics"][0]["colum"] = "px"
    res = CliRunner().invoke(app, ["sweep", str(write(tmp_path, data))])
    assert res.exit_code == 2
    assert "bad sweep" in res.output and "line 28: metrics.0.colum: unknown key 'colum'" in res.output
