"""Tasks: the energy ledger (`output.energy_ledger`), where the work put into an explicit MPM
run goes, step by step.

Every change of the grid's kinetic energy within a step has a named cause. With m the field
mass, v1 = p/m the field velocity after the extrapolation (and contact pass 1), v+ after the
momentum update with the velocity conditions, vc after contact pass 2, and the mean
v_bar = (v1 + vc)/2, the update satisfies exactly, field by field,

  1/2 m (|vc|^2 - |v1|^2) = (f + f_bc + f_c) . v_bar dt,
  f_bc = m (v+ - v1)/dt - f   (what the velocity conditions and wall mirrors add),
  f_c  = m (vc - v+)/dt        (what contact pass 2 adds).

The stress update integrates the velocity v_s = w1 v_first + w2 v_last (USAVG: halves of the
start-of-step velocity with conditions imposed and the end-of-step one, re-extrapolated for
usavg+/usl+), so the internal forces' work at v_bar is minus the stress power plus the work
f . (v_bar - v_s) dt on velocity the stress update does not integrate. Summed over the run
this gives the balance

  external_work + E0 = kinetic + strain (+ internal + interface) energy
                       (+ energy dissipated in materials: plastic work)
                       + transfer_loss + contact_loss + friction_loss + condition_loss
                       + force_gap_loss + fracture_loss + R

with the six losses (cumulative, energy units; history columns of the same names):
- transfer_loss: kinetic energy lost between particles and grid, P2G (sum 1/2 m V^2 minus the
  grid's) plus G2P (the grid's at vc minus the particles' after their update);
- contact_loss: kinetic energy removed by contact pass 1, minus the work of pass 2's contact
  changes at v_bar, plus the work a rigid contact material does there (booked in
  external_work), less friction_loss; energy stored by imperfect interfaces is in it (also in
  interface_energy);
- friction_loss: what Coulomb's law took (friction_work): minus the work of the tangential
  part of each coulomb target's contact change at its slip velocity (pass 2 at v_bar; pass 1
  at the mean of its velocities before and after, where pass 1's change reaches the
  particles: not under FLIP, whose particles add only dt a, except the held pairs' change,
  which FLIP takes as a force). Where the pair slides this is mu |f_n| |slip| dt;
- condition_loss: the work booked for the velocity conditions minus what reaches the grid:
  1/2 m (v_bc - v1)^2 where a condition lands a field on its velocity (an inelastic impact);
- force_gap_loss: minus the internal forces' work f . (v_bar - v_s) dt at free components:
  negative where the forces drive grid velocity that the stress update smooths away
  (re-extrapolation) and the transfers then take out;
- fracture_loss: what cohesive interfaces dissipated as they failed (the history's
  fracture_energy: contact/cohesive_history.py), taken out of contact_loss, where the
  interface forces' work put it.
R (history column energy_residual) is what is left: the stress update's time integration
(stress power at the force's stress against the change of the strain energy W(F)), grid
damping, and the difference between the external forces' work booked on the particles and
their grid work. It is small where F, the stress and the strain energy agree
(docs/validation.md, "Energy ledger").
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..bodies import INTERNAL, KINETIC, STRAIN
from ..contact.grid.spec import COULOMB, SLIVER
from ..stability import total_sums
from ..state import N_LOSSES

# order of the ledger's totals (state.ledger: mpmsim/state.py sizes it by N_LOSSES) and of
# their history columns
LOSSES = ("transfer_loss", "contact_loss", "friction_loss", "condition_loss", "force_gap_loss", "fracture_loss")
TRANSFER, CONTACT, FRICTION, CONDITION, FORCE_GAP, FRACTURE = range(N_LOSSES)


@njit(cache=True)
def particle_kinetic(mass, v):
    """sum 1/2 m |V|^2 over particles."""
    e = 0.0
    for p in range(mass.size):
        s = 0.0
        for d in range(v.shape[1]):
            s += v[p, d] * v[p, d]
        e += 0.5 * mass[p] * s
    return e


@njit(cache=True)
def keep_update(fields, skip, mass, mom, vel, vnew, v1, vfirst, vplus, light):
    """After the momentum update: per active field (in box order) v1 = p/m, the velocity the
    first stress update used and v+; returns the grid's kinetic energy at v1. Fields of mass
    <= light are left out of every account (`light_mass`)."""
    e = 0.0
    for q in range(fields.size):
        fid = fields[q]
        m = mass[fid]
        live = m > light and not skip[q]
        for d in range(mom.shape[1]):
            v1[q, d] = mom[fid, d] / m if live else 0.0
            vfirst[q, d] = vel[fid, d]
            vplus[q, d] = vnew[fid, d]
            if live:
                e += 0.5 * m * v1[q, d] * v1[q, d]
    return e


@njit(cache=True)
def pass_1_drop(nn, n_slots, slot_group, n_def, mass, mom, dp1, light):
    """Kinetic energy contact pass 1 removed (dp1: its change of each deformable slot's
    momentum; rigid slots keep theirs, and their dp1 rows are not written)."""
    e = 0.0
    for s in range(n_slots):
        m = mass[nn + s]
        if m <= light or slot_group[s] >= n_def:
            continue
        for d in range(mom.shape[1]):
            p = mom[nn + s, d]
            before = p - dp1[s, d]
            e += 0.5 * (before * before - p * p) / m
    return e


@njit(cache=True)
def friction_work(nn, n_slots, slot_group, n_def, role, partner, normal, law, mass, dp, v_start, v_end, v_rigid,
                  light=0.0):
    """Work of Coulomb's law at the step's contact nodes: over the target slots whose law is
    coulomb, the tangential part (to the target's contact normal) of its contact change dp[s]
    (momentum) at the slip velocity, the mean of the slot's velocities v_start[s] and v_end[s]
    before and after the change, less its partner's: a deformable partner's mean (the partner
    took the opposite change), a rigid partner's velocity v_rigid[b]; against the lumped rest
    (three or more materials) each target's own velocity. Negative where friction takes
    energy. Sliding targets (tangential change at mu |normal change|) and stuck ones (below it:
    the change that lands the pair on one tangential velocity) both count: a slab that a block
    slides on has a third of the contact nodes under the block stuck in a step, their share of
    the dissipation a third (docs/validation.md, "Energy ledger"). Slots as in
    mpmsim/contact/grid/workspace.py and plan.plan_node. Targets of mass <= light, or whose
    deformable partner's is, are left out (`light_mass`)."""
    w = 0.0
    dim = dp.shape[1]
    for s in range(n_slots):
        if slot_group[s] >= n_def or role[s] == 0 or law[s] != COULOMB or mass[nn + s] <= light:
            continue
        b = partner[s]
        if b >= 0 and slot_group[b] < n_def and mass[nn + b] <= light:
            continue
        dn = 0.0
        for d in range(dim):
            dn += dp[s, d] * normal[s, d]
        for d in range(dim):
            v = 0.5 * (v_start[s, d] + v_end[s, d])
            if b >= 0 and slot_group[b] >= n_def:
                v -= v_rigid[b, d]
            elif b >= 0:
                v -= 0.5 * (v_start[b, d] + v_end[b, d])
            w += (dp[s, d] - dn * normal[s, d]) * v
    return w


def slot_friction(cs, nn: int, mass: np.ndarray, dp: np.ndarray, v_start: np.ndarray, v_end: np.ndarray,
                  v_rigid: np.ndarray, light: float) -> float:
    """friction_work over the contact workspace cs's slots."""
    return friction_work(nn, cs.n_slots, cs.slot_group, cs.spec.n_def_groups, cs.role, cs.partner, cs.normal, cs.law,
                         mass, dp, v_start, v_end, v_rigid, light)


def light_mass(mass: np.ndarray, fields: np.ndarray) -> float:
    """The ledger's mass floor: SLIVER times the heaviest active field. A field with a sliver of
    a particle's shape function (mass ~ S, internal force ~ grad S) gets a velocity ~ 1/S that
    its particles, weighting it by S, never see; its kinetic energy, exact but huge, would be
    booked in one loss and taken back in another (the contact and transfer losses swinging by
    1e8 times the run's energy in one step, friction by 1e2 where such a slot was a target's
    partner). Left out of every account, such a field leaves its part of the stress power,
    order S, in the residual."""
    return SLIVER * float(mass[fields].max()) if fields.size else 0.0


@njit(cache=True)
def step_sums(fields, skip, mass, force, vnew, vlast, v1, vfirst, vplus, w_first, w_last, dt, light, out):
    """End of the step, over live active fields: out = (grid kinetic energy at vc, work of the
    conditions' forces at v_bar, of pass 2's contact forces at v_bar, the forces' work on
    velocity the stress update does not see at free components, and at held ones)."""
    for r in range(5):
        out[r] = 0.0
    for q in range(fields.size):
        fid = fields[q]
        m = mass[fid]
        if m <= light or skip[q]:
            continue
        for d in range(force.shape[1]):
            vc = vnew[fid, d]
            f = force[fid, d]
            vbar = 0.5 * (v1[q, d] + vc)
            jump = m * (vplus[q, d] - v1[q, d])  # (f + f_bc) dt
            bc = jump - f * dt  # f_bc dt
            vs = w_first * vfirst[q, d] + w_last * vlast[fid, d]
            gap = f * (vbar - vs) * dt
            out[0] += 0.5 * m * vc * vc
            out[1] += bc * vbar
            out[2] += m * (vc - vplus[q, d]) * vbar
            if abs(bc) > 1e-12 * (abs(jump) + abs(f * dt) + abs(m * v1[q, d])):
                out[4] += gap  # a held component: part of the condition's account
            else:
                out[3] += gap


class EnergyLedger:
    """The ledger's three tasks (after the momentum update, after contact pass 2, at the end of
    the step) and the snapshots they pass on; the totals go into state.ledger (LOSSES order)."""

    def __init__(self, stress: str, reextrapolate: bool, pass_1: bool, friction: bool = False,
                 pass_1_friction: str | None = None):
        """friction: the scene has a coulomb law (else friction_loss stays zero, uncomputed).
        pass_1_friction: which part of contact pass 1's change reaches the particles, so that
        Coulomb's share of it is friction: "dp1" (all of it: schemes whose particles take the
        grid velocity), "hold" (the held pairs' change, a force under FLIP), None (none: FLIP's
        particles add only dt a, so pass 1's change shows as equal and opposite contact and
        transfer losses)."""
        self.friction = friction
        self.pass_1_friction = pass_1_friction if friction else None
        self.w_first = {"usf": 1.0, "usavg": 0.5, "usl": 0.0}[stress]
        self.w_last = 1.0 - self.w_first
        self.last_from_vel = reextrapolate and stress != "usf"  # re-extrapolated velocities
        self.pass_1 = pass_1
        self.ke_start = -1.0  # particles' kinetic energy at the start of the step (< 0: not yet)
        self.marks = np.zeros(2)  # external_work at the step's start (a run starts at 0) and after the update
        self.v1 = self.vfirst = self.vplus = np.zeros((0, 0))
        # contact slots' v1 (p/m after pass 1; a rigid slot's: its velocity) and v+ (friction in pass 2)
        self.slot_v1 = self.slot_vplus = np.zeros((0, 0))
        self.sums = np.zeros(5)
        self.light = 0.0  # the step's light_mass

    def updated(self, state) -> None:
        """After the momentum update: keep v1, the first stress velocity and v+; book the
        P2G and pass-1 losses."""
        f, box, P = state.fields, state.box, state.particles
        if self.ke_start < 0.0:  # the first step: the particles have not moved yet
            self.ke_start = particle_kinetic(P.mass, P.v)
        n, dim = box.fields.size, state.dim
        if self.v1.shape != (n, dim):
            self.v1, self.vfirst, self.vplus = (np.zeros((n, dim)) for _ in range(3))
        self.light = light = light_mass(f.mass, box.fields)
        ke_grid = keep_update(box.fields, box.skip, f.mass, f.mom, f.vel, f.vnew, self.v1, self.vfirst, self.vplus,
                              light)
        drop = friction = 0.0
        cs = state.contact
        if cs is not None and self.pass_1:
            drop = pass_1_drop(state.grid.n_nodes, cs.n_slots, cs.slot_group, cs.spec.n_def_groups, f.mass, f.mom,
                               cs.dp1, light)
        if cs is not None and self.friction:
            nn, ns = state.grid.n_nodes, cs.n_slots
            m = f.mass[nn:nn + ns, None]
            self.slot_v1 = np.divide(f.mom[nn:nn + ns], m, out=np.zeros((ns, state.dim)), where=m > light)
            self.slot_vplus = f.vnew[nn:nn + ns].copy()
            if self.pass_1 and self.pass_1_friction is not None:
                dp1 = cs.dp1[:ns]
                before = np.divide(f.mom[nn:nn + ns] - dp1, m, out=np.zeros((ns, state.dim)), where=m > light)
                dpf = dp1 if self.pass_1_friction == "dp1" else cs.hold[:ns]
                friction = -slot_friction(cs, nn, f.mass, dpf, before, self.slot_v1, self.slot_v1, light)
        state.ledger[TRANSFER] += self.ke_start - (ke_grid + drop)
        state.ledger[CONTACT] += drop - friction
        state.ledger[FRICTION] += friction
        self.marks[1] = state.work_in

    def contact(self, state) -> None:
        """After contact pass 2: the work a rigid contact material did there is part of its
        exchange (booked in external_work); the frictional laws' share of pass 2's work."""
        friction = 0.0
        if self.friction:
            cs, f, nn = state.contact, state.fields, state.grid.n_nodes
            vc = f.vnew[nn:nn + cs.n_slots]
            dp = f.mass[nn:nn + cs.n_slots, None] * (vc - self.slot_vplus)
            friction = -slot_friction(cs, nn, f.mass, dp, self.slot_v1, vc, self.slot_v1, self.light)
        state.ledger[CONTACT] += state.work_in - self.marks[1] - friction
        state.ledger[FRICTION] += friction

    def step_end(self, state) -> None:
        """End of the step: the G2P loss, pass 2's contact work, the conditions' losses and the
        force gap."""
        f, box, P = state.fields, state.box, state.particles
        vlast = f.vel if self.last_from_vel else f.vnew
        s = self.sums
        step_sums(box.fields, box.skip, f.mass, f.force, f.vnew, vlast, self.v1, self.vfirst, self.vplus,
                  self.w_first, self.w_last, state.dt, self.light, s)
        ke_grid_end, w_bc, w_contact, gap_free, gap_held = s
        ke_particles = particle_kinetic(P.mass, P.v)
        led = state.ledger
        led[TRANSFER] += ke_grid_end - ke_particles
        led[CONTACT] -= w_contact
        led[CONDITION] += (self.marks[1] - self.marks[0]) - w_bc - gap_held
        led[FORCE_GAP] -= gap_free
        fracture = state.fracture_energy - float(np.sum(led[FRACTURE]))  # (zero without cohesive laws)
        led[CONTACT] -= fracture
        led[FRACTURE] += fracture
        self.ke_start = ke_particles
        self.marks[0] = state.work_in


def energy_residual(state) -> float:
    """external_work + E0 minus the energies and the losses (LOSSES) at this state."""
    s = total_sums(state)
    stored = s[KINETIC] + s[STRAIN] + s[INTERNAL] + state.interface_energy if s is not None else 0.0
    dissipated = dissipation(state)
    if dissipated:
        stored += sum(dissipated.values())
    return state.energy0 + state.work_in - stored - float(np.sum(state.ledger))


def dissipation(state) -> dict[str, float]:
    """{name: energy} dissipated inside the materials (plastic work); empty when no model
    dissipates."""
    P = state.particles
    return P.dissipation(state.materials) if P is not None and P.n else {}


def ledger_summary(state, energy_unit: str) -> str:
    """One line for the end of a run: the energy supplied (initial energy + external work) and
    where it is, in % of it (the parts add up to 100%)."""
    s = total_sums(state)
    if s is None:
        return "energy ledger: no deformable material"
    parts = [("kinetic", s[KINETIC]), ("strain", s[STRAIN])]
    if s[INTERNAL]:
        parts.append(("internal", s[INTERNAL]))
    if state.interface_energy:
        parts.append(("interfaces", state.interface_energy))
    parts += [(name.replace("_", " "), v) for name, v in dissipation(state).items()]
    parts += [(name.removesuffix("_loss").replace("_", " "), v) for name, v in zip(LOSSES, state.ledger)
              if name != "fracture_loss" or v]  # (fracture: only where cohesive interfaces failed)
    parts.append(("residual", energy_residual(state)))
    supplied = state.energy0 + state.work_in
    if supplied == 0.0:
        return f"energy ledger: no energy supplied ({energy_unit})"
    return (f"energy ledger: initial energy + work = {supplied:.4g} {energy_unit}; "
            + ", ".join(f"{name} {100 * v / supplied:.2f}%" for name, v in parts))
