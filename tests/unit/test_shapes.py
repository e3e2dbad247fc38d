"""Shape-function kernels: partition of unity, gradients, linear completeness, 2D and 3D."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.scene.grid import plan_grid
from mpmsim.shapes import ShapeData, shape_function


def grid(dim, h=(1.0, 0.5, 0.8), cells=6):
    h = np.array(h[:dim])
    g, problem = plan_grid(dim, h, np.zeros(dim), cells * h, [0] * (2 * dim), True, ghost=1)
    assert problem is None
    return g


def evaluate(name, dim, x, semi):
    g = grid(dim)
    sf = shape_function(name)
    sd = ShapeData.empty(len(x), sf.nodes_per_particle(dim), dim)
    lo, hi = sf.compute(x, semi, g, 3, sd)
    return g, sd, lo, hi


def node_positions(g, nodes):
    nx, ny = g.shape[0], g.shape[1]
    ijk = np.stack([nodes % nx, (nodes // nx) % ny, nodes // (nx * ny)], axis=-1)[..., : g.dim]
    return g.origin + ijk * g.h


CASES = [(name, dim) for name in ("linear", "gimp") for dim in (2, 3)]


@pytest.mark.parametrize("name,dim", CASES)
def test_partition_gradients_and_linear_completeness(name, dim):
    rng = np.random.default_rng(1)
    g = grid(dim)
    x = g.domain_lo + rng.random((200, dim)) * (g.domain_hi - g.domain_lo)
    # include particles exactly on nodes and on cell mid-lines
    x[0] = g.domain_lo + g.h
    x[1] = g.domain_lo + 1.5 * g.h
    semi = 0.25 * g.h  # 2 particles per cell edge
    g, sd, lo, hi = evaluate(name, dim, x, semi)
    xi = node_positions(g, sd.nodes)
    # partition of unity and zero-sum gradients
    np.testing.assert_allclose(sd.S.sum(axis=1), 1.0, atol=1e-13)
    np.testing.assert_allclose(sd.G.sum(axis=1), 0.0, atol=1e-12)
    # linear completeness: sum S_ip x_i = x_p; gradient consistency: sum x_i (x) G_ip = I
    np.testing.assert_allclose(np.einsum("pk,pkd->pd", sd.S, xi), x, atol=1e-12)
    grad = np.einsum("pka,pkb->pab", xi, sd.G)
    np.testing.assert_allclose(grad, np.broadcast_to(np.eye(dim), grad.shape), atol=1e-12)
    assert np.all(sd.S >= 0.0)
    # the reported box holds every node with weight
    ijk = np.stack([sd.nodes % g.shape[0], (sd.nodes // g.shape[0]) % g.shape[1],
                    sd.nodes // (g.shape[0] * g.shape[1])], axis=-1)
    used = sd.S > 0
    assert np.all(ijk[used] >= lo) and np.all(ijk[used] <= hi)


def test_gimp_matches_convolution_of_linear_hat():
    """uGIMP S(xi) is the average of the linear hat over the particle domain (1D check)."""
    l = 0.25
    g = grid(2)
    xs = np.linspace(1.0, 3.0, 41)
    x = np.stack([xs, np.full_like(xs, 1.5 * g.h[1] + 1e-9)], axis=1)
    _, sd, _, _ = evaluate("gimp", 2, x, np.array([l * g.h[0], l * g.h[1]]))
    node2 = 2 + g.ghost  # node at x = 2
    for p, xp in enumerate(xs):
        s = np.linspace(xp - l, xp + l, 20001)
        hat = np.clip(1 - np.abs(s - 2.0), 0, None).mean()
        mask = (sd.nodes[p] % g.shape[0]) == node2
        # summing over the y nodes leaves the x weight (the y weights sum to one)
        sx = sd.S[p, mask].sum()
        assert sx == pytest.approx(hat, abs=2e-5)
