"""Multimaterial contact: material fields where groups meet, the contact geometry and the
three contact passes, as tasks of the explicit step.

Tasks (in step order): `material_fields` after the shape functions, `contact_geometry` and
`contact_pass_1` after extrapolation, `contact_pass_2` after the grid update, `contact_pass_3`
after the re-extrapolation of USL+/USAVG+. Scenes with one velocity field have no contact
workspace and none of these tasks. Settings (method codes, the touching length, screening)
are bound when the task list is built (`ContactTasks`).
"""

from __future__ import annotations

import numpy as np

from ...gridops import slab_subset
from ...scene.grid import ROLLER
from ...views import RigidHold, Scatter
from .bond import bond_points, point_bond
from .fields import (assign_fields, build_clouds, build_slots, count_slots, scatter_group_masks, scatter_rigid_masks,
                     scatter_rigid_slots, scatter_slot_extras, touch_contact_nodes)
from .passes import (HOLD_FORCE, HOLD_NONE, NO_BEFORE, NO_HOLD, PASS_1, Pass2Settings, Pass2Sums, advance_rule,
                     contact_pass_2, hold_rule, pass_3_mode, law_kernels, pair_changes, settle_pairs)
from .plan import contact_geometry as plan_geometry
from .spec import SEP_LR, SEP_VELOCITY
from .traction import record_slot_forces
from .workspace import ContactWorkspace

_NO_ACC = np.zeros((1, 3))  # point_bond on momenta: no force to record

__all__ = ["ContactWorkspace", "ContactTasks", "material_fields", "extrapolate_contact",
           "screen_volume"]


def material_fields(state) -> None:
    """Find the contact nodes, give each group there its own slot, point particle entries at
    their fields, extend the step's active fields, build point clouds (notes §0, §2.1)."""
    cs, box, sd, rsd = state.contact, state.box, state.sd, state.rigid_sd
    nn = state.grid.n_nodes
    box_nodes = box.fields[: box.n_box].copy()
    cs.mask[box_nodes] = 0
    scatter_group_masks(box.scatter(sd.nodes, sd.S), cs.group, cs.mask)
    if state.rigid.n:
        scatter_rigid_masks(rsd.nodes, rsd.S, cs.rgroup, cs.mask)
    n_cn, n_slots = count_slots(box_nodes, cs.mask)
    cs.ensure(n_cn, n_slots, state.dim)
    state.fields.ensure(nn + cs.cap)
    build_slots(box_nodes, cs.mask, 0, 0, cs.node_cn, cs.cn_nodes, cs.cn_ptr, cs.slot_group, cs.slot_node)
    cs.n_cn, cs.n_slots = n_cn, n_slots
    slotted = np.empty(sd.S.shape[0], dtype=np.bool_)
    assign_fields(sd.nodes, sd.S, cs.group, cs.node_cn, cs.cn_ptr, cs.slot_group, nn, True, cs.fidx, slotted)
    if state.rigid.n:
        assign_fields(rsd.nodes, rsd.S, cs.rgroup, cs.node_cn, cs.cn_ptr, cs.slot_group, nn, False, cs.rfidx,
                      np.empty(rsd.S.shape[0], dtype=np.bool_))
    # the slot sums walk only the particles with a slot entry (the others add nothing), in the
    # step's slab order: the same sums to the bit, for a few percent of the particles
    order, ptr = box.order, box.ptr
    cs.slot_order, cs.slot_ptr = np.empty_like(order), np.empty_like(ptr)
    n_slotted = slab_subset(order, ptr, slotted, cs.slot_order, cs.slot_ptr)
    cs.slot_order = cs.slot_order[:n_slotted]
    slots = np.arange(n_slots)
    box.fields = np.concatenate([box_nodes, nn + slots])
    box.fnodes = np.concatenate([box_nodes, cs.slot_node[:n_slots]])
    box.skip = np.concatenate([np.zeros(box.n_box, dtype=np.bool_),
                               cs.slot_group[:n_slots] >= cs.spec.n_def_groups])
    if cs.spec.needs_cloud:
        ptr = np.zeros(n_cn + 1, dtype=np.int64)
        sw = cs.spec.shape_weights
        # a particle with a non-zero weight at a contact node has a slot entry there (every
        # deformable particle has a group), so only those with a slot entry are candidates
        candidates = np.flatnonzero(slotted)
        touching = np.empty(candidates.size, dtype=np.bool_)
        touch_contact_nodes(sd, cs.node_cn, candidates, state.nchunk, touching)
        near = candidates[touching]
        build_clouds(sd, near, rsd, cs.rgroup, cs.node_cn, n_cn, sw, ptr, np.zeros(0, dtype=np.int64), np.zeros(0),
                     False)
        idx, wts = np.zeros(ptr[-1], dtype=np.int64), np.zeros(ptr[-1])
        build_clouds(sd, near, rsd, cs.rgroup, cs.node_cn, n_cn, sw, ptr, idx, wts, True)
        cs.cloud_ptr, cs.cloud_idx, cs.cloud_w = ptr, idx, wts
    else:
        cs.cloud_ptr, cs.cloud_idx = np.zeros(n_cn + 1, dtype=np.int64), np.zeros(0, dtype=np.int64)
        cs.cloud_w = np.zeros(0)


def extrapolate_contact(state, with_mass: bool) -> None:
    """Slot quantities the contact methods need: contact volumes, displacements or positions,
    volume gradients; rigid contact materials' volume and momentum in their slots."""
    cs, spec, box, sd = state.contact, state.contact.spec, state.box, state.sd
    R, f = state.rigid, state.fields
    nn, ns = state.grid.n_nodes, cs.n_slots
    wants = spec.wants(state.shape.axisymmetric)
    if with_mass:
        interface_sums = (cs.udisp, cs.ugrad) if spec.has_interface else ()  # read only by interfaces
        for arr in (cs.vol, cs.rvol, cs.disp, cs.pos, cs.grad, *interface_sums):
            arr[:ns] = 0.0
        scatter_slot_extras(Scatter(cs.slot_order, cs.slot_ptr, cs.fidx, sd.S), sd.G,
                            contact_measure(state.particles, state), state.grid.view, nn, cs.slot_node, wants, cs.sums())
    if R.n:
        scatter_rigid_slots(cs.rfidx, state.rigid_sd, contact_measure(R, state), nn, with_mass, wants, f.mass, f.mom,
                            cs.sums())


def contact_measure(bodies, state):
    """The particle view whose volumes the contact methods weigh by: the volumes, or in an
    axisymmetric scene the r-z areas V_p / r_p (the LR paper's A_p, Eq. 11), so that normals and
    contact volumes do not lean toward larger radii."""
    view = bodies.view()
    if not state.shape.axisymmetric:
        return view
    return view._replace(vol=bodies.vol / bodies.x[:, 0])


def screen_volume(spec, grid, thickness: float) -> float:
    """Edge screening threshold: the fraction of a cell's volume (2D: times the thickness, as
    particle volumes are)."""
    frac = spec.edge_screening
    if frac <= 0.0:
        return 0.0
    cell = float(np.prod(grid.h[: grid.dim])) * (thickness if grid.dim == 2 else 1.0)
    return frac * cell


def mirror_planes(grid, axisymmetric: bool) -> np.ndarray:
    """(2, 3): each axis's lower and upper mirror plane, on and beyond which the contact normal
    has no component across it (-inf / +inf: none). A roller face is one: a symmetry plane, or a
    frictionless wall, which mirrors the scene the same way; so is the axisymmetric axis r = 0.
    A node there sees a one-sided point cloud (or gradient), whose normal tilts across the
    plane, and the face's condition then removes the part of the exchange along the tilt."""
    mirror = np.array([[-np.inf] * 3, [np.inf] * 3])
    for f in range(2 * grid.dim):
        if grid.face_type[f] == ROLLER:
            a, side = divmod(f, 2)
            mirror[side, a] = grid.origin[a] + grid.wall_index[f] * grid.h[a]
    if axisymmetric:
        mirror[0, 0] = max(mirror[0, 0], 0.0)
    return mirror


class ContactTasks:
    """The contact tasks of one scene, with the scene's settings bound."""

    def __init__(self, spec, grid, spline: bool, thickness: float, pass_1_moves_particles: bool = True,
                 axisymmetric: bool = False, history=None):
        """pass_1_moves_particles: the particle update takes the particles' new velocity from
        the grid velocity, so pass 1's change of the extrapolated momenta reaches the particles
        and counts in the contact force between materials (FLIP adds only dt a: it does not).
        axisymmetric: contact volumes are r-z areas and contact areas per radian (docs/axisymmetric.md).
        history: interfaces whose history the particles carry (cohesive laws,
        contact/cohesive_history.py): its after_geometry(state, grow) runs after each geometry."""
        self.spec = spec
        self.pass_1_counts = pass_1_moves_particles
        h_min = float(grid.h.min())
        self.method = spec.method(h_min, spline, screen_volume(spec, grid, thickness), mirror_planes(grid, axisymmetric),
                                  axisymmetric)
        self.laws = spec.laws()
        self.touch = self.method.touch
        self.sep_velocity = spec.separation == SEP_VELOCITY
        self.recheck = spec.recheck
        self.advance = advance_rule(spec, int(self.method.separation) == SEP_LR)
        self.pass_3_mode = pass_3_mode(spec)
        # pass 1 holds the pairs pass 2 held in the last step (`persist`); under FLIP that change is
        # a force (its particles add only dt a), elsewhere the particles take it with v+
        self.hold_code = hold_rule(spec, self.pass_1_counts)
        self.holds, self.hold_force = self.hold_code != HOLD_NONE, self.hold_code == HOLD_FORCE
        self.plan = plan_geometry(int(self.method.normal), int(self.method.separation), bool(spec.has_interface))
        self.history = history
        self.pass_2_kernel = contact_pass_2(bool(spec.has_interface), spec.plugin_laws)

    def geometry(self, state, grow: bool = True) -> None:
        """Plan the contact nodes: normals, separations, areas, cohesive damage (grow: it may
        grow; pass 3's geometry only reads it), and the consistent bond."""
        cs, spec, g, f = state.contact, self.spec, state.grid, state.fields
        self.plan(cs.nodes(g.n_nodes), g.view, f.mass, cs.sums(), cs.clouds(state.particles, state.rigid), self.laws,
                  self.method, cs.warm_phi, state.dt_rule, state.nchunk, cs.targets())
        if self.history is not None:
            self.history.after_geometry(state, grow)
        cs.n_con = 0
        if spec.consistent_bond and spec.has_interface:
            held = RigidHold(f.rigid_vol, state.materials.constrain, state.rigid.v_end)
            cs.n_con = bond_points(cs.nodes(g.n_nodes), cs.node_cn, g.view, held, cs.targets(), state.dim, cs.bonds())

    def pass_1(self, state) -> None:
        """The laws on the extrapolated momenta (part of the extrapolation)."""
        cs, f, nn = state.contact, state.fields, state.grid.n_nodes
        exchange = law_kernels(self.spec.plugin_laws).exchange_pass
        held_step = state.step - 1 if self.holds else NO_HOLD
        exchange(PASS_1, cs.nodes(nn), f.mass, f.mom, cs.targets(), cs.decisions(), self.sep_velocity, self.touch,
                 held_step, state.nchunk, cs.dp1)
        if cs.n_con:
            ns = cs.n_slots
            before = f.mom[nn:nn + ns].copy()
            point_bond(cs.bonds(), nn, f.mass, f.mom, True, _NO_ACC, 0.0, cs.normal, state.dim)
            cs.dp1[:ns] += f.mom[nn:nn + ns] - before  # part of pass 1's change (uncorrected XPIC undoes it)
        if self.pass_1_counts:
            pair_changes(cs.nodes(nn), f.mass, cs.dp1, NO_BEFORE, False, cs.pair_step)

    def pass_2(self, state) -> None:
        """The laws on the updated momenta: contact forces (and interface forces, energy)."""
        cs, g, f = state.contact, state.grid, state.fields
        nc = state.nchunk
        sums = Pass2Sums(np.zeros((nc, max(state.n_rigid_materials, 1), state.dim)), np.zeros(nc), np.zeros(nc))
        held = RigidHold(f.rigid_vol, state.materials.constrain, state.rigid.v_end)
        nn, ns = g.n_nodes, cs.n_slots
        before = f.vnew[nn:nn + ns].copy()
        settings = Pass2Settings(self.sep_velocity, self.advance, self.spec.interface_integration, self.touch,
                                 state.dt, state.step, self.hold_code)
        self.pass_2_kernel(cs.nodes(g.n_nodes), g.view, held, self.spec.rigid_of_group, f.mass, f.vnew, f.acc,
                           cs.targets(), cs.decisions(), settings, nc, sums)
        point_bond(cs.bonds(), g.n_nodes, f.mass, f.vnew, False, f.acc, state.dt, cs.normal, state.dim)
        pair_changes(cs.nodes(nn), f.mass, f.vnew[nn:nn + ns], before, True, cs.pair_step)
        if self.hold_force:
            pair_changes(cs.nodes(nn), f.mass, cs.hold, NO_BEFORE, False, cs.pair_step)
        if self.spec.traction:  # output.contact_traction: the force each slot got (what pair_changes sums)
            counted = self.pass_1_counts and self.spec.passes == 2
            record_slot_forces(cs.nodes(nn), f.mass, f.vnew[nn:nn + ns], before, cs.hold if self.hold_force else cs.dp1,
                               counted or self.hold_force, state.dt, cs.slot_force)
            cs.traction_targets = (cs.role[:ns].copy(), cs.partner[:ns].copy(), cs.normal[:ns].copy(),
                                   cs.area[:ns].copy())
        settle_pairs(cs.pair_step, cs.pair_force, cs.pair_impulse, state.dt)
        state.interface_energy = float(sums.energy.sum())  # instantaneous total at the end of the step
        if state.n_rigid_materials:
            state.reaction[6:] += sums.reaction.sum(axis=0)[: state.n_rigid_materials]
            state.work_in += float(sums.work.sum())

    def pass_3(self, state) -> None:
        """Pass 2's decisions enforced on the re-extrapolated momenta (keep), or the laws where
        the moved particles' surfaces touch and approach (recheck: the geometry recomputed), or
        pass 2's contacts kept unless they separate and new ones where the surfaces touch and
        approach (persist: the geometry recomputed)."""
        cs, f, nn = state.contact, state.fields, state.grid.n_nodes
        if self.recheck:
            self.geometry(state, grow=False)
        exchange = law_kernels(self.spec.plugin_laws).exchange_pass
        exchange(self.pass_3_mode, cs.nodes(nn), f.mass, f.mom, cs.targets(), cs.decisions(), self.sep_velocity,
                 self.touch, NO_HOLD, state.nchunk, cs.dp1)
        point_bond(cs.bonds(), nn, f.mass, f.mom, True, _NO_ACC, 0.0, cs.normal, state.dim)
