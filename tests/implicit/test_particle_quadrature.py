"""The particles' quadrature in the implicit step (implicit_mpm.domain_weights; docs/bfemp.md,
"Order of convergence"): quadratic B-splines averaged over the particles' domains integrate
N_i and grad N_i exactly over the body for every row, including the rows of basis functions cut
off by a body's end, where MPM's point values miss the kink of N_i' with an odd count per cell;
the 1D model (bench/implicit.py --quadrature) and the grid unknowns of a real deck."""

from __future__ import annotations

import numpy as np
import pytest

from tests.implicit.test_implicit_mpm import bench_implicit, simulation

pytestmark = pytest.mark.implicit


@pytest.mark.parametrize("per_cell", [2, 3, 4])
def test_point_quadrature_misses_only_the_cut_rows_with_odd_counts_and_domain_averages_miss_none(per_cell):
    """1D bar [0, 1], h = 0.1, quadratic B-splines on nodes at i h (the bar's ends on nodes):
    sum_p v_p N_i'(x_p) is exact (1e-15) for every row whose support lies inside the bar at
    every count; at 3 per cell the three rows cut off by each end are off by +1/72, -1/36,
    +1/72 (the midpoint rule over the middle particle, centred on the kink of N_i'), exactly,
    whatever h; at 2 and 4 per cell no domain contains a knot and every row is exact. The domain
    averages are exact for every row and count (1e-15), N_i as well."""
    bench = bench_implicit()
    at, eS, eG = bench.bar_row_errors(0.1, per_cell, "points")
    inside = (at > 1.5) & (at < 8.5)
    assert np.abs(eG[inside]).max() < 1e-14
    cut = (np.abs(at) < 1.5) | (np.abs(at - 10) < 1.5)
    if per_cell == 3:
        assert np.allclose(eG[np.isin(at, (-1, 0, 1))], [1 / 72, -1 / 36, 1 / 72], rtol=1e-12, atol=0)
        assert np.allclose(eG[np.isin(at, (9, 10, 11))], [-1 / 72, 1 / 36, -1 / 72], rtol=1e-12, atol=0)
    else:
        assert np.abs(eG[cut]).max() < 1e-14
    _, eS, eG = bench.bar_row_errors(0.1, per_cell, "domain")
    assert np.abs(eS).max() < 1e-14 and np.abs(eG).max() < 1e-14


def test_the_1d_bar_converges_at_second_order_with_domain_averages_at_every_count():
    """The bar held at its end by a stiff point under its weight (centre-of-mass displacement,
    exact -1/3), h = 0.05, 0.025, 0.0125: with the point rule 3 per cell is first order
    (measured 1.07, 1.04), 2 and 4 per cell second (2.02, 2.01; 2.00, 2.00); with the domain
    averages every count is second order (2.02, 2.01; 2.01, 2.00; 2.00, 2.00), also with the
    nodes a quarter cell off the bar's end (where the point rule makes 2 per cell first order)."""
    bench = bench_implicit()
    hs = (0.05, 0.025, 0.0125)

    def orders(per, rule, offset=0.0):
        e = np.abs([bench.bar_model_com(h, per, offset, 2, rule) + 1.0 / 3.0 for h in hs])
        return np.log2(e[:-1] / e[1:])

    assert np.all(np.abs(orders(3, "points") - 1.0) < 0.15)
    for per in (2, 3, 4):
        assert np.all(orders(per, "domain") > 1.95), per
        assert np.all(orders(per, "domain", 0.25) > 1.95), per
    assert np.all(orders(2, "points", 0.25) < 1.2)


@pytest.mark.parametrize("per_direction", [2, 3])
def test_grid_unknowns_integrate_the_gradients_of_every_node_over_the_column_exactly(per_direction):
    """implicit_mpm.GridUnknowns.begin on bench/implicit.py's column (0.2 x 1, its ends on grid
    lines, h = 0.1): sum_p V_p grad w_ip equals the exact integral of grad N_i over the column
    for every active node (2D tensor products of the 1D integrals) to 1e-13 of the largest;
    the weights reproduce constants and linear functions (sum w = 1, sum w X = x_p, sum grad w
    = 0, sum X grad w^T = I to 1e-13). The point values (the shape function's own weights) miss
    the cut rows at 3 per direction by up to 0.05 of the largest entry and are exact at 2."""
    bench = bench_implicit()
    sim = simulation(bench.column_deck(0.1, per_direction))
    st = sim.state
    grid = sim.integrator.grid
    grid.begin(st)
    P = st.particles
    h = 0.1
    N, _ = bench._bspline(2)

    def exact_1d(node, lo, hi):
        """(int N_i, int N_i') over [lo, hi] for the node at `node`."""
        avg, _ = bench._bspline2_domain((0.5 * (lo + hi) - node) / h, 0.5 * (hi - lo) / h)
        return avg * (hi - lo), N((hi - node) / h) - N((lo - node) / h)

    (Sx, Gx), (Sy, Gy) = exact_1d(grid.X[:, 0], -0.1, 0.1), exact_1d(grid.X[:, 1], 0.0, 1.0)
    exact = np.stack([Gx * Sy, Sx * Gy], axis=1)

    def scatter(nodes, G):
        out = np.zeros((grid.n, 2))
        np.add.at(out, nodes.ravel(), (P.vol0[:, None, None] * G).reshape(-1, 2))
        return out

    scale = np.abs(exact).max()
    assert np.abs(scatter(grid.nodes, grid.G) - exact).max() < 1e-13 * scale
    assert np.abs(grid.S.sum(axis=1) - 1.0).max() < 1e-13
    assert np.abs(np.einsum("pk,pkc->pc", grid.S, grid.X[grid.nodes]) - P.x).max() < 1e-13
    assert np.abs(grid.G.sum(axis=1)).max() < 1e-13 * np.abs(grid.G).max()
    assert np.abs(np.einsum("pkc,pke->pce", grid.X[grid.nodes], grid.G) - np.eye(2)).max() < 1e-12
    sd = st.sd  # the point values of the same step, on global node indices
    local = np.searchsorted(grid.active, sd.nodes)
    inside = (local < grid.n) & (grid.active[np.minimum(local, grid.n - 1)] == sd.nodes) & (sd.S > 0)
    point = scatter(np.where(inside, local, 0), np.where(inside[:, :, None], sd.G, 0.0))
    miss = np.abs(point - exact).max() / scale
    assert miss > 0.01
