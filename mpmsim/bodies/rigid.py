"""Rigid particle bodies: particles of rigid materials moving at a prescribed velocity.

They carry no mass and no stress. In mode `bc` they impose their velocity on the grid nodes
they touch (a velocity condition); in mode `contact` they enter the contact laws as a
material of infinite mass. Their motion is per rigid *material*: `v_start`/`v_end` are the
prescribed velocities at the start and end of the current step, `disp` the displacement
since t = 0 (history columns u_<material>_<axis>), and the reaction the material feels from
each rigid material is in `state.reaction[6 + r]` (history columns F_<material>_<axis>).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..views import RigidView
from . import BodyInfo, BodySet
from .particles import pad3


@dataclass
class RigidParticles(BodySet):
    x: np.ndarray  # (n, dim)
    v: np.ndarray  # (n, dim)
    vol: np.ndarray  # (n,)
    mat: np.ndarray  # (n,) rigid material index
    body: np.ndarray  # (n,) deck body index
    x0: np.ndarray  # (n, dim)
    v_start: np.ndarray  # (n_rigid_materials, dim) prescribed velocity at the step's start
    v_end: np.ndarray  # (n_rigid_materials, dim) at its end
    disp: np.ndarray  # (n_rigid_materials, dim) displacement since t = 0
    names: list  # rigid material names
    infos: list  # BodyInfo of each rigid particle body

    kind = "rigid particles"

    @property
    def n(self) -> int:
        return len(self.vol)

    def view(self) -> RigidView:
        return RigidView(self.x, self.v, self.vol, self.x0)

    @classmethod
    def from_seed(cls, seed, materials, infos: list[BodyInfo], dim: int) -> "RigidParticles":
        nr = len(materials.rigid)
        v0 = np.array([m.velocity(0.0) for m in materials.motions]).reshape(nr, dim)
        return cls(seed.x.copy(), seed.v.copy(), seed.vol.copy(), seed.mat.copy(), seed.body.copy(), seed.x.copy(),
                   v0, v0.copy(), np.zeros((nr, dim)), list(materials.rigid), infos)

    def history_columns(self, units, dim: int) -> list[tuple[str, str]]:
        cols = []
        for r in self.names:
            cols += [(f"F_{r}_{a}", units.force) for a in "xyz"[:dim]]
            cols += [(f"u_{r}_{a}", units.length) for a in "xyz"[:dim]]
        return cols

    def history_values(self, state) -> list[float]:
        row = []
        for r in range(len(self.names)):
            row += list(state.reaction[6 + r]) + list(self.disp[r])
        return row

    def vtu_pieces(self, state) -> list[tuple[str, dict]]:
        mats, n = state.materials, self.n
        if n == 0:
            return []
        gid = np.array([mats.global_id(m) for m in mats.rigid], dtype=np.int32)
        data = {
            "velocity": pad3(self.v),
            "displacement": pad3(self.x - self.x0),
            "stress": np.zeros((n, 6)),
            "deformation_gradient": np.tile(np.eye(3).reshape(1, 9), (n, 1)),
            "J": np.ones(n),
            "material": gid[self.mat],
            "body": self.body.astype(np.int32),
            "rigid": np.ones(n, np.uint8),
            "mass": np.zeros(n),
            "volume": self.vol,
        }
        return [("particles", {"points": pad3(self.x), "point_data": data})]

    def check(self, state, units) -> tuple[str, str] | None:
        """A rigid material whose particles (or their shape-function support) left the grid."""
        if self.n == 0:
            return None
        g = state.grid
        out = np.any((self.x < g.domain_lo) | (self.x > g.domain_hi), axis=1)
        if state.flags.bad_rigid >= 0:
            out[state.flags.bad_rigid] = True
        if not out.any():
            return None
        name = self.names[int(self.mat[np.argmax(out)])]
        return "stopped", f"rigid material '{name}' left the grid domain; enlarge grid.domain"
