"""Materials: one module per material model (linear_elastic, neo_hookean,
compressible_neo_hookean, mie_gruneisen, transversely_isotropic, j2_plasticity), each registering a
`MaterialModel` (model.py: its deck schema, property row, MPM stress update, energy, wave and
bulk moduli, FEM forms); and the table of (type code, property row) the kernels take
(`MaterialTable`; mpmsim/scene/materials.py resolves it from the deck).

Deformable materials are numbered 0..n-1 in deck order; rigid materials are numbered
separately 0..r-1 (they live in their own particle set).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..views import MaterialView
# the built-in models, in the order the deck reference lists them
from . import linear_elastic, neo_hookean, compressible_neo_hookean  # noqa: F401,I001
from . import mie_gruneisen, transversely_isotropic  # noqa: F401,I001
from . import j2_plasticity  # noqa: F401,I001
from .model import (ANISOTROPIC, COMPRESSIBLE_NH, J2_PLASTICITY, LINEAR_ELASTIC, MIE_GRUNEISEN,  # noqa: F401
                    MODELS, NEO_HOOKEAN, NPROP, MaterialModel, model_of, register)
from .transversely_isotropic import transversely_isotropic_compliance  # noqa: F401


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
    state0: np.ndarray = None  # (n_deformable, k) initial material state of each (k: the widest model's row)
    # {name: (n_deformable,) slot of the material state, -1 where the material has none}: VTU
    # fields (MaterialModel.state_output) and dissipated energies (MaterialModel.dissipation)
    state_fields: dict = field(default_factory=dict)
    dissipations: dict = field(default_factory=dict)

    def state_slots(self, kind: str) -> dict[str, np.ndarray]:
        """state_fields (kind "output") or dissipations (kind "dissipation")."""
        return self.state_fields if kind == "output" else self.dissipations

    def wave_moduli(self) -> np.ndarray:
        """(n_deformable,) rho c^2 of each deformable material at rest (its model's)."""
        return np.array([model_of(c).wave_modulus(row) for c, row in zip(self.type_code, self.props)])

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
