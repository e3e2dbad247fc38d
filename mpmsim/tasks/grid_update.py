"""Task: grid momentum update with velocity conditions acting on the force.

For a constrained component the force is replaced by (m v_BC - p)/dt so the update lands
exactly on v_BC (notes §1.1 step 9); the change is the reaction that the wall or rigid
body exerts on the material. Then v+ = (p + f dt)/m and a = f/m. The task also leaves the
start-of-step velocity with the velocity conditions imposed, v_e (= p/m where nothing is
imposed): the position updates and XPIC's filter start from it, so particles beside a fixed
wall do not creep through it with the unconstrained p/m of the wall nodes.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..gridops import chunk_range, node_ijk
from ..bc import NO_BC, add_reaction, ghost_mirror, node_bc, rigid_holds
from .boundary import has_walls, mirror_field, slot_info


@njit(parallel=True, cache=True)
def grid_update_kernel(fields, fnodes, skip, shape, dt, mass, mom, force, face_type, wall_index, rigid_vol,
                       constrain, rig_vel_start, rig_vel, nchunk, vnew, acc, vstart, chunk_reaction, chunk_work):
    dim = mom.shape[1]
    nq = fields.size
    for c in prange(nchunk):
        start, stop = chunk_range(c, nchunk, nq)
        for a in range(chunk_reaction.shape[1]):
            for d in range(dim):
                chunk_reaction[c, a, d] = 0.0
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
                fd = force[fid, d]
                owner, vbc = node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain, rig_vel)
                if owner != NO_BC:
                    owner0, vbc0 = node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain,
                                           rig_vel_start)
                    vstart[fid, d] = vbc0
                else:
                    vstart[fid, d] = mom[fid, d] / m
                if owner != NO_BC:
                    f_bc = (m * vbc - mom[fid, d]) / dt
                    dfc = f_bc - fd
                    work += dfc * vbc * dt  # signed work done on the material
                    add_reaction(chunk_reaction, c, owner, node, d, dfc, rigid_vol, constrain)
                    fd = f_bc
                acc[fid, d] = fd / m
                vnew[fid, d] = (mom[fid, d] + fd * dt) / m
        chunk_work[c] = work


@njit(parallel=True, cache=True)
def mirror_update(fields, fnodes, shape, dt, mass, mom, face_type, wall_index, rigid_vol, constrain, slots, nchunk,
                  vnew, acc, vstart, chunk_reaction):
    """Second pass of the update: constrained ghost components of the box nodes take minus
    their mirror's new velocity (boundary.py); the extra force is added to that face's reaction."""
    dim = mom.shape[1]
    nq = fields.size
    nn = shape[0] * shape[1] * shape[2]
    for c in prange(nchunk):
        start, stop = chunk_range(c, nchunk, nq)
        for a in range(chunk_reaction.shape[1]):
            for d in range(dim):
                chunk_reaction[c, a, d] = 0.0
        for q in range(start, stop):
            fid = fields[q]
            node = fnodes[q]
            i, j, k = node_ijk(node, shape)
            m = mass[fid]
            if m <= 0.0:
                continue
            for d in range(dim):
                mirror, face = ghost_mirror(i, j, k, d, dim, face_type, wall_index, shape)
                if mirror == -1 or rigid_holds(node, d, rigid_vol, constrain):
                    continue
                mf = mirror_field(fid, mirror, nn, slots)
                if mf == -1:
                    continue
                v = -vnew[mf, d] if mf >= 0 else 0.0
                chunk_reaction[c, face, d] += m * (v - vnew[fid, d]) / dt
                vnew[fid, d] = v
                acc[fid, d] = (v - mom[fid, d] / m) / dt
                vstart[fid, d] = -vstart[mf, d] if mf >= 0 else 0.0


def grid_update(state) -> None:
    g, f, box = state.grid, state.fields, state.box
    nc = state.nchunk
    reaction = np.zeros((nc,) + state.reaction.shape)
    work = np.zeros(nc)
    grid_update_kernel(box.fields, box.fnodes, box.skip, box.shape, state.dt, f.mass, f.mom, f.force, g.face_type,
                       g.wall_index,
                       f.rigid_vol, state.materials.constrain, state.rigid.v_start, state.rigid.v_end, nc, f.vnew,
                       f.acc, f.vstart, reaction, work)
    state.reaction[:] = reaction.sum(axis=0)
    state.work_in += float(work.sum())
    if has_walls(state):
        mirror_update(box.fields, box.fnodes, box.shape, state.dt, f.mass, f.mom, g.face_type, g.wall_index,
                      f.rigid_vol, state.materials.constrain, slot_info(state), nc, f.vnew, f.acc, f.vstart, reaction)
        state.reaction += reaction.sum(axis=0)
