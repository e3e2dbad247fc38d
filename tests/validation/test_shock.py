"""Shock physics against the LR paper §4.3 (numbers and measurement rules in docs/shock.md).

The nickel bar of inputs/nickel_shock.yaml, shortened to 20 x 0.75 mm (3 cells high; the
rows stay identical between roller walls), B2CPDI, XPIC(5), A1 = 0.4, A2 = 4.0, G = 0:
- the shock speed and plateau pressure lie on the linear Us-up Hugoniot within 1% for piston
  speeds of 0.1-0.4 C0;
- kinetic + internal energy follows the piston's work;
- split into two materials bonded by a perfect interface, multimaterial XPIC(5) reproduces the
  single-material particle stresses; without its contact term ("uncorrected XPIC") the
  stresses behind the interface ring (paper Fig. 7).
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

from mpmsim.deck.overrides import with_overrides
from mpmsim.scene import build_scene
from mpmsim.shock import columns, hugoniot, measure_front, run_with_profiles, shock_speed
from mpmsim.solver import Simulation

from ..conftest import ROOT, deck_from
from .helpers import example

K, RHO0, S1 = 188000.0, 0.00887, 1.44  # MPa, g/mm^3: the decks' nickel
C0 = np.sqrt(K / RHO0)  # 4603.8 mm/ms
LENGTH, HEIGHT = 20.0, 0.75  # mm
SPACING = 0.125  # particle spacing (0.25 mm cells, 2 per direction)
PISTON_MARGIN = 2.0  # mm of x0 kept out of the plateau window beside the piston


def bar(length=LENGTH, up=0.4 * C0, end=None, split=False, **over):
    """The shortened deck: single material, or split at mid-length (perfect interface)."""
    if split:
        deck = with_overrides(example("nickel_shock_split"), {
            "bodies.0.max": [length / 2, HEIGHT], "bodies.1.min": [length / 2, 0.0],
            "bodies.1.max": [length, HEIGHT], "bodies.2.min": [length, 0.0], "bodies.2.max": [length + 0.5, HEIGHT]})
    else:
        deck = with_overrides(example("nickel_shock"), {
            "bodies.0.max": [length, HEIGHT], "bodies.1.min": [length, 0.0], "bodies.1.max": [length + 0.5, HEIGHT]})
    Us, _, _ = hugoniot(K, RHO0, S1, up)
    end = end if end is not None else 0.7 * length / Us  # the front 70% down the bar
    return with_overrides(deck, {"materials.piston.velocity": [-up, 0.0], "time.end": end, **over})


def run(deck, snapshot_times=()):
    """Run a deck; column profiles of pressure at the given times (first step at or past each)."""
    sim = Simulation(build_scene(deck_from(deck, ROOT / "inputs")))
    return sim, run_with_profiles(sim, snapshot_times, SPACING)


# ------------------------------------------------------------------------------- Hugoniot
@pytest.mark.parametrize("fraction", [0.1, 0.2, 0.3, 0.4])
def test_shock_speed_and_pressure_follow_the_linear_hugoniot(fraction):
    """Plateau: mean column pressure from 3 front widths behind the front to 2 mm before the
    piston, at the end. Front: where the column pressure crosses half that plateau, fitted
    by a line over 7 times from 40% to 100% of the run. Both within 1% of Us = C0 + S1 up,
    P = rho0 Us up (measured: Us +0.21..+0.31%, P -0.57..-0.72%, docs/shock.md)."""
    up = fraction * C0
    Us, P, _ = hugoniot(K, RHO0, S1, up)
    deck = bar(up=up)
    end = deck["time"]["end"]
    sim, snaps = run(deck, end * np.arange(4, 11) / 10)
    assert len(snaps) == 7
    last = measure_front(snaps[-1][1], LENGTH, PISTON_MARGIN)
    us, _ = shock_speed([t for t, _ in snaps], [prof for _, prof in snaps], last.plateau)
    assert last.window[1] - last.window[0] > 4.0  # mm: the mean spans the post-shock ringing
    assert us == pytest.approx(Us, rel=0.01)
    assert last.plateau == pytest.approx(P, rel=0.01)
    # the material behind the front moves with the piston
    v = sim.state.particles.v[:, 0]
    behind = sim.state.particles.x0[:, 0] > last.window[0]
    assert np.mean(v[behind]) == pytest.approx(-up, rel=0.01)


# ------------------------------------------------------------------------------- energy
def energy_balance(cell_size):
    deck = bar(**{"grid.cell_size": cell_size, "output.history_interval": 2.5e-5})
    sim, _ = run(deck)
    h = sim.recorder
    t = h.column("time")
    total = h.column("kinetic_energy") + h.column("internal_energy") + h.column("strain_energy")
    work = h.column("external_work")
    return t, total, work, h.column("px")


def test_energy_follows_the_piston_work():
    """Kinetic + internal energy against the piston's work (reaction x piston velocity, the
    reaction including what the velocity condition takes in XPIC's filter increments).

    - Momentum: the particles' momentum is the piston's impulse (work / up) to round-off; it
      was 1% short before the filter's share of the reaction was counted.
    - From t = 0 the balance is within 1% on this 20 mm bar at 0.125 mm cells (measured
      -0.49%; the full 50 mm deck at 0.25 mm: -0.34%, docs/shock.md).
    - Once the shock has formed (from 20% of the run) the energy gained equals the work within
      1% (measured +0.10%). Before that the impulsive start loses a fixed amount: the piston
      grips the nodes it touches, so the bar mass within about a cell of it jumps to 1840 m/s
      in one step, an inelastic collision. That loss is O(h): it halves with the cell size
      (measured ratio 2.04); at 0.25 mm it is 1.1% of the work on this short bar."""
    up = 0.4 * C0
    t, total, work, px = energy_balance(0.25)
    assert -px[-1] == pytest.approx(work[-1] / up, rel=1e-9)
    i = np.searchsorted(t, 0.2 * t[-1])
    gained, done = total[-1] - total[i], work[-1] - work[i]
    assert done > 0.5 * work[-1]
    assert abs(gained - done) / done < 0.01
    t2, total2, work2, px2 = energy_balance(0.125)
    assert -px2[-1] == pytest.approx(work2[-1] / up, rel=1e-9)
    assert abs(total2[-1] - work2[-1]) / work2[-1] < 0.01
    # the start-up loss, measured at the same early time on the grid and the grid halved
    t_early = 0.3e-3
    loss = np.interp(t_early, t, work - total)
    loss2 = np.interp(t_early, t2, work2 - total2)
    assert loss > 0.0 and loss2 > 0.0
    assert 1.7 < loss / loss2 < 2.3


# ------------------------------------------------------------------------------- Fig. 7
def axial_stress_by_x0(deck):
    sim, _ = run(deck)
    P = sim.state.particles
    order = np.lexsort((P.x0[:, 1], P.x0[:, 0]))
    return P.x0[order], P.stress[order, 0], P.pressure[order]


@functools.cache
def fig7_deviations() -> tuple[float, float, bool, int]:
    """Just after the front has crossed the interface (x0 = 10 mm; front near x0 = 8.8 mm): max
    |split - single| particle axial stress, as fractions of the plateau, with and without the
    XPIC contact term, over the window from the front's 90% crossing to 3 mm behind the
    interface; whether the front has passed the interface; particles in the window. Shared
    with the stability suite."""
    end = 1.7e-3
    x0, smm, p = axial_stress_by_x0(bar(end=end))
    x0_mm, mm, _ = axial_stress_by_x0(bar(end=end, split=True))
    x0_un, un, _ = axial_stress_by_x0(bar(end=end, split=True, **{"contact.xpic_contact_term": False}))
    np.testing.assert_array_equal(x0, x0_mm)
    np.testing.assert_array_equal(x0, x0_un)
    front = measure_front(columns(x0, x0, p, SPACING), LENGTH, PISTON_MARGIN)
    interface = LENGTH / 2
    lo = front.x0 + 0.5 * front.width  # the 90% side of the front
    window = (x0[:, 0] > lo) & (x0[:, 0] < interface + 3.0)
    return (float(np.abs(mm - smm)[window].max() / front.plateau), float(np.abs(un - smm)[window].max() / front.plateau),
            bool(front.x0 < interface - 0.5), int(window.sum()))


def test_perfect_interface_matches_single_material_and_uncorrected_xpic_rings():
    """With the contact term, multimaterial XPIC(5) differs from the single-material bar by at
    most 2% of the plateau (measured: round-off, 4e-9 MPa). Without it the particles there
    ring at least 5x more (measured 2.2% of the plateau)."""
    corrected, uncorrected, passed, n = fig7_deviations()
    assert passed and n > 100
    assert corrected <= 0.02
    assert uncorrected >= 5.0 * corrected
    assert uncorrected > 0.005  # a visible ring, not round-off


# ------------------------------------------------------------- elastic precursor, with J2
def two_wave_state(Kb: float, G: float, gamma0: float, s1: float, rho0: float, Y: float, u2: float) -> dict:
    """The elastic-plastic two-wave solution of a piston driving uniaxial strain at u2 into a
    J2 (perfectly plastic, yield Y) Mie-Grüneisen solid at rest, in the model's own terms:

    - precursor: uniaxial strain up to yield, J |s_xx - s_yy| = 2G |ln J| = Y, so eta1 =
      1 - exp(-Y / (2G)); its pressure p(eta1, U1) with U1 from the model's energy rule
      (trapezoidal p d eta / rho0) along the elastic path; sigma1 = p + (2/3) Y / J1; u1 from the
      wave's jump conditions, sigma1 = rho0 c u1 and eta1 = u1 / c;
    - plastic shock from (sigma1, u1, eta1) to u2: Lagrangian speed U = (u2 - u1) / (eta2 - eta1),
      sigma2 = sigma1 + rho0 U (u2 - u1) on the Rayleigh line, and on the equation of state
      sigma2 = p_c(eta2) + rho0 gamma0 U2 + (2/3) Y / J2 with U2 - U1 the Rayleigh line's work
      less the deviatoric work (2/3) Y / J (eta2 - eta1) (the model's U takes the pressure's
      and the artificial viscosity's work only); eta2 solved by bisection.
    Compressive stresses positive."""
    from scipy.optimize import brentq

    def p_cold(eta):
        return Kb * eta * (1 - 0.5 * gamma0 * eta) / (1 - s1 * eta) ** 2 if eta > 0 else Kb * eta

    eta1 = 1.0 - np.exp(-Y / (2.0 * G))
    U1 = p = 0.0
    for k in range(1, 2001):  # the elastic path in 2000 increments, by the model's energy rule
        dJ = -eta1 / 2000
        pc = p_cold(eta1 * k / 2000)
        U1 = (U1 - 0.5 * (p + pc) * dJ / rho0) / (1.0 + 0.5 * gamma0 * dJ)
        p = pc + rho0 * gamma0 * U1
    sigma1 = p + 2.0 / 3.0 * Y / (1.0 - eta1)
    u1 = np.sqrt(sigma1 * eta1 / rho0)

    def rayleigh_minus_eos(eta2):
        speed = (u2 - u1) / (eta2 - eta1)
        sigma2 = sigma1 + rho0 * speed * (u2 - u1)
        jbar = 1.0 - 0.5 * (eta1 + eta2)
        U2 = U1 + (0.5 * (sigma1 + sigma2) - 2.0 / 3.0 * Y / jbar) * (eta2 - eta1) / rho0
        return sigma2 - (p_cold(eta2) + rho0 * gamma0 * U2 + 2.0 / 3.0 * Y / (1.0 - eta2)), sigma2, speed

    eta2 = brentq(lambda e: rayleigh_minus_eos(e)[0], eta1 + 1e-9, 0.5 / s1)
    _, sigma2, speed = rayleigh_minus_eos(eta2)
    return {"sigma1": sigma1, "u1": u1, "eta1": eta1, "sigma2": sigma2, "eta2": eta2, "U_plastic": speed,
            "c_elastic": np.sqrt((Kb + 4.0 * G / 3.0) / rho0)}


@pytest.mark.validation
@pytest.mark.plasticity
def test_j2_with_mie_gruneisen_gives_the_elastic_precursor_and_the_plastic_hugoniot_state(measure):
    """Nickel (Mie-Grüneisen K, gamma0, S1 of the decks) with G = 76 GPa and a yield stress of
    1 GPa (j2_plasticity with eos: mie_gruneisen), a 100 mm bar driven at 100 m/s for 15 us
    (B2CPDI, XPIC(5), A1 = 0.4, A2 = 4): the elastic precursor runs ahead at c_L and its plateau
    is the Hugoniot elastic limit Y (1 - nu)/(1 - 2 nu) within 2% (measured +1.4%: the equation
    of state stiffens over the elastic strain) and the model's own yield point (two_wave_state)
    within 0.5% (+0.1%); behind the plastic wave the axial stress is two_wave_state's sigma2
    within 1% (-0.2%)."""
    from ..unit.test_plasticity import NI, nickel_j2

    Y, u2, length, end = 1000.0, 100.0, 100.0, 0.015
    deck = with_overrides(example("nickel_shock"), {
        "bodies.0.max": [length, HEIGHT], "bodies.1.min": [length, 0.0], "bodies.1.max": [length + 0.5, HEIGHT],
        "materials.piston.velocity": [-u2, 0.0], "time.end": end, "materials.nickel": nickel_j2(Y)})
    sim = Simulation(build_scene(deck_from(deck, ROOT / "inputs")), threads=1)
    sim.run()
    P = sim.state.particles
    col = np.floor(P.x0[:, 0] / SPACING).astype(np.int64)
    x0 = np.bincount(col, weights=P.x0[:, 0]) / np.bincount(col)
    sxx = -np.bincount(col, weights=P.stress[:, 0]) / np.bincount(col)  # compression positive
    w = two_wave_state(NI["K"], NI["G"], NI["gamma0"], NI["S1"], NI["density"], Y, u2)
    elastic_front, plastic_front = length - w["c_elastic"] * end, length - w["U_plastic"] * end
    assert plastic_front - elastic_front > 12.0  # mm: the two waves apart
    precursor = sxx[(x0 > elastic_front + 3.5) & (x0 < plastic_front - 7.0)]
    plastic = sxx[(x0 > plastic_front + 6.0) & (x0 < length - 2.0)]
    assert len(precursor) >= 20 and len(plastic) >= 400
    nu = (3 * NI["K"] - 2 * NI["G"]) / (2 * (3 * NI["K"] + NI["G"]))
    measure("nickel J2 + Mie-Grueneisen: precursor, plastic state", f"{precursor.mean():.1f}, {plastic.mean():.1f} MPa",
            f"HEL {Y * (1 - nu) / (1 - 2 * nu):.1f} (2%), sigma1 {w['sigma1']:.1f} (0.5%), sigma2 {w['sigma2']:.1f} (1%)")
    assert precursor.mean() == pytest.approx(Y * (1 - nu) / (1 - 2 * nu), rel=0.02)
    assert precursor.mean() == pytest.approx(w["sigma1"], rel=0.005)
    assert precursor.max() - precursor.min() < 0.01 * w["sigma1"]  # a plateau, not a ramp
    assert plastic.mean() == pytest.approx(w["sigma2"], rel=0.01)
    # ahead of the precursor the bar is at rest
    assert np.abs(sxx[x0 < elastic_front - 8.0]).max() < 0.02 * w["sigma1"]
