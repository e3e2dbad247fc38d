"""Task: grid momentum update with velocity conditions acting on the force.

For a constrained component the force is replaced by (m v_BC - p)/dt so the update lands
exactly on v_BC (notes §1.1 step 9); the change is the reaction that the wall or rigid
body exerts on the material. Then v+ = (p + f dt)/m and a = f/m. The task also leaves the
start-of-step velocity with the velocity conditions imposed, v_e (= p/m where nothing is
imposed): the position updates and XPIC's filter start from it, so particles beside a fixed
wall do not creep through it with the unconstrained p/m of the wall nodes.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, prange

from ..bc import NO_BC, add_reaction, node_bc
from ..gridops import chunk_range, node_ijk
from ..parallel import chunk_kernel
from .boundary import NOT_GHOST, has_walls, held_by


class UpdateFields(NamedTuple):
    mass: np.ndarray
    mom: np.ndarray  # p (extrapolated)
    force: np.ndarray  # f
    vnew: np.ndarray  # out: v+ = (p + f dt) / m
    acc: np.ndarray  # out: a = f / m (condition forces included)
    vstart: np.ndarray  # out: start velocity with conditions imposed


@chunk_kernel
def grid_update_kernel(active, grid, held_start, held_end, f, dt, nchunk, chunk_reaction, chunk_work):
    """v+ and a on every active field; a component held by a velocity condition (at the step's
    end: held_end; its start value, held_start, seeds vstart) gets the force that lands it on
    the imposed velocity, and the difference is that condition's reaction and work."""
    dim = f.mom.shape[1]
    # (parallel loops read bundle members through locals: docs/architecture.md)
    fields, fnodes, skip = active.fields, active.fnodes, active.skip
    shape, face_type, wall_index = grid.shape, grid.face_type, grid.wall_index
    rigid_vol, constrain, v_start, v_end = held_end.volume, held_end.constrain, held_start.velocity, held_end.velocity
    mass, mom, force, vnew, acc, vstart = f.mass, f.mom, f.force, f.vnew, f.acc, f.vstart
    nq = fields.size
    for c in prange(nchunk):
        start, stop = chunk_range(c, nchunk, nq)
        chunk_reaction[c] = 0.0
        work = 0.0
        for q in range(start, stop):
            fid = fields[q]
            node = fnodes[q]
            i, j, k = node_ijk(node, shape)
            m = mass[fid]
            if m <= 0.0 or skip[q]:
                for d in range(dim):
                    vnew[fid, d] = 0.0
                    acc[fid, d] = 0.0
                    vstart[fid, d] = 0.0
                continue
            for d in range(dim):
                owner, vbc = node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain, v_end)
                v0 = node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain, v_start)[1] \
                    if owner != NO_BC else 0.0
                pd = mom[fid, d]
                vstart[fid, d], fd, dfc = held_force(owner != NO_BC, vbc, v0, m, pd, force[fid, d], dt)
                acc[fid, d] = fd / m
                vnew[fid, d] = (pd + fd * dt) / m
                if owner != NO_BC:
                    work += dfc * vbc * dt  # signed work done on the material
                    add_reaction(chunk_reaction, c, owner, node, d, dfc, rigid_vol, constrain)
        chunk_work[c] = work


@njit(cache=True, inline="always")
def held_force(held, vbc, v0, m, p, f, dt):
    """One component of a field (mass m > 0, momentum p, force f): (start velocity, force,
    force change). Where a velocity condition holds it (imposed vbc at the step's end, v0 at
    its start) the force is the one that lands it on vbc, and the change is the condition's
    reaction. Also the GPU step's. Scalars in and out: the same helper taking the field and
    condition arrays (and calling node_bc itself) made the kernel 4.2x slower, as numba then
    keeps an NRT incref/decref call per array argument per call (see shapes/tensor.fill_entries)."""
    if held:
        f_bc = (m * vbc - p) / dt
        return v0, f_bc, f_bc - f
    return p / m, f, 0.0


@chunk_kernel
def mirror_update(fields, ghost_src, ghost_face, f, dt, nchunk, chunk_reaction):
    """Second pass of the update: constrained ghost components of the box nodes take minus
    their mirror's new velocity (boundary.py); the extra force is added to that face's reaction."""
    dim = f.mom.shape[1]
    mass, mom, vnew, acc, vstart = f.mass, f.mom, f.vnew, f.acc, f.vstart
    nq = fields.size
    for c in prange(nchunk):
        start, stop = chunk_range(c, nchunk, nq)
        chunk_reaction[c] = 0.0
        for q in range(start, stop):
            fid = fields[q]
            m = mass[fid]
            if m <= 0.0:
                continue
            for d in range(dim):
                mf = ghost_src[q, d]
                if mf == NOT_GHOST:
                    continue
                v = -vnew[mf, d] if mf >= 0 else 0.0
                chunk_reaction[c, ghost_face[q, d], d] += m * (v - vnew[fid, d]) / dt
                vnew[fid, d] = v
                acc[fid, d] = (v - mom[fid, d] / m) / dt
                vstart[fid, d] = -vstart[mf, d] if mf >= 0 else 0.0


def grid_update(state) -> None:
    g, f, box, R = state.grid, state.fields, state.box, state.rigid
    nc = state.nchunk
    reaction = np.zeros((nc,) + state.reaction.shape)
    work = np.zeros(nc)
    uf = UpdateFields(f.mass, f.mom, f.force, f.vnew, f.acc, f.vstart)
    grid_update_kernel(box.active(), g.view, held_by(state, R.v_start), held_by(state, R.v_end), uf, state.dt, nc,
                       reaction, work)
    state.reaction[:] = reaction.sum(axis=0)
    state.work_in += float(work.sum())
    if has_walls(state):
        mirror_update(box.fields, f.ghost_src, f.ghost_face, uf, state.dt, nc, reaction)
        state.reaction += reaction.sum(axis=0)
