"""Rigid particle bodies: particles of rigid materials moving at a prescribed velocity.

They carry no mass and no stress. In mode `bc` they impose their velocity on the grid nodes
they touch (a velocity condition); in mode `contact` they enter the contact laws as a
material of infinite mass. Their motion is per rigid *material*: `v_start`/`v_end` are the
prescribed velocities at the start and end of the current step, `disp` the displacement
since t = 0 (history columns u_<material>_<axis>), and the reaction the material feels from
each rigid material is in `state.reaction[6 + r]` (history columns F_<material>_<axis>), its
impulse since t = 0 in `state.impulse[6 + r]` (J_<material>_<axis>).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

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
    watch_penetration: bool = True  # stop when a deformable particle is pushed inside (stability.rigid_penetration)
    lattices: list | None = None  # rigid_lattices, built at the first check

    kind = "rigid particles"
    find_inside = None  # inside_rigid's stand-in, when the particles are on a GPU (mpmsim/gpu/step.py)

    @property
    def n(self) -> int:
        return len(self.vol)

    def view(self) -> RigidView:
        return RigidView(self.x, self.v, self.vol, self.x0)

    @classmethod
    def from_seed(cls, seed, materials, infos: list[BodyInfo], dim: int, watch: bool = True) -> "RigidParticles":
        nr = len(materials.rigid)
        v0 = np.array([m.velocity(0.0) for m in materials.motions]).reshape(nr, dim)
        return cls(seed.x.copy(), seed.v.copy(), seed.vol.copy(), seed.mat.copy(), seed.body.copy(), seed.x.copy(),
                   v0, v0.copy(), np.zeros((nr, dim)), list(materials.rigid), infos, watch)

    def history_columns(self, units, dim: int) -> list[tuple[str, str]]:
        cols = []
        for r in self.names:
            cols += [(f"F_{r}_{a}", units.force) for a in "xyz"[:dim]]
            cols += [(f"J_{r}_{a}", units.momentum.split(" (")[0]) for a in "xyz"[:dim]]
            cols += [(f"u_{r}_{a}", units.length) for a in "xyz"[:dim]]
        return cols

    def history_values(self, state) -> list[float]:
        row = []
        for r in range(len(self.names)):
            row += list(state.reaction[6 + r]) + list(state.impulse[6 + r]) + list(self.disp[r])
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
            "mass": np.zeros(n),
            "volume": self.vol,
        }
        return [("rigid", {"points": pad3(self.x), "point_data": data})]

    def check(self, state, units) -> tuple[str, str] | None:
        """A rigid material whose particles (or their shape-function support) left the grid, or
        a deformable particle inside a rigid body (pushed into it: contact must never allow it)."""
        if self.n == 0:
            return None
        g = state.grid
        out = np.any((self.x < g.domain_lo) | (self.x > g.domain_hi), axis=1)
        if state.flags.bad_rigid >= 0:
            out[state.flags.bad_rigid] = True
        if out.any():
            name = self.names[int(self.mat[np.argmax(out)])]
            return "stopped", f"rigid material '{name}' left the grid domain; enlarge grid.domain"
        P = state.particles
        if P.n == 0 or not self.watch_penetration:
            return None
        origin, spacing = g.origin[: g.dim], 2.0 * P.semi
        if self.lattices is None:  # built once: the lattices depend on the start positions only
            self.lattices = rigid_lattices(self, origin, spacing)
        finder = self.find_inside or inside_rigid  # (a GPU run looks on the device)
        p, q = finder(P.x, self, origin, spacing, self.lattices)
        if p < 0:
            return None
        return "stopped", (f"{P.describe(state, p, units)} is inside rigid material '{self.names[int(self.mat[q])]}' "
                           f"(body '{self.body_name(int(self.body[q]))}'): it was pushed through; a smaller "
                           "time.cfl, or a slower prescribed motion, keeps contact")


def inside_rigid(x: np.ndarray, rigid: "RigidParticles", origin: np.ndarray, spacing: np.ndarray,
                 lattices: list | None = None) -> tuple[int, int]:
    """(p, q): the first deformable particle p whose centre lies inside a rigid body, with q a
    rigid particle of that body there; (-1, -1) if none. Inside means within a cell of the
    rigid body's own particle lattice whose 2^dim corners are all its particles: more than half
    a particle spacing past its surface (grid contact lets a centre cross the surface by less,
    so only a particle pushed into the body is caught). A rigid body one particle thick has
    no such cells and is not watched. The lattice moves with the rigid material's displacement;
    `lattices` (rigid_lattices, which depend only on the start positions) saves building them."""
    if lattices is None:
        lattices = rigid_lattices(rigid, origin, spacing)
    for r, lo, span, owner in lattices:
        p, q = _first_inside(x, origin + rigid.disp[r], spacing, lo, span, owner)
        if p >= 0:
            return p, q
    return -1, -1


def rigid_lattices(rigid: "RigidParticles", origin: np.ndarray, spacing: np.ndarray) -> list:
    """[(rigid material, lowest lattice index, extent, owner of each site (flat, -1: none))] of
    the rigid materials with at least 2^dim particles, from their start positions."""
    dim = rigid.x0.shape[1]
    out = []
    for r in range(len(rigid.names)):
        mine = np.flatnonzero(rigid.mat == r)
        if len(mine) < 2 ** dim:
            continue
        k = np.rint((rigid.x0[mine] - origin) / spacing - 0.5).astype(np.int64)
        lo = k.min(axis=0)
        span = k.max(axis=0) - lo + 1
        owner = np.full(tuple(span), -1, dtype=np.int64)
        owner[tuple((k - lo).T)] = mine
        out.append((r, lo, span, owner.ravel()))
    return out


@njit(cache=True)
def _first_inside(x, origin, spacing, lo, span, owner):
    """The first particle in a lattice cell (origin, spacing; cells lo .. lo + span - 1, C order
    in `owner`) whose 2^dim corner sites are all owned (>= 0): (particle, owner of the cell's
    lowest corner), or (-1, -1)."""
    n, dim = x.shape
    k = np.zeros(3, np.int64)
    # the lattice's cells with one spacing to spare on each side: a particle outside this box
    # fails the exact test below, which the box spares most particles (a divide and a floor an axis)
    near_lo, near_hi = np.zeros(3), np.zeros(3)
    for a in range(dim):
        near_lo[a] = origin[a] + (lo[a] - 0.5) * spacing[a]
        near_hi[a] = origin[a] + (lo[a] + span[a] + 0.5) * spacing[a]
    for p in range(n):
        inside = True
        for a in range(dim):
            if not (x[p, a] >= near_lo[a] and x[p, a] <= near_hi[a]):
                inside = False
                break
        if not inside:
            continue
        for a in range(dim):
            k[a] = int(np.floor((x[p, a] - origin[a]) / spacing[a] - 0.5)) - lo[a]
            if k[a] < 0 or k[a] + 1 >= span[a]:
                inside = False
                break
        if not inside:
            continue
        for c in range(2 ** dim):
            flat = 0
            for a in range(dim):
                flat = flat * span[a] + k[a] + ((c >> a) & 1)
            if owner[flat] < 0:
                inside = False
                break
        if inside:
            flat = 0
            for a in range(dim):
                flat = flat * span[a] + k[a]
            return p, owner[flat]
    return -1, -1
