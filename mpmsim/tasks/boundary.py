"""Task helpers for velocity conditions: grid velocity with conditions imposed, and the
mirrored ghost values (the per-node rules are in mpmsim/bc.py)."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..bc import NO_BC, ghost_mirror, node_bc, rigid_holds
from ..gridops import node_ijk


@njit(parallel=True, cache=True)
def grid_velocity(fields, fnodes, shape, mass, mom, face_type, wall_index, rigid_vol, constrain, rig_vel, vel):
    """vel = p/m on every active field, with velocity conditions imposed (for velocity gradients)."""
    dim = mom.shape[1]
    for q in prange(fields.size):
        f = fields[q]
        node = fnodes[q]
        i, j, k = node_ijk(node, shape)
        m = mass[f]
        for d in range(dim):
            owner, vbc = node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain, rig_vel)
            if owner != NO_BC:
                vel[f, d] = vbc
            elif m > 0.0:
                vel[f, d] = mom[f, d] / m
            else:
                vel[f, d] = 0.0


@njit(parallel=True, cache=True)
def mirror_ghosts(nodes, shape, face_type, wall_index, rigid_vol, constrain, field):
    """Constrained ghost components of the given nodes take minus their mirror node's value
    (material slots at walls keep their own values)."""
    dim = field.shape[1]
    for q in prange(nodes.size):
        node = nodes[q]
        i, j, k = node_ijk(node, shape)
        for d in range(dim):
            mirror, face = ghost_mirror(i, j, k, d, dim, face_type, wall_index, shape)
            if mirror == -1 or rigid_holds(node, d, rigid_vol, constrain):
                continue
            field[node, d] = -field[mirror, d] if mirror >= 0 else 0.0


def has_walls(state) -> bool:
    return bool(np.any(state.grid.face_type[: 2 * state.dim] != 0))


def set_grid_velocity(state, rig_vel) -> None:
    g, f, box = state.grid, state.fields, state.box
    grid_velocity(box.fields, box.fnodes, box.shape, f.mass, f.mom, g.face_type, g.wall_index,
                  f.rigid_vol, state.materials.constrain, rig_vel, f.vel)
    if has_walls(state):
        mirror_ghosts(box.fields[: box.n_box], box.shape, g.face_type, g.wall_index, f.rigid_vol,
                      state.materials.constrain, f.vel)
