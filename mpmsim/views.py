"""Typed bundles of arrays that kernels take, so a signature says what a kernel works on.

Each bundle is a `typing.NamedTuple` of numpy arrays (and a few numbers); numba compiles
attribute access to a plain field load, so a kernel taking bundles runs exactly as one
taking the arrays one by one. Task code builds the bundles from the state when it calls a
kernel (a few microseconds). Contact bundles live with the contact workspace
(mpmsim/contact/grid/workspace.py).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class GridView(NamedTuple):
    """The background grid: node (i, j, k) at origin + (i, j, k) h, flat index
    i + nx (j + ny k); domain faces as velocity conditions (mpmsim/bc.py)."""

    # The node counts and domain faces are tuples of ints, not arrays: the grid loops read them
    # once per node component inside inlined helpers (bc.node_bc, bc.ghost_mirror), and numba
    # keeps an NRT incref/decref pair per array argument per such call where the helper's
    # branches stop its pruning (on the benchmark column: grid velocities 4.3x, the ghost
    # table 5.5x slower with these as arrays). A parallel loop cannot take the view whole (numba's
    # parfor lowering refuses a tuple inside a tuple argument): unpack it before the loop and
    # build it inside (contact/grid/plan.geometry_kernel).
    shape: tuple  # 3 ints: nodes per direction (nz = 1 in 2D)
    origin: np.ndarray  # (dim,)
    h: np.ndarray  # (dim,)
    face_type: tuple  # 6 ints: FREE / FIXED / ROLLER per face in FACES order
    wall_index: tuple  # 6 ints: node index of each face's grid line along its axis


class RigidHold(NamedTuple):
    """Velocity conditions of rigid materials: where each one touches, what it constrains and
    its velocity (at the step's start or end, as the caller needs)."""

    volume: np.ndarray  # (n_nodes, n_rigid) rigid volume seen by each node
    constrain: np.ndarray  # (n_rigid, dim) bool
    velocity: np.ndarray  # (n_rigid, dim)


class ActiveFields(NamedTuple):
    """The step's active fields: nodes of the active box, then material slots at contact nodes."""

    fields: np.ndarray  # field index (node, or n_nodes + slot)
    fnodes: np.ndarray  # the node of each field
    skip: np.ndarray  # bool: fields with no dynamics of their own (rigid contact slots)


class Scatter(NamedTuple):
    """Particle -> field entries in slab order, for parallel scatters (gridops.py)."""

    order: np.ndarray  # particles sorted by slab
    ptr: np.ndarray  # (n_slabs + 1,) slab starts in `order`
    fidx: np.ndarray  # (n, K) field of each particle-node entry
    S: np.ndarray  # (n, K) weights


class ParticleView(NamedTuple):
    """Deformable particle arrays (mpmsim/bodies/particles.py)."""

    x: np.ndarray
    v: np.ndarray
    mass: np.ndarray
    vol: np.ndarray
    vol0: np.ndarray
    F: np.ndarray
    stress: np.ndarray
    mat: np.ndarray
    x0: np.ndarray
    B: np.ndarray
    C: np.ndarray
    U: np.ndarray
    pressure: np.ndarray
    q: np.ndarray
    xref: np.ndarray
    mstate: np.ndarray  # (n, k) material state (history variables; k = 0 when no model keeps any)


class RigidView(NamedTuple):
    """Rigid particle arrays (mpmsim/bodies/rigid.py)."""

    x: np.ndarray
    v: np.ndarray
    vol: np.ndarray
    x0: np.ndarray


class MaterialView(NamedTuple):
    """Deformable materials as the constitutive kernels see them (mpmsim/materials)."""

    code: np.ndarray  # (m,) type code
    props: np.ndarray  # (m, NPROP) property rows
    density: np.ndarray  # (m,)
    energy: np.ndarray  # (m,) bool: carries internal energy
    av: np.ndarray  # (m, 2) artificial viscosity A1, A2


class Faults(NamedTuple):
    """Per-chunk reports of a kernel: the first bad particle (-1: none), its code and value."""

    bad: np.ndarray  # (nchunk,) int64
    code: np.ndarray  # (nchunk,) int64
    value: np.ndarray  # (nchunk,)

    @classmethod
    def empty(cls, nchunk: int) -> "Faults":
        return cls(np.full(nchunk, -1, dtype=np.int64), np.zeros(nchunk, dtype=np.int64), np.zeros(nchunk))

    def first(self):
        """(particle, code, value) of the first chunk that flagged one, or None."""
        hits = np.nonzero(self.bad >= 0)[0]
        if not len(hits):
            return None
        c = hits[0]
        return int(self.bad[c]), int(self.code[c]), float(self.value[c])
