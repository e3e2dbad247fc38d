"""The time step follows the current wave speed; unstable runs stop with a clear message."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.errors import InstabilityError
from mpmsim.materials.neo_hookean import neo_hookean_stress
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation

from ..conftest import deck_from

K, G, RHO = 2450.0, 940.0, 0.001


def block(**time):
    return {"title": "block", "units": "mm-g-ms",
            "grid": {"cell_size": 1.0, "boundaries": {"xmin": "roller", "xmax": "roller",
                                                      "ymin": "roller", "ymax": "roller"}},
            "materials": {"m": {"type": "neo_hookean", "K": K, "G": G, "density": RHO}},
            "bodies": [{"shape": "rectangle", "min": [0, 0], "max": [4, 4], "material": "m"}],
            "time": {"end": 1.0, **time}}


def test_time_step_follows_the_current_wave_speed():
    """Stretch the block (F = diag(1.4, 1)): the next step's dt follows the stiffer state. The
    rule (dt_rule) is the CFL bound; the step taken is the longest no longer than it that splits
    the time left into equal steps (mpmsim.solver.step_length)."""
    sim = Simulation(build_scene(deck_from(block(cfl=0.5))))
    st = sim.state
    sim.step()
    dt0 = st.dt
    assert st.dt_rule == pytest.approx(0.5 * 1.0 / np.sqrt((K + 4 * G / 3) / RHO), rel=1e-12)
    left = sim.end / st.dt_rule  # steps the run has left at this rule
    assert st.dt_rule * (1.0 - 1.0 / left) <= dt0 <= st.dt_rule
    st.particles.F[:, 0, 0] = 1.4
    sim.step()  # the stress update sees the stretched state and reports its wave speed
    sim.step()
    F3 = np.diag([1.4, 1.0, 1.0])
    modulus = neo_hookean_stress(K, G, F3, np.zeros(6))
    c = np.sqrt(modulus * 1.4 / RHO)
    assert st.dt_rule == pytest.approx(0.5 * 1.0 / c, rel=1e-3)
    assert st.dt <= st.dt_rule and st.dt == pytest.approx(st.dt_rule, rel=1e-3)
    assert st.dt < 0.9 * dt0  # a stiffer, faster-wave state gets a shorter step


def test_fixed_dt_is_used_as_given():
    sim = Simulation(build_scene(deck_from(block(dt=1e-5))))
    sim.step()
    assert sim.state.dt == 1e-5


def test_too_large_a_step_stops_with_when_where_and_which_material():
    deck = block(dt=3.0 / np.sqrt((K + 4 * G / 3) / RHO))  # CFL 3
    deck["bodies"][0]["velocity"] = [1.0, 0.5]
    deck["grid"]["boundaries"] = {"ymin": "fixed"}
    sim = Simulation(build_scene(deck_from(deck)))
    with pytest.raises(InstabilityError) as err:
        sim.run()
    msg = str(err.value)
    assert "step " in msg and "t = " in msg and "particle " in msg and "material 'm'" in msg
    assert sim.state.step < 200


def test_flip_ringing_blow_up_is_detected_by_the_energy_check():
    """16 cells of neo-Hookean strip under a platen at CFL 0.5 (see docs/stability.md): FLIP
    ringing grows past 12% strain; the total-energy check stops it before garbage spreads."""
    c = np.sqrt((K + 4 * G / 3) / RHO)
    h, H = 1.25, 20.0
    deck = {"title": "strip", "units": "mm-g-ms",
            "grid": {"cell_size": h, "boundaries": {"xmin": "roller", "xmax": "roller", "ymin": "fixed"}},
            "materials": {"m": {"type": "neo_hookean", "K": K, "G": G, "density": RHO},
                          "platen": {"type": "rigid", "velocity": [0.0, -0.0005 * c], "constrain": ["y"]}},
            "bodies": [{"shape": "rectangle", "min": [0, 0], "max": [h, H], "material": "m"},
                       {"shape": "rectangle", "min": [0, H], "max": [h, H + h], "material": "platen"}],
            "time": {"end": 0.2 * H / (0.0005 * c), "cfl": 0.5}}
    sim = Simulation(build_scene(deck_from(deck)))
    with pytest.raises(InstabilityError, match="energy"):
        sim.run()
    strain = -sim.state.rigid.disp[0, 1] / H
    assert 0.08 < strain < 0.2
