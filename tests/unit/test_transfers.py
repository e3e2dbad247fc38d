"""Particle-grid transfers: conservation in P2G, exactness of G2P for affine fields, and the
slab ordering that keeps parallel scatters race-free."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.gridops import ActiveBox
from mpmsim.shapes import ShapeData, shape_function
from mpmsim.tasks.extrapolate import p2g_momentum

from .test_shapes import ALL, grid, node_positions


def scatter(g, name, x, mass, vel, threads):
    dim = g.dim
    sf = shape_function(name)
    sd = ShapeData.empty(len(x), sf.nodes_per_particle(dim), dim)
    box = ActiveBox(g.shape)
    (lo, hi), bad = sf.compute(x, None, 0.25 * g.h, g, 4, sd)
    assert bad[0] < 0
    box.update([(lo, hi)], sd.lowest, sf.span, threads)
    gm = np.zeros(g.n_nodes)
    gp = np.zeros((g.n_nodes, dim))
    C = np.zeros((1, dim, dim))
    p2g_momentum(box.scatter(sd.nodes, sd.S), mass, vel, True, gm, gp, False, C, sd.lowest,
                 np.zeros((1, 3), dtype=np.int64), g.view, x)
    return g, sd, box, gm, gp


@pytest.mark.parametrize("name,dim", ALL)
@pytest.mark.parametrize("threads", [1, 2])
def test_p2g_conserves_mass_and_momentum(name, dim, threads):
    rng = np.random.default_rng(7)
    g = grid(dim)
    x = g.domain_lo + 0.1 + rng.random((300, dim)) * (g.domain_hi - g.domain_lo - 0.2)
    mass = rng.random(300) + 0.5
    vel = rng.normal(size=(300, dim))
    g, sd, box, gm, gp = scatter(g, name, x, mass, vel, threads)
    assert gm.sum() == pytest.approx(mass.sum(), rel=1e-13)
    np.testing.assert_allclose(gp.sum(axis=0), (mass[:, None] * vel).sum(axis=0), rtol=1e-12, atol=1e-12)
    # G2P of the lumped grid velocity of an affine particle field returns it exactly
    A = rng.normal(size=(dim, dim))
    b = rng.normal(size=dim)
    affine = x @ A.T + b
    g, sd, box, gm, gp = scatter(g, name, x, mass, affine, threads)
    xi = node_positions(g, sd.nodes)
    nodal_affine = xi @ A.T + b  # an affine nodal field maps to particles exactly
    np.testing.assert_allclose(np.einsum("pk,pkd->pd", sd.S, nodal_affine), affine, atol=1e-11)


@pytest.mark.parametrize("name", ["gimp", "bspline3", "b2cpdi"])
def test_slabs_never_share_nodes_within_a_colour(name):
    """Slabs two apart touch disjoint nodes, so each colour can scatter in parallel."""
    rng = np.random.default_rng(3)
    g = grid(2, cells=20)
    x = g.domain_lo + rng.random((2000, 2)) * (g.domain_hi - g.domain_lo)
    g, sd, box, gm, gp = scatter(g, name, x, np.ones(2000), np.zeros((2000, 2)), threads=2)
    nslab = len(box.ptr) - 1
    assert nslab >= 4
    touched = []
    for s in range(nslab):
        parts = box.order[box.ptr[s]: box.ptr[s + 1]]
        touched.append(set(sd.nodes[parts][sd.S[parts] > 0].ravel()))
    for s in range(nslab - 2):
        for t in range(s + 2, nslab, 2):
            assert not touched[s] & touched[t]
    assert sorted(box.order) == list(range(2000))
