"""The energy ledger (output.energy_ledger, mpmsim/tasks/ledger.py) on cases whose losses are
known exactly, and its promise to observe without changing the run."""

from __future__ import annotations

import importlib.util
import re
import sys

import numpy as np
import pytest
import yaml

from mpmsim.scene import build_scene
from mpmsim.solver import Simulation
from mpmsim.tasks.ledger import CONDITION, CONTACT, TRANSFER, energy_residual

from ..conftest import ROOT, deck_from

SPEED = 2.0


def block(boundaries: dict, scheme: str = "pic") -> dict:
    """A 4 x 4 mm block moving at -SPEED in x, linear shape functions, 1 mm cells."""
    return {"title": "moving block", "units": "mm-g-ms", "grid": {"cell_size": 1.0, "boundaries": boundaries},
            "shape_function": "linear",
            "materials": {"block": {"type": "neo_hookean", "K": 100.0, "G": 50.0, "density": 0.001}},
            "bodies": [{"shape": "rectangle", "min": [0.0, 2.0], "max": [4.0, 6.0], "material": "block",
                        "velocity": [-SPEED, 0.0]}],
            "time": {"end": 0.05, "dt": 0.001}, "update": {"scheme": scheme, "stress": "usavg"},
            "output": {"energy_ledger": True}}


@pytest.mark.compaction
def test_a_roller_wall_stopping_a_block_loses_half_m_v_squared_of_its_nodes():
    """First step of a block arriving at a roller wall (x = 0) at SPEED: the wall nodes are
    landed on vx = 0 from vx = -SPEED, an inelastic impact losing exactly 1/2 m_wall SPEED^2
    (whatever the forces: the stress update sees the held velocity too)."""
    sim = Simulation(build_scene(deck_from(block({"xmin": "roller"}))), threads=1)
    st = sim.state
    sim.step()
    g = st.grid
    nodes = np.arange(g.n_nodes)
    x = g.origin[0] + (nodes % g.shape[0]) * g.h[0]
    m_wall = st.fields.mass[:g.n_nodes][np.isclose(x, 0.0)].sum()
    assert m_wall > 0.0
    assert st.ledger[CONDITION] == pytest.approx(0.5 * m_wall * SPEED**2, rel=1e-12)
    assert st.ledger[TRANSFER] > 0.0  # PIC's G2P of the slowed wall nodes
    assert st.ledger[CONTACT] == 0.0
    kinetic0 = 0.5 * st.particles.mass.sum() * SPEED**2
    assert abs(energy_residual(st)) < 1e-2 * kinetic0  # measured 0.4%: the stress update's time integration


@pytest.mark.compaction
@pytest.mark.parametrize("scheme", ["pic", "flip", "apic"])
def test_a_free_translation_loses_nothing(scheme):
    """A block translating freely: every loss and the residual stay at round-off."""
    sim = Simulation(build_scene(deck_from(block({}, scheme))), threads=1)
    for _ in range(20):
        sim.step()
    kinetic0 = 0.5 * sim.state.particles.mass.sum() * SPEED**2
    assert np.abs(sim.state.ledger).max() < 1e-12 * kinetic0
    assert abs(energy_residual(sim.state)) < 1e-12 * kinetic0


@pytest.mark.compaction
def test_the_ledger_observes_without_changing_the_run():
    """inputs/two_blocks.yaml (two materials, LR contact, a rigid platen, FLIP, USAVG+): 30
    steps with and without the ledger end bit for bit the same."""
    data = yaml.safe_load((ROOT / "inputs" / "two_blocks.yaml").read_text())
    runs = []
    for ledger in (False, True):
        data["output"] = {"energy_ledger": ledger}
        sim = Simulation(build_scene(deck_from(data, ROOT / "inputs", "two_blocks")), threads=1)
        for _ in range(30):
            sim.step()
        runs.append(sim.state.particles)
    for name in ("x", "v", "F", "stress"):
        assert np.array_equal(getattr(runs[0], name), getattr(runs[1], name)), name


@pytest.mark.compaction
def test_run_prints_where_the_energy_went(tmp_path):
    """`mpmsim run` ends a ledger run with one line: the energy supplied and its parts in %,
    which add up to 100% (the residual closes them)."""
    from typer.testing import CliRunner

    from mpmsim.cli import app

    deck = block({"xmin": "roller"})
    deck["time"] = {"end": 0.2}
    path = tmp_path / "block.yaml"
    path.write_text(yaml.safe_dump(deck))
    result = CliRunner().invoke(app, ["run", str(path), "--out", str(tmp_path / "out"), "--threads", "1"])
    assert result.exit_code == 0, result.output
    line = next(ln for ln in result.output.splitlines() if ln.startswith("energy ledger:"))
    parts = {k.strip(): float(v) for k, v in re.findall(r"([a-z ]+) (-?[0-9.]+)%", line.split(";")[1])}
    assert set(parts) == {"kinetic", "strain", "transfer", "contact", "friction", "condition", "force gap", "residual"}
    assert sum(parts.values()) == pytest.approx(100.0, abs=0.05)
    assert parts["condition"] > 1.0  # the wall stops the block: an inelastic impact on the grid


def test_fields_with_a_sliver_of_mass_are_left_out_of_the_losses():
    """The plain oblique-impact deck (bench/oblique_fem.py: a cylinder striking a block at
    R/h = 10, Coulomb mu = 0.1) with `separation: fit`, which brings slots of mass down to 1e-41
    (a sliver of a particle's shape function) into contact: their velocity, ~1/S, is huge. Over
    its first 100 steps every loss moves by less than 1% of the initial energy per step and the
    residual stays below 1e-4 of it. With the ledger's mass floor at zero (mpmsim.contact.grid.spec.SLIVER = 0) the
    contact and transfer losses swing by +-1.8e8 E0 in step 66 and friction by -189 E0 in step 75."""
    spec = importlib.util.spec_from_file_location("oblique_fem", ROOT / "bench" / "oblique_fem.py")
    bench = importlib.util.module_from_spec(spec)
    sys.modules["oblique_fem"] = bench  # (its NamedTuple and dataclasses look their module up)
    spec.loader.exec_module(bench)
    Scene, plain_deck = bench.Scene, bench.plain_deck

    scene = Scene()
    data = plain_deck(scene, scene.radius / 10, 0.1, {"separation": "fit"})
    sim = Simulation(build_scene(deck_from(data)), threads=1)
    st = sim.state
    rows = []
    for _ in range(100):
        sim.step()
        rows.append(np.append(st.ledger.copy(), energy_residual(st)))
    rows = np.array(rows) / st.energy0
    assert np.abs(np.diff(rows[:, :-1], axis=0)).max() < 0.01
    assert np.abs(rows[:, -1]).max() < 1e-4
