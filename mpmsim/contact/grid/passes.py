"""The contact passes (LR paper §3.2; notes §1, §3) over the sparse list of contact nodes,
with the targets planned by the geometry (plan.py).

Pass 1, after extrapolation: change the extrapolated momenta p. This change is part of the
  extrapolation, never a force; it is also kept (`dp1`) for the multimaterial XPIC term.
  `contact.passes: 1` skips it (the paper's "LR once"). With `pass_3: persist` (the default)
  it also holds a pair of materials that pass 2 held in the previous step and that still
  touch, whatever their normal velocity: where their extrapolated velocities separate, pass 2
  would otherwise stop the approach the internal forces give them and its impulse would do
  positive work at the step's mean velocity, which the stress update (at the start-of-step
  velocity) never takes back: contact that makes energy. That holding change is a force
  under FLIP (its particles add only dt a), so FLIP's particle velocities are pass 2's as
  before; the start-of-step velocity (stress update, midpoint positions) is held.
  docs/contact.md, choice 11.
Pass 2, after the momentum update: the same laws on the updated momenta p+; each change is
  added to p+ and to the force (as dp/dt), so the particle update's acceleration includes the
  contact force f = dp+/dt (Eq. 33, option 1). The separation is advanced to the end of the
  step for every method (the reference code advances only grid separations). Components held
  by velocity conditions are left alone. The force on rigid contact materials is accumulated
  here.
Pass 3, after re-extrapolation (USL+/USAVG+), `contact.pass_3`:
  keep (default): enforces pass 2's end-of-step decision on the re-extrapolated momenta,
  with the pass-1 geometry: where pass 2 found contact the relative normal velocity is
  removed whatever its sign (friction capped by mu |N|); elsewhere nothing. In a
  quasi-static compression a re-test is decided by ringing noise and decouples the two
  blocks at random node-steps for the second stress half-step (+15.8% off single-material
  XPIC(5) at 2.4% strain; 0.1% when the decision is kept).
  recheck (the reference code): the geometry is recomputed from the moved particles and the
  laws act where the surfaces touch and approach, as in pass 1; pass 2 then takes point-cloud
  separations as measured. In an impact, `keep` holds surfaces together that separate
  within the step (an oblique cylinder at R/h = 20 rebounds 9% slower than the reference
  code; 0.1% with recheck). See docs/contact.md.
XPIC increments (`increment_contact`): the laws re-imposed on each filter increment, from
  pass 2's totals (tasks/xpic.py).

Imperfect interfaces (law `interface`, 2013 paper; notes §4): no contact test. A direction
that is perfect, or too stiff for the step, is bonded (stick impulse) in every pass; the other
directions are left free in passes 1 and 3 and get the interface force in pass 2 only, from
the backward-Euler spring (default), the trapezoidal spring, the exact oscillator of notes
§4.3, or the paper's first-order force with its limit, with the end-of-step interfacial energy
summed for the history. Openings are each side's displacement at the interface point, carried
there along the particles' displacement gradients (the normal one is d_LR under LR separation).
"""

from __future__ import annotations

from functools import cache
from typing import NamedTuple

import numpy as np
from numba import njit, prange

from ...bc import NO_BC, node_bc
from ...gridops import chunk_range, node_ijk
from ...parallel import BORROWING, chunk_kernel, specialize
from ...views import GridView
from .laws import apply_law, interface_impulse, plugin_dispatch
from .spec import SLIVER
from .spec import COULOMB, FRICTIONLESS, INTERFACE, STICK

MAX_SLOTS = 64  # groups per node (masks are 64-bit)
NO_BEFORE = np.zeros((0, 3))  # pair_changes: the change itself is given
PASS_1, PASS_3, PASS_3_RECHECK, PASS_3_PERSIST = 1, 3, 4, 5
# pass 2's separation advanced to the end of the step: nowhere, everywhere, or at grid nodes where
# pass 2 made contact in the previous step (`pass_3: persist`)
ADVANCE_NONE, ADVANCE_ALL, ADVANCE_HELD = 0, 1, 2
# `pass_3: persist` releases a pass-2 contact in pass 3 where the re-extrapolated momenta
# separate the surfaces by more than this fraction of pass 2's normal impulse there: above a
# compressed interface's ringing (99% below 2.4e-4, 99.9% below 0.011 on the XPIC(5) column);
# held at 0.3 or more, ellipses compressed in a box overlap (sum J V0 1.008 of the box); released
# from 0.03, a sphere striking a block obliquely gains energy (+0.68% at R/h = 5; 0.1: +0.33%).
# docs/contact-methods.md, "One default for impacts and compression".
RELEASE = 0.1
# pass 1's limit (exchange_momenta) where it holds a pair pass 2 held in the previous step:
# the normal stick impulse whatever its sign (frictionless while it pulls). NO_HOLD: a held
# step no node has (pass 3, and the passes other than `persist`).
HOLD, NO_HOLD = 1e300, -3
HOLD_NONE, HOLD_PAIRS, HOLD_FORCE = 0, 1, 2  # Pass2Settings.hold


def advance_rule(spec, lr_separation: bool) -> int:
    """Where pass 2 advances separations to the end of the step: everywhere, except point-cloud
    ones under recheck (the reference code's passes: nowhere) and persist (where contact persists)."""
    if not (spec.recheck and lr_separation):
        return ADVANCE_ALL
    return ADVANCE_HELD if spec.persist else ADVANCE_NONE


def hold_rule(spec, pass_1_counts: bool) -> int:
    """Pass2Settings.hold for a scene: pass 1 holds pass 2's pairs with `persist` and two passes,
    and its holding change is a force where the particles do not take pass 1's change (FLIP)."""
    if not (spec.persist and spec.passes == 2):
        return HOLD_NONE
    return HOLD_PAIRS if pass_1_counts else HOLD_FORCE


def pass_3_mode(spec) -> int:
    """exchange_pass's mode for `contact.pass_3`."""
    if not spec.recheck:
        return PASS_3
    return PASS_3_PERSIST if spec.persist else PASS_3_RECHECK


# The kernels take bundles (contact.workspace, views); their parallel loops work on arrays
# bound to locals, and the small helpers called per slot take arrays (docs/architecture.md,
# "Kernels and bundles").


@njit(cache=True, inline="always")
def stick_impulse(a, b, rigid_b, s0, s1, slot_group, n_def, nn, mass, pbuf, dim, out):
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
        if slot_group[s] < n_def:
            M += mass[nn + s]
    for s in range(s0, s1):
        if slot_group[s] < n_def:
            for d in range(dim):
                out[d] += ma / M * pbuf[s - s0, d]
    for d in range(dim):
        out[d] -= pbuf[a - s0, d]
    return ma * (M - ma) / M


@njit(cache=True, inline="always")
def relative_force(a, b, rigid_b, s0, s1, slot_group, n_def, nn, mass, acc, dim, out):
    """df = (m_a/M) F - f_a over a and its partner side (f = m a of the update), or -f_a
    against a rigid material: the force that changes a's velocity relative to the rest."""
    ma = mass[nn + a]
    for d in range(dim):
        out[d] = -ma * acc[nn + a, d]
    if rigid_b:
        return
    M = 0.0
    for s in range(s0, s1):
        if slot_group[s] < n_def and (b < 0 or s == a or s == b):
            M += mass[nn + s]
    for s in range(s0, s1):
        if slot_group[s] < n_def and (b < 0 or s == a or s == b):
            for d in range(dim):
                out[d] += ma / M * mass[nn + s] * acc[nn + s, d]


@njit(cache=True, inline="always")
def _dot(a, b, dim):
    out = 0.0
    for d in range(dim):
        out += a[d] * b[d]
    return out


@njit(cache=True, inline="always")
def target_stick(a, s0, s1, slot_group, n_def, nn, mass, partner, geo_n, pbuf, dim, n, imp):
    """Target a's partner, whether that is rigid, and the reduced mass; its normal into n and
    its stick impulse on the momenta pbuf into imp."""
    b = partner[a]
    rigid_b = b >= 0 and slot_group[b] >= n_def
    for d in range(dim):
        n[d] = geo_n[a, d]
    mred = stick_impulse(a, b, rigid_b, s0, s1, slot_group, n_def, nn, mass, pbuf, dim, imp)
    return b, rigid_b, mred


@njit(cache=True, inline="always")
def cap_tangential(out, n, cap, dim):
    """Scale the tangential part of impulse `out` (across n) down to at most `cap` in size."""
    on = _dot(out, n, dim)
    t2 = 0.0
    for d in range(dim):
        t = out[d] - on * n[d]
        t2 += t * t
    if t2 > cap * cap:
        scale = cap / np.sqrt(t2)
        for d in range(dim):
            out[d] = on * n[d] + scale * (out[d] - on * n[d])


@njit(cache=True, inline="always")
def share_change(a, b, rigid_b, value, d, dpb, s0):
    """Add `value` to target a's change and its opposite to a deformable partner's."""
    dpb[a - s0, d] += value
    if b >= 0 and not rigid_b:
        dpb[b - s0, d] -= value


@njit(cache=True, inline="always")
def exchange_momenta(s0, s1, slot_group, n_def, nn, mass, mom, role, partner, geo_n, slot_law, slot_mu, slot_mus,
                     bonded, limit, dim, pbuf, dpb, imp, out, n, hpb):
    """The laws at one contact node on the momenta `mom`; the change of each slot in dpb.
    Target a is in contact where its stick impulse's normal part is below limit[a - s0]: 0 where
    the surfaces touch and contact needs them to approach, -inf where they do not touch, +inf
    for a decision already made (whatever the normal velocity), HOLD for a held pair (as +inf,
    but frictionless where the impulse pulls; that change also into hpb)."""
    for s in range(s0, s1):
        for d in range(dim):
            pbuf[s - s0, d] = mom[nn + s, d]
            dpb[s - s0, d] = 0.0
            hpb[s - s0, d] = 0.0
    for a in range(s0, s1):
        if role[a] == 0:
            continue
        b, rigid_b, mred = target_stick(a, s0, s1, slot_group, n_def, nn, mass, partner, geo_n, pbuf, dim, n, imp)
        dotn = _dot(imp, n, dim)
        in_contact = dotn < limit[a - s0]
        pulls = limit[a - s0] == HOLD and dotn >= 0.0
        law = FRICTIONLESS if pulls else slot_law[a]
        if apply_law(law, slot_mu[a], slot_mus[a], bonded[a], imp, n, dotn, in_contact, dim, out):
            for d in range(dim):
                share_change(a, b, rigid_b, out[d], d, dpb, s0)
                if pulls:
                    share_change(a, b, rigid_b, out[d], d, hpb, s0)


class NodeScratch(NamedTuple):
    """Per-node scratch of the passes (a CPU chunk's, or a GPU thread's local arrays)."""

    pbuf: np.ndarray  # (MAX_SLOTS, 3) the slots' momenta
    dpb: np.ndarray  # (MAX_SLOTS, 3) their changes
    limit: np.ndarray  # (MAX_SLOTS,) contact below this normal stick impulse (exchange_momenta)
    imp: np.ndarray  # (3,) stick impulse
    out: np.ndarray  # (3,) applied impulse
    n: np.ndarray  # (3,) normal
    df: np.ndarray  # (3,) relative force
    hpb: np.ndarray  # (MAX_SLOTS, 3) pass 1's changes that hold a separating pair


@njit(cache=True)
def node_scratch():
    return NodeScratch(np.zeros((MAX_SLOTS, 3)), np.zeros((MAX_SLOTS, 3)), np.zeros(MAX_SLOTS),
                       np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros((MAX_SLOTS, 3)))


@chunk_kernel
def exchange_pass(mode, nodes, mass, mom, geo, dec, sep_velocity, touch, held_step, nchunk, dp1):
    """Pass 1 (mode PASS_1): the laws on the extrapolated momenta where the surfaces touch
    (separation below `touch`, a length; always for velocity-only detection) and approach;
    the change is kept in dp1. Where pass 2 made contact in step `held_step` (NO_HOLD: nowhere)
    at a node of two deformable materials and the surfaces still touch, pass 1 holds them: the
    normal stick impulse whatever its sign, frictionless where it pulls (every law with a contact
    test), that pulling change kept in dec.hold as well (docs/contact.md, choice 11).
    Pass 3 (mode PASS_3): where pass 2 made contact (contact2), whatever the normal velocity.
    Pass 3 rechecked (PASS_3_RECHECK, after the geometry was recomputed from the moved
    particles): where the surfaces touch and approach, as pass 1.
    Pass 3 persisting (PASS_3_PERSIST, geometry recomputed): where pass 2 made contact unless
    the surfaces separate by more than RELEASE of pass 2's normal impulse (dec.applied2), and
    elsewhere where they touch and approach. Only deformable slots change."""
    n_cn = nodes.n_cn
    for ch in prange(nchunk):
        start, stop = chunk_range(ch, nchunk, n_cn)
        w = node_scratch()
        for c in range(start, stop):
            exchange_node(c, mode, nodes, mass, mom, geo, dec, sep_velocity, touch, held_step, w, dp1)


@njit(cache=True, error_model="numpy", **BORROWING)
def exchange_node(c, mode, nodes, mass, mom, geo, dec, sep_velocity, touch, held_step, w, dp1):
    """exchange_pass at contact node c (w: NodeScratch). Also the GPU step's, a thread per
    contact node. (A function call, not inlined, as pass_2_node: inlined into a parallel loop,
    writes into arrays of a bundle passed into the loop can be lost.)"""
    dim = mom.shape[1]
    cn_ptr, slot_group, n_def, nn = nodes.cn_ptr, nodes.slot_group, nodes.n_def, nodes.nn
    limit, dpb, contact2 = w.limit, w.dpb, dec.contact2
    s0 = cn_ptr[c]
    s1 = cn_ptr[c + 1]
    # a pair of deformable materials that pass 2 held in the held step (where three or more
    # meet, holding pushes them into each other: the ellipse box, docs/contact.md)
    hold = (mode == PASS_1 and s1 - s0 == 2 and slot_group[s0] < n_def and slot_group[s0 + 1] < n_def
            and dec.contact_step[nodes.cn_nodes[c]] == held_step)
    for a in range(s0, s1):
        if hold and geo.delta[a] < touch and geo.law[a] != STICK and geo.law[a] != INTERFACE:  # (laws with a test)
            limit[a - s0] = HOLD
        elif mode == PASS_3:
            limit[a - s0] = np.inf if contact2[a] != 0 else -np.inf  # pass 2's decision
        elif mode == PASS_3_PERSIST and contact2[a] != 0:
            n2 = 0.0  # pass 2's normal impulse, along the recomputed normal
            for d in range(dim):
                n2 += dec.applied2[a, d] * geo.normal[a, d]
            limit[a - s0] = RELEASE * abs(n2)
        else:
            limit[a - s0] = 0.0 if sep_velocity or geo.delta[a] < touch else -np.inf  # touching and approaching
    exchange_momenta(s0, s1, slot_group, n_def, nn, mass, mom, geo.role, geo.partner, geo.normal, geo.law, geo.mu,
                     geo.mus, geo.bonded, limit, dim, w.pbuf, dpb, w.imp, w.out, w.n, w.hpb)
    for s in range(s0, s1):
        if slot_group[s] >= n_def:
            continue
        for d in range(dim):
            mom[nn + s, d] += dpb[s - s0, d]
            if mode == PASS_1:
                dp1[s, d] = dpb[s - s0, d]
                dec.hold[s, d] = w.hpb[s - s0, d]


class Pass2Sums(NamedTuple):
    """Per-chunk sums of pass 2: force on each rigid contact material, its work on the
    material, interfacial energy."""

    reaction: np.ndarray  # (nchunk, n_rigid, dim)
    work: np.ndarray  # (nchunk,)
    energy: np.ndarray  # (nchunk,)


class Pass2Settings(NamedTuple):
    sep_velocity: bool  # velocity-only detection
    advance: int  # where the separation is advanced to the end of the step (ADVANCE_*)
    integration: int  # interface integrator code
    touch: float  # touching length
    dt: float
    step: int  # the step's number (dec.contact_step: where contact persists)
    hold: int  # HOLD_NONE: pass 1 holds nothing (dec.hold unread); HOLD_PAIRS: it holds pairs; HOLD_FORCE: and
    # its holding change is a force, into a (FLIP, whose particles add only dt a)


HAS_INTERFACE = True  # a constant of pass_2_node, bound by pass_2_node_of (never compiled with this value)
PASS_2_NODE = None  # pass_2_kernel's per-node function, bound by contact_pass_2


def pass_2_node(c, nodes, grid, held, rigid_of_group, mass, vnew, acc, geo, dec, settings, w, reaction, row):
    """Contact on the updated momenta p+ = m v+ at contact node c; the change goes into v+
    and a = f/m. Each target's stick impulse, applied impulse and end-of-step separation are
    kept for XPIC, and the node stamped with the step where contact acts (dec.contact_step).
    Interfaces add their force here (and only here, notes §4.2). held: the
    velocity conditions at the step's end (rigid contact slots move at that velocity). The
    force on rigid contact materials is added to reaction[row]; returns (their work on the
    material, interfacial energy at the end of the step). w: NodeScratch. Also the GPU
    step's, a thread per contact node."""
    dim = vnew.shape[1]
    cn_nodes, cn_ptr, slot_group, n_def, nn = nodes.cn_nodes, nodes.cn_ptr, nodes.slot_group, nodes.n_def, nodes.nn
    shape, face_type, wall_index = grid.shape, grid.face_type, grid.wall_index
    rigid_vol, constrain, rig_vel = held
    sep_velocity, advance, integration, touch, dt, step, hold = settings
    pbuf, dpb, imp, out, n, df = w.pbuf, w.dpb, w.imp, w.out, w.n, w.df
    work = 0.0
    energy = 0.0
    s0 = cn_ptr[c]
    s1 = cn_ptr[c + 1]
    node = cn_nodes[c]
    i, j, k = node_ijk(node, shape)
    advance_here = advance == ADVANCE_ALL or (advance == ADVANCE_HELD and dec.contact_step[node] == step - 1)
    touched = False
    for s in range(s0, s1):
        g = slot_group[s]
        for d in range(dim):
            # a rigid slot has no grid update: it moves at its end-of-step velocity
            v = rig_vel[rigid_of_group[g], d] if g >= n_def else vnew[nn + s, d]
            pbuf[s - s0, d] = mass[nn + s] * v
            dpb[s - s0, d] = 0.0
    for a in range(s0, s1):
        if geo.role[a] == 0:
            dec.contact2[a] = 0  # (a recheck may make it a target in pass 3)
            continue
        b, rigid_b, mred = target_stick(a, s0, s1, slot_group, n_def, nn, mass, geo.partner, geo.normal, pbuf, dim, n,
                                        imp)
        dotn = 0.0
        for d in range(dim):
            dotn += imp[d] * n[d]
        delta = geo.delta[a]
        interface = HAS_INTERFACE and geo.law[a] == INTERFACE
        if not sep_velocity or interface:
            # the relative force of the update: df = (m_a/M) F - f_a, or -f_a against a rigid
            # material. It advances the separation to the end of the step (the reference code
            # does this for grid separations only, and so does `pass_3: recheck`; with pass 3
            # keeping pass 2's decision d_LR needs it too: a 5 um gap closing by 70 um within
            # the step must count as contact, or the free update drives the surfaces through
            # each other, docs/contact.md), and it drives the interface force.
            relative_force(a, b, rigid_b, s0, s1, slot_group, n_def, nn, mass, acc, dim, df)
            if advance_here:
                dfn = 0.0
                for d in range(dim):
                    dfn += df[d] * n[d]
                delta += dt * (dotn - 0.5 * dfn * dt) / mred
        dec.delta2[a] = delta
        if HAS_INTERFACE and interface:
            bond = geo.bonded[a]
            if b >= 0 and not rigid_b and mred <= SLIVER * (mass[nn + a] + mass[nn + b]):
                bond = 3  # one side has a sliver of mass here: its velocity is noise, it moves with the pair
            energy += interface_impulse(geo.stiff[a], bond, imp, df, n, geo.delta[a], geo.open[a],
                                        geo.area[a], mred, dt, integration, dim, out)
            applied = True
        else:
            touching = sep_velocity or delta < touch
            applied = apply_law(geo.law[a], geo.mu[a], geo.mus[a], geo.bonded[a], imp, n, dotn, touching and dotn < 0.0,
                                dim, out)
            if applied and geo.law[a] == COULOMB and hold != HOLD_NONE:
                # where pass 1 held the pair (pulling, dec.hold), friction is capped by the step's
                # net normal impulse, pass 1's pull and pass 2's push together
                hn = _dot(dec.hold[a], n, dim)
                if hn != 0.0:
                    cap_tangential(out, n, geo.mu[a] * max(-(dotn + hn), 0.0), dim)
        for d in range(dim):
            dec.stick2[a, d] = imp[d]
            dec.applied2[a, d] = out[d] if applied else 0.0
        if HAS_INTERFACE and interface:  # XPIC increments re-impose only the bonded directions
            apply_law(INTERFACE, 0.0, 0.0, bond, imp, n, dotn, True, dim, df)
            for d in range(dim):
                dec.applied2[a, d] = df[d]
        dec.contact2[a] = 1 if applied else 0
        if applied:
            touched = True
            for d in range(dim):
                owner, vbc = node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain, rig_vel)
                if owner != NO_BC:
                    continue  # a velocity condition holds this component
                share_change(a, b, rigid_b, out[d], d, dpb, s0)
                if rigid_b:
                    r = rigid_of_group[slot_group[b]]
                    reaction[row, r, d] += out[d] / dt
                    work += out[d] * rig_vel[r, d]  # the rigid body's work on the material
    if touched:
        dec.contact_step[node] = step
    add_free_changes(node, i, j, k, s0, s1, slot_group, n_def, nn, face_type, wall_index, rigid_vol, constrain,
                     rig_vel, mass, dpb, vnew, acc, dt, dim)
    if hold == HOLD_FORCE:  # a += hold / (m dt) (v+ has the change: it is in the extrapolated momenta)
        for s in range(s0, s1):
            for d in range(dim):
                w.hpb[s - s0, d] = dec.hold[s, d] / dt
        add_free_changes(node, i, j, k, s0, s1, slot_group, n_def, nn, face_type, wall_index, rigid_vol, constrain,
                         rig_vel, mass, w.hpb, acc, acc, 0.0, dim)
    return work, energy


@cache
def pass_2_node_of(has_interface: bool, plugin_laws: tuple = ()):
    """pass_2_node with or without the interface law (a constant: scenes without interfaces do
    not compile their force integrators), and with the scene's plugin laws (`law_kernels`)."""
    tag = f"i{int(has_interface)}"
    bind = {"HAS_INTERFACE": has_interface}
    if plugin_laws:
        law_tag, bind["apply_law"] = plugin_dispatch(plugin_laws)
        tag += "_" + law_tag
    # (not inlined: inlined into pass_2_kernel's parallel loop, its writes into the arrays of
    # the `dec` bundle were lost on more than one thread; numpy's error model, as the kernels')
    return njit(cache=True, error_model="numpy", **BORROWING)(specialize(pass_2_node, tag, **bind))


def pass_2_kernel(nodes, grid, held, rigid_of_group, mass, vnew, acc, geo, dec, settings, nchunk, sums):
    """Pass 2 over the contact nodes (pass_2_node), in chunks; per-chunk sums in sums (Pass2Sums)."""
    n_cn = nodes.n_cn
    dim = vnew.shape[1]
    chunk_reaction, chunk_work, chunk_energy = sums
    shape, origin, h, face_type, wall_index = grid  # (see views.GridView)
    for ch in prange(nchunk):
        start, stop = chunk_range(ch, nchunk, n_cn)
        w = node_scratch()
        gview = GridView(shape, origin, h, face_type, wall_index)
        chunk_work[ch] = 0.0
        chunk_energy[ch] = 0.0
        for r in range(chunk_reaction.shape[1]):
            for d in range(dim):
                chunk_reaction[ch, r, d] = 0.0
        for c in range(start, stop):
            work, energy = PASS_2_NODE(c, nodes, gview, held, rigid_of_group, mass, vnew, acc, geo, dec, settings, w,
                                       chunk_reaction, ch)
            chunk_work[ch] += work
            chunk_energy[ch] += energy


@cache
def contact_pass_2(has_interface: bool, plugin_laws: tuple = ()):
    """Pass 2's kernel (a ChunkKernel) of pass_2_node_of(has_interface, plugin_laws)."""
    node = pass_2_node_of(has_interface, plugin_laws)
    tag = node.py_func.__qualname__.split("pass_2_node_", 1)[1]
    return chunk_kernel(specialize(pass_2_kernel, tag, PASS_2_NODE=node))


@njit(cache=True, inline="always")
def add_free_changes(node, i, j, k, s0, s1, slot_group, n_def, nn, face_type, wall_index, rigid_vol, constrain,
                     rig_vel, mass, dpb, arr, acc, dt, dim):
    """Add each deformable slot's change dpb / m to arr (and dpb / (m dt) to acc when dt > 0),
    except components a velocity condition holds."""
    for s in range(s0, s1):
        if slot_group[s] >= n_def:
            continue
        m = mass[nn + s]
        for d in range(dim):
            owner, vbc = node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain, rig_vel)
            if owner != NO_BC:
                continue
            arr[nn + s, d] += dpb[s - s0, d] / m
            if dt > 0.0:
                acc[nn + s, d] += dpb[s - s0, d] / (m * dt)


@njit(cache=True, **BORROWING)
def increment_contact(c, nodes, grid, held, mass, dv, geo, dec, sep_velocity, touch, w):
    """Re-impose contact on one XPIC increment dv at contact node c (notes §5.2): the
    increment's stick change is added to a running stick total (seeded by pass 2's), the law
    is applied to the total, and only the change of the applied result is put on the
    increment. With bonded contact every increment goes to the centre of mass, so the filter
    is exactly single-material XPIC. w: NodeScratch (the slots' momenta and changes, the
    impulses and the normal), cleared here for this node's slots."""
    dim = dv.shape[1]
    _, cn_nodes, cn_ptr, slot_group, n_def, _ = nodes
    shape, _, _, face_type, wall_index = grid
    rigid_vol, constrain, rig_vel = held
    role, partner, geo_n, _, _, _, bonded, slot_law, slot_mu, slot_mus, _, _ = geo
    delta2, stick_total, applied_total = dec.delta2, dec.stick_total, dec.applied_total
    nn = shape[0] * shape[1] * shape[2]
    pbuf, dpb, imp, out, n = w.pbuf, w.dpb, w.imp, w.out, w.n
    for d in range(3):
        imp[d] = 0.0
        out[d] = 0.0
        n[d] = 0.0
    s0 = cn_ptr[c]
    s1 = cn_ptr[c + 1]
    node = cn_nodes[c]
    i, j, k = node_ijk(node, shape)
    for s in range(s0, s1):
        for d in range(3):
            pbuf[s - s0, d] = mass[nn + s] * dv[nn + s, d] if slot_group[s] < n_def and d < dim else 0.0
            dpb[s - s0, d] = 0.0
    for a in range(s0, s1):
        if role[a] == 0:
            continue
        b, rigid_b, mred = target_stick(a, s0, s1, slot_group, n_def, nn, mass, partner, geo_n, pbuf, dim, n, imp)
        for d in range(dim):
            stick_total[a, d] += imp[d]
            imp[d] = stick_total[a, d]
        dotn = _dot(imp, n, dim)
        touching = sep_velocity or delta2[a] < touch
        applied = apply_law(slot_law[a], slot_mu[a], slot_mus[a], bonded[a], imp, n, dotn, touching and dotn < 0.0,
                            dim, out)
        for d in range(dim):
            now = out[d] if applied else 0.0
            change = now - applied_total[a, d]
            applied_total[a, d] = now
            share_change(a, b, rigid_b, change, d, dpb, s0)
    add_free_changes(node, i, j, k, s0, s1, slot_group, n_def, nn, face_type, wall_index, rigid_vol, constrain,
                     rig_vel, mass, dpb, dv, dv, 0.0, dim)



@njit(cache=True)
def pair_changes(nodes, mass, after, before, weighted, out):
    """Add the momentum change a pass gave each deformable slot s, after[s] - before[s] (times
    the slot's mass when `weighted`: velocities; `before` of length 0: zero), to out[g, h]
    (g its group, h the group it came from): at a node of two deformable groups all of it to
    the other one; at a node of three or more (each exchanges with the lumped rest) shared by
    the others' masses. Nodes with a rigid contact material are left out: every deformable
    slot there contacts the rigid one (its reaction, `state.reaction`)."""
    n_cn, cn_ptr, slot_group, n_def, nn = nodes.n_cn, nodes.cn_ptr, nodes.slot_group, nodes.n_def, nodes.nn
    dim = after.shape[1]
    has_before = before.shape[0] > 0
    for c in range(n_cn):
        s0 = cn_ptr[c]
        s1 = cn_ptr[c + 1]
        M = 0.0
        rigid = False
        for s in range(s0, s1):
            if slot_group[s] >= n_def:
                rigid = True
            else:
                M += mass[nn + s]
        if rigid:
            continue
        for a in range(s0, s1):
            rest = M - mass[nn + a]
            if rest <= 0.0:
                continue
            ga = slot_group[a]
            scale = mass[nn + a] if weighted else 1.0
            for b in range(s0, s1):
                if b == a:
                    continue
                w = scale * mass[nn + b] / rest
                gb = slot_group[b]
                for d in range(dim):
                    out[ga, gb, d] += w * (after[a, d] - before[a, d] if has_before else after[a, d])


@njit(cache=True)
def settle_pairs(step, force, impulse, dt):
    """The step's pair momenta as forces (/ dt) and into the impulses; the step's sums cleared."""
    for i in range(step.shape[0]):
        for j in range(step.shape[1]):
            for d in range(step.shape[2]):
                force[i, j, d] = step[i, j, d] / dt
                impulse[i, j, d] += step[i, j, d]
                step[i, j, d] = 0.0


class LawKernels(NamedTuple):
    """The kernels that apply the contact laws, for the scene's plugin laws."""

    exchange_pass: object
    increment_contact: object
    plugin_laws: tuple


@cache
def law_kernels(plugin_laws: tuple) -> LawKernels:
    """Passes 1 and 3 and XPIC's increments with the laws registered outside mpmsim that the
    scene uses compiled in (apply_law and each inlining caller bound in a copy; none: the
    module's own kernels). Pass 2: contact_pass_2(has_interface, plugin_laws)."""
    if not plugin_laws:
        return LawKernels(exchange_pass, increment_contact, ())
    tag, law = plugin_dispatch(plugin_laws)
    momenta = njit(cache=True, inline="always")(specialize(exchange_momenta.py_func, tag, apply_law=law))
    node = njit(cache=True, error_model="numpy", **BORROWING)(specialize(exchange_node.py_func, tag,
                                                                       exchange_momenta=momenta))
    return LawKernels(chunk_kernel(specialize(exchange_pass.py_func, tag, exchange_node=node)),
                      njit(cache=True, **BORROWING)(specialize(increment_contact.py_func, tag, apply_law=law)),
                      plugin_laws)
