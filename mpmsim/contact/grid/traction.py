"""Contact tractions (`output.contact_traction`): the contact force at each contact node and
the traction of its normal line of contact nodes, for the VTU output.

The force at a node is what the history's pair contact force (`contact_f*`, or a rigid
contact material's `F_<name>_*`) sums: the momentum change contact gave each deformable slot
in pass 2 (and in pass 1 too where the particle update takes its velocity from the grid,
PIC/APIC/FMPM/XPIC with its contact term: there pass 1's change reaches the particles and
the history counts it; not at nodes with a rigid contact material, whose reaction is pass
2's), divided by the step. The area is the contact area A_c the geometry computes for the
node (LR: Omega_tot max(0, 1 - d/h_perp) / h_perp, with d the distance of the nearer
material edge to the node; notes §3.5); in 2D it includes the deck's thickness, so force /
area is a stress.

The traction written at a node is its normal line's: the targets of the same pair on
consecutive nodes along the grid axis nearest their normal form a line, and each of them
carries sum f / sum A_c over the line (`normal_lines`). The LR area interpolates the surface
to the nodes that straddle it along the normal (the weights 1 - d/h_perp of two nodes a cell
apart on either side of an edge sum to 1), so only the line's sum is the surface's area; one
node's own f / A_c is not a surface traction where the edge is almost a cell away: a node
one row inside a rigid flat gets ~1% of its column's force over 1e-4 of its area, and f /
A_c there reads tens of p0 under a Hertz cylinder (docs/contact.md). Lines resolve the
traction along the surface at the grid's spacing, as the nodes do, so peaks along the
surface stay. The sum of traction x area over the targets equals the sum of their forces
(the history's contact force) to round-off, the force at nodes of zero LR area included,
unless a whole line has zero area (its traction is written as 0). With multimaterial XPIC
the filter's contact increments, which the history adds to the pair force, are not recorded
here.

Recording costs one pass over the contact slots per step (`record_slot_forces`, in pass 2);
scenes that do not ask for the output do not compile or call it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit


@njit(cache=True)
def record_slot_forces(nodes, mass, after, before, dp1, with_pass_1, dt, out):
    """out[s] = the contact force on deformable slot s this step: m_s (after - before) / dt
    (pass 2's change of the velocities), plus pass 1's momentum change dp1[s] / dt where it
    counts (with_pass_1) and the node has no rigid contact material. Rigid slots: zero."""
    n_cn, cn_ptr, slot_group, n_def, nn = nodes.n_cn, nodes.cn_ptr, nodes.slot_group, nodes.n_def, nodes.nn
    dim = after.shape[1]
    for c in range(n_cn):
        s0 = cn_ptr[c]
        s1 = cn_ptr[c + 1]
        rigid = False
        for s in range(s0, s1):
            if slot_group[s] >= n_def:
                rigid = True
        for s in range(s0, s1):
            for d in range(dim):
                if slot_group[s] >= n_def:
                    out[s, d] = 0.0
                    continue
                f = mass[nn + s] * (after[s, d] - before[s, d]) / dt
                if with_pass_1 and not rigid:
                    f += dp1[s, d] / dt
                out[s, d] = f


class NodeTractions(NamedTuple):
    """One row per contact target (a deformable material at a contact node; at a node of two
    deformable groups only the first is a target, the second takes the opposite force)."""

    slot: np.ndarray  # (m,) target slot
    node: np.ndarray  # (m,) grid node
    group: np.ndarray  # (m,) the target's material group
    partner: np.ndarray  # (m,) the partner's group (-1: the lumped rest of a node of 3+ groups)
    force: np.ndarray  # (m, dim) contact force on the target's material at the node
    normal: np.ndarray  # (m, dim) unit normal out of the target's material (towards the partner)
    area: np.ndarray  # (m,) contact area A_c
    traction: np.ndarray  # (m, dim) force / area (0 where the area is 0)
    pressure: np.ndarray  # (m,) -traction . normal: > 0 in compression
    tangential: np.ndarray  # (m, dim) traction - (traction . normal) normal
    in_contact: np.ndarray  # (m,) pass 2 applied the law there


def normal_lines(node: np.ndarray, shape: np.ndarray, normal: np.ndarray, key: np.ndarray) -> np.ndarray:
    """Line label of each contact target: targets with the same key (pair) on consecutive grid
    nodes along the grid axis nearest their normal (each choosing that axis) share a line; a
    line is a straight run of nodes along one axis. node: grid node indices (x fastest) of a
    grid of shape `shape` nodes; normal (m, dim); key (m,) int64."""
    m, dim = normal.shape
    label = np.zeros(m, dtype=np.int64)
    if m == 0:
        return label
    ijk = np.stack([node % shape[0], (node // shape[0]) % shape[1], node // (shape[0] * shape[1])], 1)[:, :dim]
    axis = np.argmax(np.abs(normal), axis=1)
    start = 0
    for k in range(dim):
        sel = np.flatnonzero(axis == k)
        if not len(sel):
            continue
        others = [ijk[sel, d] for d in range(dim) if d != k]
        order = sel[np.lexsort([ijk[sel, k], *others[::-1], key[sel]])]
        new = np.ones(len(order), dtype=bool)
        same = (key[order[1:]] == key[order[:-1]]) & (ijk[order[1:], k] - ijk[order[:-1], k] == 1)
        for d in range(dim):
            if d != k:
                same &= ijk[order[1:], d] == ijk[order[:-1], d]
        new[1:] = ~same
        label[order] = start + np.cumsum(new) - 1
        start = int(label[order[-1]]) + 1
    return label


def node_tractions(cs, shape: np.ndarray | None = None) -> NodeTractions:
    """The last step's tractions at its contact targets (workspace `cs`, traction recorded).
    With the grid's node shape, each target's traction is its normal line's: the force of the
    targets of the same pair along the grid axis nearest the normal, summed, over their areas
    summed (`normal_lines`); without it, its own f / A_c."""
    ns = cs.n_slots
    role, partner, normal, area = cs.traction_targets or (cs.role[:ns], cs.partner[:ns], cs.normal[:ns],
                                                          cs.area[:ns])  # pass 2's targets
    slots = np.flatnonzero(role != 0)
    force = cs.slot_force[slots]
    normal = normal[slots]
    area = area[slots]
    partner = partner[slots]
    pgroup = np.where(partner >= 0, cs.slot_group[np.maximum(partner, 0)], -1)
    group = cs.slot_group[slots]
    node = cs.slot_node[slots]
    if shape is None:
        inv = np.divide(1.0, area, out=np.zeros_like(area), where=area > 0.0)
        traction = force * inv[:, None]
    else:
        line = normal_lines(node, np.asarray(shape), normal, (group + 1) * (cs.spec.n_groups + 1) + pgroup + 1)
        n_lines = int(line.max()) + 1 if len(line) else 0
        line_area = np.bincount(line, weights=area, minlength=n_lines).astype(float)
        line_force = np.stack([np.bincount(line, weights=force[:, d], minlength=n_lines).astype(float)
                               for d in range(force.shape[1])], 1)
        inv = np.divide(1.0, line_area, out=np.zeros_like(line_area), where=line_area > 0.0)
        traction = (line_force * inv[:, None])[line]
    tn = np.sum(traction * normal, axis=1)
    return NodeTractions(slots, node, group, pgroup, force, normal, area, traction,
                         -tn, traction - tn[:, None] * normal, cs.contact2[slots] != 0)


def slot_shares(cs, nt: NodeTractions) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(force (n_slots, dim), normal force (n_slots,), area (n_slots,)) of each deformable
    slot's material: a target's own (normal force -f . n, > 0 in compression); the partner
    of a two-group node takes the opposite force, with the opposite normal, over the
    target's area; other slots zero."""
    ns = cs.n_slots
    dim = cs.normal.shape[1]
    f = np.zeros((ns, dim))
    fn = np.zeros(ns)
    area = np.zeros(ns)
    f[nt.slot] = nt.force
    fn[nt.slot] = -np.sum(nt.force * nt.normal, axis=1)
    area[nt.slot] = nt.area
    partner = cs.traction_targets[1][nt.slot] if cs.traction_targets else cs.partner[nt.slot]
    two = (partner >= 0) & (cs.slot_group[np.maximum(partner, 0)] < cs.spec.n_def_groups)
    other = partner[two]
    f[other] = cs.slot_force[other]
    fn[other] = np.sum(cs.slot_force[other] * nt.normal[two], axis=1)  # -f . (-n)
    area[other] = nt.area[two]
    return f, fn, area


def particle_tractions(cs, S: np.ndarray, nn: int, f_slot: np.ndarray, fn_slot: np.ndarray, a_slot: np.ndarray):
    """(traction (n, dim), pressure (n,)) per deformable particle: over the contact slots its
    entries point at, the weighted force over the weighted area, sum S f / sum S A_c (and
    sum S f_n / sum S A_c); zero for particles touching no contact area. A ratio of sums,
    so a node with a sliver of area and a share of the force does not dominate."""
    fidx = cs.fidx
    n, dim = fidx.shape[0], cs.normal.shape[1]
    if f_slot.shape[0] == 0:
        return np.zeros((n, dim)), np.zeros(n)
    slot = fidx - nn
    on = slot >= 0
    idx = np.where(on, slot, 0)
    w = np.where(on, S, 0.0)
    den = np.sum(w * a_slot[idx], axis=1)
    inv = np.divide(1.0, den, out=np.zeros_like(den), where=den > 0.0)
    t = np.einsum("pk,pkd->pd", w, f_slot[idx]) * inv[:, None]
    p = np.sum(w * fn_slot[idx], axis=1) * inv
    return t, p
