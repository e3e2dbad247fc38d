"""Imperfect-interface integration: the per-direction oscillator, the implicit (backward-Euler and
trapezoidal) springs and the paper's force limit; the opening measured at the interface; the
composite spheres assemblage the sphere tests compare with."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.contact.grid.laws import direction_force, implicit_spring, oscillator
from mpmsim.contact.grid.spec import BACKWARD_EULER, FORCE_LIMIT, OSCILLATOR, TRAPEZOIDAL
from mpmsim.sweep.metrics import csa_bulk_modulus

from ..conftest import ROOT


@pytest.mark.parametrize("phi", [1e-5, 0.3, 1.0, 1.5])
def test_oscillator_lands_the_mpm_update_on_the_exact_opening(phi):
    """m delta'' = df - k delta from (delta0, d/m): the returned constant force moves the
    ordinary update delta0 + dt/m (d + dt/2 (df - f)) exactly onto the analytic end opening."""
    m, dt, delta0, d, df = 2.0, 0.1, 0.3, -0.7, 0.4
    k = phi**2 * m / dt**2
    f, end = oscillator(k, m, delta0, d, df, dt)
    w = np.sqrt(k / m)
    # (1 - cos wt)/w^2 as 2 sin^2(wt/2)/w^2: no cancellation as k -> 0
    exact = delta0 * np.cos(w * dt) + d / (m * w) * np.sin(w * dt) + df / m * 2 * np.sin(0.5 * w * dt) ** 2 / w**2
    assert end == pytest.approx(exact, rel=1e-9, abs=1e-12)
    assert delta0 + dt / m * (d + 0.5 * dt * (df - f)) == pytest.approx(end, rel=1e-9, abs=1e-12)


def test_oscillator_tends_to_the_first_order_force():
    m, dt, delta0 = 1.0, 1e-4, 0.02
    k = 1e-3
    f, _ = oscillator(k, m, delta0, 0.0, 0.0, dt)
    assert f == pytest.approx(k * delta0, rel=1e-8)
    f0, end0 = oscillator(0.0, m, delta0, 0.5, 0.2, dt)  # D = 0: a free direction
    assert f0 == 0.0 and end0 == pytest.approx(delta0 + dt * 0.5 / m + 0.5 * 0.2 * dt**2 / m)


@pytest.mark.parametrize("theta", [0.5, 1.0], ids=["trapezoidal", "backward Euler"])
def test_implicit_spring_acts_at_its_opening(theta):
    """The force is k times (1 - theta) start + theta end opening (theta = 1/2: the mean; 1: the
    end), and the end opening is the one the ordinary update delta0 + dt/m (d + dt/2 (df - f))
    lands on."""
    m, dt, delta0, d, df = 2.0, 0.1, 0.3, -0.7, 0.4
    for phi2 in (1e-6, 0.5, 2.25, 1e4):
        k = phi2 * m / dt**2
        f, end = implicit_spring(k, m, delta0, d, df, dt, theta)
        assert f == pytest.approx(k * ((1 - theta) * delta0 + theta * end), rel=1e-9)
        assert delta0 + dt / m * (d + 0.5 * dt * (df - f)) == pytest.approx(end, rel=1e-9, abs=1e-12)
    f0, end0 = implicit_spring(0.0, m, delta0, 0.5, 0.2, dt, theta)  # D = 0: a free direction
    assert f0 == 0.0 and end0 == pytest.approx(delta0 + dt * 0.5 / m + 0.5 * 0.2 * dt**2 / m)


def pair_step(mode, k, m, dt, delta, v):
    """One step of an isolated pair (relative coordinate, reduced mass m) under FLIP's update:
    v_end = v - f dt / m, delta_end = delta + dt (v + v_end) / 2."""
    f, _, _ = direction_force(k, 1.0, m, delta, m * v, 0.0, dt, mode)
    v_end = v - f * dt / m
    return delta + 0.5 * dt * (v + v_end), v_end


@pytest.mark.parametrize("phi2", [0.1, 1.0, 2.25, 100.0])
def test_isolated_pair_energy_kept_by_trapezoidal_lost_by_backward_euler_gained_by_oscillator(phi2):
    """The exact oscillator lands on the exact end opening but not on the exact end velocity:
    its step map has determinant 2 sin(phi)/phi - cos(phi) > 1, so an isolated pair gains
    energy every step (1.6% per step at phi^2 = 0.1, 26% at 2.25, the reference code's switch; only grid damping
    or the materials around it can hold it). The trapezoidal spring is the implicit midpoint
    rule: the pair's energy is kept to round-off for any phi^2. Backward Euler (the default)
    loses energy every step and never gains: its map's determinant is 1 / (1 + phi^2 / 2)."""
    m, dt = 1.5, 0.01
    k = phi2 * m / dt**2
    energy = lambda s: 0.5 * k * s[0] ** 2 + 0.5 * m * s[1] ** 2  # noqa: E731
    start = (0.01, 0.3)
    s = start
    for _ in range(400):
        s = pair_step(TRAPEZOIDAL, k, m, dt, *s)
    assert energy(s) == pytest.approx(energy(start), rel=1e-10)
    cols = [pair_step(BACKWARD_EULER, k, m, dt, *e) for e in ((1.0, 0.0), (0.0, 1.0))]
    det = cols[0][0] * cols[1][1] - cols[1][0] * cols[0][1]
    assert det == pytest.approx(1.0 / (1.0 + 0.5 * phi2), rel=1e-9)
    s = start
    for _ in range(50):
        before = energy(s)
        s = pair_step(BACKWARD_EULER, k, m, dt, *s)
        assert energy(s) <= before * (1 + 1e-12)
    assert energy(s) < 0.5 * energy(start)
    # the oscillator's map, column by column (it is linear in (delta, v))
    cols = [pair_step(OSCILLATOR, k, m, dt, *e) for e in ((1.0, 0.0), (0.0, 1.0))]
    det = cols[0][0] * cols[1][1] - cols[1][0] * cols[0][1]
    phi = np.sqrt(phi2)
    assert det == pytest.approx(2.0 * np.sin(phi) / phi - np.cos(phi), rel=1e-9)
    if phi2 > 2.25:
        return  # above any switch the direction is bonded; the map there is not used
    assert det > 1.0 + phi2 / 9.0
    s = start
    for _ in range(50):
        s = pair_step(OSCILLATOR, k, m, dt, *s)
    assert energy(s) > 1.5 * energy(start)


def test_force_limit_switches_a_stiff_direction_to_bonded():
    """The 2013 paper: force D A delta unless it exceeds the force that brings both materials
    to the centre of mass within the step (Eq. 26); then the direction acts as perfect."""
    m, dt, delta0 = 1.0, 1e-3, 1e-3
    soft = direction_force(1.0, 1.0, m, delta0, 0.0, 0.0, dt, FORCE_LIMIT)
    assert soft[0] == pytest.approx(1.0 * delta0) and soft[1] == pytest.approx(0.5 * delta0**2) and not soft[2]
    stiff = direction_force(1e9, 1.0, m, delta0, 0.0, 0.0, dt, FORCE_LIMIT)
    assert stiff[2] and stiff[1] == 0.0
    # the oscillator never switches by itself (the geometry does, at phi^2 > 1)
    assert not direction_force(1e9, 1.0, m, delta0, 0.0, 0.0, dt, OSCILLATOR)[2]


def test_point_bond_zeroes_the_interpolated_jump_and_conserves_momentum():
    """The consistent normal bond (contact.bond) on a mid-plane pair of nodes (weights 1/2,
    1/2) and a node on the interface (weight 1): afterwards each constraint's interpolated
    relative normal velocity is zero, the tangential velocities are untouched, and the
    momentum of each node (both materials) is unchanged; with unequal jumps the pair keeps
    their difference (the in-cell strain jump the node-wise bond would remove)."""
    from mpmsim.contact.grid.bond import point_bond
    from mpmsim.contact.grid.workspace import Bonds

    nn = 1  # one grid node before the slots; slots 0..5 are fields 1..6
    mass = np.array([1.0, 2.0, 1.0, 3.0, 1.5, 2.0, 0.5])
    rng = np.random.default_rng(3)
    v = rng.normal(size=(7, 2))
    n = np.zeros((6, 2))
    n[:, 0] = 1.0
    con_ptr = np.array([0, 2, 3])
    ent_a, ent_b, ent_w = np.array([0, 2, 4]), np.array([1, 3, 5]), np.array([0.5, 0.5, 1.0])
    mom = v * mass[:, None]
    before = mom.copy()
    sweeps = point_bond(Bonds(2, con_ptr, ent_a, ent_b, ent_w), nn, mass, mom, True, np.zeros((1, 3)), 0.0, n, 2)
    assert sweeps <= 2
    vel = mom / mass[:, None]
    jump = [vel[nn + b, 0] - vel[nn + a, 0] for a, b in zip(ent_a, ent_b)]
    assert 0.5 * jump[0] + 0.5 * jump[1] == pytest.approx(0.0, abs=1e-14)
    assert jump[2] == pytest.approx(0.0, abs=1e-14)
    assert abs(jump[0]) > 0.1  # not clamped node by node
    np.testing.assert_allclose(mom[:, 1], before[:, 1], rtol=0, atol=0)
    for a, b in zip(ent_a, ent_b):
        np.testing.assert_allclose(mom[nn + a] + mom[nn + b], before[nn + a] + before[nn + b], atol=1e-14)


def interface_geometry(mid: bool, strain, offset):
    """The two-layer specimen (1 mm cells, interface on a grid line or a cell mid-plane, normal
    (1, 0)) with every particle displaced by the affine field u = E X, the right layer also by
    `offset`, and F = I + E; the contact geometry of that configuration (no step taken)."""
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation

    from ..conftest import deck_from
    from ..validation.specimens import two_layer

    sim = Simulation(build_scene(deck_from(two_layer(1.0, 1.0, mid=mid, **{"contact.default.Dn": 1.0}),
                                           ROOT / "inputs")))
    st = sim.state
    P = st.particles
    E = np.asarray(strain)
    P.x[:] = P.x0 @ (np.eye(2) + E).T
    P.F[:] = np.eye(2) + E
    P.x[P.x0[:, 0] > (4.5 if mid else 4.0)] += offset
    st.dt_rule = st.dt = sim.integrator.stable_dt(st)  # as the run loop does before a step
    for task in sim.integrator.tasks:
        task.run(st)
        if task.name == "contact geometry":
            break
    cs = st.contact
    targets = np.flatnonzero(cs.role[: cs.n_slots] != 0)
    assert targets.size > 20
    return cs.delta[targets], cs.open[targets]


@pytest.mark.parametrize("mid", [False, True], ids=["grid line", "mid-plane"])
def test_interface_opening_is_measured_at_the_interface_not_at_the_node(mid):
    """A continuous strain field opens nothing: each side's displacement is carried to the
    interface point along its own displacement gradient (I - F^-1), so the strain between the
    particles and the node (which made a bonded interface look open by ~ eps h / 2 at every
    node) drops out, exactly for an affine field. A rigid offset of one layer is measured
    exactly: normal part as delta, tangential part as the opening vector."""
    eps = [[0.01, 0.004], [0.003, -0.02]]
    delta, opening = interface_geometry(mid, eps, [0.0, 0.0])
    assert np.abs(delta).max() < 1e-12 and np.abs(opening).max() < 1e-12
    delta, opening = interface_geometry(mid, np.zeros((2, 2)), [2e-3, -5e-3])
    np.testing.assert_allclose(delta, 2e-3, rtol=1e-9)
    np.testing.assert_allclose(opening[:, 0], 0.0, atol=1e-15)
    np.testing.assert_allclose(opening[:, 1], -5e-3, rtol=1e-9)


def test_csa_bulk_modulus_spans_the_debonded_and_perfect_assemblages():
    """The composite sphere with an interface spring (the sphere tests' reference): Dn -> inf is
    Hashin's perfect-interface closed form, Dn -> 0 the hollow sphere's 4 G K (1 - f) / (4 G +
    3 K f), and K rises monotonically between them; for the glass/polymer cube 3062 MPa."""
    Em, num, Ep, nup, f = 2400.0, 0.33, 70000.0, 0.25, np.pi * 0.7**3 / 6
    Km, Gm, Kp = Em / (3 * (1 - 2 * num)), Em / (2 * (1 + num)), Ep / (3 * (1 - 2 * nup))
    perfect = Km + f * (Kp - Km) / (1 + (1 - f) * (Kp - Km) / (Km + 4 * Gm / 3))
    assert csa_bulk_modulus(Em, num, Ep, nup, f) == pytest.approx(perfect, rel=1e-12)
    assert perfect == pytest.approx(3062.0, abs=0.1)
    hollow = 4 * Gm * Km * (1 - f) / (4 * Gm + 3 * Km * f)
    assert csa_bulk_modulus(Em, num, Ep, nup, f, 1e-9, 0.7) == pytest.approx(hollow, rel=1e-9)
    curve = [csa_bulk_modulus(Em, num, Ep, nup, f, D, 0.7) for D in 10.0 ** np.arange(0, 13)]
    assert np.all(np.diff(curve) > 0) and hollow < curve[0] and curve[-1] < perfect
    assert curve[-1] == pytest.approx(perfect, rel=1e-6)
