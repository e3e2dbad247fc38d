"""BFEMP in 3D (mpmsim/contact/barrier/surface.py; docs/bfemp.md): MPM particles against FEM
boundary triangles through the log barrier and lagged friction in the implicit step. An MPM
block on a 30 degree FEM slope slides at g (sin - mu cos) and holds above tan 30; a cube dropped
on a held slab and a fast block at a held wall never put a particle inside a tetrahedron (a
point-in-tetrahedron test of this file's own) at time steps from 1e-1 to 1e-3 of the crossing
time; an MPM cube and a free FEM cube colliding with friction keep their linear momentum."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from mpmsim.errors import DeckError
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation
from tests.conftest import ROOT, deck_from

pytestmark = pytest.mark.implicit

G = 9.81
TH = np.radians(30.0)


def simulation(d: dict) -> Simulation:
    return Simulation(build_scene(deck_from(d)), threads=1)


def inside_tets(points: np.ndarray, x: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Which points lie strictly inside some tetrahedron: the four sub-volumes of (point, face)
    all have the tetrahedron's sign (independent of the solver's barycentric solve)."""
    def vol(a, b, c, d):
        return np.einsum("...i,...i->...", np.cross(b - a, c - a), d - a)

    inside = np.zeros(len(points), bool)
    for e in cells:
        a, b, c, d = x[e]
        v = vol(a, b, c, d)
        s = np.sign(v)
        inside |= ((s * vol(points, b, c, d) > 0) & (s * vol(a, points, c, d) > 0)
                   & (s * vol(a, b, points, d) > 0) & (s * vol(a, b, c, points) > 0))
    return inside


# ------------------------------------------------------------------------ slope
def slope(mu: float, end: float = 0.3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(times, mean particle x-velocity, mean particle x) of the MPM block on the 3D slope."""
    d = yaml.safe_load((ROOT / "inputs" / "implicit_mpm_slope_3d.yaml").read_text())
    d["contact"] = {"default": {"law": "coulomb", "friction": mu}}
    d["time"] = {"end": end, "dt": 1e-3}
    sim = simulation(d)
    P = sim.state.particles
    t, v, x = [], [], []
    while sim.state.t < sim.end * (1 - 1e-12):
        sim.step()
        t.append(sim.state.t)
        v.append(P.v[:, 0].mean())
        x.append(P.x[:, 0].mean())
        assert P.x[:, 1].min() > 0.01  # above the slab's top face (y = 0.01) at every step
    return np.array(t), np.array(v), np.array(x)


@pytest.fixture(scope="module")
def frictionless():
    return slope(0.0)


def test_mpm_block_slides_down_the_3d_fem_slope_at_g_sin_minus_mu_cos(frictionless):
    """mu = 0.3 < tan 30: after landing the block accelerates at g (sin 30 - mu cos 30) = 2.356
    m/s^2 within 1% (fit over 0.1-0.3 s; measured -4e-6 relative); without friction at g sin 30
    within 1% (measured -1.5e-7)."""
    t, v, _ = slope(0.3)
    late = t > 0.1
    assert np.polyfit(t[late], v[late], 1)[0] == pytest.approx(G * (np.sin(TH) - 0.3 * np.cos(TH)), rel=0.01)
    t0, v0, _ = frictionless
    assert np.polyfit(t0[late], v0[late], 1)[0] == pytest.approx(G * np.sin(TH), rel=0.01)


def test_mpm_block_on_the_3d_fem_slope_holds_above_tan30(frictionless):
    """mu = 0.7 > tan 30: once the landing's rocking has died out (it slips 2.2 mm in the first
    0.12 s while the normal force swings), the block moves less than 1% of the frictionless
    block's travel over the same time, 0.15-0.3 s (measured 0.088 mm vs 166 mm; smoothed static
    friction creeps at eps_v (1 - sqrt(1 - tan 30/mu)) = 0.58 mm/s)."""
    t, _, x = slope(0.7)
    t0, _, x0 = frictionless
    after = t >= 0.15
    moved = x[after][-1] - x[after][0]
    free = x0[after][-1] - x0[after][0]
    assert free > 0.1
    assert abs(moved) < 0.01 * free


# ------------------------------------------------------------------------ impacts
def cube_deck(speed: float, dt: float, end: float, friction: float = 0.0, free_fem: bool = False,
              sideways: float = 0.0) -> dict:
    """An MPM cube (0.1 m, 2 particles per cell direction) moving down at `speed` onto an FEM
    slab (held at its bottom) or, with free_fem, onto a free FEM cube."""
    target = ({"name": "target", "shape": "box", "min": [-0.1, -0.1, -0.1], "max": [0.1, 0.0, 0.1],
               "material": "m", "discretization": "fem", "element_size": 0.05}
              if free_fem else
              {"name": "target", "shape": "box", "min": [-0.15, -0.05, -0.15], "max": [0.15, 0.0, 0.15],
               "material": "m", "discretization": "fem", "element_size": 0.05,
               "constraints": [{"region": {"min": [-1.0, -0.06, -1.0], "max": [1.0, -0.045, 1.0]}}]})
    cube = {"name": "cube", "shape": "box", "min": [-0.04, 0.004, -0.06], "max": [0.06, 0.104, 0.04],
            "material": "m", "velocity": [sideways, -speed, 0.0]}
    return impact_deck("3D impact", [target, cube], ([-0.2, -0.15, -0.2], [0.2, 0.2, 0.2]), 0.025, dt, end,
                       friction)


def impact_deck(title: str, bodies: list, domain: tuple, cell: float, dt: float, end: float,
                friction: float = 0.0) -> dict:
    """An implicit 3D deck of `bodies` of one soft material (E = 1e6, nu = 0.3, 1000 kg/m^3),
    backward Euler, dhat = 1 mm, adaptive kappa; Coulomb friction when given."""
    d = {
        "title": title, "units": "SI", "analysis": "3d",
        "grid": {"cell_size": cell, "domain": {"min": list(domain[0]), "max": list(domain[1])}},
        "shape_function": "bspline2", "update": {"scheme": "apic"},
        "materials": {"m": {"type": "compressible_neo_hookean", "E": 1e6, "nu": 0.3, "density": 1000.0}},
        "bodies": bodies,
        "integrator": "implicit",
        "implicit": {"scheme": "backward_euler", "dhat": 1e-3, "newton_tolerance": 1e-6},
        "time": {"end": end, "dt": dt},
    }
    if friction:
        d["contact"] = {"default": {"law": "coulomb", "friction": friction}}
    return d


def test_a_fast_mpm_cube_never_enters_the_fem_slab():
    """The cube at 20 m/s onto the held slab, time step 1/10 of the time it needs to cross the
    slab's thickness plus its own gap (T = 2.6 ms), over 3 T (the whole impact): no particle
    centre inside a tetrahedron at any step, none below the slab's held bottom, and the cube
    turned back (measured with the adaptive kappa: 5.5 Newton iterations per step, 10 at most;
    rebound at 11.8 m/s). At T/100 (300 steps, 82 s, not in the suite; kappa = 1e6 fixed) the
    same holds: 3.2 iterations per step, rebound at 14.0 m/s (docs/bfemp.md)."""
    T = (0.05 + 0.002) / 20.0
    d = cube_deck(20.0, 0.1 * T, 3.0 * T)
    sim = simulation(d)
    st = sim.state
    P, f = st.particles, st.fem
    low = 1.0
    while st.t < sim.end * (1 - 1e-12):
        sim.step()
        assert not inside_tets(P.x, f.x, f.cells).any(), f"inside the slab at t = {st.t}"
        assert P.x[:, 1].min() > -0.05, f"through the slab at t = {st.t}"
        low = min(low, P.x[:, 1].min())
    assert low < 0.0125 - 0.003  # the bottom particles (0.0165 at the start) pressed the slab's face in
    assert P.v[:, 1].mean() > 0.0  # stopped and turned back


def test_mpm_cube_and_free_fem_cube_keep_linear_momentum_through_a_frictional_impact():
    """An MPM cube at (1, -2, 0) m/s hits a free FEM cube off-centre with mu = 0.5 (backward
    Euler, no gravity): the total linear momentum stays to 1e-10 of the incoming one (measured
    6.3e-14); friction hands the FEM cube 0.51 of the sideways momentum (frictionless: -0.008)
    within Coulomb's bound on the impulses, |p_x| <= mu |p_y| (p_y = -1.93)."""
    d = cube_deck(2.0, 2e-3, 0.04, friction=0.5, free_fem=True, sideways=1.0)
    sim = simulation(d)
    st = sim.state
    P, f = st.particles, st.fem
    p0 = P.mass @ P.v + f.mass @ f.v
    worst = 0.0
    while st.t < sim.end * (1 - 1e-12):
        sim.step()
        worst = max(worst, float(np.abs(P.mass @ P.v + f.mass @ f.v - p0).max()))
        assert not inside_tets(P.x, f.x, f.cells).any()
    assert worst < 1e-10 * np.abs(p0).max()
    pf = f.mass @ f.v
    assert pf[1] < -0.5 * abs(p0[1])  # the FEM cube was hit
    assert 0.2 * p0[0] < pf[0] <= 0.5 * abs(pf[1])


def test_momentum_through_a_contact_at_a_ten_thousandth_of_the_crossing_time():
    """The 3D impact of docs/bfemp.md (a 2 cm MPM cube of 512 particles at 20 m/s onto a 1 cm FEM
    slab of 150 tetrahedra, dhat = 0.25 mm) at dt = T/10^4 (T = 0.55 ms, the time to cross the
    slab and the gap), the slab free so that the total momentum is the measure: 120 steps from
    10 steps before the first contact. Every step conserves it to 1e-13 of the cube's m v0
    and the run to 1e-12 (`python bench/implicit.py --impact3d-window 400`: 4.5e-15 per step,
    2.8e-14 over 400 steps). Newton's unknowns are the displacements over the step; with the
    positions as unknowns the velocities' last bits were a position's ulp / dt (1.7e-18 m /
    5.5e-8 s): 5.3e-13 in a step of this test, 6.4e-13 per step and 5.8e-12 over the bench's
    400. No particle or FEM node enters a tetrahedron."""
    from tests.implicit.test_implicit_mpm import bench_implicit

    bench = bench_implicit()
    speed, T = bench.IMPACT3D_SPEED, bench.IMPACT3D_T
    # the bench's deck, the cube and the grid lowered so that its lowest particles (3.75 mm up in
    # the deck) start 0.261 mm above the slab: 10 steps of 1.1 um to dhat
    d = bench.impact3d_deck(1e-4, 120 * 1e-4 * T, held=False, lowered=0.003489)
    sim = simulation(d)
    st = sim.state
    P, f = st.particles, st.fem
    assert len(P.x) == 512 and len(f.cells) == 150
    assert P.x[:, 1].min() == pytest.approx(2.61e-4, rel=1e-6)
    p0 = P.mass @ P.v + f.mass @ f.v
    scale = float(P.mass.sum()) * speed
    worst = drift = 0.0
    while st.t < sim.end * (1 - 1e-12):
        before = P.mass @ P.v + f.mass @ f.v
        sim.step()
        now = P.mass @ P.v + f.mass @ f.v
        worst = max(worst, float(np.abs(now - before).max()) / scale)
        drift = max(drift, float(np.abs(now - p0).max()) / scale)
        assert not inside_tets(P.x, f.x, f.cells).any() and not inside_tets(f.x, f.x, f.cells).any()
    assert st.step == 120 and sim.integrator.barrier_term.in_contact
    assert P.v[:, 1].mean() > -19.5  # the contact acted
    assert worst < 1e-13 and drift < 1e-12


def test_a_particle_closer_than_dhat_to_an_fem_triangle_is_a_deck_error():
    d = cube_deck(1.0, 1e-3, 0.01)
    d["implicit"]["dhat"] = 0.02  # the lowest particles start 10.25 mm above the slab
    with pytest.raises(DeckError) as err:
        simulation(d)
    assert "a particle of 'cube'" in str(err.value) and "not farther than dhat" in str(err.value)


def test_a_particle_inside_an_fem_body_is_a_deck_error():
    d = cube_deck(1.0, 1e-3, 0.01)
    d["bodies"][1]["min"][1] = -0.02
    with pytest.raises(DeckError) as err:
        simulation(d)
    assert "start inside FEM body 'target'" in str(err.value)
