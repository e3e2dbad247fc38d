"""`mpmsim check`'s cost line (issue 76): no machine name or date, and the first run's compile
estimate, the run's start plus each task's compile cost from task_costs.json (measured by
bench/compile_costs.py), for the scene's own tasks."""

from __future__ import annotations

import platform
import re

import pytest

from mpmsim import cli, cost
from mpmsim.deck import load_deck
from mpmsim.integrators import make_integrator
from mpmsim.scene import build_scene

from ..conftest import ROOT

pytestmark = pytest.mark.newcomer

DECK = ROOT / "inputs" / "disks.yaml"


def cost_line(capsys) -> str:
    cli._check(build_scene(load_deck(DECK)), want_probe=False)
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("cost:")]
    assert len(lines) == 1
    return lines[0]


def test_the_cost_line_names_no_machine_and_no_date(capsys):
    line = cost_line(capsys)
    assert platform.node() not in line and "measured" not in line, line
    assert not re.search(r"\b(19|20)\d\d-\d\d-\d\d\b", line), line
    assert re.search(r"a first run from an empty kernel cache adds about \d+ s of compiling", line), line


def test_the_compile_estimate_adds_up_the_scenes_tasks(capsys, monkeypatch):
    tasks = [name for name, _ in make_integrator(build_scene(load_deck(DECK))).plan]
    table = {**cost.task_costs(), "compile": {"start": 7.0, "tasks": {t: 2.0 for t in tasks}}}
    monkeypatch.setattr(cost, "task_costs", lambda: table)
    assert cost.compile_seconds(tasks) == pytest.approx(7.0 + 2.0 * len(tasks))
    assert f"adds about {7 + 2 * len(tasks)} s of compiling" in cost_line(capsys)
    monkeypatch.setattr(cost, "task_costs", lambda: {"tasks": table["tasks"], "measured": "x"})
    assert "plus compiling on a first run" in cost_line(capsys)  # no compile table: no number


def test_every_task_of_the_explicit_decks_has_a_compile_cost():
    costs = cost.task_costs()["compile"]
    assert costs["start"] > 0.0
    for deck in ("disks", "two_blocks", "stretch", "taylor_bar_rz"):
        plan = [n for n, _ in make_integrator(build_scene(load_deck(ROOT / "inputs" / f"{deck}.yaml"))).plan]
        assert not [t for t in plan if t not in costs["tasks"]], deck
