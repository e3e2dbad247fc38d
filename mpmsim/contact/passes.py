"""The three contact passes (LR paper §3.2; notes §1, §3), each its own kernel over the
sparse list of contact nodes.

Geometry, after extrapolation: plan each contact node and compute the normal, separation
  and area of every target material, cached for the passes (and for interfaces).
Pass 1, after extrapolation: change the extrapolated momenta p. This change is part of the
  extrapolation, never a force; it is also kept (`dp1`) for the multimaterial XPIC term.
  `contact.passes: 1` skips it (the paper's "LR once").
Pass 2, after the momentum update: the same laws on the updated momenta p+; each change is
  added to p+ and to the force (as dp/dt), so the particle update's acceleration includes the
  contact force f = dp+/dt (Eq. 33, option 1). The separation is advanced to the end of the
  step for every method (the reference code advances only grid separations). Components held
  by velocity conditions are left alone. The force on rigid contact materials is accumulated
  here.
Pass 3, after re-extrapolation (USL+/USAVG+): enforces pass 2's end-of-step decision on the
  re-extrapolated momenta, with the pass-1 geometry: where pass 2 found contact the relative
  normal velocity is removed whatever its sign (friction capped by mu |N|); elsewhere
  nothing. The reference code re-tests approach here; in a quasi-static compression that
  test is decided by ringing noise and decoupled the two blocks at random node-steps for the
  second stress half-step (+15.8% off single-material XPIC(5) at 2.4% strain; 0.1% when the
  decision is kept). See docs/contact.md.

Imperfect interfaces (law `interface`, 2013 paper; notes §4): no contact test. A direction
that is perfect, or too stiff for the step, is bonded (stick impulse) in every pass; the other
directions are left free in passes 1 and 3 and get the interface force in pass 2 only, from
the backward-Euler spring (default), the trapezoidal spring, the exact oscillator of notes
§4.3, or the paper's first-order force with its limit, with the end-of-step interfacial energy
summed for the history. Openings are each side's displacement at the interface point, carried
there along the particles' displacement gradients (the normal one is d_LR under LR separation).

Node plans: with a rigid contact material present, every other material contacts the
rigid one with the largest volume (rigid mode). With exactly two materials, the first gets
dp and the second -dp (pair mode: momentum conserved). With three or more, each material
contacts the lumped rest (LR paper §3.4, option 3), using the law with the neighbour of
largest volume; momentum is then not exactly conserved.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..gridops import chunk_range, node_ijk
from ..bc import NO_BC, node_bc
from .geometry import cloud_direction, cloud_separation, contact_area, gather_cloud, h_perp, regression_normal
from .laws import apply_law, interface_impulse
from .spec import (AVERAGE_GRADIENT, FIRST_ORDER, FORCE_LIMIT, FRICTIONLESS, INTERFACE, LINEAR_REGRESSION, LOGISTIC,
                   MAX_GRADIENT, SEP_CUTOFF, STICK, SEP_DISPLACEMENT, SEP_FIT, SEP_LR, SEP_VELOCITY, SPECIFIED)

MAX_SLOTS = 64  # groups per node (masks are 64-bit)
# phi^2 = D A dt^2 / m_red above which a direction acts as perfect. The reference code uses 2.25
# (notes §4.3); at cfl 0.5, phi^2 ~ D h / E, so 1 is an interface as stiff as one cell of the
# material next to it, whose compliance the grid cannot resolve. With the interface-point
# opening, unbonded directions between 1 and 2.25 went unstable on the sphere at 50 um cells
# (docs/interfaces.md)
BOND_PHI2 = 1.0


@njit(cache=True, inline="always")
def plan_node(s0, s1, slot_group, n_def_groups, vol, role, partner):
    best_r = -1
    best_vol = -1.0
    n_non = 0
    first = -1
    second = -1
    for s in range(s0, s1):
        role[s] = 0
        partner[s] = -1
        if slot_group[s] >= n_def_groups:
            if vol[s] > best_vol:
                best_vol = vol[s]
                best_r = s
        else:
            n_non += 1
            if first < 0:
                first = s
            elif second < 0:
                second = s
    if n_non == 0:
        return
    if best_r >= 0:
        for s in range(s0, s1):
            if slot_group[s] < n_def_groups:
                role[s] = 1
                partner[s] = best_r
    elif n_non == 2:
        role[first] = 1
        partner[first] = second
    else:
        for s in range(s0, s1):
            if slot_group[s] < n_def_groups:
                role[s] = 1


@njit(cache=True, inline="always")
def lumped_neighbour(a, s0, s1, slot_group, n_def_groups, vol):
    """The other deformable material with the largest volume at the node."""
    best = -1
    bv = -1.0
    for s in range(s0, s1):
        if s != a and slot_group[s] < n_def_groups and vol[s] > bv:
            bv = vol[s]
            best = s
    return best


@njit(cache=True, inline="always")
def stick_impulse(a, b, rigid_b, s0, s1, slot_group, n_def_groups, nn, mass, pbuf, dim, out):
    """Impulse that moves a to the centre-of-mass velocity (or to the rigid velocity).
    b: partner slot (-1: the lumped rest). Returns the reduced mass."""
    ma = mass[nn + a]
    if rigid_b:
        mr = mass[nn + b]
        for d in range(dim):
            out[d] = ma * pbuf[b - s0, d] / mr - pbuf[a - s0, d]
        return ma
    M = 0.0
    for d in range(dim):
        out[d] = 0.0
    if b >= 0:
        M = ma + mass[nn + b]
        for d in range(dim):
            out[d] = ma * (pbuf[a - s0, d] + pbuf[b - s0, d]) / M - pbuf[a - s0, d]
        return ma * mass[nn + b] / M
    for s in range(s0, s1):
        if slot_group[s] < n_def_groups:
            M += mass[nn + s]
    for s in range(s0, s1):
        if slot_group[s] < n_def_groups:
            for d in range(dim):
                out[d] += ma / M * pbuf[s - s0, d]
    for d in range(dim):
        out[d] -= pbuf[a - s0, d]
    return ma * (M - ma) / M


@njit(cache=True, inline="always")
def relative_force(a, b, rigid_b, s0, s1, slot_group, n_def_groups, nn, mass, acc, dim, out):
    """df = (m_a/M) F - f_a over a and its partner side (f = m a of the update), or -f_a
    against a rigid material: the force that changes a's velocity relative to the rest."""
    ma = mass[nn + a]
    for d in range(dim):
        out[d] = -ma * acc[nn + a, d]
    if rigid_b:
        return
    M = 0.0
    for s in range(s0, s1):
        if slot_group[s] < n_def_groups and (b < 0 or s == a or s == b):
            M += mass[nn + s]
    for s in range(s0, s1):
        if slot_group[s] < n_def_groups and (b < 0 or s == a or s == b):
            for d in range(dim):
                out[d] += ma / M * mass[nn + s] * acc[nn + s, d]


@njit(cache=True, inline="always")
def on_side(s, a, b, side, slot_group, n_def_groups):
    """Whether slot s belongs to a side of target a: a itself (side 0), or its partner (side 1:
    slot b, or every other deformable slot when b < 0)."""
    if side == 0:
        return s == a
    if b >= 0:
        return s == b
    return s != a and slot_group[s] < n_def_groups


@njit(cache=True, inline="always")
def side_average(a, b, s0, s1, slot_group, n_def_groups, nn, weight, arr, dim, side, out):
    """Weighted average of a slot quantity (arr holds weighted sums) over one side of target a."""
    for d in range(dim):
        out[d] = 0.0
    w = 0.0
    for s in range(s0, s1):
        if on_side(s, a, b, side, slot_group, n_def_groups):
            w += weight[nn + s]
            for d in range(dim):
                out[d] += arr[s, d]
    for d in range(dim):
        out[d] /= w


@njit(cache=True, inline="always")
def side_at_point(a, b, s0, s1, slot_group, n_def_groups, nn, mass, udisp, ugrad, shift, dim, side, out):
    """A side's mass-weighted displacement evaluated at node + shift: (sum S m u(node) +
    sum S m H shift) / sum S m, with u(node) and H from fields.scatter_slot_extras."""
    for d in range(dim):
        out[d] = 0.0
    m = 0.0
    for s in range(s0, s1):
        if not on_side(s, a, b, side, slot_group, n_def_groups):
            continue
        m += mass[nn + s]
        for d in range(dim):
            out[d] += udisp[s, d]
            for e in range(dim):
                out[d] += ugrad[s, d, e] * shift[e]
    for d in range(dim):
        out[d] /= m


@njit(parallel=True, cache=True)
def contact_geometry(n_cn, cn_nodes, cn_ptr, slot_group, n_def_groups, nn, shape, origin, h, h_min, mass, vol, disp,
                     pos, grad, udisp, ugrad, cloud_ptr, cloud_idx, cloud_w, balance, pgroup, rgroup, n_def, x, rx, F,
                     semi, law, mu, mus,
                     normal_method, sep_method, normal_vec, radial, normal_centre, rigid_bias, cutoff, fit_r, spline,
                     warm, warm_phi, stiffness, dt, integration, area_correction, use_h_perp, screen_volume, nchunk,
                     role, partner, geo_n, geo_delta, geo_area, geo_open, bonded, slot_law, slot_mu, slot_mus,
                     slot_stiff, geo_level):
    """Plan every contact node and give each target material its law, normal, separation
    and contact area, from the extrapolation of the start-of-step particles. Interface
    targets also get their tangential opening (from displacements) and which directions
    act bonded this step (perfect, or too stiff for dt), and the node's signed distance to the
    interface along n (geo_level: negative on a's side; for the consistent bond)."""
    dim = geo_n.shape[1]
    max_cloud = 0
    for c in range(n_cn):
        max_cloud = max(max_cloud, cloud_ptr[c + 1] - cloud_ptr[c])
    for ch in prange(nchunk):
        start, stop = chunk_range(ch, nchunk, n_cn)
        labels = np.zeros(max(max_cloud, 1), dtype=np.int64)
        pts = np.zeros((max(max_cloud, 1), 3))
        pw = np.zeros(max(max_cloud, 1))
        plab = np.zeros(max(max_cloud, 1))
        A = np.zeros((4, 4))
        bvec = np.zeros(4)
        phi = np.zeros(4)
        dphi = np.zeros(4)
        xt = np.zeros(4)
        phi0 = np.zeros(4)
        cov = np.zeros((3, 3))
        pen = np.zeros((3, 3))
        n = np.zeros(3)
        xnode = np.zeros(3)
        shift = np.zeros(3)
        ga_vec = np.zeros(3)
        gb_vec = np.zeros(3)
        for c in range(start, stop):
            s0 = cn_ptr[c]
            s1 = cn_ptr[c + 1]
            node = cn_nodes[c]
            i, j, k = node_ijk(node, shape)
            xnode[0] = origin[0] + i * h[0]
            xnode[1] = origin[1] + j * h[1]
            if dim == 3:
                xnode[2] = origin[2] + k * h[2]
            plan_node(s0, s1, slot_group, n_def_groups, vol, role, partner)
            c0 = cloud_ptr[c]
            c1 = cloud_ptr[c + 1]
            for a in range(s0, s1):
                if role[a] == 0:
                    continue
                b = partner[a]
                ga = slot_group[a]
                rigid_b = b >= 0 and slot_group[b] >= n_def_groups
                nb = b if b >= 0 else lumped_neighbour(a, s0, s1, slot_group, n_def_groups, vol)
                gb = slot_group[nb] if nb >= 0 else ga
                slot_law[a] = law[ga, gb]
                slot_mu[a] = mu[ga, gb]
                slot_mus[a] = mus[ga, gb]
                omega_a = vol[a]
                omega_b = 0.0
                if b >= 0:
                    omega_b = vol[b]
                else:
                    for s in range(s0, s1):
                        if s != a and slot_group[s] < n_def_groups:
                            omega_b += vol[s]
                if omega_a + omega_b < screen_volume:
                    role[a] = 0  # a free-edge node: its normal is not to be trusted (2013 paper)
                    continue
                # --- labels for the point cloud: -1 material a, +1 its partner side
                if c1 > c0:
                    for q in range(c0, c1):
                        idx = cloud_idx[q]
                        g = pgroup[idx] if idx < n_def else rgroup[idx - n_def]
                        if g == ga:
                            labels[q - c0] = -1
                        elif b >= 0:
                            labels[q - c0] = 1 if g == slot_group[b] else 0
                        else:
                            labels[q - c0] = 1 if (g >= 0 and g < n_def_groups) else 0
                # --- normal (a -> b)
                if normal_method == LOGISTIC or normal_method == LINEAR_REGRESSION:
                    for r in range(4):
                        phi0[r] = warm_phi[node, ga, r] if warm else 0.0
                    m, wsum = gather_cloud(cloud_idx, cloud_w, balance, labels, c0, c1, n_def, x, rx, dim, pts, pw,
                                           plab)
                    ok = -1
                    if m > 0:
                        ok = regression_normal(pts, pw, plab, m, wsum, dim, h_min, normal_method == LOGISTIC, phi0, A,
                                               bvec, phi, dphi, xt, cov, pen, n)
                    if warm and ok > 0:
                        for r in range(dim + 1):
                            warm_phi[node, ga, r] = phi[r]
                    if ok < 0 and not cloud_direction(cloud_idx, labels, c0, c1, n_def, x, rx, dim, n):
                        role[a] = 0  # no usable cloud: this material is left alone here
                        continue
                    if rigid_b and rigid_bias >= 10.0:
                        gn = 0.0
                        for d in range(dim):
                            gn += grad[b, d] ** 2
                        if gn > 0.0:
                            for d in range(dim):
                                n[d] = -grad[b, d] / np.sqrt(gn)
                elif normal_method == SPECIFIED:
                    sign = -1.0 if (not rigid_b and ga > gb) else 1.0
                    if radial:
                        r2 = 0.0
                        for d in range(dim):
                            r2 += (xnode[d] - normal_centre[d]) ** 2
                        r2 = np.sqrt(r2) if r2 > 0.0 else 1.0
                        for d in range(dim):
                            n[d] = sign * (xnode[d] - normal_centre[d]) / r2
                    else:
                        for d in range(dim):
                            n[d] = sign * normal_vec[d]
                else:
                    for d in range(dim):
                        ga_vec[d] = grad[a, d]
                        gb_vec[d] = 0.0
                    if b >= 0:
                        for d in range(dim):
                            gb_vec[d] = grad[b, d]
                    else:
                        for s in range(s0, s1):
                            if s != a and slot_group[s] < n_def_groups:
                                for d in range(dim):
                                    gb_vec[d] += grad[s, d]
                    na = 0.0
                    nbm = 0.0
                    nd = 0.0
                    for d in range(dim):
                        na += ga_vec[d] ** 2
                        nbm += gb_vec[d] ** 2
                        nd += (ga_vec[d] - gb_vec[d]) ** 2
                    na, nbm, nd = np.sqrt(na), np.sqrt(nbm), np.sqrt(nd)
                    bias = rigid_bias if rigid_b else 1.0
                    use_a = True
                    if normal_method == AVERAGE_GRADIENT:
                        use_avg = True
                        if rigid_b and omega_b > 0.0:
                            use_avg = nd / (omega_a + omega_b) >= rigid_bias * nbm / omega_b
                        if use_avg:
                            for d in range(dim):
                                n[d] = (ga_vec[d] - gb_vec[d]) / nd
                        else:
                            use_a = False
                            for d in range(dim):
                                n[d] = -gb_vec[d] / nbm
                    else:
                        if normal_method == MAX_GRADIENT:
                            use_a = na >= bias * nbm
                        else:  # max_volume: the gradient of the side with more volume
                            use_a = omega_a >= omega_b
                        for d in range(dim):
                            n[d] = ga_vec[d] / na if use_a else -gb_vec[d] / nbm
                # --- separation
                hp = h_perp(n, h, dim) if use_h_perp else h[0]
                delta = -1.0
                d_edge = 0.0
                use_edge = False
                if sep_method == SEP_LR:
                    delta, da, db = cloud_separation(cloud_idx, labels, c0, c1, n_def, x, rx, F, semi, n, xnode, dim)
                    d_edge = min(abs(da), abs(db))
                    use_edge = True
                elif sep_method == SEP_DISPLACEMENT or sep_method == SEP_CUTOFF or sep_method == SEP_FIT:
                    src = disp if sep_method == SEP_DISPLACEMENT else pos
                    side_average(a, b, s0, s1, slot_group, n_def_groups, nn, mass, src, dim, 0, ga_vec)
                    side_average(a, b, s0, s1, slot_group, n_def_groups, nn, mass, src, dim, 1, gb_vec)
                    qa = 0.0
                    qb = 0.0
                    for d in range(dim):
                        qa += (ga_vec[d] - (xnode[d] if sep_method == SEP_FIT else 0.0)) * n[d]
                        qb += (gb_vec[d] - (xnode[d] if sep_method == SEP_FIT else 0.0)) * n[d]
                    if sep_method == SEP_DISPLACEMENT:
                        delta = qb - qa
                    elif sep_method == SEP_CUTOFF:
                        delta = qb - qa - cutoff * hp
                    else:
                        ea = -(2.0 * (abs(qa) / (1.25 * hp)) ** fit_r - 1.0) * hp
                        eb = (2.0 * (abs(qb) / (1.25 * hp)) ** fit_r - 1.0) * hp
                        delta = eb - ea
                for d in range(dim):
                    geo_n[a, d] = n[d]
                area = contact_area(omega_a, omega_b, hp, d_edge, use_edge, spline)
                if not area_correction:
                    area = (omega_a + omega_b) / hp
                geo_area[a] = area
                # Eq. 20's factor sqrt(2 min / total) is the linear shape function of the node at
                # the interface: 1 on the node, 1/2 half a cell away; the node sits on the side of
                # its larger volume
                tot = omega_a + omega_b
                frac = np.sqrt(min(1.0, 2.0 * min(omega_a, omega_b) / tot)) if tot > 0.0 else 1.0
                geo_level[a] = (1.0 - frac) * hp * (-1.0 if omega_a >= omega_b else 1.0)
                bonded[a] = 0
                if slot_law[a] == INTERFACE:
                    # openings: each side's displacement at the interface point x_node - level n
                    # (not at the node, where the strain between the two sides' particles would
                    # count as opening); the normal one is d_LR with LR separation
                    for d in range(dim):
                        shift[d] = -geo_level[a] * n[d]
                    side_at_point(a, b, s0, s1, slot_group, n_def_groups, nn, mass, udisp, ugrad, shift, dim, 0,
                                  ga_vec)
                    side_at_point(a, b, s0, s1, slot_group, n_def_groups, nn, mass, udisp, ugrad, shift, dim, 1,
                                  gb_vec)
                    dn = 0.0
                    for d in range(dim):
                        dn += (gb_vec[d] - ga_vec[d]) * n[d]
                    for d in range(dim):
                        geo_open[a, d] = gb_vec[d] - ga_vec[d] - dn * n[d]
                    if sep_method != SEP_LR:
                        delta = dn
                    ma = mass[nn + a]
                    if rigid_b:
                        mred = ma
                    elif b >= 0:
                        mred = ma * mass[nn + b] / (ma + mass[nn + b])
                    else:
                        M = 0.0
                        for s in range(s0, s1):
                            if slot_group[s] < n_def_groups:
                                M += mass[nn + s]
                        mred = ma * (M - ma) / M
                    for r in range(3):
                        slot_stiff[a, r] = stiffness[ga, gb, r]
                    Dn = stiffness[ga, gb, 0] if delta >= 0.0 else stiffness[ga, gb, 1]
                    Dt = stiffness[ga, gb, 2]
                    limit = (BOND_PHI2 * mred / (area * dt * dt)
                             if (area > 0.0 and integration != FORCE_LIMIT and integration != FIRST_ORDER) else 1e300)
                    if Dn < 0.0 or Dn > limit:
                        bonded[a] |= 1
                    if Dt < 0.0 or Dt > limit:
                        bonded[a] |= 2
                geo_delta[a] = delta


@njit(cache=True, inline="always")
def exchange_momenta(s0, s1, slot_group, n_def_groups, nn, mass, mom, role, partner, geo_n, slot_law, slot_mu,
                     slot_mus, bonded, touching, need_approach, dim, pbuf, dpb, imp, out, n):
    """The laws at one contact node on the momenta `mom`; the change of each slot in dpb.
    touching[a - s0]: target a's surfaces touch. A touching target is in contact if it
    approaches (need_approach) or whatever its normal velocity (a decision already made)."""
    for s in range(s0, s1):
        for d in range(dim):
            pbuf[s - s0, d] = mom[nn + s, d]
            dpb[s - s0, d] = 0.0
    for a in range(s0, s1):
        if role[a] == 0:
            continue
        b = partner[a]
        rigid_b = b >= 0 and slot_group[b] >= n_def_groups
        for d in range(dim):
            n[d] = geo_n[a, d]
        stick_impulse(a, b, rigid_b, s0, s1, slot_group, n_def_groups, nn, mass, pbuf, dim, imp)
        dotn = 0.0
        for d in range(dim):
            dotn += imp[d] * n[d]
        in_contact = touching[a - s0] and (dotn < 0.0 or not need_approach)
        if apply_law(slot_law[a], slot_mu[a], slot_mus[a], bonded[a], imp, n, dotn, in_contact, dim, out):
            for d in range(dim):
                dpb[a - s0, d] += out[d]
                if b >= 0 and not rigid_b:
                    dpb[b - s0, d] -= out[d]


@njit(parallel=True, cache=True)
def contact_pass_1(n_cn, cn_ptr, slot_group, n_def_groups, nn, mass, mom, sep_method, role, partner, geo_n,
                   geo_delta, slot_law, slot_mu, slot_mus, bonded, touch, nchunk, dp1):
    """The laws on the extrapolated momenta p; the change (kept in dp1) is part of the
    extrapolation. Contact where the surfaces touch (separation below `touch`, a length; or
    always for velocity-only detection) and approach."""
    dim = mom.shape[1]
    for ch in prange(nchunk):
        start, stop = chunk_range(ch, nchunk, n_cn)
        pbuf = np.zeros((MAX_SLOTS, 3))
        dpb = np.zeros((MAX_SLOTS, 3))
        touching = np.zeros(MAX_SLOTS, dtype=np.bool_)
        imp = np.zeros(3)
        out = np.zeros(3)
        n = np.zeros(3)
        for c in range(start, stop):
            s0 = cn_ptr[c]
            s1 = cn_ptr[c + 1]
            for a in range(s0, s1):
                touching[a - s0] = sep_method == SEP_VELOCITY or geo_delta[a] < touch
            exchange_momenta(s0, s1, slot_group, n_def_groups, nn, mass, mom, role, partner, geo_n, slot_law, slot_mu,
                             slot_mus, bonded, touching, True, dim, pbuf, dpb, imp, out, n)
            for s in range(s0, s1):
                if slot_group[s] >= n_def_groups:
                    continue
                for d in range(dim):
                    mom[nn + s, d] += dpb[s - s0, d]
                    dp1[s, d] = dpb[s - s0, d]


@njit(parallel=True, cache=True)
def contact_pass_2(n_cn, cn_nodes, cn_ptr, slot_group, n_def_groups, rigid_of_group, nn, shape, dt, mass, vnew, acc,
                   face_type, wall_index, rigid_vol, constrain, rig_vel, sep_method, role, partner, geo_n, geo_delta,
                   geo_area, geo_open, slot_law, slot_mu, slot_mus, bonded, slot_stiff, integration, touch, nchunk,
                   chunk_reaction, chunk_work, chunk_energy, stick2, applied2, delta2, contact2):
    """Contact on the updated momenta p+ = m v+; the change goes into v+ and a = f/m. Each
    target's stick impulse, applied impulse and end-of-step separation are kept for XPIC.
    Interfaces add their force here (and only here, notes §4.2) and their energy."""
    dim = vnew.shape[1]
    for ch in prange(nchunk):
        start, stop = chunk_range(ch, nchunk, n_cn)
        pbuf = np.zeros((MAX_SLOTS, 3))
        dpb = np.zeros((MAX_SLOTS, 3))
        imp = np.zeros(3)
        out = np.zeros(3)
        n = np.zeros(3)
        df = np.zeros(3)
        chunk_work[ch] = 0.0
        chunk_energy[ch] = 0.0
        for r in range(chunk_reaction.shape[1]):
            for d in range(dim):
                chunk_reaction[ch, r, d] = 0.0
        for c in range(start, stop):
            s0 = cn_ptr[c]
            s1 = cn_ptr[c + 1]
            node = cn_nodes[c]
            i, j, k = node_ijk(node, shape)
            for s in range(s0, s1):
                g = slot_group[s]
                for d in range(dim):
                    # a rigid slot has no grid update: it moves at its end-of-step velocity
                    v = rig_vel[rigid_of_group[g], d] if g >= n_def_groups else vnew[nn + s, d]
                    pbuf[s - s0, d] = mass[nn + s] * v
                    dpb[s - s0, d] = 0.0
            for a in range(s0, s1):
                if role[a] == 0:
                    continue
                b = partner[a]
                rigid_b = b >= 0 and slot_group[b] >= n_def_groups
                for d in range(dim):
                    n[d] = geo_n[a, d]
                mred = stick_impulse(a, b, rigid_b, s0, s1, slot_group, n_def_groups, nn, mass, pbuf, dim, imp)
                dotn = 0.0
                for d in range(dim):
                    dotn += imp[d] * n[d]
                delta = geo_delta[a]
                interface = slot_law[a] == INTERFACE
                if sep_method != SEP_VELOCITY or interface:
                    # the relative force of the update: df = (m_a/M) F - f_a, or -f_a against a
                    # rigid material. It advances the separation to the end of the step (the
                    # reference code does this for grid separations only; d_LR too needs it: a
                    # 5 um gap closing by 70 um within the step must count as contact, or the
                    # free update drives the surfaces through each other, docs/contact.md), and
                    # it drives the interface force.
                    relative_force(a, b, rigid_b, s0, s1, slot_group, n_def_groups, nn, mass, acc, dim, df)
                    dfn = 0.0
                    for d in range(dim):
                        dfn += df[d] * n[d]
                    delta += dt * (dotn - 0.5 * dfn * dt) / mred
                delta2[a] = delta
                if interface:
                    chunk_energy[ch] += interface_impulse(slot_stiff[a], bonded[a], imp, df, n, geo_delta[a], geo_open[a],
                                                          geo_area[a], mred, dt, integration, dim, out)
                    applied = True
                else:
                    touching = sep_method == SEP_VELOCITY or delta < touch
                    applied = apply_law(slot_law[a], slot_mu[a], slot_mus[a], bonded[a], imp, n, dotn,
                                        touching and dotn < 0.0, dim, out)
                for d in range(dim):
                    stick2[a, d] = imp[d]
                    applied2[a, d] = out[d] if applied else 0.0
                if interface:  # XPIC increments re-impose only the bonded directions
                    apply_law(INTERFACE, 0.0, 0.0, bonded[a], imp, n, dotn, True, dim, df)
                    for d in range(dim):
                        applied2[a, d] = df[d]
                contact2[a] = 1 if applied else 0
                if applied:
                    for d in range(dim):
                        owner, vbc = node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain,
                                             rig_vel)
                        if owner != NO_BC:
                            continue  # a velocity condition holds this component
                        dpb[a - s0, d] += out[d]
                        if b >= 0 and not rigid_b:
                            dpb[b - s0, d] -= out[d]
                        if rigid_b:
                            r = rigid_of_group[slot_group[b]]
                            chunk_reaction[ch, r, d] += out[d] / dt
                            chunk_work[ch] += out[d] * rig_vel[r, d]  # the rigid body's work on the material
            for s in range(s0, s1):
                if slot_group[s] >= n_def_groups:
                    continue
                m = mass[nn + s]
                for d in range(dim):
                    owner, vbc = node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain, rig_vel)
                    if owner != NO_BC:
                        continue
                    vnew[nn + s, d] += dpb[s - s0, d] / m
                    acc[nn + s, d] += dpb[s - s0, d] / (m * dt)


@njit(parallel=True, cache=True)
def contact_pass_3(n_cn, cn_ptr, slot_group, n_def_groups, nn, mass, mom, role, partner, geo_n, contact2, slot_law,
                   slot_mu, slot_mus, bonded, nchunk):
    """Pass 2's contact decisions enforced on the re-extrapolated momenta: where pass 2 made
    contact, the relative normal velocity is removed whatever its sign; elsewhere nothing."""
    dim = mom.shape[1]
    for ch in prange(nchunk):
        start, stop = chunk_range(ch, nchunk, n_cn)
        pbuf = np.zeros((MAX_SLOTS, 3))
        dpb = np.zeros((MAX_SLOTS, 3))
        touching = np.zeros(MAX_SLOTS, dtype=np.bool_)
        imp = np.zeros(3)
        out = np.zeros(3)
        n = np.zeros(3)
        for c in range(start, stop):
            s0 = cn_ptr[c]
            s1 = cn_ptr[c + 1]
            for a in range(s0, s1):
                touching[a - s0] = contact2[a] != 0
            exchange_momenta(s0, s1, slot_group, n_def_groups, nn, mass, mom, role, partner, geo_n, slot_law, slot_mu,
                             slot_mus, bonded, touching, False, dim, pbuf, dpb, imp, out, n)
            for s in range(s0, s1):
                if slot_group[s] < n_def_groups:
                    for d in range(dim):
                        mom[nn + s, d] += dpb[s - s0, d]


@njit(cache=True)
def increment_contact(c, cn_nodes, cn_ptr, slot_group, n_def_groups, nn, shape, mass, dv, face_type, wall_index,
                      rigid_vol, constrain, rig_vel, sep_method, role, partner, geo_n, delta2, slot_law, slot_mu,
                      slot_mus, bonded, touch, stick_total, applied_total, pbuf, dpb, imp, out, n):
    """Re-impose contact on one XPIC increment dv at contact node c (notes §5.2): the
    increment's stick change is added to a running stick total (seeded by pass 2's), the law
    is applied to the total, and only the change of the applied result is put on the
    increment. With bonded contact every increment goes to the centre of mass, so the filter
    is exactly single-material XPIC."""
    dim = dv.shape[1]
    s0 = cn_ptr[c]
    s1 = cn_ptr[c + 1]
    node = cn_nodes[c]
    i, j, k = node_ijk(node, shape)
    for s in range(s0, s1):
        for d in range(dim):
            pbuf[s - s0, d] = mass[nn + s] * dv[nn + s, d] if slot_group[s] < n_def_groups else 0.0
            dpb[s - s0, d] = 0.0
    for a in range(s0, s1):
        if role[a] == 0:
            continue
        b = partner[a]
        rigid_b = b >= 0 and slot_group[b] >= n_def_groups
        for d in range(dim):
            n[d] = geo_n[a, d]
        stick_impulse(a, b, rigid_b, s0, s1, slot_group, n_def_groups, nn, mass, pbuf, dim, imp)
        dotn = 0.0
        for d in range(dim):
            stick_total[a, d] += imp[d]
            dotn += stick_total[a, d] * n[d]
        touching = sep_method == SEP_VELOCITY or delta2[a] < touch
        for d in range(dim):
            imp[d] = stick_total[a, d]
        applied = apply_law(slot_law[a], slot_mu[a], slot_mus[a], bonded[a], imp, n, dotn, touching and dotn < 0.0,
                            dim, out)
        for d in range(dim):
            now = out[d] if applied else 0.0
            change = now - applied_total[a, d]
            applied_total[a, d] = now
            dpb[a - s0, d] += change
            if b >= 0 and not rigid_b:
                dpb[b - s0, d] -= change
    for s in range(s0, s1):
        if slot_group[s] >= n_def_groups:
            continue
        m = mass[nn + s]
        for d in range(dim):
            owner, vbc = node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain, rig_vel)
            if owner == NO_BC:
                dv[nn + s, d] += dpb[s - s0, d] / m
