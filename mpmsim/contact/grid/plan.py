"""Contact geometry, once per step after extrapolation: plan every contact node and give each
target material its law, normal, separation and contact area (and, at interfaces, its
openings and bonded directions), from the extrapolation of the start-of-step particles. The
passes (passes.py) read what this leaves in `Targets`.

Node plans: with a rigid contact material present, every other material contacts the rigid
one with the largest volume (rigid mode). With exactly two materials, the first gets dp and
the second -dp (pair mode: momentum conserved). With three or more, each material contacts
the lumped rest (LR paper §3.4, option 3), using the law with the neighbour of largest
volume; momentum is then not exactly conserved.

One function per concern, each readable alone:
  plan_node            roles and partners at a node
  target_law           law, friction and the two sides' volumes of one target
  label_cloud          the point cloud's classes (-1 material a, +1 its partner side)
  regression_normal_of / specified_normal / gradient_normal   the normal methods
  grid_separation      displacement, CP cutoff or DF fit separation (LR's: cloud_separation)
  contact_geometry     the kernel of one normal method and separation
  interface_setup      openings at the interface point and the bonded directions
"""

from __future__ import annotations

from functools import cache
from typing import NamedTuple

import numpy as np
from numba import njit, prange

from ...gridops import chunk_range, node_ijk
from ...parallel import BORROWING, chunk_kernel, specialize
from ...views import GridView
from .geometry import (cloud_direction, cloud_separation, contact_area, gather_cloud, h_perp, regression_normal,
                       regression_scratch)
from .spec import (AVERAGE_GRADIENT, FIRST_ORDER, FORCE_LIMIT, INTERFACE, LINEAR_REGRESSION, LOGISTIC, MAX_GRADIENT,
                   SEP_CUTOFF, SEP_DISPLACEMENT, SEP_FIT, SEP_LR, SPECIFIED)

# phi^2 = D A dt^2 / m_red above which a direction acts as perfect. The reference code uses 2.25
# (notes §4.3); at cfl 0.5, phi^2 ~ D h / E, so 1 is an interface as stiff as one cell of the
# material next to it, whose compliance the grid cannot resolve. With the interface-point
# opening, unbonded directions between 1 and 2.25 went unstable on the sphere at 50 um cells
# (docs/interfaces.md)
BOND_PHI2 = 1.0


class GeometryInputs(NamedTuple):
    """Everything the geometry reads (bundles of mpmsim/contact/grid/workspace.py and spec.py),
    assembled inside each parallel chunk (numba's parallel loops take flat bundles only)."""

    nodes: object  # ContactNodes
    grid: object  # views.GridView
    mass: np.ndarray  # field masses (slots at nn + s)
    sums: object  # SlotSums
    clouds: object  # Clouds
    laws: object  # PairLaws
    method: object  # Method
    warm_phi: np.ndarray  # (n_nodes, G, 4) last logistic fit (warm start), or a placeholder
    dt: float  # the step the CFL rule allows (interface bonding switch)


@njit(cache=True, inline="always")
def plan_node(s0, s1, nodes, vol, role, partner):
    """Roles (1: target) and partners (-1: the lumped rest) of the slots s0:s1 of a node."""
    slot_group, n_def = nodes.slot_group, nodes.n_def
    best_r = -1
    best_vol = -1.0
    n_non = 0
    first = -1
    second = -1
    for s in range(s0, s1):
        role[s] = 0
        partner[s] = -1
        if slot_group[s] >= n_def:
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
            if slot_group[s] < n_def:
                role[s] = 1
                partner[s] = best_r
    elif n_non == 2:
        role[first] = 1
        partner[first] = second
    else:
        for s in range(s0, s1):
            if slot_group[s] < n_def:
                role[s] = 1


@njit(cache=True, inline="always")
def on_side(s, a, b, side, nodes):
    """Whether slot s belongs to a side of target a: a itself (side 0), or its partner (side 1:
    slot b, or every other deformable slot when b < 0)."""
    if side == 0:
        return s == a
    if b >= 0:
        return s == b
    return s != a and nodes.slot_group[s] < nodes.n_def


@njit(cache=True, inline="always")
def side_average(a, b, s0, s1, nodes, weight, arr, dim, side, out):
    """Weighted average of a slot quantity (arr holds weighted sums) over one side of target a."""
    nn = nodes.nn
    for d in range(dim):
        out[d] = 0.0
    w = 0.0
    for s in range(s0, s1):
        if on_side(s, a, b, side, nodes):
            w += weight[nn + s]
            for d in range(dim):
                out[d] += arr[s, d]
    for d in range(dim):
        out[d] /= w


@njit(cache=True, inline="always")
def side_at_point(a, b, s0, s1, nodes, mass, sums, shift, dim, side, out):
    """A side's mass-weighted displacement evaluated at node + shift: (sum S m u(node) +
    sum S m H shift) / sum S m, with u(node) and H from fields.scatter_slot_extras."""
    nn, udisp, ugrad = nodes.nn, sums.udisp, sums.ugrad
    for d in range(dim):
        out[d] = 0.0
    m = 0.0
    for s in range(s0, s1):
        if not on_side(s, a, b, side, nodes):
            continue
        m += mass[nn + s]
        for d in range(dim):
            out[d] += udisp[s, d]
            for e in range(dim):
                out[d] += ugrad[s, d, e] * shift[e]
    for d in range(dim):
        out[d] /= m


@njit(cache=True, inline="always")
def lumped_neighbour(a, s0, s1, nodes, vol):
    """The other deformable material with the largest volume at the node."""
    best = -1
    bv = -1.0
    for s in range(s0, s1):
        if s != a and nodes.slot_group[s] < nodes.n_def and vol[s] > bv:
            bv = vol[s]
            best = s
    return best


@njit(cache=True, inline="always")
def mean_radius(s0, s1, sums):
    """Axisymmetric: the mean radius of the material at a node (its slots' r-weighted over
    their r-z volumes), which turns an r-z contact area into one per radian. The interface
    paper's node radius r_i is that mean for a node whose shape function lies whole in the
    material; on the axis (half a hat, mean radius about h/3) it gave no area, so an interface
    crossing the axis (an inclusion's pole) carried nothing there, and at a body's outer edge it
    overstated the area."""
    v = 0.0
    rv = 0.0
    for s in range(s0, s1):
        v += sums.vol[s]
        rv += sums.rvol[s]
    return rv / v if v > 0.0 else 0.0


@njit(cache=True, inline="always")
def reduced_mass(a, b, rigid_b, s0, s1, nodes, mass):
    """m_a m_b / (m_a + m_b) of target a and its partner side (m_a against a rigid one)."""
    nn = nodes.nn
    ma = mass[nn + a]
    if rigid_b:
        return ma
    if b >= 0:
        return ma * mass[nn + b] / (ma + mass[nn + b])
    M = 0.0
    for s in range(s0, s1):
        if nodes.slot_group[s] < nodes.n_def:
            M += mass[nn + s]
    return ma * (M - ma) / M


@njit(cache=True, inline="always")
def target_law(a, b, s0, s1, inp, geo):
    """Law and friction of target a (with its partner, or the lumped neighbour of largest
    volume), and the contact volumes of its two sides: (ga, gb, omega_a, omega_b)."""
    nodes, vol, laws = inp.nodes, inp.sums.vol, inp.laws
    slot_group, n_def = nodes.slot_group, nodes.n_def
    ga = slot_group[a]
    nb = b if b >= 0 else lumped_neighbour(a, s0, s1, nodes, vol)
    gb = slot_group[nb] if nb >= 0 else ga
    geo.law[a] = laws.law[ga, gb]
    geo.mu[a] = laws.mu[ga, gb]
    geo.mus[a] = laws.mus[ga, gb]
    omega_a = vol[a]
    omega_b = 0.0
    if b >= 0:
        omega_b = vol[b]
    else:
        for s in range(s0, s1):
            if s != a and slot_group[s] < n_def:
                omega_b += vol[s]
    return ga, gb, omega_a, omega_b


@njit(cache=True, inline="always")
def label_cloud(a, b, ga, c0, c1, nodes, clouds, labels):
    """labels[q - c0]: -1 for material a's particles, +1 for its partner side's, 0 others."""
    for q in range(c0, c1):
        idx = clouds.idx[q]
        g = clouds.group[idx] if idx < clouds.n_def else clouds.rgroup[idx - clouds.n_def]
        if g == ga:
            labels[q - c0] = -1
        elif b >= 0:
            labels[q - c0] = 1 if g == nodes.slot_group[b] else 0
        else:
            labels[q - c0] = 1 if (g >= 0 and g < nodes.n_def) else 0


@njit(cache=True)
def regression_normal_of(b, ga, rigid_b, node, c0, c1, method, warm_phi, clouds, grad, R, dim, n):
    """Logistic or linear regression normal of the labelled cloud (LR paper §3.1); the
    centroid direction if the fit fails; against a rigid material with rigid_bias >= 10, the
    rigid material's volume gradient (grad: the slots' volume gradients). False: no usable
    cloud (the target is dropped). (It takes the pieces of the geometry's inputs it reads,
    not the whole bundle: passing that down costs compile time at every call level.)"""
    for r in range(4):
        R.phi0[r] = warm_phi[node, ga, r] if method.warm else 0.0
    m, wsum = gather_cloud(clouds, c0, c1, dim, R)
    ok = -1
    if m > 0:
        ok = regression_normal(R, m, wsum, dim, method.h_min, method.normal == LOGISTIC, n)
    if method.warm and ok > 0:
        for r in range(dim + 1):
            warm_phi[node, ga, r] = R.phi[r]
    if ok < 0 and not cloud_direction(clouds, R.labels, c0, c1, dim, n):
        return False
    if rigid_b and method.rigid_bias >= 10.0:
        gn = 0.0
        for d in range(dim):
            gn += grad[b, d] ** 2
        if gn > 0.0:
            for d in range(dim):
                n[d] = -grad[b, d] / np.sqrt(gn)
    return True


@njit(cache=True, inline="always")
def specified_normal(ga, gb, rigid_b, xnode, method, dim, n):
    """The deck's normal (from the lower group to the higher), or radial from a centre."""
    sign = -1.0 if (not rigid_b and ga > gb) else 1.0
    if method.radial:
        r2 = 0.0
        for d in range(dim):
            r2 += (xnode[d] - method.centre[d]) ** 2
        r2 = np.sqrt(r2) if r2 > 0.0 else 1.0
        for d in range(dim):
            n[d] = sign * (xnode[d] - method.centre[d]) / r2
    else:
        for d in range(dim):
            n[d] = sign * method.normal_vec[d]


@njit(cache=True)
def gradient_normal(a, b, s0, s1, rigid_b, omega_a, omega_b, inp, dim, va, vb, n):
    """Grid normals from volume gradients (LR paper §2): AVG (their difference; against a
    rigid material the rigid one's unless the bias test passes), MVG (the larger gradient,
    rigid biased) or max volume (the gradient of the side with more volume)."""
    nodes, grad, method = inp.nodes, inp.sums.grad, inp.method
    for d in range(dim):
        va[d] = grad[a, d]
        vb[d] = 0.0
    if b >= 0:
        for d in range(dim):
            vb[d] = grad[b, d]
    else:
        for s in range(s0, s1):
            if s != a and nodes.slot_group[s] < nodes.n_def:
                for d in range(dim):
                    vb[d] += grad[s, d]
    na = 0.0
    nbm = 0.0
    nd = 0.0
    for d in range(dim):
        na += va[d] ** 2
        nbm += vb[d] ** 2
        nd += (va[d] - vb[d]) ** 2
    na, nbm, nd = np.sqrt(na), np.sqrt(nbm), np.sqrt(nd)
    bias = method.rigid_bias if rigid_b else 1.0
    if method.normal == AVERAGE_GRADIENT:
        use_avg = True
        if rigid_b and omega_b > 0.0:
            use_avg = nd / (omega_a + omega_b) >= method.rigid_bias * nbm / omega_b
        if use_avg:
            for d in range(dim):
                n[d] = (va[d] - vb[d]) / nd
        else:
            for d in range(dim):
                n[d] = -vb[d] / nbm
        return
    if method.normal == MAX_GRADIENT:
        use_a = na >= bias * nbm
    else:  # max_volume: the gradient of the side with more volume
        use_a = omega_a >= omega_b
    for d in range(dim):
        n[d] = va[d] / na if use_a else -vb[d] / nbm


@njit(cache=True)
def grid_separation(a, b, s0, s1, xnode, n, hp, inp, dim, va, vb):
    """Grid separations from the two sides' mass-weighted displacements (displacement),
    positions less a cutoff (CP), or the DF fit; -1 (touching) for velocity-only detection."""
    method, nodes, mass, sums = inp.method, inp.nodes, inp.mass, inp.sums
    sep = method.separation
    delta = -1.0
    if sep == SEP_DISPLACEMENT or sep == SEP_CUTOFF or sep == SEP_FIT:
        src = sums.disp if sep == SEP_DISPLACEMENT else sums.pos
        side_average(a, b, s0, s1, nodes, mass, src, dim, 0, va)
        side_average(a, b, s0, s1, nodes, mass, src, dim, 1, vb)
        qa = 0.0
        qb = 0.0
        for d in range(dim):
            qa += (va[d] - (xnode[d] if sep == SEP_FIT else 0.0)) * n[d]
            qb += (vb[d] - (xnode[d] if sep == SEP_FIT else 0.0)) * n[d]
        if sep == SEP_DISPLACEMENT:
            delta = qb - qa
        elif sep == SEP_CUTOFF:
            delta = qb - qa - method.cutoff * hp
        else:
            fit_r = method.fit_r
            ea = -(2.0 * (abs(qa) / (1.25 * hp)) ** fit_r - 1.0) * hp
            eb = (2.0 * (abs(qb) / (1.25 * hp)) ** fit_r - 1.0) * hp
            delta = eb - ea
    return delta


@njit(cache=True)
def interface_setup(a, b, rigid_b, s0, s1, ga, gb, delta, area, inp, geo, dim, v):
    """At an interface target: the openings (each side's displacement at the interface point
    x_node - level n, not at the node, where the strain between the two sides' particles
    would count as opening; the normal one is d_LR with LR separation), the stiffnesses, and
    which directions act bonded this step (perfect, or too stiff for dt: phi^2 > BOND_PHI2).
    v: the normal (row 0) and three scratch vectors. Returns the normal opening."""
    n, shift, va, vb = v[0], v[1], v[2], v[3]
    nodes, mass, method, stiffness = inp.nodes, inp.mass, inp.method, inp.laws.stiffness
    for d in range(dim):
        shift[d] = -geo.level[a] * n[d]
    side_at_point(a, b, s0, s1, nodes, mass, inp.sums, shift, dim, 0, va)
    side_at_point(a, b, s0, s1, nodes, mass, inp.sums, shift, dim, 1, vb)
    dn = 0.0
    for d in range(dim):
        dn += (vb[d] - va[d]) * n[d]
    for d in range(dim):
        geo.open[a, d] = vb[d] - va[d] - dn * n[d]
    if method.separation != SEP_LR:
        delta = dn
    mred = reduced_mass(a, b, rigid_b, s0, s1, nodes, mass)
    for r in range(3):
        geo.stiff[a, r] = stiffness[ga, gb, r]
    Dn = stiffness[ga, gb, 0] if delta >= 0.0 else stiffness[ga, gb, 1]
    Dt = stiffness[ga, gb, 2]
    integration, dt = method.integration, inp.dt
    limit = (BOND_PHI2 * mred / (area * dt * dt)
             if (area > 0.0 and integration != FORCE_LIMIT and integration != FIRST_ORDER) else 1e300)
    if Dn < 0.0 or Dn > limit:
        geo.bonded[a] |= 1
    if Dt < 0.0 or Dt > limit:
        geo.bonded[a] |= 2
    return delta


# The normal method, separation and whether some pair has the interface law, as constants of
# the geometry kernels (contact_geometry() binds them; these values are never compiled)
NORMAL, SEPARATION, INTERFACES = -1, -1, True


@njit(cache=True, inline="always")
def mirror_normal(xnode, mirror, dim, n):
    """On (and beyond) a mirror plane (a roller face: a symmetry plane or a frictionless wall;
    the axisymmetric axis) the normal has no component across it, by symmetry: drop that
    component and renormalise (one component left: exactly +-1). False if nothing is left."""
    cut = False
    for d in range(dim):
        if xnode[d] <= mirror[0, d] or xnode[d] >= mirror[1, d]:
            n[d] = 0.0
            cut = True
    if not cut:
        return True
    big = 0.0
    for d in range(dim):
        big = max(big, abs(n[d]))
    if not (big > 0.0):
        return False
    s = 0.0
    for d in range(dim):
        n[d] /= big  # (first to order one: a tiny remaining component would underflow when squared)
        s += n[d] * n[d]
    s = np.sqrt(s)
    for d in range(dim):
        n[d] /= s
    return True


def target_geometry(a, node, s0, s1, c0, c1, xnode, inp, geo, R, v):
    """Law, normal, separation, area, level (and interface openings) of target a at a node
    at xnode; v holds four scratch vectors. Drops the target (role 0) where it cannot be
    planned: a screened free-edge node, no usable point cloud. Compiled per method
    (contact_geometry)."""
    dim = geo.normal.shape[1]
    nodes, method = inp.nodes, inp.method
    n, va, vb = v[0], v[2], v[3]  # v[1]: interface_setup's scratch
    b = geo.partner[a]
    rigid_b = b >= 0 and nodes.slot_group[b] >= nodes.n_def
    ga, gb, omega_a, omega_b = target_law(a, b, s0, s1, inp, geo)
    if omega_a + omega_b < method.screen:
        geo.role[a] = 0  # a free-edge node: its normal is not to be trusted (2013 paper)
        return
    if c1 > c0:
        label_cloud(a, b, ga, c0, c1, nodes, inp.clouds, R.labels)
    if NORMAL == LOGISTIC or NORMAL == LINEAR_REGRESSION:
        if not regression_normal_of(b, ga, rigid_b, node, c0, c1, method, inp.warm_phi, inp.clouds, inp.sums.grad, R,
                                    dim, n):
            geo.role[a] = 0  # no usable cloud: this material is left alone here
            return
    elif NORMAL == SPECIFIED:
        specified_normal(ga, gb, rigid_b, xnode, method, dim, n)
    else:
        gradient_normal(a, b, s0, s1, rigid_b, omega_a, omega_b, inp, dim, va, vb, n)
    if not mirror_normal(xnode, method.mirror, dim, n):
        geo.role[a] = 0
        return
    hp = h_perp(n, inp.grid.h, dim) if method.use_h_perp else inp.grid.h[0]
    d_edge = 0.0
    use_edge = False
    if SEPARATION == SEP_LR:  # d_LR from the deformed particle edges (Eq. 25)
        delta, da, db = cloud_separation(inp.clouds, R.labels, c0, c1, n, xnode, dim)
        d_edge = min(abs(da), abs(db))
        use_edge = True
    else:
        delta = grid_separation(a, b, s0, s1, xnode, n, hp, inp, dim, va, vb)
    for d in range(dim):
        geo.normal[a, d] = n[d]
    area = contact_area(omega_a, omega_b, hp, d_edge, use_edge, method.spline)
    if not method.area_correction:
        area = (omega_a + omega_b) / hp
    if method.axisymmetric:  # per radian: times the mean radius of the node's material
        area *= mean_radius(s0, s1, inp.sums)
    geo.area[a] = area
    # Eq. 20's factor sqrt(2 min / total) is the linear shape function of the node at the
    # interface: 1 on the node, 1/2 half a cell away; the node sits on the side of its larger
    # volume
    tot = omega_a + omega_b
    frac = np.sqrt(min(1.0, 2.0 * min(omega_a, omega_b) / tot)) if tot > 0.0 else 1.0
    geo.level[a] = (1.0 - frac) * hp * (-1.0 if omega_a >= omega_b else 1.0)
    geo.bonded[a] = 0
    if INTERFACES and geo.law[a] == INTERFACE:
        delta = interface_setup(a, b, rigid_b, s0, s1, ga, gb, delta, area, inp, geo, dim, v)
    geo.delta[a] = delta


def plan_contact_node(c, inp, geo, R, v, xnode):
    """Plan contact node c: roles and partners, then each target's geometry (R: regression
    scratch for the node's cloud, v: four scratch vectors, xnode: 3). Also the GPU step's, a
    thread per contact node. Compiled per method (node_planner)."""
    nodes, grid, clouds = inp.nodes, inp.grid, inp.clouds
    dim = geo.normal.shape[1]
    s0 = nodes.cn_ptr[c]
    s1 = nodes.cn_ptr[c + 1]
    node = nodes.cn_nodes[c]
    i, j, k = node_ijk(node, grid.shape)
    xnode[0] = grid.origin[0] + i * grid.h[0]
    xnode[1] = grid.origin[1] + j * grid.h[1]
    if dim == 3:
        xnode[2] = grid.origin[2] + k * grid.h[2]
    plan_node(s0, s1, nodes, inp.sums.vol, geo.role, geo.partner)
    for a in range(s0, s1):
        if geo.role[a] != 0:
            target_geometry(a, node, s0, s1, clouds.ptr[c], clouds.ptr[c + 1], xnode, inp, geo, R, v)


def plan_nodes(start, stop, inp, geo):
    """Plan contact nodes start:stop."""
    clouds = inp.clouds
    max_cloud = 0
    for c in range(start, stop):
        max_cloud = max(max_cloud, clouds.ptr[c + 1] - clouds.ptr[c])
    R = regression_scratch(max_cloud)
    v = np.zeros((4, 3))
    xnode = np.zeros(3)
    plan_range(start, stop, inp, geo, R, v, xnode)


def plan_range(start, stop, inp, geo, R, v, xnode):
    """Plan contact nodes start:stop with the scratch R, v, xnode (compiled BORROWING:
    parallel.py)."""
    for c in range(start, stop):
        plan_contact_node(c, inp, geo, R, v, xnode)


def geometry_kernel(nodes, grid, mass, sums, clouds, laws, method, warm_phi, dt, nchunk, geo):
    """Plan every contact node (parallel over chunks of nodes); results in geo (Targets)."""
    n_cn = nodes.n_cn
    shape, origin, h, face_type, wall_index = grid  # (see views.GridView)
    for ch in prange(nchunk):  # (numba's parallel loops read bundle members through locals only)
        start, stop = chunk_range(ch, nchunk, n_cn)
        plan_nodes(start, stop, GeometryInputs(nodes, GridView(shape, origin, h, face_type, wall_index), mass, sums,
                                               clouds, laws, method, warm_phi, dt), geo)


def geometry_form(normal: int, separation: int) -> tuple[int, int]:
    """The codes target_geometry is compiled with for a normal method and separation: one per
    family, since within a family the code is the same and the method is read at run time
    (regression_normal_of: logistic or linear; gradient_normal: average, max gradient or max
    volume; grid_separation: displacement, cutoff, fit or velocity). A scene compiles its
    family's code only, and the suite's method variants share it."""
    if normal == LINEAR_REGRESSION:
        normal = LOGISTIC
    elif normal != LOGISTIC and normal != SPECIFIED:
        normal = AVERAGE_GRADIENT
    return normal, (SEP_LR if separation == SEP_LR else SEP_DISPLACEMENT)


@cache
def node_planner(normal: int, separation: int, interfaces: bool):
    """plan_contact_node compiled for one family of normal methods and of separations
    (geometry_form), with or without interface laws: these are constants of target_geometry,
    so a scene compiles the code of its own methods only."""
    normal, separation = geometry_form(normal, separation)
    tag = f"{normal}_{separation}_{int(interfaces)}"
    target = njit(cache=True, inline="always")(specialize(target_geometry, tag, NORMAL=normal, SEPARATION=separation,
                                         INTERFACES=interfaces))
    return njit(cache=True, inline="always")(specialize(plan_contact_node, tag, target_geometry=target))


@cache
def contact_geometry(normal: int, separation: int, interfaces: bool):
    """The geometry kernel (a ChunkKernel) of one normal method and separation (codes), with
    or without interface laws (node_planner)."""
    normal, separation = geometry_form(normal, separation)
    tag = f"{normal}_{separation}_{int(interfaces)}"
    nodes = njit(cache=True, **BORROWING)(specialize(plan_range, tag,
                                                    plan_contact_node=node_planner(normal, separation, interfaces)))
    plan = njit(cache=True)(specialize(plan_nodes, tag, plan_range=nodes))
    return chunk_kernel(specialize(geometry_kernel, tag, plan_nodes=plan))
