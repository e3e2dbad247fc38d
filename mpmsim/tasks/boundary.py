"""Velocity boundary conditions on grid nodes: domain faces and rigid materials.

A node component is constrained by a rigid material if any rigid particle touches the node
(non-zero shape function) and that material constrains the component; the imposed velocity
is the volume-weighted mean of the touching rigid materials. Otherwise a fixed face
constrains every component of the nodes on and beyond its grid line, a roller face only
the normal one. Rigid materials take precedence over faces.
"""

from __future__ import annotations

from numba import njit, prange

from ..gridops import box_node, box_size
from ..scene.grid import FIXED, ROLLER

NO_BC = -1
RIGID_OWNER = 6  # owners 0..5 are faces in FACES order


@njit(cache=True, inline="always")
def node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain, rig_vel):
    """(owner, imposed velocity) for component d of a node; owner NO_BC if free."""
    wsum = 0.0
    vsum = 0.0
    for r in range(constrain.shape[0]):
        if constrain[r, d]:
            w = rigid_vol[node, r]
            if w > 0.0:
                wsum += w
                vsum += w * rig_vel[r, d]
    if wsum > 0.0:
        return RIGID_OWNER, vsum / wsum
    for f in range(2 * dim):
        t = face_type[f]
        if t == 0:
            continue
        axis = f // 2
        idx = i if axis == 0 else (j if axis == 1 else k)
        on = idx <= wall_index[f] if f % 2 == 0 else idx >= wall_index[f]
        if on and (t == FIXED or (t == ROLLER and d == axis)):
            return f, 0.0
    return NO_BC, 0.0


@njit(parallel=True, cache=True)
def grid_velocity(lo, hi, shape, mass, mom, face_type, wall_index, rigid_vol, constrain, rig_vel, vel):
    """vel = p/m with velocity conditions imposed (used for velocity gradients)."""
    dim = mom.shape[1]
    for q in prange(box_size(lo, hi)):
        node, i, j, k = box_node(q, lo, hi, shape)
        m = mass[node]
        for d in range(dim):
            owner, vbc = node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain, rig_vel)
            if owner != NO_BC:
                vel[node, d] = vbc
            elif m > 0.0:
                vel[node, d] = mom[node, d] / m
            else:
                vel[node, d] = 0.0


def set_grid_velocity(state, rig_vel) -> None:
    g, f = state.grid, state.fields
    grid_velocity(state.box.lo, state.box.hi, state.box.shape, f.mass, f.mom, g.face_type, g.wall_index,
                  f.rigid_vol, state.materials.constrain, rig_vel, f.vel)
