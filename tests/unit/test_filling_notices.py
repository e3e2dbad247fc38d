"""What filling shapes with particles does that a deck does not say (docs/tutorial.md, "How
shapes become particles"): a later body overwriting an earlier one's particles, and a small gap
between two shapes closed by their particle domains, are warned about by `check` and `run`,
naming both bodies; shapes that touch exactly are not."""

from __future__ import annotations

import pytest
import yaml
from typer.testing import CliRunner

from mpmsim.cli import app
from mpmsim.scene import build_scene
from tests.conftest import ROOT, deck_from

pytestmark = pytest.mark.ecosystem


def deck(*bodies) -> dict:
    return {"title": "filling", "units": "mm-g-ms", "analysis": "plane_strain",
            "grid": {"cell_size": 2.0, "domain": {"min": [-30, -30], "max": [30, 40]}},
            "materials": {"a": {"type": "linear_elastic", "E": 1000.0, "nu": 0.3, "density": 0.001}},
            "bodies": list(bodies), "time": {"end": 0.1}}


BLOCK = {"name": "block", "shape": "rectangle", "min": [-20, -20], "max": [20, 0], "material": "a"}


def test_a_later_body_overwriting_particles_is_named_with_the_count():
    """A circle of radius 8 (208 particles at spacing 1) under a block from x = 4: the 42 sites
    with centres inside both go to the block."""
    d = deck({"name": "cylinder", "shape": "circle", "center": [0, 0], "radius": 8, "material": "a"},
             {"name": "block", "shape": "rectangle", "min": [4, -10], "max": [20, 10], "material": "a"})
    notices = build_scene(deck_from(d)).notices
    assert len(notices) == 1
    assert "body 'cylinder' loses 42 of its 208 particles to 'block'" in notices[0]


@pytest.mark.parametrize("gap", [0.1, 0.3])
def test_a_gap_closed_by_filling_is_named_with_its_width(gap):
    """A disk `gap` above the block (spacing 1): neighbouring sites, domains touching at t = 0.
    The warning's gap is the narrowest stretch inside neither shape between neighbouring
    centres, within 1/33 of the spacing plus the disk's curvature over that stretch."""
    d = deck(BLOCK, {"name": "disk", "shape": "circle", "center": [0, 10 + gap], "radius": 10, "material": "a"})
    notices = build_scene(deck_from(d)).notices
    assert len(notices) == 1 and "bodies 'block' and 'disk' are apart" in notices[0]
    said = float(notices[0].split("gap about ")[1].split()[0])
    assert said == pytest.approx(gap, abs=0.06)


def test_shapes_that_touch_exactly_or_stand_a_spacing_apart_are_not_warned_about():
    stacked = deck(BLOCK, {"name": "top", "shape": "rectangle", "min": [-20, 0], "max": [20, 10], "material": "a"})
    apart = deck(BLOCK, {"name": "top", "shape": "rectangle", "min": [-20, 1.2], "max": [20, 10], "material": "a"})
    assert build_scene(deck_from(stacked)).notices == ()
    assert build_scene(deck_from(apart)).notices == ()


def test_overwrites_true_says_the_overlap_is_meant():
    d = deck({"name": "matrix", "shape": "rectangle", "min": [-20, -20], "max": [20, 20], "material": "a"},
             {"name": "inclusion", "shape": "circle", "center": [0, 0], "radius": 8, "material": "a",
              "overwrites": True})
    assert build_scene(deck_from(d)).notices == ()


def test_every_deck_in_inputs_fills_without_notices():
    bad = []
    for path in sorted((ROOT / "inputs").glob("*.yaml")):
        d = yaml.safe_load(path.read_text())
        if any(b.get("discretization", "particles") == "particles" for b in d["bodies"]):
            notices = build_scene(deck_from(d, ROOT / "inputs", path.stem)).notices
            bad += [f"{path.name}: {n}" for n in notices]
    assert not bad, "\n".join(bad)


def test_check_and_run_print_the_warning(tmp_path):
    d = deck(BLOCK, {"name": "disk", "shape": "circle", "center": [0, 10.1], "radius": 10, "material": "a"})
    d["time"] = {"end": 0.001}
    path = tmp_path / "gap.yaml"
    path.write_text(yaml.safe_dump(d))
    runner = CliRunner()
    for args in (["check", str(path)], ["run", str(path), "--out", str(tmp_path / "o"), "--quiet"]):
        result = runner.invoke(app, args)
        assert result.exit_code == 0, result.output
        assert "bodies 'block' and 'disk' are apart" in " ".join(result.output.split()), args[0]
    assert "bodies 'block' and 'disk' are apart" in next((tmp_path / "o").glob("*_run.log")).read_text()
