"""Implicit FEM with barrier contact (mpmsim/integrators/implicit.py; docs/bfemp.md): free fall
against the exact parabola, the order of backward Euler, never a crossing at any time step,
momentum of a free collision, and the deck's refusals."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from matplotlib.path import Path as Polygon
from typer.testing import CliRunner

from mpmsim.cli import app
from mpmsim.fem.probes import boundary_gap
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation
from tests.conftest import ROOT, deck_from

pytestmark = pytest.mark.implicit


def deck(**over) -> dict:
    d = yaml.safe_load((ROOT / "inputs" / "implicit_blocks_2d.yaml").read_text())
    d.update(over)
    return d


def block_alone(scheme: str, dt: float, end: float) -> dict:
    d = deck()
    d["bodies"] = [d["bodies"][1]]
    d["bodies"][0]["velocity"] = [0.5, 2.0]
    d["implicit"] = {"scheme": scheme, "newton_tolerance": 1e-9}
    d["time"] = {"end": end, "dt": dt}
    return d


def test_newmark_free_fall_is_the_exact_parabola_at_every_node():
    """Midpoint Newmark with gravity alone reproduces x0 + v0 t + g t^2 / 2 at every node
    (measured 3.6e-15 relative) with a step six times the explicit limit."""
    d = block_alone("newmark", 0.01, 0.2)
    sim = Simulation(build_scene(deck_from(d)), threads=1)
    x0 = sim.state.fem.x.copy()
    sim.run()
    t = sim.state.t
    exact = x0 + np.array([0.5, 2.0]) * t + 0.5 * np.array([0.0, -9.81]) * t * t
    assert np.abs(sim.state.fem.x - exact).max() < 1e-10 * np.abs(exact).max()
    assert np.allclose(sim.state.fem.v, [0.5, 2.0 - 9.81 * t], rtol=0, atol=1e-10)


def test_backward_euler_free_fall_error_is_first_order():
    """Backward Euler's centroid error at t = 0.2 against the parabola falls with dt at slope
    1 (measured 1.00)."""
    errs, dts = [], [0.02, 0.01, 0.005, 0.0025]
    for dt in dts:
        sim = Simulation(build_scene(deck_from(block_alone("backward_euler", dt, 0.2))), threads=1)
        c0 = sim.state.fem.x.mean(axis=0)
        sim.run()
        t = sim.state.t
        exact = c0[1] + 2.0 * t - 0.5 * 9.81 * t * t
        errs.append(abs(sim.state.fem.x.mean(axis=0)[1] - exact))
    slope = np.polyfit(np.log(dts), np.log(errs), 1)[0]
    assert abs(slope - 1.0) < 0.1


def boundary_loop(fem, body):
    edges = fem.facets[fem.node_body[fem.facets[:, 0]] == body]
    after = dict(zip(edges[:, 0].tolist(), edges[:, 1].tolist()))
    loop = [int(edges[0, 0])]
    while after[loop[-1]] != loop[0]:
        loop.append(after[loop[-1]])
    return np.array(loop)


@pytest.mark.parametrize("fraction", [0.01, 0.1, 0.5, 1.0, 3.0])
def test_no_step_ever_crosses_whatever_the_time_step(fraction):
    """The block falls 0.1 onto the slab at 3 m/s (crossing time 0.033 s). With dt from 1% to
    3x that time (a single step could carry it through the slab), after every step every node
    is outside the other body and the gap stays positive."""
    crossing = 0.1 / 3.0
    dt = fraction * crossing
    d = deck(time={"end": max(3.0 * crossing, 3 * dt), "dt": dt})
    d["implicit"] = {"scheme": "backward_euler", "dhat": 0.01}
    sim = Simulation(build_scene(deck_from(d)), threads=1)
    f = sim.state.fem
    loops = [boundary_loop(f, b) for b in (0, 1)]
    smallest = np.inf
    while sim.state.t < sim.end * (1 - 1e-9):
        sim.step()
        gap = boundary_gap(f.x, f.facets, f.node_body, 0, 1)
        smallest = min(smallest, gap)
        for a, b in ((0, 1), (1, 0)):
            assert not Polygon(f.x[loops[b]]).contains_points(f.x[loops[a]], radius=-1e-12).any()
    assert 0.0 < smallest < 0.01  # they met, within the barrier distance, never touching
    assert f.v[f.node_body == 1, 1].mean() > -3.0  # the slab stopped the block


def test_free_collision_conserves_linear_momentum_to_the_newton_tolerance():
    """Two free blocks (no gravity, nothing held) meet at 2 m/s, midpoint Newmark: total
    momentum to 1e-8 relative. (At 4 m/s the trapezoidal rule gains energy in the stiff
    barrier, as it does in any stiff contact, and the stability check stops the run:
    docs/bfemp.md.)"""
    d = deck(gravity=None, time={"end": 0.1, "dt": 0.002})
    d["bodies"][0].pop("constraints")
    d["bodies"][0]["velocity"] = [0.0, -1.0]
    d["implicit"] = {"scheme": "newmark", "dhat": 0.01, "newton_tolerance": 1e-7}
    sim = Simulation(build_scene(deck_from(d)), threads=1)
    f = sim.state.fem
    p0 = f.mass @ f.v
    sim.run()
    p1 = f.mass @ f.v
    assert np.abs(p1 - p0).max() < 1e-8 * np.linalg.norm(p0)
    assert boundary_gap(f.x, f.facets, f.node_body, 0, 1) > 0.0
    assert sim.integrator.report()[0].startswith("Newton: 50 steps")


@pytest.mark.parametrize("change,words", [
    ({"implicit": {"dhat": 0.0}}, "greater than 0"),
    ({"implicit": {"dhat": 0.01, "kappa": -1.0}}, "greater than 0"),
    ({"implicit": {"dhat": 0.2}}, "start 0.1 apart, not farther than dhat"),
    ({"implicit": {}}, "give implicit.dhat"),
    ({"time": {"end": 0.1}}, "give time.dt"),
], ids=["dhat 0", "kappa < 0", "closer than dhat", "no dhat", "no dt"])
def test_bad_implicit_decks_are_one_line_errors(tmp_path, change, words):
    d = deck(**change)
    path = tmp_path / "d.yaml"
    path.write_text(yaml.safe_dump(d))
    result = CliRunner().invoke(app, ["run", str(path), "--out", str(tmp_path / "o"), "--quiet"])
    assert result.exit_code == 2, result.output
    assert words in " ".join(result.output.split()) and "Traceback" not in result.output


def slope_run(mu: float) -> tuple[np.ndarray, np.ndarray]:
    """A 0.2 x 0.2 FEM block resting (1 mm above, dhat 1 mm) on a 30 degree FEM slope whose
    bottom is fixed; backward Euler, dt = 1 ms, eps_v = 1 mm/s, Coulomb mu. Returns time and the
    block centroid's displacement along the slope."""
    d = {"title": "slope", "units": "SI", "analysis": "plane_strain",
         "materials": {"s": {"type": "compressible_neo_hookean", "E": 1e7, "nu": 0.3, "density": 1000.0}},
         "bodies": [
             {"name": "slope", "shape": "rectangle", "min": [0.0, -0.1], "max": [2.0, 0.0], "material": "s",
              "discretization": "fem", "element_size": 0.05, "transform": [{"rotate": -30.0}],
              "constraints": [{"region": {"min": [-1, -0.2], "max": [3, -0.05]}, "frame": "body"}]},
             {"name": "block", "shape": "rectangle", "min": [0.3, 0.002], "max": [0.5, 0.202], "material": "s",
              "discretization": "fem", "element_size": 0.05, "transform": [{"rotate": -30.0}]}],
         "gravity": [0.0, -9.81], "integrator": "implicit",
         "implicit": {"scheme": "backward_euler", "dhat": 1e-3, "friction_velocity": 1e-3, "newton_tolerance": 1e-6},
         "contact": {"default": {"law": "coulomb", "friction": mu}},
         "time": {"end": 0.3, "dt": 1e-3}, "output": {"history_interval": 1e-3}}
    sim = Simulation(build_scene(deck_from(d)), threads=1)
    sim.run()
    rows = np.array(sim.recorder.rows, dtype=float)
    c = {n: rows[:, i] for i, n in enumerate(sim.recorder.names)}
    th = np.radians(30.0)
    along = (c["cx_block"] - c["cx_block"][0]) * np.cos(th) - (c["cy_block"] - c["cy_block"][0]) * np.sin(th)
    return c["time"], along


def test_block_on_a_slope_slides_at_the_coulomb_rate_or_creeps_when_friction_holds():
    """FEM on FEM, lagged smoothed friction. mu = 0.2 < tan 30: the block slides with
    g (sin - mu cos) = 3.206 m/s^2 (measured 3.202 over 0.1-0.3 s, within 2%). mu = 0.8 >
    tan 30: it sticks, creeping at eps_v (1 - sqrt(1 - tan / mu)) = 4.72e-4 m/s (measured
    4.62e-4, within 10%)."""
    th = np.radians(30.0)
    t, s = slope_run(0.2)
    late = t > 0.1
    accel = 2.0 * np.polyfit(t[late], s[late], 2)[0]
    assert accel == pytest.approx(9.81 * (np.sin(th) - 0.2 * np.cos(th)), rel=0.02)
    t, s = slope_run(0.8)
    late = t > 0.1
    creep = np.polyfit(t[late], s[late], 1)[0]
    assert creep == pytest.approx(1e-3 * (1.0 - np.sqrt(1.0 - np.tan(th) / 0.8)), rel=0.10)


def pushed(ceiling: bool = False):
    """A wall (every node moving up at 1 m/s) pushes a free block (no gravity, dt = 10 ms);
    with `ceiling`, a fixed slab above blocks the way (the wall would need to pass y = 0.3)."""
    d = deck(gravity=None, time={"end": 0.35 if ceiling else 0.2, "dt": 0.01})
    d["bodies"][0]["constraints"] = [{"region": {"min": [-2.0, -1.0], "max": [2.0, 1.0]}, "velocity": [0.0, 1.0]}]
    d["bodies"][1]["velocity"] = [0.0, 0.0]
    d["bodies"][1]["min"], d["bodies"][1]["max"] = [-0.2, 0.02], [0.2, 0.22]
    if ceiling:
        d["bodies"].append({"name": "ceiling", "shape": "rectangle", "min": [-1.0, 0.3], "max": [1.0, 0.4],
                            "material": "soft", "discretization": "fem", "element_size": 0.1,
                            "constraints": [{"region": {"min": [-2.0, 0.25], "max": [2.0, 0.5]}}]})
    d["implicit"] = {"scheme": "backward_euler", "dhat": 0.005}
    return Simulation(build_scene(deck_from(d)), threads=1)


def test_a_moving_wall_reaches_its_prescribed_motion_and_pushes_without_crossing():
    """The wall's nodes are pulled to their targets by a spring stiffened until reached (within
    newton_tolerance x dt each step), so the block is pushed through contact, never crossed: after
    0.2 s the wall moved 0.2 and the block went at least as far (measured 0.207: it was struck
    and bounced slightly ahead). Against a fixed ceiling the motion cannot be completed: the run
    stops cleanly (here Newton stalls with the block crushed, before the spring gives up)."""
    from mpmsim.solver import InstabilityError

    sim = pushed()
    f = sim.state.fem
    x0 = f.x.copy()
    while sim.state.t < sim.end * (1 - 1e-9):
        sim.step()
        assert boundary_gap(f.x, f.facets, f.node_body, 0, 1) > 0.0
    wall = f.node_body == 0
    assert np.abs(f.x[wall] - x0[wall] - [0.0, 0.2]).max() < 20 * 1e-5 * 0.01  # 20 steps within tol x dt
    lift = f.x[~wall, 1].mean() - x0[~wall, 1].mean()
    assert lift > 0.2 - 0.02  # at least the wall's move less the starting gap: pushed, not crossed
    assert f.v[~wall, 1].mean() >= 1.0 - 1e-6  # moving at least with the wall
    with pytest.raises(InstabilityError, match="could not be reached|did not converge"):
        pushed(ceiling=True).run()  # measured: Newton stalls at step 27 with the block crushed
