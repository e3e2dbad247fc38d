"""Tensor helpers the material models share (each model is a module of this package;
mpmsim/materials/model.py). 2D plane strain runs the same 3x3 algebra with F33 = 1 and zero
out-of-plane velocity gradient.

Materials with internal energy (Mie–Grüneisen, or any material under artificial viscosity)
exchange it through a small `eos` row: [U, p, q, J0, rho0, 1 - S1 eta] (in/out, see
`mie_gruneisen.mie_gruneisen_stress`); the others never read it.

Stress is Cauchy, stored in Voigt order [xx, yy, zz, xy, yz, xz] (ParaView's order for
symmetric tensors).
"""

from __future__ import annotations

import numpy as np
from numba import njit


# Voigt slot of tensor component (a, b)
VOIGT = np.array([[0, 3, 5], [3, 1, 4], [5, 4, 2]], dtype=np.int64)


# glibc's cube root (sysdeps/ieee754/dbl-64/s_cbrt.c): x = m 2^e with m in [0.5, 1), a degree-6
# polynomial guess u ~ m^(1/3), one Halley step u (u^3 + 2m) / (2u^3 + m), times 2^((e mod 3)/3)
CBRT2 = 1.2599210498948731648  # 2^(1/3)
SQR_CBRT2 = 1.5874010519681994748  # 2^(2/3)
CBRT_POLY = (0.354895765043919860, 1.50819193781584896, -2.11499494167371287, 2.44693122563534430,
             -1.83469277483613086, 0.784932344976639262, -0.145263899385486377)


@njit(cache=True, inline="always")
def cube_root(x):
    """np.cbrt(x) to the last bit, inlined: the same operations as the C library's cbrt (which
    np.cbrt calls) for x in [0.25, 4), where the exponent splitting is one exact scaling and
    no power-of-two scaling is left at the end; np.cbrt itself elsewhere. The call, its frexp
    and ldexp are what make np.cbrt slow in a loop (8.9 against 2.8 ns a value, bench/traffic.py
    on the AMD EPYC VM, 2026-12-01). tests/unit/test_materials.py checks the bits against np.cbrt."""
    if x >= 0.5 and x < 1.0:
        m, f = x, 1.0
    elif x >= 1.0 and x < 2.0:
        m, f = x * 0.5, CBRT2
    elif x >= 0.25 and x < 0.5:
        m, f = x * 2.0, 1.0 / CBRT2
    elif x >= 2.0 and x < 4.0:
        m, f = x * 0.25, SQR_CBRT2
    else:
        return np.cbrt(x)
    c0, c1, c2, c3, c4, c5, c6 = CBRT_POLY
    u = c0 + (c1 + (c2 + (c3 + (c4 + (c5 + c6 * m) * m) * m) * m) * m) * m
    t2 = u * u * u
    return u * (t2 + 2.0 * m) / (2.0 * t2 + m) * f


@njit(cache=True, inline="always")
def det3(A):
    return (A[0, 0] * (A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1])
            - A[0, 1] * (A[1, 0] * A[2, 2] - A[1, 2] * A[2, 0])
            + A[0, 2] * (A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]))


@njit(cache=True, inline="always")
def inv3(A, out):
    d = det3(A)
    out[0, 0] = (A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1]) / d
    out[0, 1] = (A[0, 2] * A[2, 1] - A[0, 1] * A[2, 2]) / d
    out[0, 2] = (A[0, 1] * A[1, 2] - A[0, 2] * A[1, 1]) / d
    out[1, 0] = (A[1, 2] * A[2, 0] - A[1, 0] * A[2, 2]) / d
    out[1, 1] = (A[0, 0] * A[2, 2] - A[0, 2] * A[2, 0]) / d
    out[1, 2] = (A[0, 2] * A[1, 0] - A[0, 0] * A[1, 2]) / d
    out[2, 0] = (A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]) / d
    out[2, 1] = (A[0, 1] * A[2, 0] - A[0, 0] * A[2, 1]) / d
    out[2, 2] = (A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]) / d


@njit(cache=True, inline="always")
def rotate_stress(L, dt, s, W, A, Ai, Q):
    """sigma <- Q sigma Q^T with the Hughes–Winget increment Q = (I - W/2)^-1 (I + W/2),
    W = skew(L) dt: the objective part of a hypoelastic update."""
    for a in range(3):
        for b in range(3):
            W[a, b] = 0.5 * (L[a, b] - L[b, a]) * dt
    for a in range(3):
        for b in range(3):
            A[a, b] = (1.0 if a == b else 0.0) - 0.5 * W[a, b]
    inv3(A, Ai)
    for a in range(3):
        for b in range(3):
            q = 0.0
            for c in range(3):
                q += Ai[a, c] * ((1.0 if c == b else 0.0) + 0.5 * W[c, b])
            Q[a, b] = q
    for a in range(3):
        for b in range(3):
            A[a, b] = s[VOIGT[a, b]]
    for a in range(3):
        for b in range(a, 3):
            r = 0.0
            for c in range(3):
                for d in range(3):
                    r += Q[a, c] * A[c, d] * Q[b, d]
            W[a, b] = r  # W reused as the rotated stress (upper triangle)
    voigt_from_upper(W, s)


@njit(cache=True, inline="always")
def voigt_from_upper(M, s):
    """s <- the symmetric 3x3 tensor whose upper triangle M holds, in Voigt order."""
    s[0] = M[0, 0]
    s[1] = M[1, 1]
    s[2] = M[2, 2]
    s[3] = M[0, 1]
    s[4] = M[1, 2]
    s[5] = M[0, 2]


# slots of the eos row
EOS_U, EOS_P, EOS_Q, EOS_J0, EOS_RHO0, EOS_DEN = 0, 1, 2, 3, 4, 5
EOS_N = 6


@njit(cache=True, inline="always")
def det_small(F):
    """Determinant of a 2x2 or 3x3 matrix."""
    if F.shape[0] == 2:
        return F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]
    return det3(F)


@njit(cache=True, inline="always")
def inv_small(F, out):
    """out = F^-1 (2x2 or 3x3); returns det F."""
    J = det_small(F)
    if F.shape[0] == 2:
        out[0, 0] = F[1, 1] / J
        out[0, 1] = -F[0, 1] / J
        out[1, 0] = -F[1, 0] / J
        out[1, 1] = F[0, 0] / J
        return J
    inv3(F, out)
    return J


@njit(cache=True, inline="always")
def det_minus_one(F):
    """J - 1 from the invariants of H = F - I (no cancellation near F = I):
    det(I + H) - 1 = tr H + (sum of principal 2x2 minors of H) + det H (the last two: 3D)."""
    if F.shape[0] == 2:
        h00 = F[0, 0] - 1.0
        h11 = F[1, 1] - 1.0
        return h00 + h11 + (h00 * h11 - F[0, 1] * F[1, 0])
    h00 = F[0, 0] - 1.0
    h11 = F[1, 1] - 1.0
    h22 = F[2, 2] - 1.0
    h01, h02, h10, h12, h20, h21 = F[0, 1], F[0, 2], F[1, 0], F[1, 2], F[2, 0], F[2, 1]
    minors = (h00 * h11 - h01 * h10) + (h00 * h22 - h02 * h20) + (h11 * h22 - h12 * h21)
    detH = (h00 * (h11 * h22 - h12 * h21) - h01 * (h10 * h22 - h12 * h20) + h02 * (h10 * h21 - h11 * h20))
    return h00 + h11 + h22 + minors + detH
