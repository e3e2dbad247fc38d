"""The BFEMP paper's 3D twist (section 6.7; inputs/implicit_twist_3d.yaml, docs/bfemp.md): an FEM
shell cap whose rim follows a prescribed rigid motion (a constraint's `motion`, mpmsim/fem/
motion.py) presses down on an MPM cube held at its bottom, then turns about the vertical axis.
The cube's top centre turns with the shell until friction gives way: more friction, more twist.
Also the prescribed motion against the analytic rigid motion, and its deck checks."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from mpmsim.deck.schema import MotionPhase
from mpmsim.errors import DeckError
from mpmsim.fem.motion import RigidMotion
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation
from tests.conftest import ROOT, deck_from

pytestmark = pytest.mark.implicit

W = np.pi / 2  # the deck's turn rate, rad/s
PRESS = 0.1  # the deck's press phase, s


def deck() -> dict:
    return yaml.safe_load((ROOT / "inputs" / "implicit_twist_3d.yaml").read_text())


# ------------------------------------------------------------------------ the motion itself
def phases(*ps) -> list[MotionPhase]:
    return [MotionPhase(**p) for p in ps]


def test_a_rotation_phase_keeps_distances_to_the_axis_and_turns_by_w_t():
    """Down at 0.2 for 0.1 s, then about the z axis through (0.01, -0.02, *) at 1.3 rad/s: at any
    time of the turn every point keeps its distance to the axis and its height, and turns by
    1.3 (t - 0.1) about it (to 1e-12); the velocity is w x (x - c); after the last phase nothing
    moves."""
    rng = np.random.default_rng(3)
    X = rng.uniform(-0.1, 0.1, (50, 3))
    c = np.array([0.01, -0.02, 0.5])
    m = RigidMotion(phases({"until": 0.1, "velocity": [0.0, 0.0, -0.2]},
                           {"until": 0.7, "angular_velocity": [0.0, 0.0, 1.3], "center": c.tolist()}), 3)
    down = X + [0.0, 0.0, -0.02]
    assert np.abs(m.positions(X, 0.05) - (X + [0.0, 0.0, -0.01])).max() < 1e-15
    assert np.abs(m.positions(X, 0.1) - down).max() < 1e-15
    for t in (0.1, 0.25, 0.5, 0.7):
        x = m.positions(X, t)
        r0, r = down[:, :2] - c[:2], x[:, :2] - c[:2]
        assert np.abs(np.hypot(*r.T) - np.hypot(*r0.T)).max() < 1e-12
        assert np.abs(x[:, 2] - down[:, 2]).max() < 1e-15
        angle = np.arctan2(r0[:, 0] * r[:, 1] - r0[:, 1] * r[:, 0], (r0 * r).sum(axis=1))
        assert np.abs(angle - 1.3 * (t - 0.1)).max() < 1e-12
        v = m.velocities(X, t)  # at t = 0.1 the ending phase's rate: down
        if t == 0.1:
            assert np.abs(v - [0.0, 0.0, -0.2]).max() < 1e-15
            continue
        assert np.abs(v - np.cross([0.0, 0.0, 1.3], x - [c[0], c[1], x[0, 2]])).max() < 1e-12
    assert np.abs(m.positions(X, 2.0) - m.positions(X, 0.7)).max() == 0.0
    assert not m.velocities(X, 2.0).any()


def test_a_screw_phase_and_a_carried_centre():
    """A tilted axis with a translation along it (a screw), after a sideways move that carries the
    centre: after the screw phase the points are turned by |w| T about the moved axis and
    shifted by v T (to 1e-12), as the composition of the two rigid maps says; in 2D a number
    turns about z."""
    rng = np.random.default_rng(4)
    X = rng.uniform(-1.0, 1.0, (20, 3))
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    m = RigidMotion(phases({"until": 1.0, "velocity": [0.5, 0.0, 0.0]},
                           {"until": 3.0, "velocity": (0.1 * axis).tolist(), "angular_velocity": (0.4 * axis).tolist(),
                            "center": [0.0, 1.0, 0.0]}), 3)
    a = 0.8  # 0.4 rad/s for 2 s
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    Q = np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K
    c = np.array([0.5, 1.0, 0.0])  # the centre after the first phase
    expect = (X + [0.5, 0.0, 0.0] - c) @ Q.T + c + 0.2 * axis
    assert np.abs(m.positions(X, 3.0) - expect).max() < 1e-12
    m2 = RigidMotion(phases({"until": 2.0, "angular_velocity": 0.25, "center": [1.0, 0.0]}), 2)
    x = m2.positions(np.array([[2.0, 0.0]]), 2.0)
    assert np.abs(x - [1.0 + np.cos(0.5), np.sin(0.5)]).max() < 1e-15


def test_the_implicit_step_puts_the_held_rim_on_the_rigid_motion():
    """The deck's shell alone (no cube), 5 steps down and 3 of the turn at dt = 0.02:
    the rim's nodes sit at the motion's positions at every step to newton_tolerance x dt = 2e-7
    (the spring's reach; measured 6e-8), turned by w (t - 0.1) about the z axis at the end."""
    d = deck()
    d["bodies"] = d["bodies"][:1]
    d["time"] = {"end": 0.16, "dt": 0.02}
    for key in ("contact", "grid", "shape_function", "update"):
        d.pop(key, None)
    sim = Simulation(build_scene(deck_from(d, ROOT / "inputs")), threads=1)
    f = sim.state.fem
    rim = f.held.all(axis=1)
    ((nodes, motion),) = sim.integrator.motions
    assert set(nodes) == set(np.flatnonzero(rim)) and len(nodes) > 20
    while sim.state.t < sim.end * (1 - 1e-12):
        sim.step()
        expect = motion.positions(f.X[nodes], sim.state.t)
        assert np.abs(f.x[nodes] - expect).max() < d["implicit"]["newton_tolerance"] * 0.02
    r0, r = f.X[nodes, :2], f.x[nodes, :2]
    angle = np.arctan2(r0[:, 0] * r[:, 1] - r0[:, 1] * r[:, 0], (r0 * r).sum(axis=1))
    assert np.abs(angle - W * (0.16 - PRESS)).max() < 1e-5
    assert np.abs(f.x[nodes, 2] - (f.X[nodes, 2] - 0.02)).max() < 2e-7


@pytest.mark.parametrize("change, where, says", [
    ({"velocity": [0.0, 0.0, 1.0]}, "constraints.0.velocity", "either velocity or motion"),
    ({"axes": ["z"]}, "constraints.0.axes", "leave axes out"),
    ({"motion": [{"until": 0.1}, {"until": 0.1}]}, "constraints.0.motion.1.until", "increasing time"),
    ({"motion": [{"until": 0.1, "angular_velocity": 1.0, "center": [0, 0, 0]}]},
     "constraints.0.motion.0.angular_velocity", "vector [wx, wy, wz]"),
    ({"motion": [{"until": 0.1, "angular_velocity": [0, 0, 1.0]}]}, "constraints.0.motion.0.center", "needs center"),
    ({"motion": [{"until": 0.1, "velocity": [0, 1.0]}]}, "constraints.0.motion.0.velocity", "needs 3 components"),
])
def test_bad_motions_are_one_line_deck_errors(change, where, says):
    d = deck()
    d["bodies"][0]["constraints"][0].update(change)
    with pytest.raises(DeckError) as err:
        deck_from(d, ROOT / "inputs")
    text = str(err.value)
    assert f"bodies.0.{where}" in text and says in text and "\n" not in text


def test_a_motion_under_the_explicit_integrator_is_a_deck_error():
    d = deck()
    d["integrator"] = "explicit"
    del d["implicit"]
    with pytest.raises(DeckError) as err:
        deck_from(d, ROOT / "inputs")
    assert "bodies.0.constraints.0.motion" in str(err.value) and "implicit integrator only" in str(err.value)


# ------------------------------------------------------------------------ the twist
def z_angle(x0: np.ndarray, x: np.ndarray) -> float:
    """Least-squares rotation angle (degrees) about the z axis taking the points x0 to x."""
    return float(np.degrees(np.arctan2(np.sum(x0[:, 0] * x[:, 1] - x0[:, 1] * x[:, 0]),
                                       np.sum(x0[:, 0] * x[:, 0] + x0[:, 1] * x[:, 1]))))


def inside_tets(points: np.ndarray, x: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Which points lie strictly inside some tetrahedron: the four sub-volumes of (point, face)
    all have the tetrahedron's sign (only tetrahedra whose box meets the points' box)."""
    def vol(a, b, c, d):
        return np.einsum("...i,...i->...", np.cross(b - a, c - a), d - a)

    inside = np.zeros(len(points), bool)
    lo, hi = x[cells].min(axis=1), x[cells].max(axis=1)
    near = np.all(hi >= points.min(axis=0), axis=1) & np.all(lo <= points.max(axis=0), axis=1)
    for e in cells[near]:
        a, b, c, d = x[e]
        s = np.sign(vol(a, b, c, d))
        inside |= ((s * vol(points, b, c, d) > 0) & (s * vol(a, points, c, d) > 0)
                   & (s * vol(a, b, points, d) > 0) & (s * vol(a, b, c, points) > 0))
    return inside


def twist(mu: float, end: float = 0.2) -> list[tuple[float, float, float]]:
    """The deck at dt = 0.025 to t = end (0.2: 4 steps down, 4 turning: the shell at 9 degrees),
    with friction mu: per step (t, shell rim angle, cube top-centre angle), both in degrees; no
    particle inside a shell tetrahedron at any step."""
    d = deck()
    if mu:
        d["contact"]["default"]["friction"] = mu
    else:
        del d["contact"]
    d["time"] = {"end": end, "dt": 0.025}
    sim = Simulation(build_scene(deck_from(d, ROOT / "inputs")), threads=1)
    P, f = sim.state.particles, sim.state.fem
    X0 = P.x.copy()
    top = (X0[:, 2] > X0[:, 2].max() - 1e-9) & (np.hypot(X0[:, 0], X0[:, 1]) < 0.025)
    rim = f.held.all(axis=1)
    out = []
    while sim.state.t < sim.end * (1 - 1e-12):
        sim.step()
        assert not inside_tets(P.x, f.x, f.cells).any(), f"a particle inside the shell at t = {sim.state.t}"
        out.append((sim.state.t, z_angle(f.X[rim], f.x[rim]), z_angle(X0[top], P.x[top])))
    return out


@pytest.fixture(scope="module")
def twists():
    return {mu: twist(mu) for mu in (0.0, 0.1, 0.5)}


@pytest.mark.validation
def test_the_cube_top_turns_more_with_more_friction(twists, measure):
    """With the shell turned 9 degrees the cube's top centre (the 12 top particles within 25 mm
    of the axis) has turned: mu = 0 < mu = 0.1 < mu = 0.5 (measured 0.78, 2.97, 8.77 degrees);
    without friction it still turns a little (the barrier's roughness between particles and
    triangles: 0.78 degrees, more than 0.2). The three runs take about 80 s on one core."""
    end = {mu: run[-1] for mu, run in twists.items()}
    assert all(e[0] == pytest.approx(0.2) and e[1] == pytest.approx(9.0, abs=1e-3) for e in end.values())
    a0, a1, a5 = (end[mu][2] for mu in (0.0, 0.1, 0.5))
    measure("twist: cube top's turn at mu = 0, 0.1, 0.5", f"{a0:.2f}, {a1:.2f}, {a5:.2f} deg", "0.2 < rising")
    assert 0.2 < a0 < a1 < a5


@pytest.mark.validation
def test_with_mu_half_the_cube_top_follows_the_shell_before_it_slips(twists):
    """mu = 0.5: at a shell angle of 9 degrees (t = 0.2) the top centre is within 5% of the shell
    (measured 8.77: 2.6% behind); mu = 0.1 has slipped by then (below 50% of the shell, measured
    2.97 degrees, 33%). The deck's full run (to 45 degrees; docs/bfemp.md) slips mu = 0.5 near 10
    degrees."""
    _, shell, top = twists[0.5][-1]
    assert top == pytest.approx(shell, rel=0.05)
    assert twists[0.1][-1][2] < 0.5 * shell


@pytest.mark.validation
def test_with_mu_one_the_cube_top_does_not_slip():
    """mu = 1 (large enough): the top centre follows the shell to 18 degrees within 3% (measured
    17.59 at 18: 2.3% behind; mu = 2: 17.81), where mu = 0.5 has slipped (12.28 at 18 in this
    variant, docs/bfemp.md); no particle inside the shell at any step."""
    run = twist(1.0, end=0.3)
    for _, shell, follow in run:
        if shell > 1.0:
            assert follow == pytest.approx(shell, rel=0.03), f"slipped at shell angle {shell:.2f}"
    assert run[-1][1] == pytest.approx(18.0, abs=1e-3)
