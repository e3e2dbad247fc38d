"""A material model defined here, in the test's own file, runs through a deck with no edit of
mpmsim: its module registers a MaterialModel (mpmsim/materials/model.py), the deck accepts its
`type`, and the explicit step compiles its stress update into the stress kernel."""

from __future__ import annotations

from typing import Literal

import numpy as np
import pytest
from numba import njit
from pydantic import Field

from mpmsim.contact.grid.laws import register_law
from mpmsim.deck.overrides import with_overrides
from mpmsim.errors import DeckError
from mpmsim.materials import NPROP, MaterialModel, register
from mpmsim.materials.kernels import rotate_stress
from mpmsim.scene import build_scene
from mpmsim.schema_base import Strict
from mpmsim.solver import Simulation

from ..conftest import deck_from

pytestmark = pytest.mark.architecture


class ToyHooke(Strict):
    """Isotropic Hooke solid."""

    type: Literal["toy_hooke"]
    E: float = Field(gt=0)
    nu: float = Field(gt=-1.0, lt=0.5)
    density: float = Field(gt=0)


def toy_row(m) -> np.ndarray:
    """[lambda, mu, E, nu]"""
    out = np.zeros(NPROP)
    out[:4] = (m.E * m.nu / ((1 + m.nu) * (1 - 2 * m.nu)), m.E / (2 * (1 + m.nu)), m.E, m.nu)
    return out


@njit(cache=True, inline="always")
def toy_stress(pr, L, dt, F3, J, f00, f01, f10, f11, s, W, A, Ai, Q, eos, hs):
    """Hughes-Winget rotation, then sigma += lam tr(de) I + 2 mu de (de = sym(L) dt)."""
    lam, mu = pr[0], pr[1]
    rotate_stress(L, dt, s, W, A, Ai, Q)
    tr = (L[0, 0] + L[1, 1] + L[2, 2]) * dt
    for a in range(3):
        s[a] += lam * tr + 2.0 * mu * L[a, a] * dt
    s[3] += mu * (L[0, 1] + L[1, 0]) * dt
    s[4] += mu * (L[1, 2] + L[2, 1]) * dt
    s[5] += mu * (L[0, 2] + L[2, 0]) * dt
    return lam + 2.0 * mu


@njit(cache=True, inline="always")
def toy_energy(pr, F3, s, J):
    """Complementary energy 1/2 sigma : C^-1 : sigma."""
    mu, E, nu = pr[1], pr[2], pr[3]
    normal = s[0] ** 2 + s[1] ** 2 + s[2] ** 2 - 2.0 * nu * (s[0] * s[1] + s[1] * s[2] + s[0] * s[2])
    return 0.5 * normal / E + 0.5 * (s[3] ** 2 + s[4] ** 2 + s[5] ** 2) / mu


@njit(cache=True, inline="always")
def toy_bulk(pr, J, p):
    return pr[0] + 2.0 / 3.0 * pr[1]


TOY = register(MaterialModel("toy_hooke", ToyHooke, toy_row, wave_modulus=lambda r: r[0] + 2.0 * r[1],
                             energy=toy_energy, bulk_modulus=toy_bulk, stress_2d=toy_stress, stress_3d=toy_stress))

E, NU = 200.0, 0.3
BLOCKS = {
    "title": "a block striking a block", "units": "mm-g-ms",
    "grid": {"cell_size": 1.0},
    "materials": {"a": {"type": "linear_elastic", "E": E, "nu": NU, "density": 0.001},
                  "b": {"type": "neo_hookean", "K": 100.0, "G": 40.0, "density": 0.001}},
    "bodies": [{"shape": "rectangle", "min": [0, 0], "max": [4, 3], "material": "a", "velocity": [0.0, 0.5]},
               {"shape": "rectangle", "min": [0, 3], "max": [4, 6], "material": "b"}],
    "time": {"end": 0.05},
}


def run(data: dict, steps: int = 30):
    sim = Simulation(build_scene(deck_from(data)), threads=1)
    for _ in range(steps):
        sim.step()
        sim.recorder.record(sim.state)
    return sim


def test_a_material_model_of_ones_own_runs_through_a_deck():
    """The toy model is linear elasticity written here: a deck with it gives the built-in
    model's results to the last bit (stress, positions, history), and it is compiled into the
    stress kernel as the built-in one is (the toy's code, not the built-in's, runs: a toy with
    twice the modulus differs)."""
    toy = with_overrides(BLOCKS, {"materials.a": {"type": "toy_hooke", "E": E, "nu": NU, "density": 0.001}})
    ref, got = run(BLOCKS), run(toy)
    assert got.state.materials.type_code[0] == TOY.code >= 16
    for k in ("stress", "x", "v", "F"):
        assert np.array_equal(getattr(got.state.particles, k), getattr(ref.state.particles, k)), k
    assert np.array_equal(np.array(got.recorder.rows)[:, 4:], np.array(ref.recorder.rows)[:, 4:])
    stiffer = with_overrides(toy, {"materials.a.E": 2 * E})
    assert not np.array_equal(run(stiffer).state.particles.stress, ref.state.particles.stress)


def test_the_deck_names_the_registered_models_and_checks_the_toys_keys():
    bad = with_overrides(BLOCKS, {"materials.a": {"type": "toy_hooke", "E": E, "density": 0.001}})
    with pytest.raises(DeckError, match="nu"):
        build_scene(deck_from(bad))
    unknown = with_overrides(BLOCKS, {"materials.a": {"type": "toy_hook", "E": E, "density": 0.001}})
    with pytest.raises(DeckError, match="toy_hooke"):
        build_scene(deck_from(unknown))
    from mpmsim.deck.reference import render

    assert "toy_hooke" not in render()  # the reference documents mpmsim's own models


# --------------------------------------------------------------------------- a contact law
@njit(cache=True, inline="always")
def toy_frictionless(mu, mu_static, dp, n, dotn, dim, out):
    """Frictionless contact written here: the normal part of the stick impulse."""
    for d in range(dim):
        out[d] = dotn * n[d]
    return True


@njit(cache=True, inline="always")
def toy_sticky(mu, mu_static, dp, n, dotn, dim, out):
    """In contact, the whole stick impulse (no slip), whatever mu."""
    for d in range(dim):
        out[d] = dp[d]
    return True


TOY_LAWS = [register_law("toy_frictionless", toy_frictionless), register_law("toy_sticky", toy_sticky)]
SLIDE = {
    "title": "a block sliding into a block", "units": "mm-g-ms",
    "grid": {"cell_size": 1.0},
    "materials": {"a": {"type": "neo_hookean", "K": 100.0, "G": 40.0, "density": 0.001},
                  "b": {"type": "neo_hookean", "K": 100.0, "G": 40.0, "density": 0.001}},
    "bodies": [{"shape": "rectangle", "min": [0, 0], "max": [6, 3], "material": "a", "velocity": [0.0, 0.0]},
               {"shape": "rectangle", "min": [1, 3], "max": [5, 5], "material": "b", "velocity": [0.4, -0.2]}],
    "contact": {"default": {"law": "frictionless"}},
    "time": {"end": 0.05},
    "update": {"stress": "usavg"},
    "stability": {"energy_tolerance": 1.0},  # (the impact's energy drift is not what this tests)
}


@pytest.mark.parametrize("update", [{}, {"update": {"scheme": "xpic", "order": 3, "stress": "usavg"}}],
                         ids=["flip", "xpic3"])
def test_a_contact_law_of_ones_own_runs_through_a_deck(update):
    """A frictionless law written here gives the built-in frictionless results to the last bit
    (passes 1-3 and XPIC's increments run it); a sticky toy law is compiled in too: the top
    block's sliding is stopped where the frictionless one keeps it."""
    base = with_overrides(SLIDE, update)
    ref = run(base, 40)
    toy = run(with_overrides(base, {"contact.default": {"law": "toy_frictionless"}}), 40)
    assert toy.scene.contact.grid.plugin_laws == (TOY_LAWS[0].code,)
    for k in ("x", "v", "stress"):
        assert np.array_equal(getattr(toy.state.particles, k), getattr(ref.state.particles, k)), k
    sticky = run(with_overrides(base, {"contact.default": {"law": "toy_sticky"}}), 40)
    top = ref.state.particles.mat == 1
    vx_ref, vx_sticky = ref.state.particles.v[top, 0].mean(), sticky.state.particles.v[top, 0].mean()
    assert vx_sticky < 0.9 * vx_ref


def test_an_unknown_law_names_the_registered_ones():
    bad = with_overrides(SLIDE, {"contact.default": {"law": "toy_slippery"}})
    with pytest.raises(DeckError, match="toy_sticky"):
        build_scene(deck_from(bad))
