"""Velocity Verlet on FEM nodes with per-component constraints and gravity.

State as arrays: x, v, a (n, d); mass (n,) lumped; held (n, d) bool, a component moving at
the prescribed velocity held_velocity (n, d) (zero for a fixed one); gravity (d,).
One step (the augury contact paper's scheme; contact corrections go between the pieces):

    half_kick(v, a, dt, held, held_velocity)      # v^{n+1/2} = v^n + dt/2 a^n
    drift(x, v, dt)                               # x^{n+1} = x^n + dt v^{n+1/2}
    elements.internal_forces(x, ..., f)
    accelerations(f, mass, gravity, held, a)      # a^{n+1} = f/m + g, 0 on held components
    half_kick(v, a, dt, held, held_velocity)      # v^{n+1} = v^{n+1/2} + dt/2 a^{n+1}

With internal forces alone the scheme conserves linear momentum and (the energy being
rotation invariant) angular momentum to rounding, and is symplectic (bounded energy error)
for dt below the stable step (elements.stable_time_step). A prescribed velocity that changes
in time is updated by the caller in held_velocity before the kicks.

Loops are serial over nodes: each is one pass over memory, no scatter.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..linalg import dot, weighted_rows

__all__ = ["accelerations", "angular_momentum", "drift", "half_kick", "kinetic_energy", "linear_momentum"]


@njit(cache=True)
def accelerations(f, mass, gravity, held, a):
    """a = f / m + g on free components, 0 on held ones (and on massless nodes)."""
    n, d = f.shape
    for i in range(n):
        m = mass[i]
        for c in range(d):
            if held[i, c] or not (m > 0.0):
                a[i, c] = 0.0
            else:
                a[i, c] = f[i, c] / m + gravity[c]


@njit(cache=True)
def half_kick(v, a, dt, held, held_velocity):
    """v += dt/2 a on free components; held components are set to their prescribed velocity."""
    n, d = v.shape
    h = 0.5 * dt
    for i in range(n):
        for c in range(d):
            if held[i, c]:
                v[i, c] = held_velocity[i, c]
            else:
                v[i, c] += h * a[i, c]


@njit(cache=True)
def drift(x, v, dt):
    """x += dt v."""
    n, d = x.shape
    for i in range(n):
        for c in range(d):
            x[i, c] += dt * v[i, c]


def kinetic_energy(mass: np.ndarray, v: np.ndarray) -> float:
    """1/2 sum m |v|^2 (2D: per unit thickness)."""
    return 0.5 * float(np.einsum("i,ij,ij->", mass, v, v))


def linear_momentum(mass: np.ndarray, v: np.ndarray) -> np.ndarray:
    """sum m v, shape (d,)."""
    return weighted_rows(mass, v)


def angular_momentum(mass: np.ndarray, x: np.ndarray, v: np.ndarray, about=None) -> np.ndarray:
    """sum m (x - about) x v: shape (1,) in 2D (the z component), (3,) in 3D."""
    r = x if about is None else x - np.asarray(about, float)
    if x.shape[1] == 2:
        return np.array([float(dot(mass, r[:, 0] * v[:, 1] - r[:, 1] * v[:, 0]))])
    return weighted_rows(mass, np.cross(r, v))
