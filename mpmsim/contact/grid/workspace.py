"""The contact workspace: per-step contact nodes, their material slots and what the passes
compute at them (plain arrays, grown by doubling as a run needs more)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from typing import NamedTuple

import numpy as np

from .spec import ContactSpec

NEVER = -2  # contact_step of a node where pass 2 has not made contact (steps count from 0)


class ContactNodes(NamedTuple):
    """This step's contact nodes: node c has slots cn_ptr[c]:cn_ptr[c+1], one per group there
    (slot s is field n_nodes + s)."""

    n_cn: int
    cn_nodes: np.ndarray  # (n_cn,) grid node
    cn_ptr: np.ndarray  # (n_cn + 1,)
    slot_group: np.ndarray  # (n_slots,) group of each slot
    n_def: int  # deformable groups are 0..n_def-1, rigid contact groups follow
    nn: int  # grid nodes (slot s is field nn + s)


class SlotMap(NamedTuple):
    """Which field a group has at a node (boundary.mirror_field)."""

    node_cn: np.ndarray  # (n_nodes,) contact node or -1
    cn_ptr: np.ndarray
    slot_group: np.ndarray
    mask: np.ndarray  # (n_nodes,) uint64 groups present
    n_def: int


class SlotSums(NamedTuple):
    """Extrapolated per-slot quantities the contact methods need (fields.scatter_slot_extras)."""

    vol: np.ndarray  # sum S V
    disp: np.ndarray  # sum S m u (displacement separation)
    pos: np.ndarray  # sum S m x (cutoff and fit separations)
    grad: np.ndarray  # sum G V (gradient normals)
    udisp: np.ndarray  # interfaces: sum S m u carried to the node
    ugrad: np.ndarray  # interfaces: sum S m H
    rvol: np.ndarray  # axisymmetric: sum S V r (the slot's mean radius is rvol / vol)


class Clouds(NamedTuple):
    """Particles touching each contact node (CSR) for the point-cloud methods; rigid contact
    particles are numbered after the n_def deformable ones."""

    ptr: np.ndarray
    idx: np.ndarray
    w: np.ndarray  # regression weight of each entry
    group: np.ndarray  # (n,) group of each deformable particle
    rgroup: np.ndarray  # (n_rigid,) group of each rigid particle
    n_def: int  # deformable particles
    x: np.ndarray  # deformable positions
    rx: np.ndarray  # rigid positions
    F: np.ndarray  # deformable deformation gradients
    semi: np.ndarray  # undeformed particle semi-lengths
    balance: bool  # scale each class's weights to half the points (shape-function weights)


class Targets(NamedTuple):
    """What the geometry plans per slot: role (0: not a target), partner (-1: the lumped
    rest), normal a -> b, separation, area, tangential opening and bonded directions
    (interfaces), law and friction, interface stiffness, and the node's signed distance to
    the interface along n."""

    role: np.ndarray
    partner: np.ndarray
    normal: np.ndarray
    delta: np.ndarray
    area: np.ndarray
    open: np.ndarray
    bonded: np.ndarray
    law: np.ndarray
    mu: np.ndarray
    mus: np.ndarray
    stiff: np.ndarray
    level: np.ndarray


class Decisions(NamedTuple):
    """Pass 2's outcome per target, for the XPIC increments: stick and applied impulses,
    end-of-step separation, contact flag; and the running totals of the increments. Per grid
    node: the last step pass 2 made contact there (`pass_3: persist` advances the separation
    only where contact persists, and pass 1 holds the pairs there: passes.exchange_node). Per
    slot: pass 1's change where it held a separating pair, a force for FLIP (`hold`)."""

    stick2: np.ndarray
    applied2: np.ndarray
    delta2: np.ndarray
    contact2: np.ndarray
    stick_total: np.ndarray
    applied_total: np.ndarray
    contact_step: np.ndarray
    hold: np.ndarray


class Bonds(NamedTuple):
    """Consistent-bond constraints (contact.bond): constraint q has entries
    con_ptr[q]:con_ptr[q+1], each a pair of slots (a, b) with a weight."""

    n_con: int
    con_ptr: np.ndarray
    ent_a: np.ndarray
    ent_b: np.ndarray
    ent_w: np.ndarray


@dataclass
class ContactWorkspace:
    spec: ContactSpec
    group: np.ndarray  # (n,) group of each deformable particle
    rgroup: np.ndarray  # (n_rigid_particles,) group of each rigid particle (-1: velocity-condition rigid)
    mask: np.ndarray  # (n_nodes,) uint64 groups touching each node
    node_cn: np.ndarray  # (n_nodes,) contact-node index or -1
    fidx: np.ndarray  # (n, K) field of each deformable particle-node entry
    rfidx: np.ndarray  # (n_rigid_particles, K) slot of each rigid entry, -1 off contact nodes
    warm_phi: np.ndarray  # (n_nodes, G, 4) last logistic fit per node and group (warm start only)
    n_cn: int = 0
    n_slots: int = 0
    cap: int = 0
    cloud_ptr: np.ndarray = None
    cloud_idx: np.ndarray = None
    cloud_w: np.ndarray = None
    # the deformable particles with a slot entry, in the step's slab order (slot_ptr: the slabs'
    # starts), for the slot sums
    slot_order: np.ndarray = None
    slot_ptr: np.ndarray = None
    # momentum contact gives each deformable group from each other one (G x G x dim, G the
    # deformable groups; [a, b]: what b gives a): this step's so far, the last step's as a
    # force, and the impulse since t = 0 (history columns contact_f*, contact_impulse_*)
    pair_step: np.ndarray = None
    pair_force: np.ndarray = None
    pair_impulse: np.ndarray = None
    slot_force: np.ndarray = None  # (cap, dim) the step's contact force on each slot (spec.traction only)
    contact_step: np.ndarray = None  # (n_nodes,) the last step pass 2 made contact at each grid node
    # the targets pass 2 acted on (role, partner, normal, area of its slots; spec.traction only): a
    # pass 3 that recomputes the geometry (recheck, persist) must not change what the output reads
    traction_targets: tuple = None

    def ensure(self, n_cn: int, n_slots: int, dim: int) -> None:
        """Grow the per-contact-node and per-slot arrays (doubling) to hold this step."""
        if n_slots <= self.cap and n_cn < self.cn_nodes.size:
            return
        cap = max(64, 2 * n_slots)
        z = np.zeros
        self.cap = cap
        self.cn_nodes = z(cap, dtype=np.int64)
        self.cn_ptr = z(cap + 1, dtype=np.int64)
        self.slot_group = z(cap, dtype=np.int64)
        self.slot_node = z(cap, dtype=np.int64)
        self.vol, self.rvol, self.delta, self.area = z(cap), z(cap), z(cap), z(cap)
        self.disp, self.pos, self.grad, self.dp1, self.hold, self.normal = (z((cap, dim)) for _ in range(6))
        self.udisp, self.ugrad = z((cap, dim)), z((cap, dim, dim))  # interfaces: displacement at the node, gradient
        self.stick2, self.applied2, self.stick_total, self.applied_total = (z((cap, dim)) for _ in range(4))
        self.delta2 = z(cap)
        self.contact2 = z(cap, dtype=np.int64)
        self.role = z(cap, dtype=np.int64)
        self.partner = z(cap, dtype=np.int64)
        self.law = z(cap, dtype=np.int64)
        self.mu, self.mus = z(cap), z(cap)
        self.open, self.stiff = z((cap, dim)), z((cap, 3))  # interfaces: tangential opening, [Dn, Dnc, Dt]
        self.bonded = z(cap, dtype=np.int64)  # interfaces: bit 1 normal, bit 2 tangential act as perfect,
        # bit 4 normal held by the consistent-bond constraints (contact.bond)
        self.level = z(cap)  # signed distance of the node to the interface along n (a's side < 0)
        # consistent-bond constraints: entries con_ptr[q]:con_ptr[q+1], slots of a and b and weights
        self.con_ptr = z(cap + 1, dtype=np.int64)
        self.ent_a, self.ent_b, self.ent_w = z(8 * cap, dtype=np.int64), z(8 * cap, dtype=np.int64), z(8 * cap)
        self.n_con = 0
        if self.spec.traction:
            self.slot_force = z((cap, dim))

    @classmethod
    def create(cls, spec: ContactSpec, mat: np.ndarray, rigid_mat: np.ndarray, n_nodes: int, K: int,
               dim: int) -> "ContactWorkspace":
        """For particles of deformable materials `mat` and rigid materials `rigid_mat`, K
        shape-function entries each, on a grid of n_nodes nodes."""
        n, nr = len(mat), len(rigid_mat)
        cs = cls(spec, spec.mat_group[mat], spec.rigid_group[rigid_mat] if nr else np.zeros(0, dtype=np.int64),
                 np.zeros(n_nodes, dtype=np.uint64), np.full(n_nodes, -1, dtype=np.int64),
                 np.zeros((n, K), dtype=np.int64), np.full((nr, K), -1, dtype=np.int64),
                 np.zeros((n_nodes, spec.n_groups, 4) if spec.warm_start else (1, 1, 4)))
        cs.cn_nodes = np.zeros(0, dtype=np.int64)
        # empty clouds until material_fields builds them: the bundles have their types from the
        # start (a helper compiling a first step's kernels from their types reads them before)
        cs.cloud_ptr, cs.cloud_idx, cs.cloud_w = np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0)
        cs.slot_order, cs.slot_ptr = np.zeros(0, dtype=np.int64), np.zeros(2, dtype=np.int64)
        G = spec.n_def_groups
        cs.pair_step, cs.pair_force, cs.pair_impulse = (np.zeros((G, G, dim)) for _ in range(3))
        cs.contact_step = np.full(n_nodes, NEVER, dtype=np.int64)
        cs.ensure(1, 1, dim)
        return cs

    def nodes(self, nn: int) -> ContactNodes:
        return ContactNodes(self.n_cn, self.cn_nodes, self.cn_ptr, self.slot_group, self.spec.n_def_groups, nn)

    def slot_map(self) -> SlotMap:
        return SlotMap(self.node_cn, self.cn_ptr, self.slot_group, self.mask, self.spec.n_def_groups)

    def sums(self) -> SlotSums:
        return SlotSums(self.vol, self.disp, self.pos, self.grad, self.udisp, self.ugrad, self.rvol)

    def clouds(self, P, R) -> Clouds:
        return Clouds(self.cloud_ptr, self.cloud_idx, self.cloud_w, self.group, self.rgroup, P.n, P.x, R.x, P.F,
                      P.semi, self.spec.shape_weights)

    def targets(self) -> Targets:
        return Targets(self.role, self.partner, self.normal, self.delta, self.area, self.open, self.bonded, self.law,
                       self.mu, self.mus, self.stiff, self.level)

    def decisions(self) -> Decisions:
        return Decisions(self.stick2, self.applied2, self.delta2, self.contact2, self.stick_total, self.applied_total,
                         self.contact_step, self.hold)

    def bonds(self) -> Bonds:
        return Bonds(self.n_con, self.con_ptr, self.ent_a, self.ent_b, self.ent_w)


class NoContact(NamedTuple):
    nodes: ContactNodes
    geo: Targets
    dec: Decisions
    bonds: Bonds
    slots: SlotMap


@cache
def no_contact(dim: int) -> NoContact:
    """Bundles of the same types as a workspace's, for kernels that loop over zero contact
    nodes (one compiled kernel serves scenes with and without contact). Made once per
    dimension: nothing reads or writes them past their zero nodes."""
    i1, f1, f2, f3 = np.zeros(1, dtype=np.int64), np.zeros(1), np.zeros((1, dim)), np.zeros((1, 3))
    nodes = ContactNodes(0, i1, i1, i1, 0, 0)
    geo = Targets(i1, i1, f2, f1, f1, f2, i1, i1, f1, f1, f3, f1)
    dec = Decisions(f2, f2, f1, i1, f2, f2, i1, f2)
    return NoContact(nodes, geo, dec, Bonds(0, i1, i1, i1, f1), SlotMap(np.full(1, -1, dtype=np.int64), i1, i1,
                                                                         np.zeros(1, dtype=np.uint64), 0))
