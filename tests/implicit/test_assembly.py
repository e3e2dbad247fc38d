"""The Newton matrix's assembly (mpmsim/integrators/implicit.py, free_csc): triplets with
duplicates, restricted to the free unknowns, against scipy's COO -> CSR and slicing."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from mpmsim.integrators.implicit import free_csc

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
