"""Shape-function kernels: partition of unity, gradients, linear completeness, 2D and 3D,
for every shape function, including CPDI on deformed particle domains."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.scene.grid import plan_grid
from mpmsim.shapes import SHAPE_FUNCTIONS, ShapeData, shape_function

ALL = [(name, dim) for name, sf in SHAPE_FUNCTIONS.items() for dim in sf.dims]


def grid(dim, h=(1.0, 0.5, 0.8), cells=6, ghost=3):
    h = np.array(h[:dim])
    g, problem = plan_grid(dim, h, np.zeros(dim), cells * h, [0] * (2 * dim), True, ghost=ghost)
    assert problem is None
    return g


def evaluate(name, dim, x, semi, F=None, g=None):
    g = g if g is not None else grid(dim)
    sf = shape_function(name)
    sd = ShapeData.empty(len(x), sf.nodes_per_particle(dim), dim)
    (lo, hi), bad = sf.compute(x, F, semi, g, 3, sd)
    assert bad == (-1, 0)
    return g, sd, lo, hi


def node_positions(g, nodes):
    nx, ny = g.shape[0], g.shape[1]
    ijk = np.stack([nodes % nx, (nodes // nx) % ny, nodes // (nx * ny)], axis=-1)[..., : g.dim]
    return g.origin + ijk * g.h


@pytest.mark.parametrize("deformed", [False, True], ids=["undeformed", "deformed"])
@pytest.mark.parametrize("name,dim", ALL)
def test_partition_gradients_and_linear_completeness(name, dim, deformed):
    rng = np.random.default_rng(1)
    g = grid(dim)
    x = g.domain_lo + rng.random((200, dim)) * (g.domain_hi - g.domain_lo)
    # include particles exactly on nodes and on cell mid-lines
    x[0] = g.domain_lo + g.h
    x[1] = g.domain_lo + 1.5 * g.h
    semi = 0.25 * g.h  # 2 particles per cell edge
    F = np.broadcast_to(np.eye(dim), (200, dim, dim)).copy()
    if deformed:  # sheared, stretched, rotated domains (only CPDI uses them)
        F += 0.25 * rng.normal(size=F.shape)
        F[np.linalg.det(F) < 0.3] = np.eye(dim)
    g, sd, lo, hi = evaluate(name, dim, x, semi, F)
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


@pytest.mark.parametrize("name", ["gimp", "bspline3", "cpdi", "b2cpdi"])
def test_support_leaving_the_grid_is_flagged_not_written(name):
    g = grid(2, ghost=1)
    sf = shape_function(name)
    x = np.array([[1.0, 1.0], [g.origin[0] - 0.3, 1.0], [1.5, 1.5]])
    sd = ShapeData.empty(3, sf.nodes_per_particle(2), 2)
    _, bad = sf.compute(x, None, 0.25 * g.h, g, 1, sd)
    assert bad[0] == 1
    assert np.all(sd.S[1] == 0) and np.all(sd.nodes[1] == 0)
    assert sd.S[0].sum() == pytest.approx(1.0) and sd.S[2].sum() == pytest.approx(1.0)


def test_cpdi_flags_over_stretched_and_inverted_domains():
    g = grid(2)
    sf = shape_function("cpdi")
    x = np.array([[3.0, 1.5], [3.0, 1.5], [3.0, 1.5]])
    F = np.array([np.eye(2), np.diag([12.0, 1.0]), np.diag([-1.0, 1.0])])  # fine, 6 cells long, inverted
    for p, code in ((1, 6), (2, 7)):
        sd = ShapeData.empty(3, sf.nodes_per_particle(2), 2)
        _, bad = sf.compute(x[[0, p]], F[[0, p]], 0.25 * g.h, g, 1, sd)
        assert bad == (1, code)


def test_cpdi_undeformed_weights_match_corner_average():
    """lCPDI S for an undeformed particle is the mean of the hat at its four corners."""
    g = grid(2)
    x = np.array([[2.3, 1.1]])
    semi = 0.25 * g.h
    _, sd, _, _ = evaluate("cpdi", 2, x, semi, np.eye(2)[None])
    node = g.shape[0] * (2 + g.ghost) + (2 + g.ghost)  # node at (2, 1.0): i = 2, j = 2 (h_y = 0.5)
    corners = [(2.3 + sx * semi[0], 1.1 + sy * semi[1]) for sx in (-1, 1) for sy in (-1, 1)]
    hat = np.mean([max(0, 1 - abs(cx - 2.0)) * max(0, 1 - abs(cy - 1.0) / 0.5) for cx, cy in corners])
    assert sd.S[0][sd.nodes[0] == node].sum() == pytest.approx(hat, abs=1e-12)
