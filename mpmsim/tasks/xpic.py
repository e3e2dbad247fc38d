"""Task: XPIC(m) / FMPM(k) null-space filtering of the grid velocity (notes §1.4, §5).

The filtered grid velocity is the series

    v* = sum_{j=0}^{m-1} (I - S+S)^j v,     (S+S q)_i = (1/m_i) sum_p m_p S_ip sum_j S_jp q_j

built incrementally, dv(1) = v, dv(l) = dv(l-1) - S+S dv(l-1), v* = sum dv(l). Components
held by velocity conditions are zeroed in every increment, so constrained nodes keep their
imposed velocity. The whole series is one numba call: m - 1 fused gather/scatter passes
over the active nodes. The result left in `vstar` is the grid velocity the particles take,
V = S vstar:

- XPIC filters the start-of-step velocity and adds the step's change: vstar = v* + (v+ - v_e).
  v_e is the start velocity with velocity conditions imposed (p/m elsewhere), so inside the
  material v+ - v_e = a dt (the published V = S(v* + a dt)), and on a constrained node v*
  starts from the imposed velocity rather than the unconstrained p/m. Seeding with p/m there
  (as the reference code does) lets a fixed wall's spurious p/m leak into every filtered
  velocity near it: a fixed-free bar then loses 4.3% of its energy in 10 periods with
  XPIC(5), against 0.002% with this seed (docs/shape-functions.md).
- FMPM filters v+ itself (already on the imposed values): vstar = v*(v+).

Multimaterial (LR paper §3.3): S+ is per material (particles reach their material's slots
through their field indices) and v^a is contact-corrected by pass 1. After every increment
the contact law is re-imposed on it at the contact nodes, with pass 2's normal, separation and
law (notes §5.2, contact.passes.increment_contact), so the filtered velocity satisfies the
contact law as a whole; with bonded contact it is exactly single-material XPIC.
We chose this incremental form over the paper's Eq. (37): Eq. (37) keeps the uncorrected
one-sided velocity as its leading term and is consistent only when contact is applied at
every pass (bonded contact). Where contact switches on and off between passes, as the
approach test does in a quasi-static compression, it went far off the single-material
result (+8.5% at 2.4% strain on the two-block column, against 0.04% for always-on contact);
see docs/contact.md. `contact.xpic_contact_term: false` gives the paper's "uncorrected
XPIC": the filter starts from the uncorrected extrapolation v^a - dv^a and nothing is
re-imposed.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..gridops import chunk_range, node_ijk
from ..bc import NO_BC, add_reaction, node_bc
from ..contact.bond import point_bond
from ..contact.passes import MAX_SLOTS, increment_contact
from .boundary import has_walls, mirror_ghosts, slot_info


@njit(parallel=True, cache=True)
def xpic_series(order_, ptr, nodes, S, pmass, fields, fnodes, skip, n_box, shape, mass, vnew, vstart, seed_shift,
                use_shift, filter_updated, m_order, face_type, wall_index, rigid_vol, constrain, rig_vel, walls, n_cn, cn_nodes,
                cn_ptr, slot_group, n_def_groups, sep_method, role, partner, geo_n, delta2, slot_law, slot_mu, slot_mus,
                bonded, touch, stick_total, applied_total, n_con, con_ptr, ent_a, ent_b, ent_w, slots, nchunk, dv, tmp,
                vstar, chunk_impulse, chunk_work):
    """`nodes` are the particles' field indices (material slots at contact nodes). The impulses
    the velocity conditions exert on the increments (and their work) go to chunk_impulse and
    chunk_work, so reactions and the energy check see the filter's share of the condition."""
    dim = vnew.shape[1]
    chunk_work[:] = 0.0
    chunk_impulse[:] = 0.0
    nq = fields.size
    K = S.shape[1]
    n_slab = ptr.size - 1
    nn = shape[0] * shape[1] * shape[2]
    for q in prange(nq):
        f = fields[q]
        for d in range(dim):
            if skip[q]:
                dv[f, d] = 0.0
                vstar[f, d] = 0.0
                continue
            # seed: v (XPIC) or v+ (FMPM); seed_shift holds -dv^a for the uncorrected variant
            shift = seed_shift[f - nn, d] if (use_shift and f >= nn) else 0.0
            dv[f, d] = (vnew[f, d] if filter_updated else vstart[f, d]) + shift
            vstar[f, d] = dv[f, d] if filter_updated else vnew[f, d] + shift  # v0 + (v+ - v_e)
    for ell in range(2, m_order + 1):
        for q in prange(nq):
            f = fields[q]
            for d in range(dim):
                tmp[f, d] = 0.0
        # tmp = sum_p m_p S_ip (S dv)_p: gather then scatter, slab by slab
        for color in range(2):
            for s in prange((n_slab - color + 1) // 2):
                slab = color + 2 * s
                for qq in range(ptr[slab], ptr[slab + 1]):
                    p = order_[qq]
                    g0 = 0.0
                    g1 = 0.0
                    g2 = 0.0
                    for kk in range(K):
                        w = S[p, kk]
                        node = nodes[p, kk]
                        g0 += w * dv[node, 0]
                        g1 += w * dv[node, 1]
                        if dim == 3:
                            g2 += w * dv[node, 2]
                    mp = pmass[p]
                    for kk in range(K):
                        wm = S[p, kk] * mp
                        if wm == 0.0:
                            continue
                        node = nodes[p, kk]
                        tmp[node, 0] += wm * g0
                        tmp[node, 1] += wm * g1
                        if dim == 3:
                            tmp[node, 2] += wm * g2
        for ch in prange(nchunk):
            start, stop = chunk_range(ch, nchunk, nq)
            work_ch = 0.0
            for q in range(start, stop):
                f = fields[q]
                node = fnodes[q]
                i, j, k = node_ijk(node, shape)
                m = mass[f]
                for d in range(dim):
                    owner = NO_BC
                    v_held = 0.0
                    if m > 0.0 and not skip[q]:
                        owner, v_held = node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain,
                                             rig_vel)
                    if owner == NO_BC:
                        dv[f, d] = dv[f, d] - tmp[f, d] / m if m > 0.0 and not skip[q] else 0.0
                        continue
                    # The condition holds this component at zero increment; the momentum the
                    # increment would have put here, m dv - (S+S dv) m, is taken by the wall or
                    # rigid body instead (the free nodes' increments sum to minus it).
                    held = tmp[f, d] - m * dv[f, d]
                    work_ch += held * v_held
                    add_reaction(chunk_impulse, ch, owner, node, d, held, rigid_vol, constrain)
                    dv[f, d] = 0.0
            chunk_work[ch] += work_ch
        for c in prange(n_cn):  # contact re-imposed on the increment (notes §5.2)
            pbuf = np.zeros((MAX_SLOTS, 3))
            dpb = np.zeros((MAX_SLOTS, 3))
            imp = np.zeros(3)
            out = np.zeros(3)
            nvec = np.zeros(3)
            increment_contact(c, cn_nodes, cn_ptr, slot_group, n_def_groups, nn, shape, mass, dv, face_type,
                              wall_index, rigid_vol, constrain, rig_vel, sep_method, role, partner, geo_n, delta2,
                              slot_law, slot_mu, slot_mus, bonded, touch, stick_total, applied_total, pbuf, dpb, imp,
                              out, nvec)
        if n_cn > 0:  # and the consistent normal bond (contact.bond); a 1-row acc: no force to record
            point_bond(n_con, con_ptr, ent_a, ent_b, ent_w, nn, mass, dv, False, vstar[:1], 0.0, geo_n, dim)
        if walls:  # ghost components of the increment mirror their interior node
            mirror_ghosts(fields, fnodes, shape, face_type, wall_index, rigid_vol, constrain, slots, dv)
        for q in prange(nq):
            f = fields[q]
            for d in range(dim):
                vstar[f, d] += dv[f, d]


def xpic(scheme: str, order: int):
    """XPIC(order) (scheme xpic) or FMPM(order) (scheme fmpm)."""

    def run(state) -> None:
        _xpic(state, scheme == "fmpm", order)

    return run


def _xpic(state, fmpm: bool, order: int) -> None:
    f, g, box, sd = state.fields, state.grid, state.box, state.sd
    cs = state.contact
    dim = state.dim
    if cs is None or fmpm or cs.spec.passes == 1:
        n_cn, shift, contact = 0, _NO_SHIFT[dim], None
    else:
        ns = cs.n_slots
        if cs.spec.xpic_term:  # re-impose contact on the increments, from pass 2's totals
            n_cn, shift = cs.n_cn, _NO_SHIFT[dim]
            cs.stick_total[:ns] = cs.stick2[:ns]
            cs.applied_total[:ns] = cs.applied2[:ns]
        else:  # uncorrected: filter v - dv^a (the extrapolation without pass 1)
            n_cn = 0
            m = f.mass[g.n_nodes:g.n_nodes + ns, None]
            shift = -cs.dp1[:ns] / np.where(m > 0.0, m, 1.0)
        contact = cs
    c = contact if contact is not None else _EMPTY
    spec_groups = contact.spec.n_def_groups if contact is not None else 0
    sep = contact.spec.separation if contact is not None else 0
    touch = contact.spec.touch * float(g.h.min()) if contact is not None else 0.0
    nc = state.nchunk
    impulse = np.zeros((nc,) + state.reaction.shape)
    work = np.zeros(nc)
    xpic_series(box.order, box.ptr, state.field_index, sd.S, state.particles.mass, box.fields, box.fnodes, box.skip,
                box.n_box, box.shape, f.mass, f.vnew, f.vstart, shift, shift is not _NO_SHIFT[dim], fmpm, order, g.face_type,
                g.wall_index, f.rigid_vol, state.materials.constrain, state.rigid.v_end, has_walls(state), n_cn,
                c.cn_nodes, c.cn_ptr, c.slot_group, spec_groups, sep, c.role, c.partner, c.normal, c.delta2, c.law,
                c.mu, c.mus, c.bonded, touch, c.stick_total, c.applied_total, c.n_con if n_cn else 0, c.con_ptr,
                c.ent_a, c.ent_b, c.ent_w, slot_info(state), nc, f.dv, f.tmp, f.vstar,
                impulse, work)
    state.reaction += impulse.sum(axis=0) / state.dt
    state.work_in += float(work.sum())


class _NoContact:
    """Placeholder arrays for scenes without contact (the kernel loops over zero contact nodes)."""

    def __init__(self):
        i1, f1, f2 = np.zeros(1, dtype=np.int64), np.zeros(1), np.zeros((1, 3))
        self.cn_nodes = self.cn_ptr = self.slot_group = self.role = self.partner = self.law = self.bonded = i1
        self.normal = self.stick_total = self.applied_total = f2
        self.delta2 = self.mu = self.mus = self.ent_w = f1
        self.con_ptr = self.ent_a = self.ent_b = i1
        self.n_con = 0


_EMPTY = _NoContact()
_NO_SHIFT = {2: np.zeros((1, 2)), 3: np.zeros((1, 3))}
