"""Small dense linear algebra in a fixed order of operations, without BLAS or LAPACK.

numpy's `@`, `np.dot` and `np.linalg`, and numba's versions of them, call OpenBLAS, which picks
its kernels by CPU when it loads (AVX-512, AVX2, SSE): the same product of two vectors sums in a
different order on another x86-64 CPU and rounds differently in the last bits. A run must give
the same bits wherever it runs (docs/architecture.md, "Results stay put"), so the steps and the
history sum through these functions instead: each adds its terms one after another in index
order. They are for the short vectors and small matrices of a step (3-vectors, element and
pair Hessians) and for the history's mass-weighted sums; the sparse solve of the implicit step
has its own kernels (integrators/ldl.py).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .materials.kernels import det_small


@njit(cache=True, inline="always")
def dot(a, b):
    """sum_i a[i] b[i], in index order (1-D arrays of equal length)."""
    s = 0.0
    for i in range(a.shape[0]):
        s += a[i] * b[i]
    return s


@njit(cache=True)
def weighted_rows(w, M):
    """sum_i w[i] M[i, :] (w (n,), M (n, k)) -> (k,), each column summed in row order."""
    n, k = M.shape
    out = np.zeros(k)
    for i in range(n):
        for j in range(k):
            out[j] += w[i] * M[i, j]
    return out


@njit(cache=True)
def rows_dot(A, b):
    """A @ b row by row (A (n, k), b (k,)) -> (n,), each row summed in column order."""
    n, k = A.shape
    out = np.zeros(n)
    for i in range(n):
        s = 0.0
        for j in range(k):
            s += A[i, j] * b[j]
        out[i] = s
    return out


@njit(cache=True)
def det_batch(F):
    """det F[p] of a stack of 1x1, 2x2 or 3x3 matrices (n, d, d) -> (n,), by cofactors (the
    materials' det_small)."""
    n, d = F.shape[0], F.shape[1]
    out = np.empty(n)
    for p in range(n):
        out[p] = F[p, 0, 0] if d == 1 else det_small(F[p])
    return out


def det(F: np.ndarray) -> np.ndarray:
    """det of a stack of d x d matrices (..., d, d), d <= 3 (np.linalg.det without LAPACK)."""
    F = np.ascontiguousarray(F, dtype=np.float64)
    d = F.shape[-1]
    return det_batch(F.reshape(-1, d, d)).reshape(F.shape[:-2])


@njit(cache=True, inline="always")
def rotate(a, p, q, c, s, dim, rows):
    """Columns p, q of a (rows: rows p, q) turned by the Jacobi rotation (c, s)."""
    for k in range(dim):
        x = a[p, k] if rows else a[k, p]
        y = a[q, k] if rows else a[k, q]
        if rows:
            a[p, k] = c * x - s * y
            a[q, k] = s * x + c * y
        else:
            a[k, p] = c * x - s * y
            a[k, q] = s * x + c * y


@njit(cache=True, inline="always")
def symmetric_eigen(a, dim, work, evals, evecs):
    """Eigenvalues and eigenvectors (columns of evecs) of the symmetric dim x dim matrix a by
    cyclic Jacobi rotations (work: a dim x dim scratch), unordered. Written out, not LAPACK, so
    that every CPU and the GPU step run the same arithmetic; Jacobi's eigenvalues carry a small
    relative error even for graded matrices (Demmel, Veselic 1992, doi:10.1137/0613074)."""
    norm = 0.0
    for r in range(dim):
        for c in range(dim):
            work[r, c] = a[r, c]
            evecs[r, c] = 1.0 if r == c else 0.0
            norm += a[r, c] * a[r, c]
    for sweep in range(32):
        off = 0.0
        for r in range(dim - 1):
            for c in range(r + 1, dim):
                off += work[r, c] * work[r, c]
        if not (off > 1e-36 * norm):
            break
        for p in range(dim - 1):
            for q in range(p + 1, dim):
                apq = work[p, q]
                if apq == 0.0:
                    continue
                theta = (work[q, q] - work[p, p]) / (2.0 * apq)
                t = 1.0 / (abs(theta) + np.sqrt(theta * theta + 1.0))
                if theta < 0.0:
                    t = -t
                c = 1.0 / np.sqrt(t * t + 1.0)
                s = t * c
                rotate(work, p, q, c, s, dim, False)  # work <- J^T work J
                rotate(work, p, q, c, s, dim, True)
                rotate(evecs, p, q, c, s, dim, False)  # evecs <- evecs J
    for e in range(dim):
        evals[e] = work[e, e]


@njit(cache=True)
def svd3(F, U, s, V):
    """F = U diag(s) V^T for a 3 x 3 F by one-sided Jacobi (Hestenes 1958): the columns of F V
    are made orthogonal by plane rotations accumulated in V; s their lengths (unordered, >= 0),
    U's columns their directions (U orthogonal: a zero column is completed to an orthonormal
    basis). Each singular value to a small relative error, without forming F^T F."""
    for a in range(3):
        for b in range(3):
            U[a, b] = F[a, b]
            V[a, b] = 1.0 if a == b else 0.0
    for sweep in range(40):
        turned = False
        for i in range(2):
            for j in range(i + 1, 3):
                alpha = 0.0
                beta = 0.0
                gamma = 0.0
                for k in range(3):
                    alpha += U[k, i] * U[k, i]
                    beta += U[k, j] * U[k, j]
                    gamma += U[k, i] * U[k, j]
                if not (abs(gamma) > 1e-15 * np.sqrt(alpha * beta)):
                    continue
                turned = True
                zeta = (beta - alpha) / (2.0 * gamma)
                t = 1.0 / (abs(zeta) + np.sqrt(1.0 + zeta * zeta))
                if zeta < 0.0:
                    t = -t
                c = 1.0 / np.sqrt(1.0 + t * t)
                sn = c * t
                rotate(U, i, j, c, sn, 3, False)
                rotate(V, i, j, c, sn, 3, False)
        if not turned:
            break
    big = 0.0
    for i in range(3):
        n2 = 0.0
        for k in range(3):
            n2 += U[k, i] * U[k, i]
        s[i] = np.sqrt(n2)
        big = max(big, s[i])
    done = np.zeros(3, dtype=np.bool_)
    for i in range(3):
        if s[i] > 1e-300 and s[i] > 1e-14 * big:
            for k in range(3):
                U[k, i] /= s[i]
            done[i] = True
    for i in range(3):  # complete U: Gram-Schmidt of the unit vectors against the columns done
        if done[i]:
            continue
        for e in range(3):
            for k in range(3):
                U[k, i] = 1.0 if k == e else 0.0
            for j in range(3):
                if done[j]:
                    p = U[0, i] * U[0, j] + U[1, i] * U[1, j] + U[2, i] * U[2, j]
                    for k in range(3):
                        U[k, i] -= p * U[k, j]
            n2 = U[0, i] * U[0, i] + U[1, i] * U[1, i] + U[2, i] * U[2, i]
            if n2 > 0.25:
                for k in range(3):
                    U[k, i] /= np.sqrt(n2)
                break
        done[i] = True


@njit(cache=True)
def inverse(A):
    """A^-1 of a small square matrix by Gauss-Jordan elimination with partial pivoting, in a
    fixed order (np.linalg.inv without LAPACK); raises on a singular matrix."""
    n = A.shape[0]
    M = A.astype(np.float64).copy()
    out = np.eye(n)
    for col in range(n):
        piv = col
        for r in range(col + 1, n):
            if abs(M[r, col]) > abs(M[piv, col]):
                piv = r
        if M[piv, col] == 0.0:
            raise ValueError("singular matrix")
        if piv != col:
            for k in range(n):
                M[col, k], M[piv, k] = M[piv, k], M[col, k]
                out[col, k], out[piv, k] = out[piv, k], out[col, k]
        d = M[col, col]
        for k in range(n):
            M[col, k] /= d
            out[col, k] /= d
        for r in range(n):
            if r != col and M[r, col] != 0.0:
                f = M[r, col]
                for k in range(n):
                    M[r, k] -= f * M[col, k]
                    out[r, k] -= f * out[col, k]
    return out


@njit(cache=True)
def matmul(A, B):
    """A B of 2-D arrays (n, k) (k, m) -> (n, m), each entry summed in k order."""
    n, k = A.shape
    m = B.shape[1]
    out = np.zeros((n, m))
    for i in range(n):
        for j in range(m):
            s = 0.0
            for q in range(k):
                s += A[i, q] * B[q, j]
            out[i, j] = s
    return out


def norm(x) -> float:
    """The Euclidean length of a vector, summed in index order (np.linalg.norm of a 1-D array
    calls BLAS's dot)."""
    x = np.ascontiguousarray(x, dtype=np.float64).ravel()
    return float(np.sqrt(dot(x, x)))


def matvec(A, x) -> np.ndarray:
    """A x (A (n, k), x (k,)) -> (n,) in a fixed order."""
    return rows_dot(np.ascontiguousarray(A, dtype=np.float64), np.ascontiguousarray(x, dtype=np.float64))


def eigvalsh(A) -> np.ndarray:
    """The eigenvalues of a small symmetric matrix (unordered), by Jacobi rotations."""
    A = np.ascontiguousarray(A, dtype=np.float64)
    n = A.shape[0]
    w = np.empty(n)
    symmetric_eigen(A, n, np.empty((n, n)), w, np.empty((n, n)))
    return w


@njit(cache=True)
def solve_batch(T, r):
    """x[p] with T[p] x[p] = r[p] for a stack of 2 x 2 or 3 x 3 systems (Cramer's rule)."""
    n, d = T.shape[0], T.shape[1]
    out = np.zeros((n, d))
    M = np.empty((1, d, d))
    for p in range(n):
        for a in range(d):
            for b in range(d):
                M[0, a, b] = T[p, a, b]
        D = det_batch(M)[0]
        for c in range(d):
            for a in range(d):
                M[0, a, c] = r[p, a]
            out[p, c] = det_batch(M)[0] / D
            for a in range(d):
                M[0, a, c] = T[p, a, c]
    return out
