"""mpmsim/linalg.py: the fixed-order dense algebra that replaces BLAS and LAPACK in the steps,
against numpy's (LAPACK's) answers on random and degenerate inputs."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim import linalg


@pytest.fixture
def rng():
    return np.random.default_rng(7)


def test_products_and_sums_match_numpy_and_add_in_index_order(rng):
    w, M = rng.standard_normal(500), rng.standard_normal((500, 6))
    assert np.allclose(linalg.weighted_rows(w, M), w @ M, rtol=1e-12, atol=1e-12)
    A, B = rng.standard_normal((7, 4)), rng.standard_normal((4, 5))
    assert np.allclose(linalg.matmul(A, B), A @ B, rtol=1e-13, atol=1e-14)
    assert np.allclose(linalg.matvec(A, B[:, 0]), A @ B[:, 0], rtol=1e-13, atol=1e-14)
    x = rng.standard_normal(3)
    assert linalg.norm(x) == pytest.approx(np.linalg.norm(x), rel=1e-15)
    # index order, exactly: 1 + 1e16 - 1e16 is 0 in floating point, summed left to right
    assert linalg.dot(np.array([1.0, 1e16, -1e16]), np.ones(3)) == 0.0
    assert linalg.weighted_rows(np.ones(3), np.array([[1.0], [1e16], [-1e16]]))[0] == 0.0


def test_det_inverse_and_small_solves_match_lapack(rng):
    for d in (1, 2, 3):
        F = rng.standard_normal((50, d, d))
        assert np.allclose(linalg.det(F), np.linalg.det(F), rtol=1e-12, atol=1e-14)
    assert linalg.det(np.eye(3)[None].repeat(4, 0)).tolist() == [1.0] * 4
    S = rng.standard_normal((6, 6)) + 6 * np.eye(6)
    assert np.allclose(linalg.inverse(S) @ S, np.eye(6), atol=1e-13)
    P = np.eye(3)[[2, 0, 1]]  # needs pivoting: a zero on the diagonal
    assert np.array_equal(linalg.inverse(P), P.T)
    with pytest.raises(ValueError, match="singular"):
        linalg.inverse(np.ones((3, 3)))
    T, r = rng.standard_normal((20, 3, 3)) + 3 * np.eye(3), rng.standard_normal((20, 3))
    assert np.allclose(linalg.solve_batch(T, r), np.linalg.solve(T, r[:, :, None])[:, :, 0], rtol=1e-11, atol=1e-12)


def test_jacobi_eigen_solves_symmetric_matrices_up_to_12x12(rng):
    for n in (2, 3, 6, 12):
        A = rng.standard_normal((n, n))
        A = A + A.T
        w = np.empty(n)
        V = np.empty((n, n))
        linalg.symmetric_eigen(A, n, np.empty((n, n)), w, V)
        assert np.allclose(np.sort(w), np.linalg.eigvalsh(A), rtol=1e-12, atol=1e-12 * np.abs(A).max())
        assert np.allclose(V @ np.diag(w) @ V.T, A, atol=1e-12 * np.abs(A).max())
        assert np.allclose(V.T @ V, np.eye(n), atol=1e-13)
    assert np.allclose(np.sort(linalg.eigvalsh(np.diag([3.0, -1.0, 2.0]))), [-1.0, 2.0, 3.0])


@pytest.mark.parametrize("case", ["random", "rotation", "reflection", "rank2", "rank1", "zero", "repeated"])
def test_one_sided_jacobi_svd_of_3x3(case, rng):
    F = {"random": rng.standard_normal((3, 3)),
         "rotation": np.linalg.qr(rng.standard_normal((3, 3)))[0] * np.sign(np.linalg.det(np.linalg.qr(rng.standard_normal((3, 3)))[0])),
         "reflection": np.diag([1.0, 1.0, -1.0]) @ np.linalg.qr(rng.standard_normal((3, 3)))[0],
         "rank2": np.outer(rng.standard_normal(3), rng.standard_normal(3)) + np.outer(rng.standard_normal(3), rng.standard_normal(3)),
         "rank1": np.outer(rng.standard_normal(3), rng.standard_normal(3)),
         "zero": np.zeros((3, 3)),
         "repeated": 2.0 * np.eye(3) + 1e-3 * np.outer([1.0, 0, 0], [1.0, 0, 0])}[case]
    U, s, V = np.empty((3, 3)), np.empty(3), np.empty((3, 3))
    linalg.svd3(F, U, s, V)
    assert np.allclose(U @ np.diag(s) @ V.T, F, atol=1e-13 * max(1.0, np.abs(F).max()))
    assert np.allclose(U.T @ U, np.eye(3), atol=1e-12) and np.allclose(V.T @ V, np.eye(3), atol=1e-13)
    assert np.allclose(np.sort(s), np.sort(np.linalg.svd(F, compute_uv=False)), atol=1e-13 * max(1.0, np.abs(F).max()))
    assert (s >= 0).all()
