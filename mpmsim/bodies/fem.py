"""FEM bodies: linear triangles (2D plane strain) and tetrahedra (3D) with lumped masses,
advanced by velocity Verlet (mpmsim/tasks/fem.py), in contact through APIC augury transfers
of their boundary nodes (mpmsim/contact/augury/transfers.py).

All FEM bodies of a deck share one set of node and cell arrays with a body index. Boundary
nodes carry the augury's affine part B (APIC) and its rate; its kinetic energy
1/2 m tr(B D^-1 B^T) counts in the body's kinetic energy and its angular momentum m eps:B in
the body's angular momentum. In 2D masses, volumes, energies and forces are per the deck's
thickness, as the particles' are.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from .. import linalg
from ..fem import elements
from ..fem.mesh import node_normal_kernel
from . import (ANGULAR, FIRST_MOMENT, INTERNAL, KINETIC, MASS, MOMENTUM, NSUMS, STRAIN, STRESS, VOLUME, BodySet,
               Sums)
from .particles import angular_density, pad3


# a node counts as inside another body when every barycentric coordinate of it in one of that
# body's elements exceeds this: 1% of the element deep, beyond the near-zero gap at which
# APIC augury contact holds bodies (touching bodies are not flagged)
CROSSING_DEPTH = 0.01


@dataclass
class FemBodies(BodySet):
    X: np.ndarray  # (n, dim) reference positions
    x: np.ndarray  # (n, dim)
    v: np.ndarray  # (n, dim)
    a: np.ndarray  # (n, dim) acceleration of the last force evaluation (mechanical + contact)
    a_contact: np.ndarray  # (n, dim) its contact (augury) part
    mass: np.ndarray  # (n,) lumped
    cells: np.ndarray  # (m, dim + 1)
    cell_body: np.ndarray  # (m,) row in infos
    cell_mat: np.ndarray  # (m,) deformable material index
    node_body: np.ndarray  # (n,) row in infos
    node_mat: np.ndarray  # (n,) deformable material index of each node (FemSeed.node_mat)
    Dm_inv: np.ndarray  # (m, dim, dim)
    vol0: np.ndarray  # (m,) reference volume (2D: area x thickness)
    held: np.ndarray  # (n, dim) bool
    held_velocity: np.ndarray  # (n, dim)
    facets: np.ndarray  # (b, dim) outward boundary edges / triangles
    boundary: np.ndarray  # (nb,) boundary nodes (the augury particles)
    B: np.ndarray  # (nb, dim, dim) APIC affine part of the boundary nodes
    Bdot: np.ndarray  # (nb, dim, dim) its rate from the last contact evaluation
    Dinv: np.ndarray  # (nb, 3, 3) D_p^-1 of the last augury transfer (affine kinetic energy)
    contact_work: np.ndarray  # (n_bodies,) work of the contact forces on each body since t = 0
    force: np.ndarray  # (n, dim) scratch: internal forces
    infos: list  # BodyInfo of each FEM body
    thickness: float
    bad_element: int = -1  # an element with J <= 0 this step (-1: none)
    started: bool = False  # the first accelerations are evaluated
    check_crossing: bool = True  # stop when a boundary node ends inside another body
    check_every: int = 10
    crossing_depth: float = CROSSING_DEPTH  # barycentric depth a boundary node may sit inside another body
    particle_contact_work: float = 0.0  # implicit runs: work of the contact forces on the particle bodies

    kind = "fem"
    has_mass = True

    @property
    def n(self) -> int:
        return len(self.mass)

    @property
    def stepped(self) -> int:
        return len(self.cells)

    def stable_dt(self, state, cfl: float) -> float:
        """cfl x the smallest element's h / c at the current positions."""
        m = state.materials
        return cfl * elements.stable_time_step(self.x, self.cells, self.cell_mat, m.props, m.density)

    @classmethod
    def from_seed(cls, seed, materials, thickness: float, dim: int) -> "FemBodies":
        scale = thickness if dim == 2 else 1.0
        Dm_inv, vol0 = elements.reference_geometry(seed.points, seed.cells)
        vol0 = vol0 * scale
        mass = elements.lumped_masses(seed.cells, vol0, seed.cell_mat, materials.density, len(seed.points))
        boundary = np.unique(seed.facets)
        nb = len(boundary)
        return cls(seed.points.copy(), seed.points.copy(), seed.velocity.copy(), np.zeros_like(seed.points),
                   np.zeros_like(seed.points), mass, seed.cells, seed.cell_body, seed.cell_mat, seed.node_body,
                   seed.node_mat, Dm_inv,
                   vol0, seed.held, seed.held_velocity, seed.facets, boundary, np.zeros((nb, dim, dim)),
                   np.zeros((nb, dim, dim)), np.zeros((nb, 3, 3)), np.zeros(len(seed.infos)),
                   np.zeros_like(seed.points), list(seed.infos), float(scale))

    def normals(self) -> np.ndarray:
        """(nb, dim) outward unit normals of the boundary nodes at the current positions."""
        out = np.zeros_like(self.x)
        node_normal_kernel(self.x, self.facets, out)
        return out[self.boundary]

    def element_stresses(self, state):
        """(Cauchy stress (m, 6), J (m,)) of every element."""
        m = state.materials
        dim = self.x.shape[1]
        stress = np.zeros((len(self.cells), 6))
        elements.cauchy_stresses(self.x, self.cells, self.Dm_inv, self.cell_mat, m.type_code, m.props, stress)
        F = np.zeros((len(self.cells), dim, dim))
        elements.deformation_gradients(self.x, self.cells, self.Dm_inv, F)
        return stress, linalg.det(F)

    def energy_densities(self, state) -> np.ndarray:
        """(m,) strain energy of each element (vol0 psi)."""
        m = state.materials
        out = np.zeros(len(self.cells))
        elements.element_energies(self.x, self.cells, self.Dm_inv, self.vol0, self.cell_mat, m.type_code, m.props,
                                  out)
        return out

    def affine_energy(self) -> np.ndarray:
        """(nb,) kinetic energy of the boundary nodes' affine part, 1/2 m tr(B D^-1 B^T)."""
        if not self.B.size:
            return np.zeros(0)
        dim = self.x.shape[1]
        Di = self.Dinv[:, :dim, :dim]
        return 0.5 * self.mass[self.boundary] * np.einsum("pab,pbc,pac->p", self.B, Di, self.B)

    def sums(self, state, detail: bool = True) -> Sums:
        dim = self.x.shape[1]
        energy = self.energy_densities(state)
        ke_nodes = 0.5 * self.mass * np.sum(self.v**2, axis=1)
        ke_aff = self.affine_energy()
        total = np.zeros(NSUMS)
        total[KINETIC] = ke_nodes.sum() + ke_aff.sum()
        total[STRAIN] = energy.sum()
        total[MOMENTUM.start:MOMENTUM.start + dim] = linalg.weighted_rows(self.mass, self.v)
        if detail:
            stress, J = self.element_stresses(state)
            vol = J * self.vol0
            total[STRESS] = linalg.weighted_rows(vol, stress)
            total[VOLUME] = vol.sum()
            B = np.zeros((self.n, dim, dim))
            B[self.boundary] = self.B
            L = self.mass[:, None] * angular_density(self.x, self.v, B)
            total[ANGULAR] = L.sum(axis=0)
            total[MASS] = self.mass.sum()
            total[FIRST_MOMENT.start:FIRST_MOMENT.start + dim] = linalg.weighted_rows(self.mass, self.x)
        total[INTERNAL] = 0.0
        nb = len(self.infos)
        rows = np.zeros((nb if detail else 0, NSUMS))
        if detail:
            count = lambda idx, w: np.bincount(idx, weights=w, minlength=nb)  # noqa: E731
            nodes = self.node_body
            rows[:, KINETIC] = count(nodes, ke_nodes) + count(nodes[self.boundary], ke_aff)
            rows[:, STRAIN] = count(self.cell_body, energy)
            rows[:, MASS] = count(nodes, self.mass)
            rows[:, VOLUME] = count(self.cell_body, vol)
            for d in range(dim):
                rows[:, MOMENTUM.start + d] = count(nodes, self.mass * self.v[:, d])
                rows[:, FIRST_MOMENT.start + d] = count(nodes, self.mass * self.x[:, d])
            for a in range(3):
                rows[:, ANGULAR.start + a] = count(nodes, L[:, a])
        return Sums(total, rows)

    def history_columns(self, units, dim: int) -> list[tuple[str, str]]:
        return [(f"contact_work_{b.name}", units.energy) for b in self.infos] + [("contact_dissipated", units.energy)]

    def history_values(self, state) -> list[float]:
        return list(self.contact_work) + [-float(self.contact_work.sum()) - self.particle_contact_work]

    def vtu_pieces(self, state) -> list[tuple[str, dict]]:
        mats, dim = state.materials, self.x.shape[1]
        stress, J = self.element_stresses(state)
        gid = np.array([mats.global_id(m) for m in mats.deformable], dtype=np.int32)
        body = np.array([b.index for b in self.infos], dtype=np.int32)
        kind = "triangle" if dim == 2 else "tetra"
        piece = {
            "points": pad3(self.x),
            "cells": [(kind, self.cells)],
            "point_data": {"displacement": pad3(self.x - self.X), "velocity": pad3(self.v),
                           "body": body[self.node_body], "held": self.held.any(axis=1).astype(np.uint8)},
            "cell_data": {"stress": [stress], "strain_energy_density": [self.energy_densities(state) / self.vol0],
                          "J": [J], "material": [gid[self.cell_mat]], "body": [body[self.cell_body]]},
        }
        return [("fem", piece)]

    def describe_element(self, state, e: int, units) -> str:
        name = state.materials.deformable[int(self.cell_mat[e])]
        body = self.infos[int(self.cell_body[e])].name
        centre = ", ".join(f"{c:.6g}" for c in self.x[self.cells[e]].mean(axis=0))
        return f"element {e} (material '{name}', body '{body}') at ({centre}) {units.length}"

    def crossing(self, depth: float | None = None) -> tuple[int, int]:
        """(boundary node, element of another body it is inside of by more than `depth` in
        barycentric terms; default crossing_depth), or (-1, -1)."""
        if len(self.infos) < 2:
            return -1, -1
        depth = self.crossing_depth if depth is None else depth
        p, e = first_crossing(self.x, self.cells, self.cell_body, self.boundary, self.node_body, depth)
        return int(p), int(e)

    def check(self, state, units) -> tuple[str, str] | None:
        if self.check_crossing and state.step % self.check_every == 0:  # from the first step on
            p, e = self.crossing()
            if p >= 0:
                a, b = self.infos[int(self.node_body[p])].name, self.infos[int(self.cell_body[e])].name
                return "stopped", (f"bodies '{a}' and '{b}' interpenetrate: node {p} of '{a}' is inside "
                                   f"{self.describe_element(state, e, units)} by more than "
                                   f"{self.crossing_depth:g} of the element (contact lost its repulsion; try a "
                                   "coarser contact.augury.cell_size, PIC transfers or a lower impact speed; "
                                   "contact.augury.overlap_tolerance accepts deeper overlaps)")
        if self.bad_element >= 0:
            return "unstable", f"{self.describe_element(state, self.bad_element, units)}: J <= 0, the element inverted"
        if not (np.isfinite(self.x).all() and np.isfinite(self.v).all()):
            i = int(np.argmax(~(np.isfinite(self.x).all(axis=1) & np.isfinite(self.v).all(axis=1))))
            return "unstable", f"FEM node {i} (body '{self.infos[int(self.node_body[i])].name}'): position or " \
                               "velocity is not finite (NaN/Inf)"
        return None

    def fastest(self, state, units) -> str | None:
        i = int(np.argmax(np.sum(self.v**2, axis=1)))
        pos = ", ".join(f"{c:.6g}" for c in self.x[i])
        return f"FEM node {i} (body '{self.infos[int(self.node_body[i])].name}') at ({pos}) {units.length}"


@njit(cache=True)
def first_crossing(x, cells, cell_body, boundary, node_body, depth):
    """(node, element) of the first boundary node that lies inside an element of another body
    by more than `depth` in barycentric terms (every barycentric coordinate > depth), or
    (-1, -1). Elements are binned into a uniform grid of their largest extent, so each node
    is tested against the few elements near it."""
    m, k = cells.shape
    dim = x.shape[1]
    lo = np.full(dim, np.inf)
    hi = np.full(dim, -np.inf)
    size = 0.0
    for e in range(m):
        for a in range(dim):
            emin, emax = np.inf, -np.inf
            for c in range(k):
                emin = min(emin, x[cells[e, c], a])
                emax = max(emax, x[cells[e, c], a])
            lo[a] = min(lo[a], emin)
            hi[a] = max(hi[a], emax)
            size = max(size, emax - emin)
    if not (size > 0.0) or not np.all(np.isfinite(lo)):
        return -1, -1
    n_cells = np.ones(3, dtype=np.int64)
    for a in range(dim):
        n_cells[a] = int((hi[a] - lo[a]) / size) + 1
    total = n_cells[0] * n_cells[1] * n_cells[2]
    count = np.zeros(total + 1, dtype=np.int64)
    home = np.zeros(m, dtype=np.int64)
    for e in range(m):  # each element in the bin of its first node; neighbours cover the rest
        idx = 0
        stride = 1
        for a in range(dim):
            idx += min(int((x[cells[e, 0], a] - lo[a]) / size), n_cells[a] - 1) * stride
            stride *= n_cells[a]
        home[e] = idx
        count[idx + 1] += 1
    for b in range(total):
        count[b + 1] += count[b]
    order = np.zeros(m, dtype=np.int64)
    fill = count[:-1].copy()
    for e in range(m):
        order[fill[home[e]]] = e
        fill[home[e]] += 1
    T = np.zeros((3, 3))
    rhs = np.zeros(3)
    for q in range(boundary.size):
        p = boundary[q]
        cell = np.zeros(3, dtype=np.int64)
        outside = False
        for a in range(dim):
            c = int(np.floor((x[p, a] - lo[a]) / size))
            if c < -1 or c > n_cells[a]:
                outside = True
            cell[a] = c
        if outside:
            continue
        for di in range(-1, 2):
            for dj in range(-1, 2):
                for dk in range(-1, 2) if dim == 3 else range(0, 1):
                    ci, cj, ck = cell[0] + di, cell[1] + dj, cell[2] + dk
                    if ci < 0 or cj < 0 or ck < 0 or ci >= n_cells[0] or cj >= n_cells[1] or ck >= n_cells[2]:
                        continue
                    b = ci + n_cells[0] * (cj + n_cells[1] * ck)
                    for s in range(count[b], count[b + 1]):
                        e = order[s]
                        if cell_body[e] == node_body[p]:
                            continue
                        if inside_element(x, cells, e, p, depth, T, rhs):
                            return p, e
    return -1, -1


@njit(cache=True)
def inside_element(x, cells, e, p, depth, T, rhs):
    """Whether point x[p] is inside element e with every barycentric coordinate > depth."""
    dim = x.shape[1]
    i0 = cells[e, 0]
    for a in range(dim):
        for c in range(dim):
            T[a, c] = x[cells[e, c + 1], a] - x[i0, a]
        rhs[a] = x[p, a] - x[i0, a]
    if dim == 2:
        det = T[0, 0] * T[1, 1] - T[0, 1] * T[1, 0]
        if det == 0.0:
            return False
        l1 = (rhs[0] * T[1, 1] - rhs[1] * T[0, 1]) / det
        l2 = (T[0, 0] * rhs[1] - T[1, 0] * rhs[0]) / det
        return l1 > depth and l2 > depth and 1.0 - l1 - l2 > depth
    det = (T[0, 0] * (T[1, 1] * T[2, 2] - T[1, 2] * T[2, 1]) - T[0, 1] * (T[1, 0] * T[2, 2] - T[1, 2] * T[2, 0])
           + T[0, 2] * (T[1, 0] * T[2, 1] - T[1, 1] * T[2, 0]))
    if det == 0.0:
        return False
    lam = np.zeros(3)
    for c in range(3):  # Cramer's rule
        M = T.copy()
        for a in range(3):
            M[a, c] = rhs[a]
        lam[c] = (M[0, 0] * (M[1, 1] * M[2, 2] - M[1, 2] * M[2, 1]) - M[0, 1] * (M[1, 0] * M[2, 2] - M[1, 2] * M[2, 0])
                  + M[0, 2] * (M[1, 0] * M[2, 1] - M[1, 1] * M[2, 0])) / det
    return lam[0] > depth and lam[1] > depth and lam[2] > depth and 1.0 - lam[0] - lam[1] - lam[2] > depth
