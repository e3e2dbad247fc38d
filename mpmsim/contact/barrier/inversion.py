"""Inversion filter for the line search: the largest step that keeps every determinant positive.

Along a search direction the deformation gradient of a triangle / tetrahedron (FEM) or of an MPM
particle is affine in the step size alpha, F(alpha) = A + alpha B (for an MPM particle
A = I + sum_i (x_i - x_i^n) grad w_ip^T and B = sum_i p_i grad w_ip^T, both times F_p^n from the
right, which scales det by the constant det F_p^n; for a triangle A = [x1 - x0, x2 - x0],
B = [p1 - p0, p2 - p0], which scales det by the constant det D_m^-1). Then
    det(A + alpha B) = det A + c1 alpha + c2 alpha^2 (+ det B alpha^3 in 3D)
with, in 2D, c1 = a11 b22 + a22 b11 - a12 b21 - a21 b12, c2 = det B, and in 3D
c1 = tr(adj(A) B) = sum cof(A) : B, c2 = sum cof(B) : A, c3 = det B.
The filter returns the smallest alpha in (0, 1] with det(A + alpha B) = frac det A (frac = 0.1,
as in BFEMP Sec. 5 and the IPC line search of Smith et al. 2019 / Li et al. 2020), or 1 if
the determinant stays above frac det A on [0, 1]: every step in [0, alpha] is then inversion free.

Root finding (robust to a vanishing leading coefficient, double roots and nearly flat
polynomials): the normalised polynomial f(alpha) = det(A + alpha B)/det A - frac has f(0) =
1 - frac > 0. [0, 1] is split at the real roots of f' (stable quadratic formula; a degenerate
leading coefficient just drops a root), f is monotone on each piece, and the first piece whose
right end has f <= 0 is bisected to machine precision, keeping the feasible end. No cubic
formula, no division by a small leading coefficient.
"""

from __future__ import annotations

import numpy as np
from numba import njit

DET_FRACTION = 0.1


@njit(cache=True, inline="always")
def _cubic(c0, c1, c2, c3, x):
    return c0 + x * (c1 + x * (c2 + x * c3))


@njit(cache=True)
def first_nonpositive_in_unit(c0, c1, c2, c3):
    """Smallest x in (0, 1] with c0 + c1 x + c2 x^2 + c3 x^3 <= 0, given c0 > 0, returned from
    the feasible side (the polynomial is > 0 on [0, result)); 1.0 if it stays positive on
    [0, 1]. Non-finite coefficients give 0.0."""
    if not (np.isfinite(c0) and np.isfinite(c1) and np.isfinite(c2) and np.isfinite(c3)):
        return 0.0
    if not c0 > 0.0:
        return 0.0
    # critical points: roots of c1 + 2 c2 x + 3 c3 x^2 inside (0, 1)
    qa = 3.0 * c3
    qb = 2.0 * c2
    qc = c1
    r0 = 2.0  # 2.0 = "none"
    r1 = 2.0
    if qa == 0.0:
        if qb != 0.0:
            r0 = -qc / qb
    else:
        disc = qb * qb - 4.0 * qa * qc
        if disc >= 0.0:
            q = -0.5 * (qb + np.sqrt(disc)) if qb >= 0.0 else -0.5 * (qb - np.sqrt(disc))
            r0 = q / qa
            if q != 0.0:
                r1 = qc / q
    if not (r0 > 0.0 and r0 < 1.0):
        r0 = 2.0
    if not (r1 > 0.0 and r1 < 1.0):
        r1 = 2.0
    lo_c = min(r0, r1)
    hi_c = max(r0, r1)
    ends = (lo_c, hi_c, 1.0)
    left = 0.0
    for k in range(3):
        right = ends[k]
        if right > 1.0:
            continue
        if _cubic(c0, c1, c2, c3, right) <= 0.0:
            lo = left
            hi = right
            for _ in range(200):
                mid = 0.5 * (lo + hi)
                if mid <= lo or mid >= hi:
                    break
                if _cubic(c0, c1, c2, c3, mid) > 0.0:
                    lo = mid
                else:
                    hi = mid
            return lo
        left = right
    return 1.0


@njit(cache=True)
def det_step_bound_2x2(A, B, frac=DET_FRACTION):
    """Largest alpha in (0, 1] with det(A + s B) > frac det A for all s in [0, alpha) (2x2
    A, B; det A > 0). Returns 0.0 if det A <= 0."""
    detA = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    if not detA > 0.0:
        return 0.0
    c1 = A[0, 0] * B[1, 1] + A[1, 1] * B[0, 0] - A[0, 1] * B[1, 0] - A[1, 0] * B[0, 1]
    c2 = B[0, 0] * B[1, 1] - B[0, 1] * B[1, 0]
    return first_nonpositive_in_unit(1.0 - frac, c1 / detA, c2 / detA, 0.0)


@njit(cache=True, inline="always")
def _cof3(M, i, j):
    """Cofactor (i, j) of a 3x3 matrix."""
    i1 = (i + 1) % 3
    i2 = (i + 2) % 3
    j1 = (j + 1) % 3
    j2 = (j + 2) % 3
    return M[i1, j1] * M[i2, j2] - M[i1, j2] * M[i2, j1]


@njit(cache=True)
def det_step_bound_3x3(A, B, frac=DET_FRACTION):
    """Largest alpha in (0, 1] with det(A + s B) > frac det A for all s in [0, alpha) (3x3
    A, B; det A > 0). Returns 0.0 if det A <= 0."""
    detA = 0.0
    detB = 0.0
    c1 = 0.0
    c2 = 0.0
    for j in range(3):
        detA += A[0, j] * _cof3(A, 0, j)
        detB += B[0, j] * _cof3(B, 0, j)
    if not detA > 0.0:
        return 0.0
    for i in range(3):
        for j in range(3):
            c1 += _cof3(A, i, j) * B[i, j]
            c2 += _cof3(B, i, j) * A[i, j]
    return first_nonpositive_in_unit(1.0 - frac, c1 / detA, c2 / detA, detB / detA)


@njit(cache=True)
def det_step_bound(As, Bs, frac=DET_FRACTION):
    """Common step bound for a batch: As, Bs (n, d, d) with d = 2 or 3; min over the batch of
    `det_step_bound_2x2/3x3` (1.0 for an empty batch)."""
    alpha = 1.0
    d = As.shape[1]
    for k in range(As.shape[0]):
        if d == 2:
            a = det_step_bound_2x2(As[k], Bs[k], frac)
        else:
            a = det_step_bound_3x3(As[k], Bs[k], frac)
        alpha = min(alpha, a)
    return alpha


@njit(cache=True)
def triangle_step_bound(x, dx, tris, frac=DET_FRACTION):
    """Common step bound of 2D triangles (m, 3) over vertex positions x (n, 2) moving by dx
    (n, 2): A = [x1 - x0, x2 - x0], B = [dx1 - dx0, dx2 - dx0] (columns). Triangles must be
    positively oriented (det A > 0)."""
    A = np.empty((2, 2))
    B = np.empty((2, 2))
    alpha = 1.0
    for k in range(tris.shape[0]):
        i0 = tris[k, 0]
        for c in range(2):
            v = tris[k, c + 1]
            for r in range(2):
                A[r, c] = x[v, r] - x[i0, r]
                B[r, c] = dx[v, r] - dx[i0, r]
        alpha = min(alpha, det_step_bound_2x2(A, B, frac))
    return alpha
