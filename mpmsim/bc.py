"""Velocity conditions of one node component: domain faces and rigid materials.

A node component is constrained by a rigid material if any rigid particle touches the node
(non-zero shape function) and that material constrains the component; the imposed velocity
is the volume-weighted mean of the touching rigid materials. Otherwise a fixed face
constrains every component of the nodes on and beyond its grid line, a roller face only
the normal one. Rigid materials take precedence over faces.

On the face's grid line the constrained velocity is zero. Beyond it (ghost nodes) it is the
mirror image, v_ghost = -v_mirror, so the velocity interpolated *at the wall* vanishes for
every shape function: B-splines are not interpolatory, and with zero ghost velocities a
quadratic spline still gives v(wall) = v_1/8 (a fixed-free bar then rings 1.3% slow, and
material creeps through a confining wall). For linear and uGIMP particles inside the
domain the ghost nodes carry no weight, so nothing changes for them.
"""

from __future__ import annotations

from numba import njit

# These helpers run once per node component inside the grid kernels' loops, so they take
# plain arrays (bound to locals once per chunk), not bundles: a bundle passed into an inlined
# helper is reloaded from memory at every call (2.3x slower measured on the grid update).

from .scene.grid import FIXED, ROLLER

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


@njit(cache=True, inline="always")
def ghost_mirror(i, j, k, d, dim, face_type, wall_index, shape):
    """(mirror node or -2 for 'zero', face) if component d of node (i, j, k) is a constrained
    ghost value of a face; (-1, -1) otherwise."""
    for f in range(2 * dim):
        t = face_type[f]
        if t == 0:
            continue
        axis = f // 2
        if not (t == FIXED or (t == ROLLER and d == axis)):
            continue
        idx = i if axis == 0 else (j if axis == 1 else k)
        beyond = idx < wall_index[f] if f % 2 == 0 else idx > wall_index[f]
        if not beyond:
            continue
        mi, mj, mk = i, j, k
        m = 2 * wall_index[f] - idx
        if axis == 0:
            mi = m
        elif axis == 1:
            mj = m
        else:
            mk = m
        for g in range(2 * dim):  # a mirror in another face's ghost layer (a corner): use zero
            if face_type[g] == 0:
                continue
            ga = g // 2
            gi = mi if ga == 0 else (mj if ga == 1 else mk)
            if (gi < wall_index[g]) if g % 2 == 0 else (gi > wall_index[g]):
                return -2, f
        if mi < 0 or mj < 0 or mk < 0 or mi >= shape[0] or mj >= shape[1] or mk >= shape[2]:
            return -2, f
        return mi + shape[0] * (mj + shape[1] * mk), f
    return -1, -1


@njit(cache=True, inline="always")
def rigid_holds(node, d, rigid_vol, constrain):
    for r in range(constrain.shape[0]):
        if constrain[r, d] and rigid_vol[node, r] > 0.0:
            return True
    return False


@njit(cache=True, inline="always")
def add_reaction(chunk_reaction, ch, owner, node, d, amount, rigid_vol, constrain):
    """Credit a constrained component's reaction to its owner: a face, or the rigid materials
    holding the node, shared by their volumes there."""
    if owner != RIGID_OWNER:
        chunk_reaction[ch, owner, d] += amount
        return
    wsum = held_volume(node, d, rigid_vol, constrain)
    for r in range(constrain.shape[0]):
        if constrain[r, d] and rigid_vol[node, r] > 0.0:
            chunk_reaction[ch, RIGID_OWNER + r, d] += amount * rigid_vol[node, r] / wsum


@njit(cache=True, inline="always")
def held_volume(node, d, rigid_vol, constrain):
    """The volume of the rigid materials that hold component d at `node` (their shares of a
    reaction go by volume). Also the GPU step's."""
    wsum = 0.0
    for r in range(constrain.shape[0]):
        if constrain[r, d]:
            wsum += rigid_vol[node, r]
    return wsum
