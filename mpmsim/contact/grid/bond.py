"""Consistent bond of a perfect interface normal (docs/interfaces.md, "The consistent bond").

The reference code bonds a perfect normal node by node: (v_b - v_a).n = 0 at every contact
node. Where the interface crosses a cell between two nodes, that clamps both nodes, so the two
materials' particles in the crossed cell get one normal strain rate, although (Poisson) they
contract by different amounts: on cell mid-planes it stiffens the two-layer specimen's
interface (-16% interfacial energy at 1 mm cells, plane strain).

Here the bond is imposed at points on the interface, not at nodes. Each candidate node on
material a's side projects itself onto the interface along n (its signed distance `level`
comes from Eq. 20's volume factor), and the relative normal velocity interpolated there with
the linear shape functions of the cell the point falls in must vanish:
    sum_k w_k [v_n]_k = 0,   [v_n]_k = (v_b - v_a)_k . n_k.
A node on the interface gives the node-wise bond; a mid-plane interface gives one constraint
per pair of nodes across it (1/2, 1/2), which leaves the in-cell normal-strain jump free. Only
a's side owns points: with points from both sides a tilted interface would have about as many
constraints as nodes, which locks it back to the node-wise bond. Each constraint's impulse is
+/- lambda w_k n_k on the two materials at node k, so momentum is conserved at every node.
Constraints sharing nodes (tilted or curved interfaces) are solved by Gauss-Seidel sweeps; on
a grid-aligned interface one sweep is exact.

Grid-aligned normals only, for now. With a tilted normal (the DLS specimen at 30 deg on
0.25 x 0.5 mm cells) the points of neighbouring a-side nodes fall in shared cells and the
constraints come out nearly as many as the unknowns: Gauss-Seidel does not converge in 100
sweeps (2.3x the run time) and the result is the node-wise one (k = 160.04 against 160.06
N/mm). So a tilted (or curved, radial) normal keeps the node-wise bond; a constraint space
that does not lock there is open (docs/interfaces.md).

Scope: interface targets in pair mode (two deformable materials) whose normal is bonded
(perfect, or too stiff for the step) and whose tangential direction is not (a fully bonded
node is the single-body velocity, exactly). Nodes with a velocity condition, and candidates
that end up in no constraint, keep the node-wise bond.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ...bc import NO_BC, node_bc
from ...gridops import node_ijk
from .spec import INTERFACE

NORMAL_BONDED, TANGENT_BONDED, NORMAL_BY_POINTS = 1, 2, 4
MAX_SWEEPS = 100
ALIGNED = 1.0 - 1e-6  # |n_d| of a grid-aligned normal


@njit(cache=True, inline="always")
def _candidate(c, nodes, geo):
    """The target slot a of contact node c if its normal may join the constraints, else -1."""
    for a in range(nodes.cn_ptr[c], nodes.cn_ptr[c + 1]):
        if geo.role[a] == 0:
            continue
        b = geo.partner[a]
        if b < 0 or nodes.slot_group[b] >= nodes.n_def or geo.law[a] != INTERFACE:
            return -1
        return a if (geo.bonded[a] & 3) == NORMAL_BONDED else -1
    return -1


@njit(cache=True)
def bond_points(nodes, node_cn, grid, held_bc, geo, dim, bonds):
    """One constraint per candidate node on material a's side of the interface, at its
    projection on the interface, over the nodes of the cell it falls in (weights: their linear
    shape functions there; nodes that are not candidates drop out). The slots of every node
    in a constraint lose the node-wise normal bond (bit 1) and get bit 4. Returns the number
    of constraints; bonds.con_ptr indexes their entries (at most 2^dim each) in
    bonds.ent_a/ent_b/ent_w. held_bc: the velocity conditions (nodes they hold keep the
    node-wise bond)."""
    n_cn, cn_nodes, slot_group, partner = nodes.n_cn, nodes.cn_nodes, nodes.slot_group, geo.partner
    shape, h, geo_level, geo_n, bonded = grid.shape, grid.h, geo.level, geo.normal, geo.bonded
    con_ptr, ent_a, ent_b, ent_w = bonds.con_ptr, bonds.ent_a, bonds.ent_b, bonds.ent_w
    held = np.zeros(n_cn, dtype=np.bool_)
    for c in range(n_cn):
        node = cn_nodes[c]
        i, j, k = node_ijk(node, shape)
        for d in range(dim):
            owner, v = node_bc(node, i, j, k, d, dim, grid.face_type, grid.wall_index, held_bc.volume,
                               held_bc.constrain, held_bc.velocity)
            if owner != NO_BC:
                held[c] = True
    base = np.zeros(3, dtype=np.int64)
    xi = np.zeros(3)
    n_con = 0
    q = 0
    con_ptr[0] = 0
    for c in range(n_cn):
        a1 = _candidate(c, nodes, geo)
        if a1 < 0 or held[c] or geo_level[a1] > 0.0:
            continue
        along = 0.0
        for d in range(dim):
            along = max(along, abs(geo_n[a1, d]))
        if along < ALIGNED:
            continue  # a tilted normal: node-wise (see the module notes)
        ijk = node_ijk(cn_nodes[c], shape)
        for d in range(dim):  # the interface point, x_node + |level| n, in grid units
            u = ijk[d] - geo_level[a1] * geo_n[a1, d] / h[d]
            base[d] = min(max(int(np.floor(u)), 0), shape[d] - 2)
            xi[d] = min(max(u - base[d], 0.0), 1.0)
        q0 = q
        kept = 0.0
        for corner in range(1 << dim):
            w = 1.0
            node = 0
            stride = 1
            for d in range(dim):
                bit = (corner >> d) & 1
                w *= xi[d] if bit else 1.0 - xi[d]
                node += (base[d] + bit) * stride
                stride *= shape[d]
            if w <= 1e-12:
                continue
            c2 = node_cn[node]
            if c2 < 0 or c2 >= n_cn or cn_nodes[c2] != node or held[c2]:  # (node_cn is stale outside the box)
                continue
            a2 = _candidate(c2, nodes, geo)
            if a2 < 0 or slot_group[a2] != slot_group[a1] or slot_group[partner[a2]] != slot_group[partner[a1]]:
                continue
            ent_a[q] = a2
            ent_b[q] = partner[a2]
            ent_w[q] = w
            kept += w
            q += 1
        if kept < 0.5:  # most of the point's cell is not interface: node c keeps its node-wise bond
            q = q0
            continue
        n_con += 1
        con_ptr[n_con] = q
    for e in range(q):
        a = ent_a[e]
        bonded[a] = (bonded[a] & ~NORMAL_BONDED) | NORMAL_BY_POINTS
    return n_con


@njit(cache=True)
def point_bond(bonds, nn, mass, arr, is_momentum, acc, dt, geo_n, dim):
    """Impose the constraints (bonds: contact.workspace.Bonds) on nodal momenta (is_momentum)
    or velocities (with acc, when acc.shape[0] > 1, the matching force per mass is added:
    pass 2). Returns the number of Gauss-Seidel sweeps."""
    n_con, con_ptr, ent_a, ent_b, ent_w = bonds.n_con, bonds.con_ptr, bonds.ent_a, bonds.ent_b, bonds.ent_w
    if n_con == 0:
        return 0
    tol = 0.0
    for sweep in range(MAX_SWEEPS):
        worst = 0.0
        for q in range(n_con):
            g = 0.0
            den = 0.0
            for e in range(con_ptr[q], con_ptr[q + 1]):
                fa = nn + ent_a[e]
                fb = nn + ent_b[e]
                jump = 0.0
                for d in range(dim):
                    va = arr[fa, d] / mass[fa] if is_momentum else arr[fa, d]
                    vb = arr[fb, d] / mass[fb] if is_momentum else arr[fb, d]
                    jump += (vb - va) * geo_n[ent_a[e], d]
                    if sweep == 0:
                        tol = max(tol, abs(va), abs(vb))
                g += ent_w[e] * jump
                den += ent_w[e] ** 2 * (1.0 / mass[fa] + 1.0 / mass[fb])
            worst = max(worst, abs(g))
            lam = g / den
            for e in range(con_ptr[q], con_ptr[q + 1]):
                fa = nn + ent_a[e]
                fb = nn + ent_b[e]
                for d in range(dim):
                    dp = lam * ent_w[e] * geo_n[ent_a[e], d]
                    if is_momentum:
                        arr[fa, d] += dp
                        arr[fb, d] -= dp
                    else:
                        arr[fa, d] += dp / mass[fa]
                        arr[fb, d] -= dp / mass[fb]
                        if acc.shape[0] > 1:
                            acc[fa, d] += dp / (mass[fa] * dt)
                            acc[fb, d] -= dp / (mass[fb] * dt)
        if worst <= 1e-12 * tol:
            return sweep + 1
    return MAX_SWEEPS
