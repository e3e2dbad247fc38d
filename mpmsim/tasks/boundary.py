"""Task helpers for velocity conditions: grid velocity with conditions imposed, and the
mirrored ghost values (the per-node rules are in mpmsim/bc.py).

Ghost values act per *field*: where materials meet (mpmsim/contact), a ghost node's material
slot mirrors the same material's slot at the mirror node, so two materials bonded across a
wall-side node see the same wall as one material does (B-spline supports reach the ghosts).
`slot_info(state)` carries what that lookup needs. Which field each ghost component mirrors
is found once per step (`find_ghosts`, after the extrapolation decides which nodes rigid
bodies hold) into `fields.ghost_src`/`ghost_face`; every later mirror reads that table.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..bc import NO_BC, ghost_mirror, node_bc, rigid_holds
from ..contact.grid.workspace import no_contact
from ..gridops import node_ijk
from ..parallel import chunk_kernel
from ..views import RigidHold

NOT_GHOST, ZERO = -1, -2  # ghost_src codes: not a constrained ghost component; held at zero


@chunk_kernel
def grid_velocity(active, grid, held, mass, mom, vel):
    """vel = p/m on every active field, with velocity conditions imposed (for velocity gradients)."""
    dim = mom.shape[1]
    # (parallel loops work on arrays bound to locals: docs/architecture.md)
    fields, fnodes, _ = active
    shape, _, _, face_type, wall_index = grid
    rigid_vol, constrain, rig_vel = held
    for q in prange(fields.size):
        f = fields[q]
        node = fnodes[q]
        i, j, k = node_ijk(node, shape)
        m = mass[f]
        for d in range(dim):
            owner, vbc = node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain, rig_vel)
            vel[f, d] = velocity_of(owner != NO_BC, vbc, m, mom[f, d])


@njit(cache=True, inline="always")
def velocity_of(held, vbc, m, p):
    """A node's velocity component: vbc where a velocity condition holds it, else p/m (0
    without mass). Also the GPU step's."""
    if held:
        return vbc
    if m > 0.0:
        return p / m
    return 0.0


def slot_info(state):
    """The SlotMap of this step's material slots (an empty one without contact)."""
    cs = state.contact
    return no_contact(state.dim).slots if cs is None else cs.slot_map()


@njit(cache=True, inline="always")
def mirror_field(fid, mirror, nn, node_cn, cn_ptr, slot_group, mask, n_def):
    """The field at node `mirror` that field `fid` mirrors: the field of the same material
    group there (its slot, or the node if that group is the node's only one). -1 where there
    is none (rigid contact slots, a group absent at the mirror, a contact node's unused node
    field): the field keeps its own values, as every field did before ghosts were mirrored."""
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


@chunk_kernel
def ghost_table(active, grid, held, slots, src, face):
    """For each active field and component: the field whose value a constrained ghost takes
    with the opposite sign (ZERO: held at zero; NOT_GHOST: not a constrained ghost value, or
    a rigid body holds it, or no field of its group at the mirror), and the face."""
    dim = src.shape[1]
    # (parallel loops work on arrays bound to locals: docs/architecture.md)
    fields, fnodes, _ = active
    shape, _, _, face_type, wall_index = grid
    rigid_vol, constrain, _ = held
    node_cn, cn_ptr, slot_group, mask, n_def = slots
    nn = shape[0] * shape[1] * shape[2]
    for q in prange(fields.size):
        fid = fields[q]
        node = fnodes[q]
        i, j, k = node_ijk(node, shape)
        for d in range(dim):
            mirror, f = ghost_mirror(i, j, k, d, dim, face_type, wall_index, shape)
            face[q, d] = f
            if mirror == -1 or rigid_holds(node, d, rigid_vol, constrain):
                src[q, d] = NOT_GHOST
            else:
                src[q, d] = mirror_field(fid, mirror, nn, node_cn, cn_ptr, slot_group, mask, n_def)


def find_ghosts(state) -> None:
    """This step's ghost table (fields.ghost_src, ghost_face), after the extrapolation."""
    f, box = state.fields, state.box
    n = box.fields.size
    if f.ghost_src.shape[0] < n:
        f.ghost_src = np.zeros((2 * n, state.dim), dtype=np.int64)
        f.ghost_face = np.zeros((2 * n, state.dim), dtype=np.int64)
    ghost_table(box.active(), state.grid.view, held_by(state, state.rigid.v_end), slot_info(state), f.ghost_src,
                f.ghost_face)


@njit(cache=True)
def mirror_ghosts(fields, ghost_src, field):
    """Constrained ghost components of the active fields take minus their mirror field's value."""
    dim = field.shape[1]
    for q in prange(fields.size):
        fid = fields[q]
        for d in range(dim):
            mf = ghost_src[q, d]
            if mf != NOT_GHOST:
                field[fid, d] = -field[mf, d] if mf >= 0 else 0.0


@njit(cache=True)
def fold_ghost_forces(fields, ghost_src, ghost_face, force):
    """Add minus each ghost node's normal force to its mirror node: the force the mirror image
    of the material (the symmetric extension a wall implies) would exert there. Without it a
    B-spline node one cell inside a wall, whose support crosses the wall, feels an unbalanced
    -p/8 per cell from a uniform pressure and squeezes the rows beside roller walls (+16%
    pressure at a 118 GPa shock, docs/shock.md). Used with B-spline grid functions only."""
    dim = force.shape[1]
    for q in range(fields.size):
        fid = fields[q]
        for d in range(dim):
            mf = ghost_src[q, d]
            if mf >= 0 and ghost_face[q, d] // 2 == d:
                force[mf, d] -= force[fid, d]


def has_walls(state) -> bool:
    return state.grid.has_walls


def held_by(state, velocity) -> RigidHold:
    """The rigid velocity conditions with the given rigid velocities (start or end of step)."""
    return RigidHold(state.fields.rigid_vol, state.materials.constrain, velocity)


def set_grid_velocity(state, rig_vel) -> None:
    f, box, held = state.fields, state.box, held_by(state, rig_vel)
    grid_velocity(box.active(), state.grid.view, held, f.mass, f.mom, f.vel)
    if has_walls(state):
        mirror_ghosts(box.fields, f.ghost_src, f.vel)
