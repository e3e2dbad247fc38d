"""The deck's run settings, resolved once for everything below the scene (state, integrators,
tasks): the validated records of `update`, `time`, `output`, `stability` and `implicit`, and
the values the step uses (gravity, grid damping, shape function, boundary conditions, loads).
The records are read-only data; nothing below the scene holds the deck itself."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..deck.schema import Implicit


@dataclass(frozen=True)
class RunSettings:
    title: str
    dim: int  # 2 (plane strain) or 3
    integrator: str  # explicit or implicit
    units: str  # the deck's unit system name (mpmsim/deck/units.py)
    shape_function: str
    update: object  # deck.schema.Update
    time: object  # deck.schema.Time
    output: object  # deck.schema.Output
    stability: object  # deck.schema.Stability
    implicit: Implicit  # the deck's, or the defaults
    boundaries: object  # deck.schema grid boundaries (a face name -> condition); None without a grid
    gravity: np.ndarray  # (dim,) zeros without gravity
    damping: float  # grid damping alpha (1/time)
    loads: list  # the deck's traction loads
    artificial_viscosity: bool
    axisymmetric: bool = False  # x = r, y = z: masses, volumes and forces per radian (docs/axisymmetric.md)
    gravity_ramp: float = 0.0  # time over which gravity grows from zero (0: whole from the start)

    @property
    def has_gravity(self) -> bool:
        return bool(np.any(self.gravity != 0.0))


def run_settings(deck) -> RunSettings:
    g = np.zeros(deck.dim)
    if deck.gravity is not None:
        g[:] = deck.gravity
    implicit = deck.implicit if deck.implicit is not None else Implicit()
    if implicit.particle_quadrature == "auto":  # resolved here: domain averages where point values lose order
        odd = deck.particles_per_direction % 2 == 1
        implicit = implicit.model_copy(update={"particle_quadrature": "domain" if odd else "points"})
    return RunSettings(deck.title, deck.dim, deck.integrator, deck.units, deck.shape_function, deck.update, deck.time,
                       deck.output, deck.stability, implicit,
                       deck.grid.boundaries if deck.grid is not None else None, g,
                       deck.damping.grid if deck.damping is not None else 0.0, list(deck.loads),
                       deck.artificial_viscosity is not None, deck.analysis == "axisymmetric", deck.gravity_ramp)
