"""Traction loads on particle edges and grid damping: the external forces of static problems.

A load acts on the outermost particle layer (toward its face) of the particles inside its
region; each carries traction x its face area. Only loaded particles are visited each step.
A face or band load reaches the grid through the particle's own weights S_ip (as if it acted
at the particle's centre); a pressure load through the linear grid function at the point of
the surface in front of the particle (x_p + its offset), so the layer between the surface and
the particle centres carries its share of the load and does not stiffen the surface (first
order in h otherwise: -1.0% radial displacement on a thick sphere at 20 cells through the
wall, docs/axisymmetric.md).
The work of a load is force x the particles' displacement (not x their velocity: a FLIP
particle velocity carries null-space noise the positions never see, and its power drifts).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from . import linalg


def ramped_gravity(full: np.ndarray, ramp: float, t: float) -> np.ndarray:
    """The deck's gravity at time t under `gravity_ramp` (ramp > 0): full x min(t / ramp, 1)."""
    return full * min(t / ramp, 1.0)


FACE_AXIS = {"xmin": (0, -1), "xmax": (0, 1), "ymin": (1, -1), "ymax": (1, 1), "zmin": (2, -1), "zmax": (2, 1)}


@dataclass
class Loads:
    particle: np.ndarray  # (k,) loaded particles
    force: np.ndarray  # (k, dim) full force on each
    ramp: np.ndarray  # (k,) ramp time of its load
    offset: np.ndarray = None  # (k, dim) from the particle's centre to the surface point its load acts at
    at_surface: np.ndarray = None  # (k,) bool: acts at x_p + offset (pressure loads), else through S_ip
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
    idx, force, ramp, offset = [], [], [], []
    for load in scene.settings.loads:
        lo, hi = np.asarray(load.region.min), np.asarray(load.region.max)
        inside = np.nonzero(np.all((x >= lo) & (x <= hi), axis=1))[0]  # not empty: checked by the scene
        if load.pressure is not None:
            edge, f, off = pressure_forces(load, x[inside], vol[inside], float(size.min()), dim,
                                           scene.settings.axisymmetric)
            idx.append(inside[edge])
            force.append(f)
            ramp.append(np.full(edge.size, load.ramp))
            offset.append(off)
            continue
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
            area = np.full(edge.size, float(np.prod(np.delete(size, axis))) * (scene.thickness if dim == 2 else 1.0))
            if scene.settings.axisymmetric:  # per radian: times the face's radius
                area *= x[edge, 0] + (0.5 * size[0] * sign if axis == 0 else 0.0)
            f = area[:, None] * np.asarray(load.traction, float)[None, :]
        else:
            share = vol[edge] / vol[edge].sum()
            f = share[:, None] * np.asarray(load.force, float)[None, :]
        idx.append(edge)
        force.append(f)
        ramp.append(np.full(edge.size, load.ramp))
        offset.append(np.full((edge.size, dim), np.nan))  # (through S_ip)
    off = np.concatenate(offset)
    surface = ~np.isnan(off[:, 0])
    return Loads(np.concatenate(idx), np.concatenate(force), np.concatenate(ramp), np.where(surface[:, None], off, 0.0),
                 surface)


def pressure_forces(load, x: np.ndarray, vol: np.ndarray, spacing: float, dim: int,
                    axisymmetric: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(rows of x loaded, their forces, the offsets from each to its surface point) of a pressure
    on the round surface about load.center.

    The loaded layer is the particles within half a spacing (or load.depth) of the nearest
    (side inner) or farthest (outer) distance from the centre; the surface lies half a spacing
    beyond it (radius s), the layer one spacing deep (its other face s +- spacing). A particle's
    share of the surface is its volume times area/volume of that shell: (k+1) s^k / |s'^(k+1) -
    s^(k+1)| with k = 1 for a cylinder (plane strain) and 2 for a sphere (3d; axisymmetric about
    a centre on the axis). Exact for a layer of ring-seeded particles whose ring step is the
    spacing (a wall a whole number of spacings thick; ring_seed rounds the step otherwise); for
    a lattice-seeded surface only as good as the layer's volume follows the shell."""
    c = np.asarray(load.center, float)
    rel = x - c
    d = np.sqrt(np.sum(rel * rel, axis=1))
    cut = load.depth if load.depth is not None else 0.5 * spacing
    inner = load.side == "inner"
    edge = np.nonzero(d <= d.min() + cut * (1.0 + 1e-9) if inner else d >= d.max() - cut * (1.0 + 1e-9))[0]
    k = 2 if (dim == 3 or axisymmetric) else 1
    s = d.min() - 0.5 * spacing if inner else d.max() + 0.5 * spacing
    s2 = s + spacing if inner else s - spacing
    area_per_volume = (k + 1) * s**k / abs(s2 ** (k + 1) - s ** (k + 1))
    n = rel[edge] / d[edge, None] * (1.0 if inner else -1.0)  # the pressure pushes into the body
    surface_point = (s - d[edge])[:, None] * rel[edge] / d[edge, None]
    return edge, (load.pressure * area_per_volume * vol[edge])[:, None] * n, surface_point


@njit(cache=True)
def p2g_loads(particle, force, at_surface, offset, x, field_index, S, lowest, offs, grid, gforce):
    """Add the loads (this step's forces) to the nodal forces; serial: few particles. A load
    `at_surface` goes to the particle's nodes by the linear grid function at x_p + offset (its
    weights on the particle's node list; where that point's cell is not all in the list, as
    can happen with linear particle weights off the lattice, by S_ip), the others by S_ip."""
    dim = force.shape[1]
    K = S.shape[1]
    w = np.zeros(K)
    origin, h = grid.origin, grid.h
    for q in range(particle.size):
        p = particle[q]
        total = 0.0
        if at_surface[q]:
            for k in range(K):
                wk = 1.0
                for a in range(dim):
                    node = origin[a] + (lowest[p, a] + offs[k, a]) * h[a]
                    wk *= max(0.0, 1.0 - abs(x[p, a] + offset[q, a] - node) / h[a])
                w[k] = wk
                total += wk
        if not (abs(total - 1.0) < 1e-9):
            for k in range(K):
                w[k] = S[p, k]
        for a in range(dim):
            for k in range(K):
                gforce[field_index[p, k], a] += w[k] * force[q, a]


@njit(cache=True)
def damp_grid(fields, mom, alpha, force):
    """Grid damping: f -= alpha p on every active field."""
    dim = force.shape[1]
    for q in range(fields.size):
        f = fields[q]
        for d in range(dim):
            force[f, d] -= alpha * mom[f, d]
