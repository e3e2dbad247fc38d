"""Energy terms of an incremental potential: the seam through which physics enters an implicit
step. The implicit integrator (mpmsim/integrators/implicit.py) minimises

    E(y) = 1/2 (y - y~)^T M (y - y~) + c sum_terms Phi_term(y)

over the unknowns y (n, d) and knows each term only through the interface below; strain energy
(FEM elements, MPM particles), gravity, barrier contact and lagged friction are terms
(mpmsim/integrators/terms.py, mpmsim/contact/barrier/energy.py). A term:

    begin(step)            once per time step, before the solve (StepStart: state, y^n, masses, dt)
    sweep(y, p)            the active set for positions y + alpha p, alpha in [0, 1] (contact
                           pairs from a swept broad phase); the next value/derivatives use it
    value(y)               Phi_term(y) (inf where y is infeasible: an inverted element, a touch)
    derivatives(y, force, exact=False)
                           after value(y): adds its nodal forces (minus a dense gradient) into
                           `force` (n, d) and returns Derivatives: local gradients to scatter and
                           the PSD-projected Hessian as local blocks (Blocks) or triplets, both
                           unscaled; with exact=True the term's own, unprojected Hessian (Newton's
                           last iterations). A term without the `exact` argument is always asked
                           for its one Hessian.
    step_bound(y, p)       the largest alpha in (0, 1] that keeps y + alpha p feasible
    relag(y)               lagged terms only (lagged = True): re-evaluate the lagged quantities
                           at y; returns whether the term is still active

`ccd = True` marks a term whose step bound is a collision bound (the Newton table counts the
steps it limited). The integrator sums values in the terms' order, so the order of the list is
part of the result to the last bit.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Triplets(NamedTuple):
    """A sparse matrix as (rows, cols, values) over the unknowns' DOFs (node d + component),
    duplicates to be summed. The integrator's pattern holds whole d x d node blocks: a triplet
    brings its node pair's block in (energy.triplets gives whole blocks anyway)."""

    rows: np.ndarray
    cols: np.ndarray
    vals: np.ndarray


class Blocks(NamedTuple):
    """Local Hessians of g groups of unknowns: group q couples the k unknowns nodes[q] (rows of
    y); its matrix local[q] is node-major ((n d) square over n local nodes). Unweighted
    (weights None): n = k and the (a, b) d x d block of the global matrix gets local[q]'s (a, b)
    block. Weighted: unknown a stands for local node block[a] with weight weights[q, a] (a
    contact point interpolated from grid nodes), and the (a, b) block gets weights[q, a]
    weights[q, b] times local[q]'s (block[a], block[b]) block. The integrator keeps the matrix
    pattern (and its symbolic factorisation) while every bundle's node lists stay the same:
    return the same array object for node lists that do not change, and never modify one in
    place."""

    nodes: np.ndarray  # (g, k) int
    local: np.ndarray  # (g, n d, n d)
    weights: np.ndarray | None = None  # (g, k)
    block: np.ndarray | None = None  # (k,) int


class Scatter(NamedTuple):
    """Local gradients G (k, m, d) of k groups of m unknowns `nodes` (k, m), to be summed into
    the global gradient."""

    nodes: np.ndarray
    G: np.ndarray


class Derivatives(NamedTuple):
    local: tuple  # Scatter, ...
    hessian: tuple  # Blocks or Triplets, ...


NONE = Derivatives((), ())


class StepStart(NamedTuple):
    """What a term may read when a step begins."""

    state: object
    y: np.ndarray  # (n, d) the unknowns at the step's start
    mass: np.ndarray  # (n,) lumped masses of the unknowns
    dt: float


def triplets(nodes: np.ndarray, local: np.ndarray, dim: int) -> Triplets:
    """Triplets of local node-major Hessians local (m, k d, k d) over node lists nodes (m, k)."""
    m, k = nodes.shape
    dofs = (nodes[:, :, None] * dim + np.arange(dim)[None, None, :]).reshape(m, k * dim)
    return Triplets(np.repeat(dofs, k * dim, axis=1).ravel(), np.tile(dofs, (1, k * dim)).ravel(),
                    np.asarray(local).ravel())


class Potential:
    """One term of the incremental potential (the interface above; defaults for a term without
    an active set, a step bound or lagged quantities)."""

    name = "potential"
    ccd = False
    lagged = False
    contact = False  # a force between bodies (its work is the history's contact work)

    def begin(self, step: StepStart) -> None:
        pass

    def sweep(self, y: np.ndarray, p: np.ndarray) -> None:
        pass

    def value(self, y: np.ndarray) -> float:  # pragma: no cover - every term defines it
        raise NotImplementedError

    def derivatives(self, y: np.ndarray, force: np.ndarray, exact: bool = False) -> Derivatives:  # pragma: no cover
        raise NotImplementedError

    def step_bound(self, y: np.ndarray, p: np.ndarray) -> float:
        return 1.0

    def relag(self, y: np.ndarray) -> bool:  # pragma: no cover - lagged terms define it
        raise NotImplementedError
