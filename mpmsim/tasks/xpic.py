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

from functools import cache
from typing import NamedTuple

import numpy as np
from numba import prange

from ..bc import NO_BC, add_reaction, node_bc
from ..contact.grid.bond import point_bond
from ..contact.grid.laws import plugin_dispatch
from ..contact.grid.passes import NO_BEFORE, increment_contact, law_kernels, node_scratch, pair_changes
from ..contact.grid.spec import SEP_VELOCITY
from ..contact.grid.workspace import no_contact
from ..gridops import chunk_range, node_ijk, slab
from ..parallel import chunk_kernel, specialize
from ..views import GridView, RigidHold
from .boundary import has_walls, mirror_ghosts


class FilterFields(NamedTuple):
    """The grid fields the filter reads and writes."""

    mass: np.ndarray
    vnew: np.ndarray  # v+ (updated velocity)
    vstart: np.ndarray  # v_e (start velocity, velocity conditions imposed)
    dv: np.ndarray  # the current increment
    tmp: np.ndarray  # scratch: sum_p m_p S_ip (S dv)_p
    vstar: np.ndarray  # the result


class FilterOptions(NamedTuple):
    order: int  # m: number of terms of the series
    filter_updated: bool  # FMPM: filter v+ (else XPIC: the start velocity, plus the step's change)
    seed_shift: np.ndarray  # per slot: -dv^a of pass 1 (uncorrected multimaterial XPIC), else (1, dim)
    use_shift: bool
    walls: bool  # ghost components mirror their interior node
    sep_velocity: bool  # contact re-imposed on the increments: velocity-only detection
    touch: float  # and its touching length


class HeldSums(NamedTuple):
    """Per chunk, what the velocity conditions take from the increments: impulse, work."""

    impulse: np.ndarray  # (nchunk, 6 + n_rigid, dim)
    work: np.ndarray  # (nchunk,)


class SlotGain(NamedTuple):
    """Momentum the contact re-imposed on the increments gives each material slot, summed over
    the increments (for the contact forces between materials); (0, dim) arrays: not tracked."""

    gain: np.ndarray  # (n_slots, dim)
    prev: np.ndarray  # (n_slots, dim) scratch: the slots' increment before contact


@chunk_kernel
def xpic_series(sc, pmass, active, grid, held, f, opts, cnodes, geo, dec, bonds, ghost_src, nchunk, sums, slot_gain):
    """The series v* = sum_j (I - S+S)^j v over the active fields (sc: the particles' entries
    into their fields, material slots at contact nodes), with contact re-imposed on every
    increment at the cnodes.n_cn contact nodes. The impulses the velocity conditions exert on
    the increments (and their work) go to sums (HeldSums), so reactions and the energy check
    see the filter's share of the condition. What contact gives each slot goes to slot_gain."""
    # (parallel loops work on arrays bound to locals: docs/architecture.md)
    order_, ptr, nodes, S = sc
    fields, fnodes, skip = active
    shape, origin, h, face_type, wall_index = grid  # (the contact increments rebuild the view: views.GridView)
    rigid_vol, constrain, rig_vel = held
    mass, vnew, vstart, dv, tmp, vstar = f
    m_order, filter_updated, seed_shift, use_shift, walls, sep_velocity, touch = opts
    n_cn = cnodes.n_cn
    nn = shape[0] * shape[1] * shape[2]
    geo_n = geo.normal
    chunk_impulse, chunk_work = sums
    gain, prev = slot_gain
    dim = vnew.shape[1]
    chunk_work[:] = 0.0
    chunk_impulse[:] = 0.0
    nq = fields.size
    K = S.shape[1]
    for q in prange(nq):
        fld = fields[q]
        for d in range(dim):
            if skip[q]:
                dv[fld, d] = 0.0
                vstar[fld, d] = 0.0
                continue
            # seed: v (XPIC) or v+ (FMPM); seed_shift holds -dv^a for the uncorrected variant
            shift = seed_shift[fld - nn, d] if (use_shift and fld >= nn) else 0.0
            dv[fld, d] = (vnew[fld, d] if filter_updated else vstart[fld, d]) + shift
            vstar[fld, d] = dv[fld, d] if filter_updated else vnew[fld, d] + shift  # v0 + (v+ - v_e)
    for ell in range(2, m_order + 1):
        for q in prange(nq):
            fld = fields[q]
            for d in range(dim):
                tmp[fld, d] = 0.0
        # tmp = sum_p m_p S_ip (S dv)_p: gather then scatter, slab by slab
        for color in range(2):
            for s in prange((ptr.size - color) // 2):
                for q in slab(ptr, color, s):
                    p = order_[q]
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
                fld = fields[q]
                node = fnodes[q]
                i, j, k = node_ijk(node, shape)
                m = mass[fld]
                for d in range(dim):
                    owner = NO_BC
                    v_held = 0.0
                    if m > 0.0 and not skip[q]:
                        owner, v_held = node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain,
                                                rig_vel)
                    if owner == NO_BC:
                        dv[fld, d] = dv[fld, d] - tmp[fld, d] / m if m > 0.0 and not skip[q] else 0.0
                        continue
                    # The condition holds this component at zero increment; the momentum the
                    # increment would have put here, m dv - (S+S dv) m, is taken by the wall or
                    # rigid body instead (the free nodes' increments sum to minus it).
                    held_p = tmp[fld, d] - m * dv[fld, d]
                    work_ch += held_p * v_held
                    add_reaction(chunk_impulse, ch, owner, node, d, held_p, rigid_vol, constrain)
                    dv[fld, d] = 0.0
            chunk_work[ch] += work_ch
        for s in prange(gain.shape[0]):
            for d in range(dim):
                prev[s, d] = dv[nn + s, d]
        for ch in prange(nchunk):  # contact re-imposed on the increment (notes §5.2), node by node
            start, stop = chunk_range(ch, nchunk, n_cn)
            w = node_scratch()
            gview = GridView(shape, origin, h, face_type, wall_index)
            for c in range(start, stop):
                increment_contact(c, cnodes, gview, held, mass, dv, geo, dec, sep_velocity, touch, w)
        if n_cn > 0:  # and the consistent normal bond (contact.bond); a 1-row acc: no force to record
            point_bond(bonds, nn, mass, dv, False, vstar[:1], 0.0, geo_n, dim)
        for s in prange(gain.shape[0]):
            for d in range(dim):
                gain[s, d] += mass[nn + s] * (dv[nn + s, d] - prev[s, d])
        if walls:  # ghost components of the increment mirror their interior node
            mirror_ghosts(fields, ghost_src, dv)
        for q in prange(nq):
            fld = fields[q]
            for d in range(dim):
                vstar[fld, d] += dv[fld, d]


@cache
def series_kernel(plugin_laws: tuple):
    """xpic_series with the scene's plugin contact laws in its increments (law_kernels)."""
    if not plugin_laws:
        return xpic_series
    tag, _ = plugin_dispatch(plugin_laws)
    increment = law_kernels(plugin_laws).increment_contact
    return chunk_kernel(specialize(xpic_series.py_func, tag, increment_contact=increment))


def xpic(scheme: str, order: int, spec):
    """XPIC(order) (scheme xpic) or FMPM(order) (scheme fmpm); spec: the scene's contact spec
    or None."""
    fmpm = scheme == "fmpm"
    reimpose = spec is not None and not fmpm and spec.passes == 2
    series = series_kernel(spec.plugin_laws if spec is not None else ())
    sep_velocity = spec is not None and spec.separation == SEP_VELOCITY

    def run(state) -> None:
        f, g, box, sd, cs = state.fields, state.grid, state.box, state.sd, state.contact
        dim, nn = state.dim, g.n_nodes
        shift = _NO_SHIFT[dim]
        empty = no_contact(dim)
        cnodes, geo, dec, bonds, touch = empty.nodes, empty.geo, empty.dec, empty.bonds, 0.0
        tracked = 0  # slots whose contact gain is tracked
        if reimpose:
            ns = cs.n_slots
            if spec.xpic_term:  # re-impose contact on the increments, from pass 2's totals
                cs.stick_total[:ns] = cs.stick2[:ns]
                cs.applied_total[:ns] = cs.applied2[:ns]
                cnodes, geo, dec, bonds = cs.nodes(nn), cs.targets(), cs.decisions(), cs.bonds()
                touch = spec.touch * float(g.h.min())
                tracked = ns
            else:  # uncorrected: filter v - dv^a (the extrapolation without pass 1)
                m = f.mass[nn:nn + ns, None]
                shift = -cs.dp1[:ns] / np.where(m > 0.0, m, 1.0)
        nc = state.nchunk
        sums = HeldSums(np.zeros((nc,) + state.reaction.shape), np.zeros(nc))
        held = RigidHold(f.rigid_vol, state.materials.constrain, state.rigid.v_end)
        ff = FilterFields(f.mass, f.vnew, f.vstart, f.dv, f.tmp, f.vstar)
        opts = FilterOptions(order, fmpm, shift, shift is not _NO_SHIFT[dim], has_walls(state),
                             sep_velocity, touch)
        slot_gain = SlotGain(np.zeros((tracked, dim)), np.zeros((tracked, dim)))
        series(box.scatter(state.field_index, sd.S), state.particles.mass, box.active(), g.view, held, ff, opts,
                    cnodes, geo, dec, bonds, f.ghost_src, nc, sums, slot_gain)
        if tracked:  # the increments' contact reaches the particles: part of the contact forces
            add_pair_impulse(state, slot_gain.gain)
        state.reaction += sums.impulse.sum(axis=0) / state.dt
        state.work_in += float(sums.work.sum())

    return run


_NO_SHIFT = {2: np.zeros((1, 2)), 3: np.zeros((1, 3))}


def add_pair_impulse(state, gain: np.ndarray) -> None:
    """Add the momentum `gain` (per slot) that the filter's contact moved between materials to
    the step's contact forces and impulses (set by contact pass 2, which ran before)."""
    cs = state.contact
    change = np.zeros_like(cs.pair_step)
    pair_changes(cs.nodes(state.grid.n_nodes), state.fields.mass, gain, NO_BEFORE, False, change)
    cs.pair_force += change / state.dt
    cs.pair_impulse += change
