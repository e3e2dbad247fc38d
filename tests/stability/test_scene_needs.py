"""Model no more than a scene needs: `mpmsim check` says which tasks the scene switched on and
why, and which it left out; one material runs no contact task, a 2D deck no 3D work."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from mpmsim.cli import app
from mpmsim.scene import build_scene
from mpmsim.state import State
from mpmsim.tasks import plan_tasks

from ..conftest import ROOT, deck_from
from ..validation.helpers import example

CONTACT_TASKS = {"material fields", "contact geometry", "contact pass 1", "contact pass 2", "contact pass 3"}


def names(deck: dict) -> set[str]:
    return {t.name for t in plan_tasks(build_scene(deck_from(deck, ROOT / "inputs")))[0]}


def test_single_material_deck_runs_no_contact_task():
    assert not names(example("column")) & CONTACT_TASKS
    assert {"material fields", "contact geometry", "contact pass 1", "contact pass 2"} <= names(example("two_blocks"))
    merged = example("two_blocks")
    merged["contact"]["default"] = {"law": "none"}  # two materials joined: one velocity field
    assert not names(merged) & CONTACT_TASKS


def test_tasks_follow_the_options():
    deck = example("two_blocks")
    assert "contact pass 1" not in names({**deck, "contact": {**deck["contact"], "passes": 1}})
    assert "xpic" in names({**deck, "update": {"scheme": "xpic", "order": 5}}) and "xpic" not in names(deck)
    usl = names({**deck, "update": {"scheme": "flip", "stress": "usl"}})
    assert "update stress first" not in usl and "update stress last" in usl


@pytest.mark.parametrize("deck, dim, nodes", [("column", 2, 9), ("column_3d", 3, 27)])
def test_2d_deck_runs_no_3d_work(deck, dim, nodes):
    """One kernel per concern, parameterised by dimension: a 2D deck gives it 2-component
    arrays, 3^2 uGIMP nodes per particle and a single node layer in z."""
    st = State.from_scene(build_scene(deck_from(example(deck), ROOT / "inputs")), threads=1)
    assert st.particles.x.shape[1] == dim and st.particles.F.shape[1:] == (dim, dim)
    assert st.sd.S.shape[1] == nodes and st.sd.G.shape[2] == dim
    assert (st.grid.shape[2] == 1) == (dim == 2)


def test_check_reports_tasks_with_reasons_and_what_was_left_out():
    res = CliRunner().invoke(app, ["check", str(ROOT / "inputs" / "column.yaml")])
    assert res.exit_code == 0, res.output
    assert "kernels: 2D: 2-component vectors, 2x2 F, 9 nodes per particle (gimp), 1 node layer(s) in z" in res.output
    assert "update stress first    usavg: half step from extrapolated velocities" in res.output
    assert "contact (fields, geometry, passes) one material: a single velocity field" in res.output
    assert "contact pass" not in res.output
    res = CliRunner().invoke(app, ["check", str(ROOT / "inputs" / "two_blocks.yaml")])
    assert "contact geometry       logistic_regression normals" in res.output
