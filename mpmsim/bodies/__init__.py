"""Bodies: what each kind of body brings to a run.

A scene is a list of bodies in deck order; each body is of one *kind*. All bodies of a kind
share one struct-of-arrays set in the state (a `BodySet`), with a per-item body index, so
kernels run over the whole set at once. A kind brings:

- its state arrays (the dataclass fields of its set),
- its sums for the history and the energy check (`sums`: totals over the set and one row per
  body, in the `Sums` layout below),
- its history columns beyond those sums (`history_columns` / `history_values`),
- its part of the output time series (`vtu_pieces`: named point/cell sets; pieces of the same
  part from several kinds are written as one file),
- its own checks after a step (`check`: a stop message or None),
- how many points a step advances (`stepped`) and its explicit step bound (`stable_dt`).

Kinds today: deformable particles (`particles.Particles`), rigid particles
(`rigid.RigidParticles`) and FEM meshes (`fem.FemBodies`). A new kind (a rigid mesh) is a new
`BodySet` subclass: the history, the output, the explicit step bound and the run loop ask every
set in `state.bodies` the same questions and need no change.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# layout of a sums row (totals of a set, or one body): volume-integrated Cauchy stress
# [xx, yy, zz, xy, yz, xz], volume, kinetic, strain and internal energy, linear and angular
# momentum (about the origin; with APIC's affine part), mass, first moment of mass sum m x
STRESS, VOLUME, KINETIC, STRAIN, MOMENTUM, INTERNAL = slice(0, 6), 6, 7, 8, slice(9, 12), 12
ANGULAR, MASS, FIRST_MOMENT = slice(13, 16), 16, slice(17, 20)
NSUMS = 20


@dataclass(frozen=True)
class BodyInfo:
    """One deck body: its index in the deck's `bodies` list, its name, its kind."""

    index: int
    name: str
    kind: str
    material: str | None = None  # the deck body's material (None: an image body of several)


@dataclass
class Sums:
    """Totals over a body set and one row per body (same layout, `NSUMS` entries)."""

    total: np.ndarray  # (NSUMS,)
    per_body: np.ndarray  # (n_bodies, NSUMS), rows in the set's `bodies` order


class BodySet:
    """Base of every body kind's state. Subclasses are dataclasses of arrays."""

    kind = "body"
    has_mass = False  # whether `sums` returns sums (else None)

    @property
    def bodies(self) -> list[BodyInfo]:
        """The deck bodies this set holds."""
        return self.infos

    def body_name(self, index: int) -> str:
        """The name of deck body `index` (its `name`, or body<index>)."""
        return next((i.name for i in self.infos if i.index == index), f"body{index}")

    def sums(self, state, detail: bool = True) -> Sums | None:
        """Mass-carrying kinds return their sums; kinds without mass (prescribed rigid motion)
        return None. detail=False: only the energies, momentum, stress and volume of the total
        (the energy check), nothing per body."""
        return None

    def history_columns(self, units, dim: int) -> list[tuple[str, str]]:
        return []

    def history_values(self, state) -> list[float]:
        return []

    def vtu_pieces(self, state) -> list[tuple[str, dict]]:
        """[(part name, piece)]: a piece is {"points": (n, 3), "cells": [(type, array)] or None
        for vertex cells, "point_data": {...}, "cell_data": {...}}."""
        return []

    def check(self, state, units) -> tuple[str, str] | None:
        """(verb, what) if something of this set went bad this step, else None; the run stops
        with "<verb> at <step and time>: <what>"."""
        return None

    def fastest(self, state, units) -> str | None:
        """Where this set moves fastest (for an energy-growth stop message), or None."""
        return None

    @property
    def stepped(self) -> int:
        """How many points a step advances (the unit of the run's speed): deformable particles,
        FEM elements; 0 for prescribed motion."""
        return 0

    def stable_dt(self, state, cfl: float) -> float:
        """The largest explicit step this set allows now at Courant number cfl (inf: no bound of
        its own; the particles' bound is the grid's, integrators.explicit)."""
        return np.inf
