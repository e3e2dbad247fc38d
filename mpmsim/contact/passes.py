"""The contact passes (LR paper §3.2; notes §1, §3) over the sparse list of contact nodes,
with the targets planned by the geometry (plan.py).

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

from typing import NamedTuple

import numpy as np
from numba import njit, prange

from ..bc import NO_BC, node_bc
from ..gridops import chunk_range, node_ijk
from .laws import apply_law, interface_impulse
from .plan import BOND_PHI2, plan_node  # noqa: F401  (re-exported: the bonding switch)
from .spec import INTERFACE

MAX_SLOTS = 64  # groups per node (masks are 64-bit)
PASS_1, PASS_3 = 1, 3


class NodeScratch(NamedTuple):
    """Per-thread scratch of the passes: one node's slot momenta and their changes."""

    pbuf: np.ndarray  # (MAX_SLOTS, 3)
    dpb: np.ndarray  # (MAX_SLOTS, 3)
    touching: np.ndarray  # (MAX_SLOTS,) bool
    imp: np.ndarray  # (3,) stick impulse
    out: np.ndarray  # (3,) applied impulse
    n: np.ndarray  # (3,) normal
    df: np.ndarray  # (3,) relative force


@njit(cache=True)
def node_scratch():
    return NodeScratch(np.zeros((MAX_SLOTS, 3)), np.zeros((MAX_SLOTS, 3)), np.zeros(MAX_SLOTS, dtype=np.bool_),
                       np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3))


@njit(cache=True, inline="always")
def stick_impulse(a, b, rigid_b, s0, s1, nodes, mass, pbuf, dim, out):
    """Impulse that moves a to the centre-of-mass velocity (or to the rigid velocity).
    b: partner slot (-1: the lumped rest). Returns the reduced mass."""
    nn, slot_group, n_def = nodes.nn, nodes.slot_group, nodes.n_def
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
def relative_force(a, b, rigid_b, s0, s1, nodes, mass, acc, dim, out):
    """df = (m_a/M) F - f_a over a and its partner side (f = m a of the update), or -f_a
    against a rigid material: the force that changes a's velocity relative to the rest."""
    nn, slot_group, n_def = nodes.nn, nodes.slot_group, nodes.n_def
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
def target_stick(a, s0, s1, nodes, mass, geo, w, dim):
    """Target a's partner, whether that is rigid, and the reduced mass; its normal into w.n
    and its stick impulse on the momenta w.pbuf into w.imp."""
    b = geo.partner[a]
    rigid_b = b >= 0 and nodes.slot_group[b] >= nodes.n_def
    for d in range(dim):
        w.n[d] = geo.normal[a, d]
    mred = stick_impulse(a, b, rigid_b, s0, s1, nodes, mass, w.pbuf, dim, w.imp)
    return b, rigid_b, mred


@njit(cache=True, inline="always")
def share_change(a, b, rigid_b, value, d, dpb, s0):
    """Add `value` to target a's change and its opposite to a deformable partner's."""
    dpb[a - s0, d] += value
    if b >= 0 and not rigid_b:
        dpb[b - s0, d] -= value


@njit(cache=True, inline="always")
def exchange_momenta(s0, s1, nodes, mass, mom, geo, need_approach, dim, w):
    """The laws at one contact node on the momenta `mom`; the change of each slot in w.dpb.
    w.touching[a - s0]: target a's surfaces touch. A touching target is in contact if it
    approaches (need_approach) or whatever its normal velocity (a decision already made)."""
    nn = nodes.nn
    pbuf, dpb, imp, out, n = w.pbuf, w.dpb, w.imp, w.out, w.n
    for s in range(s0, s1):
        for d in range(dim):
            pbuf[s - s0, d] = mom[nn + s, d]
            dpb[s - s0, d] = 0.0
    for a in range(s0, s1):
        if geo.role[a] == 0:
            continue
        b, rigid_b, mred = target_stick(a, s0, s1, nodes, mass, geo, w, dim)
        dotn = 0.0
        for d in range(dim):
            dotn += imp[d] * n[d]
        in_contact = w.touching[a - s0] and (dotn < 0.0 or not need_approach)
        if apply_law(geo.law[a], geo.mu[a], geo.mus[a], geo.bonded[a], imp, n, dotn, in_contact, dim, out):
            for d in range(dim):
                share_change(a, b, rigid_b, out[d], d, dpb, s0)


@njit(cache=True)
def exchange_nodes(start, stop, mode, nodes, mass, mom, geo, contact2, sep_velocity, touch, dp1):
    """Pass 1 or 3 at contact nodes start:stop (exchange_pass)."""
    dim = mom.shape[1]
    nn, cn_ptr, slot_group, n_def = nodes.nn, nodes.cn_ptr, nodes.slot_group, nodes.n_def
    w = node_scratch()
    for c in range(start, stop):
        s0 = cn_ptr[c]
        s1 = cn_ptr[c + 1]
        for a in range(s0, s1):
            if mode == PASS_1:
                w.touching[a - s0] = sep_velocity or geo.delta[a] < touch
            else:
                w.touching[a - s0] = contact2[a] != 0
        exchange_momenta(s0, s1, nodes, mass, mom, geo, mode == PASS_1, dim, w)
        for s in range(s0, s1):
            if slot_group[s] >= n_def:
                continue
            for d in range(dim):
                mom[nn + s, d] += w.dpb[s - s0, d]
                if mode == PASS_1:
                    dp1[s, d] = w.dpb[s - s0, d]


@njit(parallel=True, cache=True)
def exchange_pass(mode, nodes, mass, mom, geo, contact2, sep_velocity, touch, nchunk, dp1):
    """Pass 1 (mode PASS_1): the laws on the extrapolated momenta where the surfaces touch
    (separation below `touch`, a length; always for velocity-only detection) and approach;
    the change is kept in dp1. Pass 3 (mode PASS_3): where pass 2 made contact (contact2),
    whatever the normal velocity. Only deformable slots change."""
    n_cn = nodes.n_cn
    for ch in prange(nchunk):  # (numba's parallel loops read bundle members through locals only)
        start, stop = chunk_range(ch, nchunk, n_cn)
        exchange_nodes(start, stop, mode, nodes, mass, mom, geo, contact2, sep_velocity, touch, dp1)


@njit(cache=True, inline="always")
def add_free_changes(node, s0, s1, nodes, grid, held, mass, dpb, arr, acc, dt, dim):
    """Add each deformable slot's change dpb / m to arr (and dpb / (m dt) to acc when dt > 0),
    except components a velocity condition holds."""
    nn, slot_group, n_def = nodes.nn, nodes.slot_group, nodes.n_def
    face_type, wall_index, rigid_vol, constrain, rig_vel = (grid.face_type, grid.wall_index, held.volume,
                                                            held.constrain, held.velocity)
    i, j, k = node_ijk(node, grid.shape)
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


class Pass2Sums(NamedTuple):
    """Per-chunk sums of pass 2: force on each rigid contact material, its work on the
    material, interfacial energy."""

    reaction: np.ndarray  # (nchunk, n_rigid, dim)
    work: np.ndarray  # (nchunk,)
    energy: np.ndarray  # (nchunk,)


@njit(cache=True)
def pass2_target(a, s0, s1, node, nodes, grid, held, rigid_of_group, mass, acc, geo, dec, settings, w, sums, ch):
    """Pass 2 for target a: the law (or the interface force) on the updated momenta in
    w.pbuf; its share of the node's change into w.dpb; the stick and applied impulses, the
    end-of-step separation and the contact flag into dec; interfacial energy, the force on a
    rigid partner and its work into chunk ch of sums (Pass2Sums)."""
    dim = geo.normal.shape[1]
    sep_velocity, integration, touch, dt = settings.sep_velocity, settings.integration, settings.touch, settings.dt
    i, j, k = node_ijk(node, grid.shape)
    imp, out, n, df = w.imp, w.out, w.n, w.df
    b, rigid_b, mred = target_stick(a, s0, s1, nodes, mass, geo, w, dim)
    dotn = 0.0
    for d in range(dim):
        dotn += imp[d] * n[d]
    delta = geo.delta[a]
    interface = geo.law[a] == INTERFACE
    if not sep_velocity or interface:
        # the relative force of the update: df = (m_a/M) F - f_a, or -f_a against a rigid
        # material. It advances the separation to the end of the step (the reference code
        # does this for grid separations only; d_LR too needs it: a 5 um gap closing by 70 um
        # within the step must count as contact, or the free update drives the surfaces
        # through each other, docs/contact.md), and it drives the interface force.
        relative_force(a, b, rigid_b, s0, s1, nodes, mass, acc, dim, df)
        dfn = 0.0
        for d in range(dim):
            dfn += df[d] * n[d]
        delta += dt * (dotn - 0.5 * dfn * dt) / mred
    dec.delta2[a] = delta
    if interface:
        sums.energy[ch] += interface_impulse(geo, a, imp, df, n, mred, dt, integration, dim, out)
        applied = True
    else:
        touching = sep_velocity or delta < touch
        applied = apply_law(geo.law[a], geo.mu[a], geo.mus[a], geo.bonded[a], imp, n, dotn, touching and dotn < 0.0,
                            dim, out)
    for d in range(dim):
        dec.stick2[a, d] = imp[d]
        dec.applied2[a, d] = out[d] if applied else 0.0
    if interface:  # XPIC increments re-impose only the bonded directions
        apply_law(INTERFACE, 0.0, 0.0, geo.bonded[a], imp, n, dotn, True, dim, df)
        for d in range(dim):
            dec.applied2[a, d] = df[d]
    dec.contact2[a] = 1 if applied else 0
    if applied:
        for d in range(dim):
            owner, vbc = node_bc(node, i, j, k, d, dim, grid.face_type, grid.wall_index, held.volume, held.constrain,
                                 held.velocity)
            if owner != NO_BC:
                continue  # a velocity condition holds this component
            share_change(a, b, rigid_b, out[d], d, w.dpb, s0)
            if rigid_b:
                r = rigid_of_group[nodes.slot_group[b]]
                sums.reaction[ch, r, d] += out[d] / dt
                sums.work[ch] += out[d] * held.velocity[r, d]  # the rigid body's work on the material


class Pass2Settings(NamedTuple):
    sep_velocity: bool  # velocity-only detection
    integration: int  # interface integrator code
    touch: float  # touching length
    dt: float


@njit(parallel=True, cache=True)
def contact_pass_2(nodes, grid, held, rigid_of_group, mass, vnew, acc, geo, dec, settings, nchunk, sums):
    """Contact on the updated momenta p+ = m v+; the change goes into v+ and a = f/m. Each
    target's stick impulse, applied impulse and end-of-step separation are kept for XPIC.
    Interfaces add their force here (and only here, notes §4.2) and their energy. held: the
    velocity conditions at the step's end (rigid contact slots move at that velocity)."""
    n_cn = nodes.n_cn
    for ch in prange(nchunk):  # (numba's parallel loops read bundle members through locals only)
        start, stop = chunk_range(ch, nchunk, n_cn)
        pass2_nodes(ch, start, stop, nodes, grid, held, rigid_of_group, mass, vnew, acc, geo, dec, settings, sums)


@njit(cache=True)
def pass2_nodes(ch, start, stop, nodes, grid, held, rigid_of_group, mass, vnew, acc, geo, dec, settings, sums):
    """Pass 2 at contact nodes start:stop, chunk ch of the sums (contact_pass_2)."""
    dim = vnew.shape[1]
    nn, cn_ptr, slot_group, n_def = nodes.nn, nodes.cn_ptr, nodes.slot_group, nodes.n_def
    dt = settings.dt
    w = node_scratch()
    sums.work[ch] = 0.0
    sums.energy[ch] = 0.0
    for r in range(sums.reaction.shape[1]):
        for d in range(dim):
            sums.reaction[ch, r, d] = 0.0
    for c in range(start, stop):
        s0 = cn_ptr[c]
        s1 = cn_ptr[c + 1]
        node = nodes.cn_nodes[c]
        for s in range(s0, s1):
            g = slot_group[s]
            for d in range(dim):
                # a rigid slot has no grid update: it moves at its end-of-step velocity
                v = held.velocity[rigid_of_group[g], d] if g >= n_def else vnew[nn + s, d]
                w.pbuf[s - s0, d] = mass[nn + s] * v
                w.dpb[s - s0, d] = 0.0
        for a in range(s0, s1):
            if geo.role[a] == 0:
                continue
            pass2_target(a, s0, s1, node, nodes, grid, held, rigid_of_group, mass, acc, geo, dec, settings, w, sums, ch)
        add_free_changes(node, s0, s1, nodes, grid, held, mass, w.dpb, vnew, acc, dt, dim)


@njit(cache=True)
def increment_contact(c, nodes, grid, held, mass, dv, geo, dec, sep_velocity, touch, w):
    """Re-impose contact on one XPIC increment dv at contact node c (notes §5.2): the
    increment's stick change is added to a running stick total (seeded by pass 2's), the law
    is applied to the total, and only the change of the applied result is put on the
    increment. With bonded contact every increment goes to the centre of mass, so the filter
    is exactly single-material XPIC."""
    dim = dv.shape[1]
    nn, cn_ptr, slot_group, n_def = nodes.nn, nodes.cn_ptr, nodes.slot_group, nodes.n_def
    pbuf, dpb, imp, out, n = w.pbuf, w.dpb, w.imp, w.out, w.n
    stick_total, applied_total = dec.stick_total, dec.applied_total
    s0 = cn_ptr[c]
    s1 = cn_ptr[c + 1]
    for s in range(s0, s1):
        for d in range(dim):
            pbuf[s - s0, d] = mass[nn + s] * dv[nn + s, d] if slot_group[s] < n_def else 0.0
            dpb[s - s0, d] = 0.0
    for a in range(s0, s1):
        if geo.role[a] == 0:
            continue
        b, rigid_b, mred = target_stick(a, s0, s1, nodes, mass, geo, w, dim)
        dotn = 0.0
        for d in range(dim):
            stick_total[a, d] += imp[d]
            dotn += stick_total[a, d] * n[d]
        touching = sep_velocity or dec.delta2[a] < touch
        for d in range(dim):
            imp[d] = stick_total[a, d]
        applied = apply_law(geo.law[a], geo.mu[a], geo.mus[a], geo.bonded[a], imp, n, dotn, touching and dotn < 0.0,
                            dim, out)
        for d in range(dim):
            now = out[d] if applied else 0.0
            change = now - applied_total[a, d]
            applied_total[a, d] = now
            share_change(a, b, rigid_b, change, d, dpb, s0)
    add_free_changes(nodes.cn_nodes[c], s0, s1, nodes, grid, held, mass, dpb, dv, dv, 0.0, dim)
