"""Task helpers for velocity conditions: grid velocity with conditions imposed, and the
mirrored ghost values (the per-node rules are in mpmsim/bc.py).

Ghost values act per *field*: where materials meet (mpmsim/contact), a ghost node's material
slot mirrors the same material's slot at the mirror node, so two materials bonded across a
wall-side node see the same wall as one material does (B-spline supports reach the ghosts).
`slot_info(state)` carries what that lookup needs.
"""

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


_NO_SLOTS = (np.full(1, -1, dtype=np.int64), np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.int64),
             np.zeros(1, dtype=np.uint64), 0)


def slot_info(state):
    """(node_cn, cn_ptr, slot_group, mask, n_def_groups) of this step's material slots."""
    cs = state.contact
    if cs is None:
        return _NO_SLOTS
    return cs.node_cn, cs.cn_ptr, cs.slot_group, cs.mask, cs.spec.n_def_groups


@njit(cache=True, inline="always")
def mirror_field(fid, mirror, nn, slots):
    """The field at node `mirror` that field `fid` mirrors: the field of the same material
    group there (its slot, or the node if that group is the node's only one). -1 where there
    is none (rigid contact slots, a group absent at the mirror, a contact node's unused node
    field): the field keeps its own values, as every field did before ghosts were mirrored."""
    node_cn, cn_ptr, slot_group, mask, n_def = slots
    if mirror < 0 or node_cn.size <= 1:
        return mirror
    if fid >= nn:
        g = slot_group[fid - nn]
        if g >= n_def:
            return -1
    else:
        m = mask[fid]
        if m == np.uint64(0) or (m & (m - np.uint64(1))) != np.uint64(0):
            return -1  # no particles, or a contact node (its particles use the slots)
        g = 0
        while (m & np.uint64(1)) == np.uint64(0):
            m >>= np.uint64(1)
            g += 1
    c = node_cn[mirror]
    if c < 0:
        return mirror if mask[mirror] == (np.uint64(1) << np.uint64(g)) else -1
    for s in range(cn_ptr[c], cn_ptr[c + 1]):
        if slot_group[s] == g:
            return nn + s
    return -1


@njit(parallel=True, cache=True)
def mirror_ghosts(fields, fnodes, shape, face_type, wall_index, rigid_vol, constrain, slots, field):
    """Constrained ghost components of the given fields take minus their mirror field's value."""
    dim = field.shape[1]
    nn = shape[0] * shape[1] * shape[2]
    for q in prange(fields.size):
        fid = fields[q]
        node = fnodes[q]
        i, j, k = node_ijk(node, shape)
        for d in range(dim):
            mirror, face = ghost_mirror(i, j, k, d, dim, face_type, wall_index, shape)
            if mirror == -1 or rigid_holds(node, d, rigid_vol, constrain):
                continue
            mf = mirror_field(fid, mirror, nn, slots)
            if mf != -1:
                field[fid, d] = -field[mf, d] if mf >= 0 else 0.0


@njit(cache=True)
def fold_ghost_forces(fields, fnodes, shape, face_type, wall_index, rigid_vol, constrain, slots, force):
    """Add minus each ghost node's normal force to its mirror node: the force the mirror image
    of the material (the symmetric extension a wall implies) would exert there. Without it a
    B-spline node one cell inside a wall, whose support crosses the wall, feels an unbalanced
    -p/8 per cell from a uniform pressure and squeezes the rows beside roller walls (+16%
    pressure at a 118 GPa shock, docs/shock.md). Used with B-spline grid functions only."""
    dim = force.shape[1]
    nn = shape[0] * shape[1] * shape[2]
    for q in range(fields.size):
        fid = fields[q]
        node = fnodes[q]
        i, j, k = node_ijk(node, shape)
        for d in range(dim):
            mirror, face = ghost_mirror(i, j, k, d, dim, face_type, wall_index, shape)
            if mirror < 0 or face // 2 != d or rigid_holds(node, d, rigid_vol, constrain):
                continue
            mf = mirror_field(fid, mirror, nn, slots)
            if mf >= 0:
                force[mf, d] -= force[fid, d]


def has_walls(state) -> bool:
    return bool(np.any(state.grid.face_type[: 2 * state.dim] != 0))


def set_grid_velocity(state, rig_vel) -> None:
    g, f, box = state.grid, state.fields, state.box
    grid_velocity(box.fields, box.fnodes, box.shape, f.mass, f.mom, g.face_type, g.wall_index,
                  f.rigid_vol, state.materials.constrain, rig_vel, f.vel)
    if has_walls(state):
        mirror_ghosts(box.fields, box.fnodes, box.shape, g.face_type, g.wall_index, f.rigid_vol,
                      state.materials.constrain, slot_info(state), f.vel)
