"""Materials: the table of (type code, property row) the kernels take (mpmsim/scene/materials.py
resolves it from the deck).

Deformable materials are numbered 0..n-1 in deck order; rigid materials are numbered
separately 0..r-1 (they live in their own particle set). The constitutive kernels
dispatch on the integer type code; the property row layout per type is fixed here.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..views import MaterialView

LINEAR_ELASTIC = 0
NEO_HOOKEAN = 1
MIE_GRUNEISEN = 2
ANISOTROPIC = 3
COMPRESSIBLE_NH = 4  # FEM bodies only (mpmsim/fem)
TYPE_NAMES = {LINEAR_ELASTIC: "linear_elastic", NEO_HOOKEAN: "neo_hookean", MIE_GRUNEISEN: "mie_gruneisen",
              ANISOTROPIC: "transversely_isotropic", COMPRESSIBLE_NH: "compressible_neo_hookean"}

# property row: linear_elastic and compressible_neo_hookean [lambda, mu, E, nu, ...]; neo_hookean [K, G, ...];
# mie_gruneisen [K, G, gamma0, S1, ...];
# anisotropic [C (6x6, row major), S = C^-1 (6x6)] in Voigt xx yy zz xy yz xz, engineering shear
NPROP = 72
VOIGT_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))


def transversely_isotropic_compliance(EA, ET, GA, nuA, nuT, axis) -> np.ndarray:
    """6x6 compliance (strain = S stress, engineering shear) in global axes, for axial
    properties along `axis` and isotropy normal to it."""
    a = np.zeros(3)
    a[: len(axis)] = axis
    a /= np.linalg.norm(a)
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
    t1 /= np.linalg.norm(t1)
    R = np.array([a, t1, np.cross(a, t1)])
    Sg = np.einsum("ai,bj,ck,dl,abcd->ijkl", R, R, R, R, Sm)
    S = np.zeros((6, 6))
    for I, (i, j) in enumerate(VOIGT_PAIRS):
        for J, (k, l) in enumerate(VOIGT_PAIRS):
            S[I, J] = Sg[i, j, k, l] * (2.0 if I >= 3 else 1.0) * (2.0 if J >= 3 else 1.0)
    return S


@dataclass
class RigidMotion:
    """Prescribed rigid velocity: piecewise linear in time, held constant outside the table."""

    times: np.ndarray  # (k,)
    values: np.ndarray  # (k, dim)

    def velocity(self, t: float) -> np.ndarray:
        return np.array([np.interp(t, self.times, self.values[:, d]) for d in range(self.values.shape[1])])

    def displacement_envelope(self, t_end: float) -> tuple[np.ndarray, np.ndarray]:
        """Min and max displacement over [0, t_end] (exact at table breakpoints)."""
        ts = np.union1d(np.linspace(0.0, t_end, 1001), self.times[(self.times > 0) & (self.times < t_end)])
        v = np.stack([self.velocity(t) for t in ts])
        d = np.concatenate([np.zeros((1, v.shape[1])), np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(ts)[:, None], axis=0)])
        return d.min(axis=0), d.max(axis=0)


@dataclass
class MaterialTable:
    names: list[str]  # all materials, deck order (the VTU "material" id)
    deformable: list[str]
    rigid: list[str]
    type_code: np.ndarray  # (n_deformable,) int64
    props: np.ndarray  # (n_deformable, NPROP)
    density: np.ndarray  # (n_deformable,)
    motions: list[RigidMotion] = field(default_factory=list)
    constrain: np.ndarray = None  # (n_rigid, dim) bool: components each rigid material imposes
    av: np.ndarray = None  # (n_deformable, 2) artificial viscosity [A1, A2], zeros where off
    energy: np.ndarray = None  # (n_deformable,) bool: particles carry internal energy U and pressure
    rigid_bc: list = field(default_factory=list)  # (n_rigid,) bool: the rigid material sets velocity conditions

    def view(self) -> MaterialView:
        """The deformable materials as the kernels take them."""
        return MaterialView(self.type_code, self.props, self.density, self.energy, self.av)

    @property
    def tracks_energy(self) -> bool:
        """Some material needs internal energy (Mie–Grüneisen or artificial viscosity)."""
        return bool(self.energy.any())

    def is_rigid(self, name: str) -> bool:
        return name in self.rigid

    def local_index(self, name: str) -> int:
        return self.rigid.index(name) if name in self.rigid else self.deformable.index(name)

    def global_id(self, name: str) -> int:
        return self.names.index(name)
