"""Mie–Grüneisen EOS (Eq. 51), its energy update and artificial viscosity (Eq. 52)."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from mpmsim.deck.overrides import with_overrides
from mpmsim.errors import InstabilityError
from mpmsim.materials.kernels import EOS_DEN, EOS_J0, EOS_N, EOS_P, EOS_Q, EOS_RHO0, EOS_U
from mpmsim.materials.mie_gruneisen import mie_gruneisen_stress
from mpmsim.materials.neo_hookean import neo_hookean_stress
from mpmsim.output.vtu import MAIN_PART, part_meshes
from mpmsim.shock import hugoniot

from ..conftest import ROOT, simulate

K, G0, S1, RHO0 = 188000.0, 2.0, 1.44, 0.00887


def increment(J, J0=1.0, U0=0.0, p0=0.0, q=0.0, G=0.0):
    """One update of a uniaxially compressed particle from J0 to J; returns (stress, eos, modulus)."""
    eos = np.zeros(EOS_N)
    eos[EOS_U], eos[EOS_P], eos[EOS_Q], eos[EOS_J0], eos[EOS_RHO0] = U0, p0, q, J0, RHO0
    s = np.zeros(6)
    modulus = mie_gruneisen_stress(K, G, G0, S1, np.diag([J, 1.0, 1.0]), s, eos)
    return s, eos, modulus


@pytest.mark.parametrize("fraction", [0.1, 0.4, 0.8])
def test_one_jump_from_rest_lands_on_the_linear_hugoniot(fraction):
    """The trapezoidal energy update is the Rankine–Hugoniot energy jump, so a single increment
    from rest to the Hugoniot compression gives exactly P = rho0 Us up and U = up^2/2."""
    up = fraction * np.sqrt(K / RHO0)
    Us, P, eta = hugoniot(K, RHO0, S1, up)
    s, eos, _ = increment(1.0 - eta)
    assert eos[EOS_P] == pytest.approx(P, rel=1e-12)
    assert eos[EOS_U] == pytest.approx(0.5 * up**2, rel=1e-12)
    np.testing.assert_allclose(s[:3], -P, rtol=1e-12)  # G = 0: hydrostatic
    assert eos[EOS_DEN] == pytest.approx(1.0 - S1 * eta)


def test_energy_update_is_the_trapezoidal_pressure_work_and_q_is_dissipated():
    """U - U0 = -((p0 + p)/2 + q)(J - J0)/rho0 with p evaluated at the new U."""
    _, e1, _ = increment(0.9)
    _, e2, _ = increment(0.85, J0=0.9, U0=e1[EOS_U], p0=e1[EOS_P], q=5000.0)
    work = -(0.5 * (e1[EOS_P] + e2[EOS_P]) + 5000.0) * (0.85 - 0.9) / RHO0
    assert e2[EOS_U] - e1[EOS_U] == pytest.approx(work, rel=1e-12)


def test_wave_modulus_is_the_isentropic_tangent():
    """J dp/deta along a path of small increments (dU = p deta / rho0) matches the modulus."""
    _, e1, modulus = increment(0.8)
    eps = 1e-7
    _, e2, _ = increment(0.8 - eps, J0=0.8, U0=e1[EOS_U], p0=e1[EOS_P])
    assert modulus == pytest.approx(0.8 * (e2[EOS_P] - e1[EOS_P]) / eps, rel=1e-5)


def test_tension_is_linear_and_shear_is_the_neo_hookean_deviator():
    s, eos, _ = increment(1.05, U0=100.0, p0=0.0)
    assert eos[EOS_P] == pytest.approx(K * (1 - 1.05) + RHO0 * G0 * eos[EOS_U])
    F = np.array([[0.8, 0.1, 0.0], [0.0, 0.95, 0.0], [0.0, 0.0, 1.0]])
    eos = np.zeros(EOS_N)
    eos[EOS_J0], eos[EOS_RHO0] = 1.0, RHO0
    s = np.zeros(6)
    mie_gruneisen_stress(K, 76000.0, G0, S1, F, s, eos)
    dev = np.zeros(6)
    neo_hookean_stress(0.0, 76000.0, F, dev)
    np.testing.assert_allclose(s[3:], dev[3:])
    np.testing.assert_allclose(s[:3] + eos[EOS_P], dev[:3])


def shock_deck(**over):
    deck = yaml.safe_load((ROOT / "inputs" / "nickel_shock.yaml").read_text())
    return with_overrides(deck, {"bodies.0.max": [4.0, 0.5], "bodies.1.min": [4.0, 0.0],
                                 "bodies.1.max": [4.5, 0.5], "time.end": 2e-4, **over})


def test_compression_past_one_over_s1_stops_the_run_with_a_clear_message():
    deck = shock_deck(**{"materials.nickel.S1": 20.0, "materials.piston.velocity": [-9000.0, 0.0]})
    with pytest.raises(InstabilityError, match=r"1 - S1 eta = .*Eq. \(51\)"):
        simulate(deck, ROOT / "inputs")


def test_only_scenes_with_internal_energy_pay_for_it():
    """Particles of a plain elastic scene keep one-element placeholders and no history column;
    artificial viscosity on an elastic (neo-Hookean) bar dissipates into U, never below 0."""
    plain = simulate(with_overrides(yaml.safe_load((ROOT / "inputs" / "bar_vibration.yaml").read_text()),
                                    {"time.end": 0.01}), ROOT / "inputs")
    assert plain.state.particles.U.shape == (1,)
    assert "internal_energy" not in plain.recorder.names
    deck = shock_deck(**{"materials.nickel": {"type": "neo_hookean", "K": 188000.0, "G": 0.0, "density": 0.00887},
                         "materials.piston.velocity": [-200.0, 0.0]})
    sim = simulate(deck, ROOT / "inputs")
    U = sim.state.particles.U
    assert U.shape == (sim.state.particles.n,) and U.max() > 0.0 and U.min() >= 0.0
    h = sim.recorder
    total = h.column("kinetic_energy") + h.column("strain_energy") + h.column("internal_energy")
    assert h.column("internal_energy")[-1] > 0.01 * total[-1]  # the viscosity did dissipate


def test_vtu_and_history_carry_internal_energy_and_pressure():
    sim = simulate(shock_deck(**{"time.end": 5e-5}), ROOT / "inputs")
    P = sim.state.particles
    mesh = part_meshes(sim.state)[MAIN_PART]
    np.testing.assert_array_equal(mesh.point_data["internal_energy"][: P.n], P.U)
    np.testing.assert_array_equal(mesh.point_data["pressure"][: P.n], P.pressure)
    assert P.pressure.max() > 1000.0  # MPa: the shock has entered
    assert sim.recorder.column("internal_energy")[-1] == pytest.approx(float((P.mass * P.U).sum()))
