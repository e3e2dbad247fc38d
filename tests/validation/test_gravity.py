"""Free fall: the midpoint position updates reproduce x0 + v0 t + g t^2 / 2 exactly, the
updated-velocity positions (a leapfrog started from V(0)) x0 + v0 t + g t^2 / 2 + g t dt / 2
exactly, and the energy balance counts gravity's work (no false instability stop)."""

from __future__ import annotations

import numpy as np
import pytest

from ..conftest import simulate


@pytest.mark.parametrize("position", ["updated", "midpoint"])
@pytest.mark.parametrize("scheme", ["flip", "pic"])
@pytest.mark.parametrize("dim", [2, 3])
def test_free_fall_is_exact(scheme, dim, position):
    g = [0.0, -9.81e-3] + [0.0] * (dim - 2)  # mm/ms^2
    v0 = [0.5, 2.0] + [0.0] * (dim - 2)
    body = {"shape": "rectangle", "min": [10, 40], "max": [14, 44], "material": "m", "velocity": v0}
    if dim == 3:
        body = {"shape": "box", "min": [10, 40, 0], "max": [14, 44, 4], "material": "m", "velocity": v0}
    deck = {"title": "free fall", "units": "mm-g-ms", "analysis": "3d" if dim == 3 else "plane_strain",
            "grid": {"cell_size": 1.0, "domain": {"min": [0, 0] + [0] * (dim - 2), "max": [30, 60] + [4] * (dim - 2)}},
            "materials": {"m": {"type": "neo_hookean", "K": 100.0, "G": 40.0, "density": 0.001}},
            "bodies": [body], "gravity": g, "time": {"end": 2.0, "dt": 0.001},  # CFL 0.4
            "update": {"scheme": scheme, "position": position}}
    sim = simulate(deck)
    P, t = sim.state.particles, sim.state.t
    lag = 0.5 * 0.001 * t if position == "updated" else 0.0  # leapfrog: dt/2 of velocity ahead
    expected = P.x0 + np.array(v0) * t + 0.5 * np.array(g) * t * t + np.array(g) * lag
    np.testing.assert_allclose(P.x, expected, atol=1e-9)
    np.testing.assert_allclose(P.v, np.broadcast_to(np.array(v0) + np.array(g) * t, P.v.shape), atol=1e-11)
    # gravity's work equals the kinetic energy gained
    ke = 0.5 * np.sum(P.mass[:, None] * P.v**2)
    assert sim.state.energy0 + sim.state.work_in == pytest.approx(ke, rel=1e-9)
    assert np.abs(P.stress).max() < 1e-9  # a rigid-body motion strains nothing
