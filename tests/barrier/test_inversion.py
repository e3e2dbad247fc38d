"""Inversion filter: the largest alpha in (0, 1] with det(A + s B) >= 0.1 det A on [0, alpha],
checked on random 2x2 and 3x3 cases (including fast determinant decrease, vanishing leading
coefficients, B = -k A, B = 0) against the defining inequality and an independent reference
(numpy's polynomial roots of the exactly computed determinant polynomial)."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from mpmsim.contact.barrier import (det_step_bound, det_step_bound_2x2, det_step_bound_3x3, first_nonpositive_in_unit,
                            triangle_step_bound)

pytestmark = pytest.mark.implicit

FRAC = 0.1


def random_case(d, rng):
    A = rng.normal(size=(d, d))
    if np.linalg.det(A) < 0:
        A[:, 0] *= -1
    kind = rng.integers(6)
    scale = 10 ** rng.uniform(-1, 2)
    if kind == 0:
        B = scale * rng.normal(size=(d, d))
    elif kind == 1:  # det decreases fast: B pushes toward inversion along A's columns
        B = -scale * A + 0.1 * rng.normal(size=(d, d))
    elif kind == 2:  # rank-one B: vanishing leading coefficient(s)
        B = scale * np.outer(rng.normal(size=d), rng.normal(size=d))
    elif kind == 3:  # B = -k A exactly
        B = -rng.uniform(0.2, 20) * A
    elif kind == 4:  # rank d-1 B in 3D / tiny B
        B = scale * rng.normal(size=(d, d))
        B[:, -1] = B[:, 0]
    else:
        B = 1e-3 * rng.normal(size=(d, d))
    return A, B


def bound(A, B):
    return det_step_bound_2x2(A, B, FRAC) if len(A) == 2 else det_step_bound_3x3(A, B, FRAC)


def exact_det(M):
    """Determinant of a 2x2 or 3x3 matrix of Fractions (Leibniz formula)."""
    if len(M) == 2:
        return M[0][0] * M[1][1] - M[0][1] * M[1][0]
    return (M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) - M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0])
            + M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0]))


def reference(A, B):
    """Smallest root in (0, 1] of det(A + s B) - FRAC det A, independently: the polynomial's
    coefficients exactly (rational interpolation of exact determinants at s = 0..3), roots by
    numpy's companion matrix, polished by Newton steps."""
    d = len(A)
    FA = [[Fraction(float(v)) for v in row] for row in A]
    FB = [[Fraction(float(v)) for v in row] for row in B]
    vals = [exact_det([[FA[i][j] + s * FB[i][j] for j in range(d)] for i in range(d)]) for s in range(4)]
    # Newton forward differences -> monomial coefficients of the cubic through s = 0, 1, 2, 3
    d1 = [vals[i + 1] - vals[i] for i in range(3)]
    d2 = [d1[i + 1] - d1[i] for i in range(2)]
    d3 = d2[1] - d2[0]
    c3 = d3 / 6
    c2 = d2[0] / 2 - 3 * c3
    c1 = d1[0] - c2 - c3
    c0 = vals[0] - Fraction(FRAC) * vals[0]
    c = np.array([float(c0), float(c1), float(c2), float(c3)])
    c = np.trim_zeros(c, "b")
    if len(c) < 2:
        return 1.0
    P = np.polynomial.polynomial
    real = []
    for r in P.polyroots(c):
        if abs(r.imag) < 1e-6 * max(1.0, abs(r.real)):
            x = r.real
            for _ in range(3):
                dp = P.polyval(x, P.polyder(c))
                if dp != 0:
                    x -= P.polyval(x, c) / dp
            if 0 < x <= 1:
                real.append(x)
    return min(real) if real else 1.0


@pytest.mark.parametrize("d", [2, 3])
def test_det_step_bound_is_the_largest_feasible_step(d):
    rng = np.random.default_rng(d)
    grid = np.linspace(0, 1, 401)
    n_limited = 0
    for _ in range(2000):
        A, B = random_case(d, rng)
        a = bound(A, B)
        detA = np.linalg.det(A)

        def f(s, A=A, B=B, detA=detA):
            return np.linalg.det(A + s * B) / detA - FRAC

        assert 0 < a <= 1
        # feasible on [0, a]: at a, and densely before it
        assert f(a) >= -1e-10
        dets = np.linalg.det(A[None] + (a * grid)[:, None, None] * B[None]) / detA - FRAC
        assert dets.min() >= -1e-10
        if a < 1:
            n_limited += 1
            # the largest: just beyond, the inequality fails
            assert f(min(1.0, a * (1 + 1e-6) + 1e-12)) < 0
        assert a == pytest.approx(reference(A, B), rel=1e-6, abs=1e-12)
    assert n_limited > 500


def test_closed_forms_and_degenerate_cases():
    A = np.eye(2)
    # det(I - s I) = (1 - s)^2 = 0.1 -> s = 1 - sqrt(0.1)
    assert det_step_bound_2x2(A, -np.eye(2), FRAC) == pytest.approx(1 - np.sqrt(0.1), rel=1e-14)
    assert det_step_bound_3x3(np.eye(3), -np.eye(3), FRAC) == pytest.approx(1 - 0.1 ** (1 / 3), rel=1e-14)
    assert det_step_bound_3x3(np.eye(3), -4 * np.eye(3), FRAC) == pytest.approx((1 - 0.1 ** (1 / 3)) / 4, rel=1e-14)
    # linear (leading coefficient exactly 0): det(I + s diag(-2, 0)) = 1 - 2 s -> s = 0.45
    assert det_step_bound_2x2(A, np.diag([-2.0, 0.0]), FRAC) == pytest.approx(0.45, rel=1e-14)
    # nearly vanishing leading coefficient
    B = np.array([[-2.0, 0.0], [0.0, 1e-14]])
    assert det_step_bound_2x2(A, B, FRAC) == pytest.approx(0.45, rel=1e-12)
    assert det_step_bound_2x2(A, np.zeros((2, 2)), FRAC) == 1.0
    assert det_step_bound_3x3(np.eye(3), np.zeros((3, 3)), FRAC) == 1.0
    # growing determinant, and one that dips but stays above 0.1 det A
    assert det_step_bound_2x2(A, np.eye(2), FRAC) == 1.0
    assert det_step_bound_2x2(A, -0.5 * np.eye(2), FRAC) == 1.0  # (1 - s/2)^2 >= 0.25
    # det = (1 - 2 s)^2 reaches 0.1 at s = (1 - sqrt(0.1))/2, before its double root at 0.5
    a = det_step_bound_2x2(A, np.array([[-2.0, 0.0], [0.0, -2.0]]), FRAC)
    assert a == pytest.approx((1 - np.sqrt(0.1)) / 2, rel=1e-14)
    # tangency: det(I + s B) - 0.1 = 0.9 (1 - 2 s)^2 touches zero at s = 0.5 (ill-conditioned:
    # rounding decides between "touches at 0.5" and "stays positive", i.e. 1.0)
    B = np.array([[-1.8, 0.6], [-0.6, -1.8]])
    a = det_step_bound_2x2(A, B, FRAC)
    assert a == pytest.approx(0.5, abs=1e-6) or a == 1.0
    s = np.linspace(0, a, 1001)
    assert ((1 - 1.8 * s) ** 2 + 0.36 * s ** 2 - FRAC).min() >= -1e-12
    # an inverted or degenerate start gives 0
    assert det_step_bound_2x2(np.diag([1.0, -1.0]), np.eye(2), FRAC) == 0.0
    assert first_nonpositive_in_unit(0.9, np.nan, 0.0, 0.0) == 0.0


def test_batched_bounds():
    rng = np.random.default_rng(7)
    for d in (2, 3):
        cases = [random_case(d, rng) for _ in range(100)]
        As = np.array([c[0] for c in cases])
        Bs = np.array([c[1] for c in cases])
        assert det_step_bound(As, Bs, FRAC) == min(bound(A, B) for A, B in cases)
    # triangles: a unit right triangle whose apex is pushed through the base
    x = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    dx = np.array([[0.0, 0.0], [0.0, 0.0], [0.0, -2.0]])
    tris = np.array([[0, 1, 2]], dtype=np.int64)
    assert triangle_step_bound(x, dx, tris, FRAC) == pytest.approx(0.45, rel=1e-14)
