"""`mpmsim check`'s time per step for explicit particle scenes: the cost model of mpmsim/cost.py
(each task a + b n K microseconds on one thread, from task_costs.json) applied to the scene's own
task list, particle count n and nodes per particle K.

What is checked here does not depend on the machine: every task of these scenes has a
calibrated cost, and with cost tables whose answer is known (a = 1, b = 0: one microsecond per
task; a = 0, b = 1: n K per task) `check` prints exactly that, so the tasks it counts are the
step's tasks and n and K are the scene's. How close the calibrated costs come to a measured
step is a timing, measured on a quiet machine by bench/estimate.py (docs/performance.md)."""

from __future__ import annotations

import re

import pytest
from typer.testing import CliRunner

from mpmsim import cost
from mpmsim.cli import app
from mpmsim.deck import load_deck
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation

from ..conftest import ROOT

pytestmark = pytest.mark.speed


def check_ms(deck) -> tuple[float, str]:
    result = CliRunner().invoke(app, ["check", str(deck)])
    assert result.exit_code == 0, result.output
    text = " ".join(result.output.split())
    return float(re.search(r"about ([\d.e+-]+) ms per step on one thread", text).group(1)), text


@pytest.mark.parametrize("name", ["disks", "two_blocks", "stretch"])
def test_check_applies_the_task_costs_to_the_scenes_tasks_particles_and_nodes(name, monkeypatch):
    deck = ROOT / "inputs" / f"{name}.yaml"
    _, text = check_ms(deck)
    assert "no cost measured" not in text  # every task of the scene is calibrated
    sim = Simulation(build_scene(load_deck(deck)), out_dir=None, threads=1)
    tasks = [t for t, _ in sim.integrator.plan] + [cost.CHECK]
    n, K = sim.state.particles.n, int(sim.state.entries.nodes.shape[1])
    assert n > 10 and K >= 9 and len(tasks) >= 8
    for a, b, want_us in [(1.0, 0.0, len(tasks)), (0.0, 1.0, len(tasks) * n * K), (2.0, 0.5, len(tasks) * (2 + 0.5 * n * K))]:
        table = {"tasks": {t: [a, b] for t in tasks}, "measured": "test"}
        monkeypatch.setattr(cost, "task_costs", lambda table=table: table)
        got, _ = check_ms(deck)
        assert got == pytest.approx(want_us / 1e3, rel=5e-3), (a, b)  # printed to 3 digits
    # a task without a cost is named, not counted as free
    table = {"tasks": {t: [1.0, 0.0] for t in tasks[1:]}, "measured": "test"}
    monkeypatch.setattr(cost, "task_costs", lambda: table)
    got, text = check_ms(deck)
    assert got == pytest.approx((len(tasks) - 1) / 1e3, rel=5e-3) and f"no cost measured for {tasks[0]}" in text
