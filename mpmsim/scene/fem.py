"""Deck -> FEM bodies: meshes generated from shapes or read from files, placed by the body's
transforms, with their initial velocities and held nodes; all FEM bodies of a deck
concatenated into one seed (node and cell arrays with a body index)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..bodies import BodyInfo
from ..deck.schema import RotationVelocity, SineVelocity
from ..deck.semantics import body_name
from .memory import FEM_NODE_BYTES, too_big


@dataclass
class FemSeed:
    points: np.ndarray  # (n, dim) reference node positions
    cells: np.ndarray  # (m, dim + 1) positively oriented simplices
    facets: np.ndarray  # (b, dim) boundary edges/triangles, outward oriented
    node_body: np.ndarray  # (n,) row of the node's body in `infos`
    cell_body: np.ndarray  # (m,) row of the cell's body in `infos`
    cell_mat: np.ndarray  # (m,) deformable material index
    velocity: np.ndarray  # (n, dim) initial velocity
    held: np.ndarray  # (n, dim) bool: component held
    held_velocity: np.ndarray  # (n, dim) its prescribed velocity
    infos: list  # BodyInfo of each FEM body
    motions: list = field(default_factory=list)  # (node indices, fem.motion.RigidMotion) of prescribed motions

    @property
    def n_nodes(self) -> int:
        return len(self.points)

    @property
    def node_mat(self) -> np.ndarray:
        """(n,) material of each node: that of the last cell listing it (a node joins cells
        of one body, and a body has one material)."""
        node_mat = np.zeros(len(self.points), dtype=np.int64)
        node_mat[self.cells.ravel()] = np.repeat(self.cell_mat, self.cells.shape[1])
        return node_mat


def mesh_nodes_estimate(body, dim: int) -> float | None:
    """Nodes of a meshed shape, from its bounding box over element_size (None: a mesh file)."""
    h = body.element_size
    if h is None:
        return None
    if body.shape in ("rectangle", "box"):
        extent = np.subtract(body.max, body.min, dtype=float)
    elif body.shape == "circle":
        extent = np.full(dim, 2.0 * body.radius)
    elif body.shape == "annulus":
        extent = np.full(dim, 2.0 * body.outer_radius)
    else:
        return None
    return math.prod(float(e) / h + 2.0 for e in np.abs(extent))  # Python floats: inf, no overflow warning


def body_mesh(body, dim: int, base_dir):
    """(the body's mesh before its transforms, the mesh placed by them)."""
    from ..fem import mesh as femmesh

    h = body.element_size
    if body.shape == "mesh":
        m = femmesh.read_mesh(base_dir / body.file, dim)
        if body.scale != 1.0 or body.translate is not None:
            m = femmesh.transformed(m, scale=body.scale, translation=body.translate)
    elif body.shape in ("rectangle", "box"):
        m = femmesh.rectangle(body.min, body.max, h) if dim == 2 else femmesh.box(body.min, body.max, h)
    elif body.shape == "circle":
        m = femmesh.disk(body.center, body.radius, h)
    else:  # annulus
        m = femmesh.ring(body.center, body.inner_radius, body.outer_radius, h)
    own = m
    for t in body.transform:
        if t.rotate is not None:
            m = femmesh.transformed(m, rotation_deg=t.rotate, axis=t.axis,
                                    about=np.zeros(dim) if t.center is None else np.asarray(t.center, float))
        else:
            m = femmesh.transformed(m, translation=np.asarray(t.translate, float))
    return own, m


def initial_velocity(body, x: np.ndarray) -> np.ndarray:
    dim = x.shape[1]
    v = np.zeros_like(x)
    vel = body.velocity
    if isinstance(vel, SineVelocity):
        phase = 2 * np.pi * (x[:, "xyz".index(vel.axis)] - vel.origin) / vel.wavelength
        v[:] = np.sin(phase)[:, None] * np.array(vel.amplitude)[None, :]
    elif isinstance(vel, RotationVelocity):
        r = x - np.array(vel.center)
        v[:] = (vel.angular_velocity * np.stack([-r[:, 1], r[:, 0]], axis=1) if dim == 2
                else np.cross(np.array(vel.angular_velocity), r))
        if vel.translation is not None:
            v += np.array(vel.translation)
    elif vel is not None:
        v[:] = np.array(vel)
    return v


def held_nodes(body, mesh, own: np.ndarray, x: np.ndarray, problems: list, path: tuple):
    """(held (n, dim) bool, prescribed velocity (n, dim), [(nodes, RigidMotion)]) from the body's
    constraints; `own`: the node positions before the body's transforms. A prescribed motion
    holds every component of its nodes (velocity 0 here: the integrator sets it each step)."""
    from ..fem.motion import RigidMotion

    n, dim = x.shape
    held = np.zeros((n, dim), dtype=bool)
    value = np.zeros((n, dim))
    motions = []
    for j, c in enumerate(body.constraints):
        if c.region is not None:
            pos = own if c.frame == "body" else x
            pad = 1e-9 * float(np.ptp(pos, axis=0).max())
            lo, hi = np.asarray(c.region.min, float), np.asarray(c.region.max, float)
            sel = np.all((pos >= lo - pad) & (pos <= hi + pad), axis=1)
        else:
            nodes = mesh.node_sets.get(c.node_set) if getattr(mesh, "node_sets", None) else None
            if nodes is None:
                problems.append(((*path, "constraints", j, "node_set"), f"the mesh has no node set '{c.node_set}'"))
                continue
            sel = np.zeros(n, dtype=bool)
            sel[nodes] = True
        if not sel.any():
            problems.append(((*path, "constraints", j), "selects no node of the body"))
            continue
        for a in c.axes or "xyz"[:dim]:
            d = "xyz".index(a)
            held[sel, d] = True
            value[sel, d] = c.velocity[d] if c.velocity is not None else 0.0
        if c.motion:
            motions.append((np.flatnonzero(sel), RigidMotion(c.motion, dim)))
    return held, value, motions


def build_fem(deck, base_dir, materials) -> tuple[FemSeed | None, list]:
    """The deck's FEM bodies as one seed, and the problems found (key path, message)."""
    from ..fem.mesh import MeshError

    dim = deck.dim
    parts, problems = [], []
    for i, body in enumerate(deck.bodies):
        if body.discretization != "fem":
            continue
        path = ("bodies", i)
        nodes = mesh_nodes_estimate(body, dim)
        problem = too_big(nodes * FEM_NODE_BYTES[dim], f"about {nodes:.3g} mesh nodes",
                          "a larger element_size") if nodes is not None else None
        if problem:
            problems.append(((*path, "element_size"), problem))
            continue
        try:
            own, m = body_mesh(body, dim, base_dir)
        except MeshError as exc:
            problems.append(((*path, "file" if body.shape == "mesh" else "shape"), str(exc)))
            continue
        x = np.asarray(m.points, float)
        held, value, motion = held_nodes(body, m, own.points, x, problems, path)
        parts.append((i, body, m, x, initial_velocity(body, x), held, value, motion))
    if not parts or problems:
        return None, problems
    offset = 0
    cells, facets, node_body, cell_body, cell_mat, vel, held, value, pts, infos, motions = ([] for _ in range(11))
    for row, (i, body, m, x, v, hd, hv, mo) in enumerate(parts):
        infos.append(BodyInfo(i, body_name(body, i), "fem", body.material))
        pts.append(x)
        cells.append(np.asarray(m.cells, np.int64) + offset)
        facets.append(np.asarray(m.facets, np.int64) + offset)
        node_body.append(np.full(len(x), row, np.int64))
        cell_body.append(np.full(len(m.cells), row, np.int64))
        cell_mat.append(np.full(len(m.cells), materials.local_index(body.material), np.int64))
        vel.append(v)
        held.append(hd)
        value.append(hv)
        motions += [(nodes + offset, motion) for nodes, motion in mo]
        offset += len(x)
    cat = np.concatenate
    return FemSeed(cat(pts), cat(cells), cat(facets), cat(node_body), cat(cell_body), cat(cell_mat), cat(vel),
                   cat(held), cat(value), infos, motions), []
