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
from ..contact.workspace import no_contact
from ..gridops import node_ijk
from ..views import RigidHold


@njit(parallel=True, cache=True)
def grid_velocity(active, grid, held, mass, mom, vel):
    """vel = p/m on every active field, with velocity conditions imposed (for velocity gradients)."""
    dim = mom.shape[1]
    fields, fnodes, shape = active.fields, active.fnodes, grid.shape
    for q in prange(fields.size):  # (numba's parallel loops read bundle members through locals only)
        f = fields[q]
        node = fnodes[q]
        i, j, k = node_ijk(node, shape)
        m = mass[f]
        for d in range(dim):
            owner, vbc = node_bc(node, i, j, k, d, dim, grid, held)
            if owner != NO_BC:
                vel[f, d] = vbc
            elif m > 0.0:
                vel[f, d] = mom[f, d] / m
            else:
                vel[f, d] = 0.0


def slot_info(state):
    """The SlotMap of this step's material slots (an empty one without contact)."""
    cs = state.contact
    return no_contact(state.dim).slots if cs is None else cs.slot_map()


@njit(cache=True)
def mirror_field(fid, mirror, nn, slots):
    """The field at node `mirror` that field `fid` mirrors: the field of the same material
    group there (its slot, or the node if that group is the node's only one). -1 where there
    is none (rigid contact slots, a group absent at the mirror, a contact node's unused node
    field): the field keeps its own values, as every field did before ghosts were mirrored."""
    node_cn, cn_ptr, slot_group, mask, n_def = slots.node_cn, slots.cn_ptr, slots.slot_group, slots.mask, slots.n_def
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


@njit(cache=True)
def ghost_source(fid, node, d, dim, grid, held, slots):
    """(source, face) of component d of field fid at node: source -1 if the component is not
    a constrained ghost value (or a rigid body holds it), -2 if it is held at zero, else the
    mirror field whose value it takes with the opposite sign."""
    i, j, k = node_ijk(node, grid.shape)
    mirror, face = ghost_mirror(i, j, k, d, dim, grid)
    if mirror == -1 or rigid_holds(node, d, held):
        return -1, face
    nn = grid.shape[0] * grid.shape[1] * grid.shape[2]
    return mirror_field(fid, mirror, nn, slots), face


@njit(parallel=True, cache=True)
def mirror_ghosts(active, grid, held, slots, field):
    """Constrained ghost components of the given fields take minus their mirror field's value."""
    dim = field.shape[1]
    fields, fnodes = active.fields, active.fnodes
    for q in prange(fields.size):
        fid = fields[q]
        for d in range(dim):
            mf, face = ghost_source(fid, fnodes[q], d, dim, grid, held, slots)
            if mf != -1:
                field[fid, d] = -field[mf, d] if mf >= 0 else 0.0


@njit(cache=True)
def fold_ghost_forces(active, grid, held, slots, force):
    """Add minus each ghost node's normal force to its mirror node: the force the mirror image
    of the material (the symmetric extension a wall implies) would exert there. Without it a
    B-spline node one cell inside a wall, whose support crosses the wall, feels an unbalanced
    -p/8 per cell from a uniform pressure and squeezes the rows beside roller walls (+16%
    pressure at a 118 GPa shock, docs/shock.md). Used with B-spline grid functions only."""
    dim = force.shape[1]
    for q in range(active.fields.size):
        fid = active.fields[q]
        for d in range(dim):
            mf, face = ghost_source(fid, active.fnodes[q], d, dim, grid, held, slots)
            if mf >= 0 and face // 2 == d:
                force[mf, d] -= force[fid, d]


def has_walls(state) -> bool:
    return bool(np.any(state.grid.face_type[: 2 * state.dim] != 0))


def held_by(state, velocity) -> RigidHold:
    """The rigid velocity conditions with the given rigid velocities (start or end of step)."""
    return RigidHold(state.fields.rigid_vol, state.materials.constrain, velocity)


def set_grid_velocity(state, rig_vel) -> None:
    f, box, held = state.fields, state.box, held_by(state, rig_vel)
    grid_velocity(box.active(), state.grid.view, held, f.mass, f.mom, f.vel)
    if has_walls(state):
        mirror_ghosts(box.active(), state.grid.view, held, slot_info(state), f.vel)
