"""Cohesive interfaces whose history the material points carry (issue 78; laws in cohesive.py).

Multimaterial contact rebuilds its contact nodes every step, so a node cannot remember how far
an interface has failed. Here the particles do: each deformable particle carries a damage
`interface_damage` (0 intact, 1 failed; Particles), and in every step, after the contact
geometry has planned the contact nodes (normals, areas, openings at the interface point):

0. bond: in the first step, the particles at contact nodes of a cohesive pair are the bonded
   interface (`interface_bonded`); a particle that was never bonded reads as failed, so bodies
   of a cohesive pair that meet elsewhere later only touch and slide, never bond;
1. read: each contact slot gets the shape-function and mass-weighted mean damage of its
   particles, sum S m d / sum S m; a target's node damage is the mean over its pair's two
   slots (both sides' particles);
2. law: the node's damage is the larger of that and what its opening (normal opening, the
   magnitude of the tangential one, as the interface measures them) reaches under the law;
   the interface's tension and shear stiffnesses are scaled by (1 - d) (compression keeps the
   intact one); a failed node (d = 1) is handed to the pair's contact law after failure
   (frictionless or coulomb), so what was bonded then touches and slides; the damage growth
   times the contact area is the step's fracture energy;
3. write: each particle touching cohesive nodes takes the largest of its damage and the
   shape-function mean of those nodes' *law* damage (what the openings imply, not the smoothed
   read), so the damage moves with the material, never decreases, and smoothing cannot
   ratchet it up step after step.

Cohesive directions are never bonded: the damaged spring is integrated by the interface's
integrator (backward Euler by default) in pass 2. In pass 3 the recomputed geometry reads the
damage again (no new growth).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from .cohesive import damage_at, dissipation, law_parameters, scaled_opening
from .grid.spec import COULOMB, FRICTIONLESS

AFTER_CODES = {"frictionless": FRICTIONLESS, "coulomb": COULOMB}


class CohesiveTable(NamedTuple):
    """The scene's cohesive laws: row[ga, gb] (-1: the pair is not cohesive), each row's law
    parameters, and the contact law (code, friction) a failed node is handed to."""

    row: np.ndarray  # (G, G) int64
    params: np.ndarray  # (n_laws, N_PARAMS)
    after: np.ndarray  # (n_laws,) int64 law code
    after_mu: np.ndarray  # (n_laws,)
    precracks: tuple  # ((group a, group b, lower corner (3,), upper corner (3,)), ...): boxes that start debonded


def cohesive_table(n_groups: int, entries: list) -> CohesiveTable:
    """entries: (group a, group b, the deck's Cohesive block, Dn, Dt)."""
    row = np.full((n_groups, n_groups), -1, dtype=np.int64)
    params, after, mu, cracks = [], [], [], []
    for ga, gb, c, Dn, Dt in entries:
        row[ga, gb] = row[gb, ga] = len(params)
        params.append(law_parameters(c.shape, c.peak_traction, c.shear_peak_traction, c.G_Ic, c.G_IIc,
                                     Dn if c.shape == "bilinear" else None, Dt if c.shape == "bilinear" else None,
                                     c.mixed_mode, c.exponent))
        after.append(AFTER_CODES[c.after])
        mu.append(c.friction)
        for box in c.precrack:
            lo, hi = np.full(3, -np.inf), np.full(3, np.inf)
            lo[: len(box.min)], hi[: len(box.max)] = box.min, box.max
            cracks.append((ga, gb, lo, hi))
    return CohesiveTable(row, np.array(params), np.array(after, dtype=np.int64), np.array(mu), tuple(cracks))


def unbond_precracks(x, group, bonded, table: CohesiveTable) -> None:
    """The first step, after the bond: the pair's particles (group: each one's contact group)
    inside a pre-crack box were never bonded (they read as failed from the start)."""
    dim = x.shape[1]
    for ga, gb, lo, hi in table.precracks:
        inside = np.all((x >= lo[:dim]) & (x <= hi[:dim]), axis=1) & ((group == ga) | (group == gb))
        bonded[inside] = False


@njit(cache=True)
def slot_damage(order, fidx, S, pmass, damage, bonded, n_nodes, num, den):
    """num[s] = sum S m d, den[s] = sum S m over each slot's particles (order: the particles
    with a slot entry); a particle that was never bonded counts as failed (d = 1)."""
    K = S.shape[1]
    for q in range(order.size):
        p = order[q]
        d = damage[p] if bonded[p] else 1.0
        for k in range(K):
            f = fidx[p, k]
            if f < n_nodes or S[p, k] <= 0.0:
                continue
            wm = S[p, k] * pmass[p]
            num[f - n_nodes] += wm * d
            den[f - n_nodes] += wm


@njit(cache=True)
def bond_start(order, fidx, S, n_nodes, cn_ptr, n_cn, slot_group, row, bonded):
    """The first step: the particles at contact nodes of a cohesive pair are the bonded
    interface (bonded = True); every other particle never was, and never becomes, bonded."""
    n_slots = cn_ptr[n_cn]
    cohesive = np.zeros(n_slots, dtype=np.bool_)
    for c in range(n_cn):
        for s in range(cn_ptr[c], cn_ptr[c + 1]):
            for o in range(cn_ptr[c], cn_ptr[c + 1]):
                if o != s and row[slot_group[s], slot_group[o]] >= 0:
                    cohesive[s] = True
    K = S.shape[1]
    for q in range(order.size):
        p = order[q]
        for k in range(K):
            f = fidx[p, k]
            if f >= n_nodes and S[p, k] > 0.0 and cohesive[f - n_nodes]:
                bonded[p] = True


@njit(cache=True)
def node_damage(n_cn, cn_ptr, slot_group, role, partner, delta, open_t, area, law, mu, stiff, bonded, table, params,
                after, after_mu, num, den, grow, trial, slot_area, slot_mix, slot_open, slot_row):
    """Each cohesive target's node damage (the read, raised by the law where grow), applied to
    its stiffnesses or, failed, its law. Where grow, at each cohesive pair's two slots: trial,
    the law's damage from the opening (-1 elsewhere); slot_area, half the contact area (each
    side's particles share it); slot_mix, the mode mixity; slot_open, the opening's size
    (|(<dn>, dt)|); slot_row, the pair's law row."""
    dim = open_t.shape[1]
    for c in range(n_cn):
        for a in range(cn_ptr[c], cn_ptr[c + 1]):
            if role[a] == 0:
                continue
            b = partner[a]
            if b < 0:
                continue
            r = table[slot_group[a], slot_group[b]]
            if r < 0:
                continue
            p = params[r]
            tot = den[a] + den[b]
            d_read = (num[a] + num[b]) / tot if tot > 0.0 else 0.0
            dt_mag = 0.0
            for d in range(dim):
                dt_mag += open_t[a, d] * open_t[a, d]
            dt_mag = np.sqrt(dt_mag)
            d_node = d_read
            if grow:
                lam, B = scaled_opening(delta[a], dt_mag, p)
                d_law = damage_at(lam, B, p)
                d_node = max(d_read, d_law)
                if trial[a] < 0.0:  # a pair's values once (its first target's)
                    for s in (a, b):
                        trial[s] = d_law
                        slot_area[s] = 0.5 * area[a]
                        slot_mix[s] = B
                        slot_open[s] = np.sqrt(max(delta[a], 0.0) ** 2 + dt_mag * dt_mag)
                        slot_row[s] = r
            bonded[a] = 0
            if d_node >= 1.0:
                law[a] = after[r]
                mu[a] = after_mu[r]
            else:
                stiff[a, 0] *= 1.0 - d_node
                stiff[a, 2] *= 1.0 - d_node


@njit(cache=True)
def carry_damage(order, fidx, S, pmass, n_nodes, den, trial, slot_area, slot_mix, slot_open, damage, opening, bonded,
                 area, law_of, params):
    """Each particle with cohesive slots: damage = max(damage, the shape-function mean of
    their law damage). Its share of the interface (each slot's half area by its mass weight
    there) when it was bonded (`area`, set in the first step: the reference area, which a crack
    whose nodes leave contact one by one, or bodies sliding off each other, do not shrink)
    times what its damage growth dissipates is the fracture energy; where it fails, that share
    is debonded; its opening is the shape-function mean of those nodes' openings (kept where it
    has none). Returns (fracture energy, debonded area) of the step."""
    K = S.shape[1]
    energy = 0.0
    failed = 0.0
    for q in range(order.size):
        p = order[q]
        if not bonded[p]:
            continue
        sw = 0.0
        sd = 0.0
        mix = 0.0
        op = 0.0
        r = -1
        for k in range(K):
            f = fidx[p, k]
            if f < n_nodes or S[p, k] <= 0.0:
                continue
            s = f - n_nodes
            if trial[s] < 0.0:
                continue
            w = S[p, k] * pmass[p] / den[s] * slot_area[s]  # its share of the slot's area
            sw += w
            sd += w * trial[s]
            mix += w * slot_mix[s]
            op += w * slot_open[s]
            r = law_of[s]
        if sw > 0.0:
            opening[p] = op / sw
            if area[p] == 0.0:
                area[p] = sw
        if sw > 0.0 and sd / sw > damage[p]:
            new = min(sd / sw, 1.0)
            energy += area[p] * dissipation(damage[p], new, mix / sw, params[r])
            if new >= 1.0:
                failed += area[p]
            damage[p] = new
    return energy, failed


class CohesiveInterfaces:
    """The seam: ContactTasks.geometry calls `after_geometry(state, grow)` between the planned
    geometry and the consistent bond (grow: the step's first geometry; pass 3's only reads)."""

    def __init__(self, table: CohesiveTable):
        self.table = table

    def after_geometry(self, state, grow: bool) -> None:
        cs, P, sd = state.contact, state.particles, state.sd
        nn, ns = state.grid.n_nodes, cs.n_slots
        t = self.table
        if P.interface_damage is None or P.interface_damage.size != P.n:
            P.interface_damage, P.interface_opening = np.zeros(P.n), np.zeros(P.n)
            P.interface_bonded = np.zeros(P.n, dtype=np.bool_)
            P.interface_area = np.zeros(P.n)
            bond_start(cs.slot_order, cs.fidx, sd.S, nn, cs.cn_ptr, cs.n_cn, cs.slot_group, t.row, P.interface_bonded)
            unbond_precracks(P.x, cs.spec.mat_group[P.mat], P.interface_bonded, t)
        num, den = np.zeros(ns), np.zeros(ns)
        slot_damage(cs.slot_order, cs.fidx, sd.S, P.mass, P.interface_damage, P.interface_bonded, nn, num, den)
        trial, slot_area, slot_mix, slot_open = np.full(ns, -1.0), np.zeros(ns), np.zeros(ns), np.zeros(ns)
        slot_row = np.full(ns, -1, dtype=np.int64)
        node_damage(cs.n_cn, cs.cn_ptr, cs.slot_group, cs.role, cs.partner, cs.delta, cs.open, cs.area, cs.law, cs.mu,
                    cs.stiff, cs.bonded, t.row, t.params, t.after, t.after_mu, num, den, grow, trial, slot_area, slot_mix,
                    slot_open, slot_row)
        if grow:
            energy, failed = carry_damage(cs.slot_order, cs.fidx, sd.S, P.mass, nn, den, trial, slot_area, slot_mix,
                                          slot_open, P.interface_damage, P.interface_opening, P.interface_bonded,
                                          P.interface_area, slot_row, t.params)
            state.fracture_energy += energy
            state.debonded_area += failed
