"""Multimaterial contact: material fields where groups meet, and the three contact passes.

Tasks (in step order): `material_fields` after the shape functions, `contact_geometry` and
`contact_pass_1` after extrapolation, `contact_pass_2` after the grid update, `contact_pass_3` after the
re-extrapolation of USL+/USAVG+. Scenes with one velocity field have no ContactState and none
of these tasks.
"""

from __future__ import annotations

import numpy as np

from .fields import (assign_fields, build_clouds, build_slots, count_slots, scatter_group_masks, scatter_rigid_masks,
                     scatter_rigid_slots, scatter_slot_extras)
from .bond import bond_points as _bond_points
from .bond import point_bond as _point_bond
from .passes import contact_geometry as _geometry
from .passes import contact_pass_1 as _pass_1
from .passes import contact_pass_2 as _pass_2
from .passes import contact_pass_3 as _pass_3
from .spec import build_contact_spec
from .workspace import ContactWorkspace

_NO_ACC = np.zeros((1, 3))  # point_bond on momenta: no force to record

__all__ = ["ContactWorkspace", "build_contact_spec", "material_fields", "contact_geometry", "contact_pass_1", "contact_pass_2",
           "contact_pass_3", "extrapolate_contact"]


def material_fields(state) -> None:
    """Find the contact nodes, give each group there its own slot, point particle entries at
    their fields, extend the step's active fields, build point clouds (notes §0, §2.1)."""
    cs, box, sd, rsd = state.contact, state.box, state.sd, state.rigid_sd
    nn = state.grid.n_nodes
    box_nodes = box.fields[: box.n_box].copy()
    cs.mask[box_nodes] = 0
    scatter_group_masks(box.order, box.ptr, sd.nodes, sd.S, cs.group, cs.mask)
    if state.rigid.n:
        scatter_rigid_masks(rsd.nodes, rsd.S, cs.rgroup, cs.mask)
    n_cn, n_slots = count_slots(box_nodes, cs.mask)
    cs.ensure(n_cn, n_slots, state.dim)
    state.fields.ensure(nn + cs.cap)
    build_slots(box_nodes, cs.mask, cs.node_cn, cs.cn_nodes, cs.cn_ptr, cs.slot_group, cs.slot_node)
    cs.n_cn, cs.n_slots = n_cn, n_slots
    assign_fields(sd.nodes, sd.S, cs.group, cs.node_cn, cs.cn_ptr, cs.slot_group, nn, True, cs.fidx)
    if state.rigid.n:
        assign_fields(rsd.nodes, rsd.S, cs.rgroup, cs.node_cn, cs.cn_ptr, cs.slot_group, nn, False, cs.rfidx)
    slots = np.arange(n_slots)
    box.fields = np.concatenate([box_nodes, nn + slots])
    box.fnodes = np.concatenate([box_nodes, cs.slot_node[:n_slots]])
    box.skip = np.concatenate([np.zeros(box.n_box, dtype=np.bool_),
                               cs.slot_group[:n_slots] >= cs.spec.n_def_groups])
    if cs.spec.needs_cloud:
        ptr = np.zeros(n_cn + 1, dtype=np.int64)
        sw = cs.spec.shape_weights
        none_i, none_f = np.zeros(0, dtype=np.int64), np.zeros(0)
        build_clouds(sd.nodes, sd.S, rsd.nodes, rsd.S, cs.rgroup, cs.node_cn, n_cn, state.particles.n, sw, ptr,
                     none_i, none_f, False)
        idx, wts = np.zeros(ptr[-1], dtype=np.int64), np.zeros(ptr[-1])
        build_clouds(sd.nodes, sd.S, rsd.nodes, rsd.S, cs.rgroup, cs.node_cn, n_cn, state.particles.n, sw, ptr,
                     idx, wts, True)
        cs.cloud_ptr, cs.cloud_idx, cs.cloud_w = ptr, idx, wts
    else:
        cs.cloud_ptr, cs.cloud_idx = np.zeros(n_cn + 1, dtype=np.int64), np.zeros(0, dtype=np.int64)
        cs.cloud_w = np.zeros(0)


def extrapolate_contact(state, with_mass: bool) -> None:
    """Slot quantities the contact methods need: contact volumes, displacements or positions,
    volume gradients; rigid contact materials' volume and momentum in their slots."""
    cs, spec, box, sd = state.contact, state.contact.spec, state.box, state.sd
    P, R, f = state.particles, state.rigid, state.fields
    nn, ns = state.grid.n_nodes, cs.n_slots
    if with_mass:
        interface_sums = (cs.udisp, cs.ugrad) if spec.has_interface else ()  # read only by interfaces
        for arr in (cs.vol, cs.disp, cs.pos, cs.grad, *interface_sums):
            arr[:ns] = 0.0
        g = state.grid
        scatter_slot_extras(box.order, box.ptr, cs.fidx, sd.S, sd.G, P.mass, P.vol, P.x, P.x0, P.F, nn, cs.slot_node,
                            g.shape, g.origin, g.h, spec.needs_displacement, spec.needs_position,
                            spec.needs_gradients, spec.has_interface, spec.opening_at_interface, cs.vol, cs.disp,
                            cs.pos, cs.grad, cs.udisp, cs.ugrad)
    if R.n:
        scatter_rigid_slots(cs.rfidx, state.rigid_sd.S, state.rigid_sd.G, R.vol, R.v, R.x, R.x0, nn, with_mass,
                            spec.needs_displacement, spec.needs_position, spec.needs_gradients, spec.has_interface,
                            f.mass, f.mom, cs.vol, cs.disp, cs.pos, cs.grad, cs.udisp)


def contact_geometry(screen: float):
    """Task: plan the contact nodes, their normals, separations and areas. `screen`: the
    edge-screening volume (0: off; see screen_volume)."""

    def run(state) -> None:
        _contact_geometry(state, screen)

    return run


def _contact_geometry(state, screen: float) -> None:
    cs, spec, g, f = state.contact, state.contact.spec, state.grid, state.fields
    spline = state.shape.grid_kind >= 2  # B-spline grid functions weight the area with the spline
    _geometry(cs.n_cn, cs.cn_nodes, cs.cn_ptr, cs.slot_group, spec.n_def_groups, g.n_nodes, g.shape, g.origin, g.h,
              float(g.h.min()), f.mass, cs.vol, cs.disp, cs.pos, cs.grad, cs.udisp, cs.ugrad, cs.cloud_ptr,
              cs.cloud_idx, cs.cloud_w, spec.shape_weights, cs.group,
              cs.rgroup, state.particles.n, state.particles.x, state.rigid.x, state.particles.F, state.particles.semi,
              spec.law, spec.mu, spec.mu_static, spec.normal, spec.separation, spec.normal_vector, spec.radial,
              spec.normal_center, spec.rigid_bias, spec.cutoff, spec.fit_exponent, spline, spec.warm_start, cs.warm_phi,
              spec.stiffness, state.dt_rule, spec.interface_integration, spec.area_correction, spec.use_h_perp,
              screen,
              state.nchunk, cs.role, cs.partner, cs.normal, cs.delta, cs.area, cs.open, cs.bonded, cs.law, cs.mu, cs.mus,
              cs.stiff, cs.level)
    cs.n_con = 0
    if spec.consistent_bond and spec.has_interface:
        cs.n_con = _bond_points(cs.n_cn, cs.cn_nodes, cs.cn_ptr, cs.node_cn, g.shape, g.origin, g.h, cs.slot_group,
                                spec.n_def_groups, cs.role, cs.partner, cs.law, cs.level, cs.normal, g.face_type,
                                g.wall_index, f.rigid_vol, state.materials.constrain, state.rigid.v_end, state.dim,
                                cs.bonded, cs.con_ptr, cs.ent_a, cs.ent_b, cs.ent_w)


def screen_volume(spec, grid, thickness: float) -> float:
    """Edge screening threshold: the fraction of a cell's volume (2D: times the thickness, as
    particle volumes are)."""
    frac = spec.edge_screening
    if frac <= 0.0:
        return 0.0
    cell = float(np.prod(grid.h[: grid.dim])) * (thickness if grid.dim == 2 else 1.0)
    return frac * cell


def contact_pass_1(state) -> None:
    cs, spec, f = state.contact, state.contact.spec, state.fields
    _pass_1(cs.n_cn, cs.cn_ptr, cs.slot_group, spec.n_def_groups, state.grid.n_nodes, f.mass, f.mom, spec.separation,
            cs.role, cs.partner, cs.normal, cs.delta, cs.law, cs.mu, cs.mus, cs.bonded, touch_length(state), state.nchunk,
            cs.dp1)
    if cs.n_con:
        nn, ns = state.grid.n_nodes, cs.n_slots
        before = f.mom[nn:nn + ns].copy()
        _point_bond(cs.n_con, cs.con_ptr, cs.ent_a, cs.ent_b, cs.ent_w, nn, f.mass, f.mom, True, _NO_ACC, 0.0,
                    cs.normal, state.dim)
        cs.dp1[:ns] += f.mom[nn:nn + ns] - before  # part of pass 1's change (uncorrected XPIC undoes it)


def touch_length(state) -> float:
    return state.contact.spec.touch * float(state.grid.h.min())


def contact_pass_2(state) -> None:
    cs, spec, g, f = state.contact, state.contact.spec, state.grid, state.fields
    reaction = np.zeros((state.nchunk, max(state.n_rigid_materials, 1), state.dim))
    work = np.zeros(state.nchunk)
    energy = np.zeros(state.nchunk)
    _pass_2(cs.n_cn, cs.cn_nodes, cs.cn_ptr, cs.slot_group, spec.n_def_groups, spec.rigid_of_group, g.n_nodes,
            g.shape, state.dt, f.mass, f.vnew, f.acc, g.face_type, g.wall_index, f.rigid_vol, state.materials.constrain,
            state.rigid.v_end, spec.separation, cs.role, cs.partner, cs.normal, cs.delta, cs.area, cs.open, cs.law,
            cs.mu, cs.mus, cs.bonded, cs.stiff, spec.interface_integration, touch_length(state), state.nchunk, reaction,
            work, energy, cs.stick2, cs.applied2, cs.delta2, cs.contact2)
    _point_bond(cs.n_con, cs.con_ptr, cs.ent_a, cs.ent_b, cs.ent_w, g.n_nodes, f.mass, f.vnew, False, f.acc, state.dt,
                cs.normal, state.dim)
    state.interface_energy = float(energy.sum())  # instantaneous total at the end of the step
    if state.n_rigid_materials:
        state.reaction[6:] += reaction.sum(axis=0)[: state.n_rigid_materials]
        state.work_in += float(work.sum())


def contact_pass_3(state) -> None:
    cs, spec, f = state.contact, state.contact.spec, state.fields
    _pass_3(cs.n_cn, cs.cn_ptr, cs.slot_group, spec.n_def_groups, state.grid.n_nodes, f.mass, f.mom, cs.role,
            cs.partner, cs.normal, cs.contact2, cs.law, cs.mu, cs.mus, cs.bonded, state.nchunk)
    _point_bond(cs.n_con, cs.con_ptr, cs.ent_a, cs.ent_b, cs.ent_w, state.grid.n_nodes, f.mass, f.mom, True, _NO_ACC,
                0.0, cs.normal, state.dim)

