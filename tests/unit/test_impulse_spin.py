"""History columns that close a body's momentum balance and give its spin: J_<face>_<axis> and
J_<rigid>_<axis> (impulses since t = 0), spin / spin_<body> (angular momentum about the centre
of mass)."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from mpmsim.scene import build_scene
from mpmsim.solver import Simulation

from ..conftest import deck_from

pytestmark = pytest.mark.ecosystem

# a soft block thrown down and sideways onto a fixed floor under gravity, beside a roller wall; a
# rigid platen (velocity imposed on the nodes it covers) comes down above it
FLOOR = {
    "title": "block on a floor", "units": "SI", "analysis": "plane_strain",
    "grid": {"cell_size": 0.01, "domain": {"min": [0.0, 0.0], "max": [0.4, 0.2]},
             "boundaries": {"ymin": "fixed", "xmin": "roller"}},
    "shape_function": "gimp", "particles_per_direction": 2,
    "materials": {"soft": {"type": "linear_elastic", "E": 2.0e5, "nu": 0.3, "density": 1000.0},
                  "platen": {"type": "rigid", "velocity": [0.0, -0.8]}},
    "bodies": [
        {"shape": "rectangle", "min": [0.1, 0.03], "max": [0.2, 0.09], "material": "soft", "velocity": [0.4, -1.5],
         "name": "block"},
        {"shape": "rectangle", "min": [0.12, 0.1], "max": [0.24, 0.12], "material": "platen", "name": "plate"},
    ],
    "gravity": [0.0, -9.81],
    "time": {"end": 0.04, "cfl": 0.4},
    "update": {"scheme": "flip", "stress": "usavg"},
    "output": {"history_interval": 2e-3, "vtu_interval": 1.0},  # rows far apart: J must not need every step
}


def _run(data: dict) -> Simulation:
    sim = Simulation(build_scene(deck_from(data, name="floor")), threads=1)
    sim.run()
    return sim


@pytest.mark.parametrize("scheme", ["flip", "xpic"])
def test_face_and_rigid_impulses_close_the_momentum_balance(scheme):
    """p(t) - p(0) = M g t + J_ymin + J_xmin + J_platen at every row, to round-off (measured
    1e-15 relative to the floor's impulse): the floor stops the block's fall and the platen
    holds its top back, both large parts of the balance; leaving out either, or summing
    the rows' forces instead of every step's, misses by more than 1% (checked below)."""
    data = copy.deepcopy(FLOOR)
    data["update"]["scheme"] = scheme
    sim = _run(data)
    h = sim.recorder.frame()
    mass = float(sim.state.particles.mass.sum())
    t = h["time"].to_numpy()
    for a, g in (("x", 0.0), ("y", -9.81)):
        change = h[f"p{a}"].to_numpy() - h[f"p{a}"].iloc[0]
        parts = {k: h[f"J_{k}_{a}"].to_numpy() for k in ("ymin", "xmin", "platen")}
        balance = change - mass * g * t - sum(parts.values())
        scale = float(np.abs(h["J_ymin_y"]).max())
        assert np.abs(balance).max() < 1e-10 * scale, (a, np.abs(balance).max() / scale)
    # the floor and the platen each give a part that matters (the platen's nodes meet the
    # block's from the start and hold its top back, then the floor stops it)
    assert h["J_ymin_y"].iloc[-1] > 0.5 * mass * 1.5
    assert np.abs(h["J_platen_y"]).max() > 0.3 * h["J_ymin_y"].iloc[-1]
    # the force columns sampled at the rows (every 2 ms) do not integrate to the impulse
    sampled = np.sum(h["F_ymin_y"].to_numpy()[1:] * np.diff(t))
    assert abs(sampled - h["J_ymin_y"].iloc[-1]) > 0.01 * h["J_ymin_y"].iloc[-1]


def test_spin_is_the_angular_momentum_about_the_centre_of_mass():
    """Two blocks, each spinning about its centre while it translates, no gravity, no walls,
    APIC: spin = omega sum m |x - c|^2 at t = 0 (the particles' sum) and stays so while L about
    the origin carries c x p as well; with two bodies each spin_<body> is its own, and
    L = sum_b (spin_b + c_b x p_b)."""
    data = copy.deepcopy(FLOOR)
    data["grid"].pop("boundaries")
    data["gravity"] = [0.0, 0.0]
    data["materials"]["hard"] = {"type": "linear_elastic", "E": 2.0e6, "nu": 0.3, "density": 3000.0}
    data["bodies"] = [
        {"shape": "rectangle", "min": [0.1, 0.05], "max": [0.2, 0.1], "material": "soft", "velocity": [0.5, 0.2],
         "name": "A"},
        {"shape": "rectangle", "min": [0.28, 0.06], "max": [0.34, 0.12], "material": "hard", "velocity": [0.0, -0.1],
         "name": "B"},
    ]
    data["time"]["end"] = 0.02
    data["update"]["scheme"] = "apic"  # conserves angular momentum (FLIP loses 7% of B's here)
    sim = Simulation(build_scene(deck_from(data, name="spin")), threads=1)
    P = sim.state.particles
    omega = {0: 3.0, 1: -2.0}
    expected = {}
    for b, w in omega.items():
        sel = P.body == b
        m, x = P.mass[sel], P.x[sel]
        c = (m[:, None] * x).sum(axis=0) / m.sum()
        r = x - c
        P.v[sel] += w * np.stack([-r[:, 1], r[:, 0]], axis=1)
        expected[b] = w * float(np.sum(m * (r**2).sum(axis=1)))
    sim.run()
    h = sim.recorder.frame()
    for b, name in ((0, "A"), (1, "B")):
        first = h[f"spin_{name}"].iloc[0]
        assert abs(first - expected[b]) < 1e-12 * abs(expected[b])
        # a free body's spin stays with APIC: L and p are conserved and c moves at p / M, so
        # c x p does not change (measured 1e-15 relative; c x v_c or a sign slip would be O(1))
        assert np.abs(h[f"spin_{name}"] - expected[b]).max() < 1e-10 * abs(expected[b])
        cross = h[f"cx_{name}"] * h[f"py_{name}"] - h[f"cy_{name}"] * h[f"px_{name}"]
        assert np.allclose(h[f"L_{name}"], h[f"spin_{name}"] + cross, rtol=0, atol=1e-12 * abs(expected[b]))
    total = sum(h[f"spin_{n}"] + h[f"cx_{n}"] * h[f"py_{n}"] - h[f"cy_{n}"] * h[f"px_{n}"] for n in "AB")
    assert np.allclose(h["L"], total, rtol=0, atol=1e-12 * abs(expected[0]))
    # the scene's spin is about the common centre: not the sum of the bodies' spins
    assert abs(h["spin"].iloc[0] - (expected[0] + expected[1])) > 0.01 * abs(expected[0])
