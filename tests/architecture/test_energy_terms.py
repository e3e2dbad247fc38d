"""The implicit step composes energy terms (mpmsim/energy.py): a term written here, in the test's
own file, plugs into the Newton solve with no edit of mpmsim. A copy of gravity as an outside
term, on a deck without gravity, gives the built-in gravity's run to the last bit (the block
falls onto the slab: barrier contact, CCD and the line search all take part); without it the
block does not accelerate."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from mpmsim.deck.overrides import with_overrides
from mpmsim.energy import NONE, Potential
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation

from ..conftest import ROOT, deck_from

pytestmark = [pytest.mark.architecture, pytest.mark.implicit]

DECK = yaml.safe_load((ROOT / "inputs" / "implicit_blocks_2d.yaml").read_text())
G = np.array([0.0, -9.81])
STEPS = 15  # the block (3 m/s down, 0.1 m above the slab) is in contact from about step 3


class Weight(Potential):
    """-sum_i m_i g . y_i for a field g of the test's own."""

    name = "weight"

    def __init__(self, g):
        self.g = g
        self.w = None

    def begin(self, step):
        self.w = step.mass[:, None] * self.g[None, :]

    def value(self, y):
        return -float(np.sum(self.w * y))

    def derivatives(self, y, force):
        force += self.w
        return NONE


def run(data, terms=()):
    sim = Simulation(build_scene(deck_from(data, ROOT / "inputs")), out_dir=None, threads=1)
    for term in terms:
        sim.integrator.add_term(term)
    for _ in range(STEPS):
        sim.step()
    return sim


def test_an_energy_term_from_outside_runs_in_the_newton_solve():
    built_in = run(DECK)
    weightless = with_overrides(DECK, {"gravity": [0.0, 0.0]})
    outside = run(weightless, [Weight(G)])
    none = run(weightless)
    assert any(s[2] for s in built_in.integrator.stats)  # the CCD bound cut a step
    f_in, f_out = built_in.state.fem, outside.state.fem
    assert np.array_equal(f_in.x, f_out.x) and np.array_equal(f_in.v, f_out.v)
    # the term matters: without it the block's centre is higher by about g t^2 / 2 before contact
    block = f_in.node_body == 1
    assert none.state.fem.x[block, 1].mean() > f_in.x[block, 1].mean() + 1e-3
