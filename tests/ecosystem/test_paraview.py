"""VTU output for ParaView: material names as field data, rigid bodies in their own
collection, and the script `mpmsim paraview` writes, run by ParaView itself (pvbatch) when it
is installed, on a virtual screen of its own (tests/ecosystem/pvbatch.py; CI installs Debian's
paraview and xvfb; MPMSIM_REQUIRE_PARAVIEW=1 there makes a
missing ParaView a failure)."""

from __future__ import annotations

import os
import re
from pathlib import Path

import meshio
import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from mpmsim.cli import app
from mpmsim.output.paraview import PALETTE, parse_report
from mpmsim.output.vtu import material_names

from .pvbatch import failure, pvbatch, run_pvbatch

pytestmark = pytest.mark.ecosystem
DECK = Path(__file__).with_name("platens.yaml")  # two deformable blocks between rigid platens


@pytest.fixture(scope="module")
def results(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("platens") / "res"
    result = CliRunner().invoke(app, ["run", str(DECK), "--out", str(out), "--quiet", "--threads", "1"])
    assert result.exit_code == 0, result.output
    return out


def frames(pvd: Path) -> list[str]:
    return re.findall(r'file="([^"]+)"', pvd.read_text())


def frame_times(pvd: Path) -> list[float]:
    return [float(t) for t in re.findall(r'timestep="([^"]+)"', pvd.read_text())]


def test_material_names_and_rigid_collection(results):
    main, rigid = frames(results / "platens.pvd"), frames(results / "platens_rigid.pvd")
    assert len(main) == len(rigid) == 6  # t = 0, 5 outputs
    assert all("_rigid_" not in f for f in main) and all("_rigid_" in f for f in rigid)
    deformable = meshio.read(results / main[-1])
    walls = meshio.read(results / rigid[-1])
    for mesh in (deformable, walls):
        assert material_names(mesh) == ["soft", "hard", "bottom", "top"]
    # 2 particles per direction in 2.5 mm cells: 8 x 16 deformable, 2 x (8 x 2) rigid
    assert len(deformable.points) == 128 and len(walls.points) == 32
    assert set(np.unique(deformable.point_data["material"])) == {0, 1}
    assert set(np.unique(walls.point_data["material"])) == {2, 3}
    assert np.all(walls.point_data["stress"] == 0.0)
    assert np.all(walls.point_data["mass"] == 0.0)


def test_paraview_command_errors(tmp_path):
    result = CliRunner().invoke(app, ["paraview", str(tmp_path / "nowhere")])
    assert result.exit_code == 2 and "nowhere" in result.output and "Traceback" not in result.output
    (tmp_path / "empty").mkdir()
    result = CliRunner().invoke(app, ["paraview", str(tmp_path / "empty")])
    assert result.exit_code == 2 and "holds no .pvd" in result.output


def test_paraview_script(results, tmp_path):
    result = CliRunner().invoke(app, ["paraview", str(results)])
    assert result.exit_code == 0, result.output
    script = results / "platens_paraview.py"
    compile(script.read_text(), str(script), "exec")  # valid Python whatever ParaView is here
    if pvbatch() is None:
        assert not os.environ.get("MPMSIM_REQUIRE_PARAVIEW"), "pvbatch not found"
        pytest.skip("ParaView (pvbatch) is not installed: the script was generated and compiled only")
    shot = tmp_path / "shot.png"
    run = run_pvbatch([str(script), "--report", "--screenshot", str(shot)])
    assert run.returncode == 0, failure(run)
    report = parse_report(run.stdout)
    last = meshio.read(results / frames(results / "platens.pvd")[-1])
    syy = last.point_data["stress"][:, 1]
    assert report["time"] == pytest.approx(0.5)
    assert report["times"] == 6
    assert report["materials"] == ["0", "soft", "1", "hard", "2", "bottom", "3", "top"]
    assert report["points"] == len(last.points) and report["rigid_points"] == 32
    assert report["stress_range"] == pytest.approx([syy.min(), syy.max()], rel=1e-12)
    # the picture: the two deformable materials in their table colours, the platens grey
    pixels = np.asarray(Image.open(shot).convert("RGB")).reshape(-1, 3).astype(int)
    left = np.asarray(Image.open(shot).convert("RGB"))[:, :700].reshape(-1, 3).astype(int)

    def count(img, rgb):
        return int(np.sum(np.abs(img - np.array(rgb) * 255).max(axis=1) <= 3))

    assert count(left, PALETTE[0]) > 5000 and count(left, PALETTE[1]) > 5000  # soft, hard
    assert count(left, PALETTE[2]) == 0 and count(left, PALETTE[3]) == 0  # rigid ones are not coloured
    assert count(pixels, (0.6, 0.6, 0.6)) > 2000  # grey platens
    # the legend lists the platens in the grey they are drawn in, the deformable ones in theirs
    colours = np.reshape(report["colours"], (-1, 3))
    assert np.allclose(colours[:2], PALETTE[:2]) and np.allclose(colours[2:], 0.6)
    assert report["stress_title"] == "stress yy (MPa)"  # the deck's mm-g-ms unit
    # the data in the left 75% of each view, the colour bars in the strip right of it
    assert report["data_box"][1] <= 0.75 + 1e-9 and report["bar_at"][0] >= 0.8
    strip = np.asarray(Image.open(shot).convert("RGB"))[:, int(0.76 * 800):int(0.83 * 800)].reshape(-1, 3).astype(int)
    assert count(strip, PALETTE[0]) == 0 and count(strip, PALETTE[1]) == 0  # no data there
    # a time off every frame by more than half their interval (frames every 0.1) is an error;
    # a frame is written at the first step end past its output time, so 0.4's frame is a little later
    times = frame_times(results / "platens.pvd")
    assert times[-1] == 0.5 and 0.4 < times[-2] < 0.401
    off = run_pvbatch([str(script), "--time", "0.58"])
    assert off.returncode == 2, failure(off)
    assert f"no output frame at --time 0.58: the nearest are {times[-2]:g} and 0.5" in off.stderr
    near = run_pvbatch([str(script), "--time", "0.44", "--report"])
    assert near.returncode == 0 and parse_report(near.stdout)["time"] == pytest.approx(times[-2], abs=1e-6)


DECK_3D = {
    "title": "two blocks 3D", "units": "mm-g-ms", "analysis": "3d",
    "grid": {"cell_size": 2.0, "boundaries": {"ymin": "fixed"}}, "shape_function": "gimp",
    "particles_per_direction": 2,
    "materials": {"lower": {"type": "linear_elastic", "E": 1000.0, "nu": 0.3, "density": 0.001},
                  "upper": {"type": "linear_elastic", "E": 1000.0, "nu": 0.3, "density": 0.001}},
    "bodies": [{"shape": "box", "min": [0.0, 0.0, 0.0], "max": [8.0, 6.0, 8.0], "material": "lower"},
               {"shape": "box", "min": [0.0, 6.0, 0.0], "max": [8.0, 12.0, 8.0], "material": "upper",
                "velocity": [0.0, -50.0, 0.0]}],
    "contact": {"normal": "logistic_regression", "default": {"law": "coulomb", "friction": 0.2}},
    "time": {"end": 0.02}, "output": {"vtu_interval": 0.01},
}


def test_paraview_script_in_3d_cuts_through_the_contact(tmp_path):
    """3D: an oblique left view, and the stress view of the half below the middle z plane seen
    from its cut face (the contact plane y = 6 runs across it); --view puts the left camera on an
    axis."""
    import yaml

    deck = tmp_path / "blocks3d.yaml"
    deck.write_text(yaml.safe_dump(DECK_3D))
    out = tmp_path / "res"
    result = CliRunner().invoke(app, ["run", str(deck), "--out", str(out), "--quiet", "--threads", "1"])
    assert result.exit_code == 0, result.output
    result = CliRunner().invoke(app, ["paraview", str(out)])
    assert result.exit_code == 0, result.output
    if pvbatch() is None:
        assert not os.environ.get("MPMSIM_REQUIRE_PARAVIEW"), "pvbatch not found"
        pytest.skip("ParaView (pvbatch) is not installed")
    script = out / "blocks3d_paraview.py"
    for extra, view in (([], "iso"), (["--view", "x"], "x")):
        run = run_pvbatch([str(script), "--report"] + extra)
        assert run.returncode == 0, failure(run)
        report = parse_report(run.stdout)
        assert report["view"] == view and report["cut"] == "z"
        # 4 particle layers of 8 in z: the crinkle clip keeps those below the middle, half
        assert report["shown_points"] == report["points"] // 2


def test_paraview_script_with_fem_bodies(tmp_path):
    """An FEM block and a particle disk: one collection, both blocks shown (FEM cell stresses
    averaged to the nodes, so the stress view covers both)."""
    out = tmp_path / "res"
    deck = Path(__file__).parents[2] / "inputs" / "fem_disk_block_2d.yaml"
    result = CliRunner().invoke(app, ["run", str(deck), "--out", str(out), "--quiet", "--steps", "30"])
    assert result.exit_code == 0, result.output
    files = frames(out / "fem_disk_block_2d.pvd")
    particles = meshio.read(out / [f for f in files if "_fem_" not in f][-1])
    fem = meshio.read(out / [f for f in files if "_fem_" in f][-1])
    assert material_names(fem) == material_names(particles) == ["disk", "block"]
    result = CliRunner().invoke(app, ["paraview", str(out / "fem_disk_block_2d.pvd")])
    assert result.exit_code == 0, result.output
    if pvbatch() is None:
        assert not os.environ.get("MPMSIM_REQUIRE_PARAVIEW"), "pvbatch not found"
        pytest.skip("ParaView (pvbatch) is not installed")
    run = run_pvbatch([str(out / "fem_disk_block_2d_paraview.py"), "--report"])
    assert run.returncode == 0, failure(run)
    report = parse_report(run.stdout)
    assert report["points"] == len(particles.points) + len(fem.points)
    assert report["materials"] == ["0", "disk", "1", "block"]
    nodal_min = min(particles.point_data["stress"][:, 1].min(), fem.cell_data["stress"][0][:, 1].min())
    assert report["stress_range"][0] >= nodal_min - 1e-9 * abs(nodal_min)  # node averages within the cells'
    assert report["stress_range"][0] < 0.5 * nodal_min  # and the disk's impact shows


@pytest.mark.axisymmetric
def test_paraview_script_revolves_an_axisymmetric_series(tmp_path):
    """An r-z series (its particles carry hoop_stress): the left view is the section turned
    upright and swept 270 degrees about the axis (73 copies of every particle, ParaView's
    RotationalExtrusion at resolution 72), the right view the section with the stress;
    --section shows the section in both."""
    out = tmp_path / "res"
    deck = Path(__file__).parents[2] / "tests" / "validation" / "data" / "sphere_rz" / "sphere_impact_rz.yaml"
    result = CliRunner().invoke(app, ["run", str(deck), "--out", str(out), "--quiet", "--steps", "10", "--threads", "1"])
    assert result.exit_code == 0, result.output
    last = meshio.read(out / frames(out / "sphere_impact_rz.pvd")[-1])
    assert "hoop_stress" in last.point_data and "hoop_stretch" in last.point_data
    result = CliRunner().invoke(app, ["paraview", str(out)])
    assert result.exit_code == 0, result.output
    if pvbatch() is None:
        assert not os.environ.get("MPMSIM_REQUIRE_PARAVIEW"), "pvbatch not found"
        pytest.skip("ParaView (pvbatch) is not installed")
    script = out / "sphere_impact_rz_paraview.py"
    run = run_pvbatch([str(script), "--report"])
    assert run.returncode == 0, failure(run)
    report = parse_report(run.stdout)
    assert report["revolved"] and report["revolved_points"] == 73 * report["points"] == 73 * len(last.points)
    run = run_pvbatch([str(script), "--report", "--section"])
    assert run.returncode == 0, failure(run)
    assert not parse_report(run.stdout)["revolved"]
