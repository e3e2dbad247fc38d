"""Traction loads on particle edges and grid damping: the external forces of static problems.

A load acts on the outermost particle layer (toward its face) of the particles inside its
region; each carries traction x its face area. Only loaded particles are visited each step.
The work of a load is force x the particles' displacement (not x their velocity: a FLIP
particle velocity carries null-space noise the positions never see, and its power drifts).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from . import linalg


FACE_AXIS = {"xmin": (0, -1), "xmax": (0, 1), "ymin": (1, -1), "ymax": (1, 1), "zmin": (2, -1), "zmax": (2, 1)}


@dataclass
class Loads:
    particle: np.ndarray  # (k,) loaded particles
    force: np.ndarray  # (k, dim) full force on each
    ramp: np.ndarray  # (k,) ramp time of its load
    x_start: np.ndarray = None  # (k, dim) positions at the start of the step
    f_step: np.ndarray = None  # (k, dim) this step's forces

    def start_step(self, x: np.ndarray, t_mid: float) -> np.ndarray:
        self.x_start = x[self.particle]
        self.f_step = self.force * self.factor(t_mid)[:, None]
        return self.f_step

    def work_of_step(self, x: np.ndarray) -> float:
        """Work of this step's forces over the particles' displacement in the step."""
        return float(np.sum(self.f_step * (x[self.particle] - self.x_start)))

    def factor(self, t: float) -> np.ndarray:
        """Ramp factor of each loaded particle's load at time t."""
        return np.where(self.ramp > 0.0, np.minimum(1.0, t / np.where(self.ramp > 0.0, self.ramp, 1.0)), 1.0)


def build_loads(scene, x: np.ndarray, vol: np.ndarray) -> Loads | None:
    if not scene.settings.loads:
        return None
    dim = scene.dim
    size = 2.0 * np.asarray(scene.semi_size)[:dim]
    idx, force, ramp = [], [], []
    for load in scene.settings.loads:
        lo, hi = np.asarray(load.region.min), np.asarray(load.region.max)
        inside = np.nonzero(np.all((x >= lo) & (x <= hi), axis=1))[0]  # not empty: checked by the scene
        if load.face is not None:
            axis, sign = FACE_AXIS[load.face]
            n = np.zeros(dim)
            n[axis] = sign
            cut = 0.5 * size[axis]  # exactly the outermost layer
        else:
            n = np.asarray(load.normal, float) / linalg.norm(load.normal)
            # a band about one particle deep: on a tilted edge the centres' depths spread evenly
            cut = load.depth if load.depth is not None else float(linalg.dot(np.abs(n), np.asarray(size, float)))
        along = linalg.matvec(x[inside], n)
        # a centre at the band's inner edge within round-off is in it: on a lattice the depths
        # tie there exactly, and the last bit of their sums must not decide the band
        edge = inside[along >= along.max() - cut * (1.0 + 1e-9)]
        if load.traction is not None:  # axis-aligned layer: each particle's face area
            area = float(np.prod(np.delete(size, axis))) * (scene.thickness if dim == 2 else 1.0)
            f = np.tile(np.asarray(load.traction, float) * area, (edge.size, 1))
        else:
            share = vol[edge] / vol[edge].sum()
            f = share[:, None] * np.asarray(load.force, float)[None, :]
        idx.append(edge)
        force.append(f)
        ramp.append(np.full(edge.size, load.ramp))
    return Loads(np.concatenate(idx), np.concatenate(force), np.concatenate(ramp))


@njit(cache=True)
def p2g_loads(particle, force, field_index, S, gforce):
    """Add the loads (this step's forces) to the nodal forces; serial: few particles."""
    dim = force.shape[1]
    K = S.shape[1]
    for q in range(particle.size):
        p = particle[q]
        for a in range(dim):
            for k in range(K):
                gforce[field_index[p, k], a] += S[p, k] * force[q, a]


@njit(cache=True)
def damp_grid(fields, mom, alpha, force):
    """Grid damping: f -= alpha p on every active field."""
    dim = force.shape[1]
    for q in range(fields.size):
        f = fields[q]
        for d in range(dim):
            force[f, d] -= alpha * mom[f, d]
