"""Material velocity fields where groups meet (notes §0, §2.1), rebuilt every step.

1. Each node collects the set of groups whose particles touch it (non-zero weight) as a
   64-bit mask.
2. Nodes with two or more groups are *contact nodes*; each gets one slot per group, stored
   after the regular nodes: slot s is field n_nodes + s. A sparse list, so scenes pay for
   contact only where materials meet.
3. Each particle-node entry gets its field: the node, or its group's slot at contact nodes.
4. For point-cloud methods, each contact node lists the particles that touch it (CSR);
   rigid contact particles are numbered after the deformable ones.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ...gridops import chunk_range, node_ijk, slab
from ...materials.kernels import inv3
from ...parallel import chunk_kernel

ONE = np.uint64(1)


@chunk_kernel
def scatter_group_masks(sc, group, mask):
    """mask[node] |= bit of each particle's group at the nodes it weighs (sc: views.Scatter
    with grid nodes as fields)."""
    nodes, S = sc.fidx, sc.S
    K = S.shape[1]
    order, ptr = sc.order, sc.ptr
    for color in range(2):
        for s in prange((ptr.size - color) // 2):
            for q in slab(ptr, color, s):
                p = order[q]
                bit = ONE << np.uint64(group[p])
                for k in range(K):
                    if S[p, k] > 0.0:
                        mask[nodes[p, k]] |= bit


@njit(cache=True)
def scatter_rigid_masks(nodes, S, group, mask):
    n, K = S.shape
    for p in range(n):
        g = group[p]
        if g < 0:
            continue
        bit = ONE << np.uint64(g)
        for k in range(K):
            if S[p, k] > 0.0:
                mask[nodes[p, k]] |= bit


@njit(cache=True, inline="always")
def popcount(m):
    c = 0
    while m != np.uint64(0):
        m &= m - ONE
        c += 1
    return c


@njit(cache=True)
def count_slots(box_nodes, mask):
    n_cn = 0
    n_slots = 0
    for q in range(box_nodes.size):
        c = popcount(mask[box_nodes[q]])
        if c >= 2:
            n_cn += 1
            n_slots += c
    return n_cn, n_slots


@njit(cache=True)
def build_slots(box_nodes, mask, c, s, node_cn, cn_nodes, cn_ptr, slot_group, slot_node):
    """Number contact nodes and their slots (groups in increasing order), the first of these
    nodes as contact node c with slot s (0, 0 for the whole box; the GPU step numbers chunks
    of nodes from their offsets)."""
    cn_ptr[c] = s
    for q in range(box_nodes.size):
        node = box_nodes[q]
        m = mask[node]
        if popcount(m) < 2:
            node_cn[node] = -1
            continue
        node_cn[node] = c
        cn_nodes[c] = node
        g = 0
        while m != np.uint64(0):
            if m & ONE:
                slot_group[s] = g
                slot_node[s] = node
                s += 1
            m >>= ONE
            g += 1
        c += 1
        cn_ptr[c] = s


@chunk_kernel
def assign_fields(nodes, S, group, node_cn, cn_ptr, slot_group, n_nodes, keep_nodes, fidx, slotted):
    """fidx = n_nodes + the slot of the particle's group at contact nodes; elsewhere the node
    itself (keep_nodes, deformable particles) or -1 (rigid contact particles live only in
    slots; rigid velocity-condition particles have group -1 and no fields). slotted[p]: some
    entry of p is a slot (the particles the slot sums and the point clouds walk)."""
    for p in prange(S.shape[0]):
        slotted[p] = assign_particle(p, nodes, group, node_cn, cn_ptr, slot_group, n_nodes, keep_nodes, fidx)


@njit(cache=True, inline="always")
def assign_particle(p, nodes, group, node_cn, cn_ptr, slot_group, n_nodes, keep_nodes, fidx):
    """assign_fields for particle p (also the GPU step's, a thread per particle); whether an
    entry of p is a slot."""
    g = group[p]
    slotted = False
    for k in range(fidx.shape[1]):
        node = nodes[p, k]
        f = node if keep_nodes else -1
        c = node_cn[node]
        if c >= 0 and g >= 0:
            for s in range(cn_ptr[c], cn_ptr[c + 1]):
                if slot_group[s] == g:
                    f = n_nodes + s
                    slotted = True
                    break
        fidx[p, k] = f
    return slotted


@chunk_kernel
def touch_contact_nodes(sd, node_cn, candidates, nchunk, out):
    """out[q]: deformable particle candidates[q] weighs a contact node (sd: shapes.ShapeData; a
    non-zero weight); in chunks, so the clouds' serial passes below walk only these particles."""
    nodes, S = sd.nodes, sd.S
    K = S.shape[1]
    n = candidates.size
    for c in prange(nchunk):
        start, stop = chunk_range(c, nchunk, n)
        for q in range(start, stop):
            p = candidates[q]
            hit = False
            for k in range(K):
                if S[p, k] > 0.0 and node_cn[nodes[p, k]] >= 0:
                    hit = True
                    break
            out[q] = hit


@njit(cache=True)
def build_clouds(sd, near, rsd, rgroup, node_cn, n_cn, shape_weights, ptr, idx, wts, fill):
    """CSR of the particles touching each contact node (sd, rsd: shapes.ShapeData of the
    deformable and rigid particles; near: the deformable particles that weigh a contact node,
    in index order), with each one's regression weight (its shape function at the node, or 1);
    rigid contact particles are numbered after the deformable ones. With fill=False only
    counts (ptr[c + 1] = count); call again with fill=True after the prefix sum."""
    nodes, S, rnodes, rS = sd.nodes, sd.S, rsd.nodes, rsd.S
    n, K = S.shape
    n_def = n
    if not fill:
        for c in range(n_cn + 1):
            ptr[c] = 0
    else:
        cursor = ptr[:-1].copy()
    for q in range(near.size):
        p = near[q]
        for k in range(K):
            if S[p, k] > 0.0:
                c = node_cn[nodes[p, k]]
                if c >= 0:
                    if fill:
                        idx[cursor[c]] = p
                        wts[cursor[c]] = S[p, k] if shape_weights else 1.0
                        cursor[c] += 1
                    else:
                        ptr[c + 1] += 1
    for r in range(rS.shape[0]):
        if rgroup[r] < 0:
            continue
        for k in range(rS.shape[1]):
            if rS[r, k] > 0.0:
                c = node_cn[rnodes[r, k]]
                if c >= 0:
                    if fill:
                        idx[cursor[c]] = n_def + r
                        wts[cursor[c]] = rS[r, k] if shape_weights else 1.0
                        cursor[c] += 1
                    else:
                        ptr[c + 1] += 1
    if not fill:
        for c in range(n_cn):
            ptr[c + 1] += ptr[c]


@chunk_kernel
def scatter_slot_extras(sc, G, P, grid, n_nodes, slot_node, wants, sums):
    """Per-slot contact volume sum S V, and when asked (wants) mass-weighted displacement and
    position and the volume gradient sum G V (deformable particles P; slab-parallel over sc).
    want_open (interfaces): each particle's displacement carried to the node along its own
    displacement gradient H = I - F^-1, udisp = sum S m (u + H (x_i - x)), and ugrad = sum S m H,
    so that a side's displacement can be evaluated at the interface point (its opening then
    excludes the strain between the particles and the interface). Without carry (the reference
    code's opening at the node) udisp = sum S m u and ugrad stays zero."""
    fidx, S = sc.fidx, sc.S
    pmass, pvol, x, x0, F = P.mass, P.vol, P.x, P.x0, P.F
    shape, origin, h = grid.shape, grid.origin, grid.h
    want_disp, want_pos, want_grad, want_open, carry = wants.disp, wants.pos, wants.grad, wants.open, wants.carry
    want_radius = wants.radius
    vol, disp, pos, grad, udisp, ugrad, rvol = sums.vol, sums.disp, sums.pos, sums.grad, sums.udisp, sums.ugrad, sums.rvol
    K = S.shape[1]
    dim = x.shape[1]
    order, ptr = sc.order, sc.ptr
    for color in range(2):
        for s in prange((ptr.size - color) // 2):
            H = np.zeros((3, 3))
            Finv = np.zeros((3, 3))
            for q in slab(ptr, color, s):
                p = order[q]
                have_h = False
                for k in range(K):
                    f = fidx[p, k]
                    if f < n_nodes:
                        continue
                    sl = f - n_nodes
                    w = S[p, k]
                    vol[sl] += w * pvol[p]
                    if want_radius:  # pvol is the r-z area (contact_measure): times r, the volume per radian
                        rvol[sl] += w * pvol[p] * x[p, 0]
                    for d in range(dim):
                        if want_disp:
                            disp[sl, d] += w * pmass[p] * (x[p, d] - x0[p, d])
                        if want_pos:
                            pos[sl, d] += w * pmass[p] * x[p, d]
                        if want_grad:
                            grad[sl, d] += G[p, k, d] * pvol[p]
                    if want_open:
                        wm = w * pmass[p]
                        if not carry:
                            for d in range(dim):
                                udisp[sl, d] += wm * (x[p, d] - x0[p, d])
                            continue
                        if not have_h:
                            displacement_gradient(F[p], dim, Finv, H)
                            have_h = True
                        i, j, kk = node_ijk(slot_node[sl], shape)
                        xi = (origin[0] + i * h[0], origin[1] + j * h[1], origin[2] + kk * h[2] if dim == 3 else 0.0)
                        for d in range(dim):
                            u = x[p, d] - x0[p, d]
                            for e in range(dim):
                                u += H[d, e] * (xi[e] - x[p, e])
                                ugrad[sl, d, e] += wm * H[d, e]
                            udisp[sl, d] += wm * u


@njit(cache=True, inline="always")
def displacement_gradient(Fp, dim, Finv, H):
    """H = du/dx = I - F^-1 (spatial gradient of the displacement)."""
    if dim == 2:
        det = Fp[0, 0] * Fp[1, 1] - Fp[0, 1] * Fp[1, 0]
        Finv[0, 0] = Fp[1, 1] / det
        Finv[0, 1] = -Fp[0, 1] / det
        Finv[1, 0] = -Fp[1, 0] / det
        Finv[1, 1] = Fp[0, 0] / det
    else:
        inv3(Fp, Finv)
    for d in range(dim):
        for e in range(dim):
            H[d, e] = (1.0 if d == e else 0.0) - Finv[d, e]


@njit(cache=True)
def scatter_rigid_slots(fidx, rsd, R, n_nodes, with_mass, wants, mass, mom, sums):
    """Rigid contact particles R (RigidView; fields fidx, shape data rsd) fill their slots
    with volume-weighted quantities: the slot's 'mass' is sum S V and its momentum sum S V v,
    so p/m is the rigid velocity (notes §0). Without with_mass (re-extrapolation) only the
    momentum is added."""
    S, G, rvol, rv, rx, rx0 = rsd.S, rsd.G, R.vol, R.v, R.x, R.x0
    want_disp, want_pos, want_grad, want_open = wants.disp, wants.pos, wants.grad, wants.open
    vol, disp, pos, grad, udisp, vol_r = sums.vol, sums.disp, sums.pos, sums.grad, sums.udisp, sums.rvol
    n, K = S.shape
    dim = rx.shape[1]
    for p in range(n):
        for k in range(K):
            f = fidx[p, k]
            if f < n_nodes:
                continue
            sl = f - n_nodes
            w = S[p, k] * rvol[p]
            for d in range(dim):
                mom[f, d] += w * rv[p, d]
            if not with_mass:
                continue
            mass[f] += w
            vol[sl] += w
            if wants.radius:
                vol_r[sl] += w * rx[p, 0]
            for d in range(dim):
                if want_disp:
                    disp[sl, d] += w * (rx[p, d] - rx0[p, d])
                if want_open:  # a rigid body has no displacement gradient
                    udisp[sl, d] += w * (rx[p, d] - rx0[p, d])
                if want_pos:
                    pos[sl, d] += w * rx[p, d]
                if want_grad:
                    grad[sl, d] += G[p, k, d] * rvol[p]
