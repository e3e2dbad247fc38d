"""The Newton matrix's assembly (mpmsim/integrators/assembly.py): local Hessian bundles
scattered on a kept pattern give, to the bit, the sparse matrix of their triplets (free_csc,
checked against scipy's COO -> CSR and slicing), in full or as its lower triangle."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from mpmsim.energy import Blocks, Triplets, triplets
from mpmsim.integrators.assembly import Assembler, free_csc

pytestmark = pytest.mark.implicit


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_free_csc_is_scipys_matrix_restricted_to_the_free_unknowns_in_canonical_form(seed):
    rng = np.random.default_rng(seed)
    n, k = 60, 4000
    rows, cols = rng.integers(0, n, k), rng.integers(0, n, k)
    vals = rng.normal(size=k)
    free = rng.random(n) > 0.3
    m = int(free.sum())
    index = np.full(n, -1, np.int64)
    index[free] = np.arange(m)
    indptr, indices, data = free_csc(rows, cols, vals, index, m)
    got = sp.csc_matrix((data, indices, indptr), shape=(m, m))
    want = sp.coo_matrix((vals, (rows, cols)), shape=(n, n)).tocsr()[free][:, free]
    assert abs(got - want).max() < 1e-12
    assert got.nnz == want.nnz  # duplicates summed: one entry per (row, column)
    for j in range(m):  # rows sorted and distinct within each column
        assert np.all(np.diff(indices[indptr[j]:indptr[j + 1]]) > 0)


def test_free_csc_of_nothing_free_or_no_triplets_is_empty():
    index = np.full(5, -1, np.int64)
    indptr, indices, data = free_csc(np.array([0, 1]), np.array([1, 2]), np.array([1.0, 2.0]), index, 0)
    assert len(indptr) == 1 and len(indices) == 0 and len(data) == 0
    index = np.arange(5)
    indptr, indices, data = free_csc(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0), index, 5)
    assert np.array_equal(indptr, np.zeros(6)) and len(indices) == 0


def symmetric(rng, g, n):
    A = rng.normal(size=(g, n, n))
    return A + A.transpose(0, 2, 1)


def bundles(rng, n_nodes, d, contact_pairs=5):
    """Elements (3 nodes), particles (9 grid nodes), weighted contact pairs (a point on 4 nodes
    with weights, some zero, against an edge of 2: local Hessians over 3 local nodes) and a
    term's triplets of whole node blocks (energy.triplets; the pattern holds whole d x d node
    blocks, so a triplet's block enters whole)."""
    elements = Blocks(rng.integers(0, n_nodes, (30, 3)), symmetric(rng, 30, 3 * d))
    particles = Blocks(rng.integers(0, n_nodes, (40, 9)), symmetric(rng, 40, 9 * d))
    K = 4
    w = rng.random((contact_pairs, K + 2))
    w[:, K:] = 1.0
    w[::2, 1:K] = 0.0  # an FEM node as the point: one weight, padding nodes of weight 0
    contact = Blocks(rng.integers(0, n_nodes, (contact_pairs, K + 2)), symmetric(rng, contact_pairs, 3 * d), w,
                     np.r_[np.zeros(K, np.int64), 1, 2])
    edge_edge = triplets(rng.integers(0, n_nodes, (6, 4)), symmetric(rng, 6, 4 * d), d)  # a term's own triplets
    return [elements, particles, contact, edge_edge]


def as_triplets(h, d):
    """The triplets the integrator summed before: weighted blocks expanded through their weights."""
    if isinstance(h, Triplets):
        return h
    if h.weights is None:
        return triplets(h.nodes, h.local, d)
    g, k = h.nodes.shape
    nb = h.local.shape[1] // d
    H4 = h.local.reshape(g, nb, d, nb, d)[:, h.block][:, :, :, h.block]
    H4 = H4 * (h.weights[:, :, None, None, None] * h.weights[:, None, None, :, None])
    return triplets(h.nodes, H4.reshape(g, k * d, k * d), d)


@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("seed", [0, 1])
def test_bundles_scattered_on_the_kept_pattern_are_the_triplets_matrix_to_the_bit(d, seed):
    rng = np.random.default_rng(seed)
    n_nodes = 70
    hs = bundles(rng, n_nodes, d)
    free = rng.random(n_nodes * d) > 0.2
    index = np.full(n_nodes * d, -1, np.int64)
    index[free] = np.arange(int(free.sum()))
    diag = rng.random(n_nodes * d)
    c = 0.37
    tr = [as_triplets(h, d) for h in hs]
    every = np.arange(n_nodes * d)
    rows = np.concatenate([t.rows for t in tr] + [every])
    cols = np.concatenate([t.cols for t in tr] + [every])
    vals = np.concatenate([c * t.vals for t in tr] + [diag])  # the integrator's former sum, in this order
    indptr, indices, data = free_csc(rows, cols, vals, index, int(free.sum()))
    full = Assembler(d).matrix(hs, diag, c, index)
    assert np.array_equal(full.indptr, indptr) and np.array_equal(full.indices, indices)
    assert np.array_equal(full.data, data)  # every sum in the same order: bit for bit
    lower = Assembler(d, lower=True).matrix(hs, diag, c, index)
    want = sp.tril(sp.csc_matrix((data, indices, indptr))).tocsc()
    want.sort_indices()
    assert np.array_equal(lower.indptr, want.indptr) and np.array_equal(lower.indices, want.indices)
    assert np.array_equal(lower.data, want.data)


def test_the_pattern_is_kept_while_the_node_lists_stay_and_rebuilt_when_they_change():
    rng = np.random.default_rng(3)
    d, n_nodes = 2, 70
    hs = bundles(rng, n_nodes, d)
    index = np.arange(n_nodes * d)
    diag = np.ones(n_nodes * d)
    asm = Assembler(d)
    A = asm.matrix(hs, diag, 1.0, index)
    new_values = [h._replace(local=2.0 * h.local) if isinstance(h, Blocks) else h._replace(vals=2.0 * h.vals)
                  for h in hs]
    B = asm.matrix(new_values, diag, 1.0, index)  # same node lists: values only
    assert asm.rebuilds == 1 and asm.version == 1
    assert abs((B - sp.diags(diag)) - 2.0 * (A - sp.diags(diag))).max() < 1e-12
    moved = list(hs)
    moved[2] = hs[2]._replace(nodes=hs[2].nodes.copy())  # equal contents, a new array: kept
    asm.matrix(moved, diag, 1.0, index)
    assert asm.rebuilds == 1
    nodes = hs[2].nodes.copy()
    nodes[0, -1] = (nodes[0, -1] + 1) % n_nodes  # a contact pair moves to another edge node
    moved[2] = hs[2]._replace(nodes=nodes)
    C = asm.matrix(moved, diag, 1.0, index)
    assert asm.rebuilds == 2 and asm.version == 2
    want = Assembler(d).matrix(moved, diag, 1.0, index)
    assert np.array_equal(C.indices, want.indices) and np.array_equal(C.data, want.data)
