"""The bodies' energy terms of the implicit step (mpmsim/energy.py: the interface): the strain
energy of the FEM elements and of the MPM particles, and gravity. The unknowns are the FEM
nodes, rows [0, nf), then the particle bodies' active grid nodes, rows [nf, nf + n_grid)."""

from __future__ import annotations

import numpy as np

from ..contact.barrier import DET_FRACTION, det_step_bound, triangle_step_bound
from ..energy import Blocks, Derivatives, Potential, StepStart
from ..fem import elements


class FemStrain(Potential):
    """Psi_FEM = sum_e vol0_e psi(F_e) over the FEM elements (mpmsim/fem/elements.py); its step
    bound keeps every triangle's det F > 0 (2D)."""

    name = "FEM strain energy"

    def __init__(self, fem, materials):
        self.fem, self.materials = fem, materials
        self.nf = fem.n

    def _args(self, y):
        fem, m = self.fem, self.materials
        return y[:self.nf], fem.cells, fem.Dm_inv, fem.vol0, fem.cell_mat, m.type_code, m.props

    def value(self, y):
        e = np.empty(len(self.fem.cells))
        elements.element_energies(*self._args(y), e)
        return float(e.sum())

    def forces(self, y):
        """The elements' nodal forces -dPsi/dx (nf, d)."""
        f = np.zeros((self.nf, y.shape[1]))
        elements.internal_forces(*self._args(y), f)
        return f

    def derivatives(self, y, force, exact=False):
        force[:self.nf] += self.forces(y)
        if not len(self.fem.cells):
            return Derivatives((), ())
        d = y.shape[1]
        local = np.empty((len(self.fem.cells), (d + 1) * d, (d + 1) * d))  # every entry written
        elements.element_hessians(*self._args(y), not exact, local)
        return Derivatives((), (Blocks(self.fem.cells, local),))

    def step_bound(self, y, p):
        if len(self.fem.cells) and y.shape[1] == 2:
            return triangle_step_bound(y[:self.nf], p[:self.nf], self.fem.cells, DET_FRACTION)
        return 1.0


class ParticleStrain(Potential):
    """Psi_MPM = sum_p vol0_p psi(F_p(y)) over the particles, each an element over its grid nodes
    (integrators/implicit_mpm.GridUnknowns); its step bound keeps every particle's det F > 0."""

    name = "particle strain energy"

    def __init__(self, grid, materials, nf: int):
        self.grid, self.materials, self.nf = grid, materials, nf
        self.rows = None  # the particles' grid nodes as rows of y, for the step

    def begin(self, step: StepStart):
        self.rows = self.nf + self.grid.nodes

    def value(self, y):
        return self.grid.energy(y[self.nf:] - self.grid.X, self.materials)

    def derivatives(self, y, force, exact=False):
        grid, nf = self.grid, self.nf
        u = y[nf:] - grid.X
        force[nf:] += grid.forces(u, self.materials)
        return Derivatives((), (Blocks(self.rows, grid.hessians(u, self.materials, not exact)),))

    def step_bound(self, y, p):
        grid = self.grid
        # (every argument given: a call that leaves a default to numba takes its slow dispatch, ~0.25 ms)
        return det_step_bound(grid.deformation(y[self.nf:] - grid.X), grid.deformation(p[self.nf:]) - grid.F0,
                              DET_FRACTION)


class Gravity(Potential):
    """-sum_i m_i g . y_i (the unknowns' lumped masses of this step)."""

    name = "gravity"

    def __init__(self, gravity: np.ndarray):
        self.gravity = gravity
        self.weight = None

    def begin(self, step: StepStart):
        self.weight = step.mass[:, None] * self.gravity[None, :]

    def value(self, y):
        return -float(np.sum(self.weight * y))

    def derivatives(self, y, force, exact=False):
        force += self.weight
        return Derivatives((), ())
