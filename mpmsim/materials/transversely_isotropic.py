"""Transversely isotropic linear elastic (wood, fibre composites): hypoelastic MPM update with
a full stiffness after the Hughes–Winget rotation."""

from __future__ import annotations

import numpy as np
from numba import njit
from pydantic import Field
from typing import Literal

from .. import linalg
from ..schema_base import Strict, Vector
from .kernels import rotate_stress
from .model import ANISOTROPIC, NPROP, MaterialModel, register

VOIGT_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))


class TransverselyIsotropic(Strict):
    """Transversely isotropic linear elastic (wood, fibre composites): axial properties along
    `axis`, isotropic in the plane normal to it; hypoelastic with the Hughes–Winget stress
    rotation. The axis stays fixed in space (small rotations), as in the 2013 paper's specimens."""

    type: Literal["transversely_isotropic"]
    EA: float = Field(gt=0, description="Axial Young's modulus.")
    ET: float = Field(gt=0, description="Transverse Young's modulus.")
    GA: float = Field(gt=0, description="Axial shear modulus.")
    nuA: float = Field(description="Axial Poisson's ratio (transverse strain / axial strain under axial load).")
    nuT: float = Field(gt=-1.0, lt=1.0, description="Transverse Poisson's ratio (in the isotropic plane).")
    axis: Vector = Field(description="Axial direction (normalised).")
    density: float = Field(gt=0, description="Mass density (density unit of the deck's units).")


def transversely_isotropic_compliance(EA, ET, GA, nuA, nuT, axis) -> np.ndarray:
    """6x6 compliance (strain = S stress, engineering shear) in global axes, for axial
    properties along `axis` and isotropy normal to it."""
    a = np.zeros(3)
    a[: len(axis)] = axis
    a /= linalg.norm(a)
    # material frame: 1 = axis; compliance as a 4th-order tensor there
    GT = ET / (2.0 * (1.0 + nuT))
    Sm = np.zeros((3, 3, 3, 3))
    normal = np.array([[1 / EA, -nuA / EA, -nuA / EA], [-nuA / EA, 1 / ET, -nuT / ET], [-nuA / EA, -nuT / ET, 1 / ET]])
    for i in range(3):
        for j in range(3):
            Sm[i, i, j, j] = normal[i, j]
    for (i, j), G in (((0, 1), GA), ((0, 2), GA), ((1, 2), GT)):
        for k, l in ((i, j), (j, i)):
            for m, n in ((i, j), (j, i)):
                Sm[k, l, m, n] = 1.0 / (4.0 * G)
    # rotation R: rows are the material axes in global coordinates
    helper = np.array([0.0, 0.0, 1.0]) if abs(a[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    t1 = np.cross(helper, a)
    t1 /= linalg.norm(t1)
    R = np.array([a, t1, np.cross(a, t1)])
    Sg = np.einsum("ai,bj,ck,dl,abcd->ijkl", R, R, R, R, Sm)
    S = np.zeros((6, 6))
    for I, (i, j) in enumerate(VOIGT_PAIRS):
        for J, (k, l) in enumerate(VOIGT_PAIRS):
            S[I, J] = Sg[i, j, k, l] * (2.0 if I >= 3 else 1.0) * (2.0 if J >= 3 else 1.0)
    return S


def row(m) -> np.ndarray:
    """[C (6x6, row major), S = C^-1 (6x6)], Voigt xx yy zz xy yz xz, engineering shear."""
    out = np.zeros(NPROP)
    S = transversely_isotropic_compliance(m.EA, m.ET, m.GA, m.nuA, m.nuT, m.axis)
    out[:36] = linalg.inverse(S).ravel()
    out[36:] = S.ravel()
    return out


def check(m, dim: int) -> list[tuple[tuple, str]]:
    if len(m.axis) != dim or not any(m.axis):
        return []  # (the axis's length and the zero vector: mpmsim/deck/semantics.py)
    S = transversely_isotropic_compliance(m.EA, m.ET, m.GA, m.nuA, m.nuT, m.axis)
    if linalg.eigvalsh(0.5 * (S + S.T)).min() <= 0.0:
        return [(("nuA",), "these constants give no positive strain energy (need nuA^2 < EA/ET (1 - nuT)/2 and "
                           "|nuT| < 1)")]
    return []


@njit(cache=True, inline="always")
def anisotropic_stress(props, L, dt, s, W, A, Ai, Q):
    """Linear elastic increment with a full stiffness C (props[0:36], Voigt xx yy zz xy yz xz,
    engineering shear strains) after the rotation: sigma <- Q sigma Q^T + C de."""
    rotate_stress(L, dt, s, W, A, Ai, Q)
    de0 = L[0, 0] * dt
    de1 = L[1, 1] * dt
    de2 = L[2, 2] * dt
    de3 = (L[0, 1] + L[1, 0]) * dt
    de4 = (L[1, 2] + L[2, 1]) * dt
    de5 = (L[0, 2] + L[2, 0]) * dt
    for a in range(6):
        r = 6 * a
        s[a] += (props[r] * de0 + props[r + 1] * de1 + props[r + 2] * de2 + props[r + 3] * de3
                 + props[r + 4] * de4 + props[r + 5] * de5)
    return max(props[0], max(props[7], props[14]))


@njit(cache=True, inline="always")
def compliance_energy(props, s):
    """1/2 sigma . S sigma with the compliance S in props[36:72]."""
    e = 0.0
    for a in range(6):
        for b in range(6):
            e += s[a] * props[36 + 6 * a + b] * s[b]
    return 0.5 * e


@njit(cache=True, inline="always")
def stress(pr, L, dt, F3, J, f00, f01, f10, f11, s, W, A, Ai, Q, eos, hs):
    return anisotropic_stress(pr, L, dt, s, W, A, Ai, Q)


@njit(cache=True, inline="always")
def energy(pr, F3, s, J):
    return compliance_energy(pr, s)


@njit(cache=True, inline="always")
def bulk_modulus(pr, J, p):
    """1 / (sum of the normal-normal compliances)"""
    c = 0.0
    for a in range(3):
        for b in range(3):
            c += pr[36 + 6 * a + b]
    return 1.0 / c


MODEL = register(MaterialModel(
    "transversely_isotropic", TransverselyIsotropic, row, wave_modulus=lambda r: max(r[0], max(r[7], r[14])),
    energy=energy, bulk_modulus=bulk_modulus, stress_2d=stress, stress_3d=stress, check=check), ANISOTROPIC)
