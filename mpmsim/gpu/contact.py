"""Multimaterial grid contact on the GPU: material fields, LR geometry and the three passes
(the CPU tasks of mpmsim/contact/grid), with the contact workspace on the device.

The per-item work is the CPU path's own compiled code, called from these kernels (as in
kernels.py): a particle's fields (fields.assign_particle), a chunk of nodes numbered into
contact nodes and slots (fields.count_slots, build_slots), a contact node's plan (the
specialised plan.plan_contact_node: roles, logistic-regression normal, d_LR separation,
area), its exchange in passes 1 and 3 (passes.exchange_node) and pass 2 (passes.pass_2_node),
the pair sums (passes.pair_changes, settle_pairs). What differs is how the work is spread:

- group masks: an atomic OR per particle entry into 64-bit node masks;
- numbering: the nodes in chunks of CHUNK, each chunk counted by a thread, the chunk offsets
  summed by one thread, then each chunk numbered from its offset: contact nodes and slots in
  node order, as the CPU numbers them;
- point clouds: entries counted per contact node (atomic adds), offsets summed, entries
  placed by an atomic cursor, then each cloud sorted by particle index (a thread per contact
  node), so a cloud lists its particles in the CPU's order and the regression sums in the
  same order;
- regression scratch: a contact node's gathered points live in global arrays beside its
  cloud entries (the CPU allocates them per chunk); small systems in thread-local arrays.

What the GPU step does not do with contact yet is refused by mpmsim.gpu.unsupported: rigid
contact materials, interface laws and the consistent bond, plugin laws, warm-started
regressions, the traction output, XPIC/FMPM (the update schemes).
"""

from __future__ import annotations

from functools import cache

import numpy as np
from numba import cuda, float64, uint64

from ..contact.grid import fields as cf
from ..contact.grid.geometry import Regression
from ..contact.grid.passes import (HOLD_FORCE, HOLD_NONE, MAX_SLOTS, NO_HOLD, PASS_1, NodeScratch, Pass2Settings,
                                   advance_rule, hold_rule, pass_3_mode, exchange_node as _exchange_node,
                                   pair_changes as _pair_changes, pass_2_node_of, settle_pairs as _settle_pairs)
from ..contact.grid.plan import GeometryInputs, node_planner
from ..contact.grid.spec import SEP_LR, SEP_VELOCITY, PairLaws
from ..contact.grid.workspace import Clouds, ContactNodes, Decisions, SlotMap, SlotSums, Targets
from ..views import RigidHold
from . import kernels as K
from .kernels import blocks, device_function

CHUNK = 256  # nodes (or counts) per thread of the numbering and prefix sums
count_slots, build_slots = device_function(cf.count_slots), device_function(cf.build_slots)
assign_particle = device_function(cf.assign_particle)
exchange_node, pair_changes, settle_pairs = (device_function(f) for f in (_exchange_node, _pair_changes,
                                                                          _settle_pairs))
ONE = np.uint64(1)


# ---------------------------------------------------------------------- material fields
@cuda.jit
def group_masks(nodes, S, group, mask):
    """fields.scatter_group_masks: the bit of each particle's group at the nodes it weighs."""
    p = cuda.grid(1)
    if p >= S.shape[0]:
        return
    bit = uint64(ONE << uint64(group[p]))
    for k in range(S.shape[1]):
        if S[p, k] > 0.0:
            cuda.atomic.or_(mask, nodes[p, k], bit)


@cuda.jit
def count_chunks(all_nodes, mask, counts):
    """counts[t] = (contact nodes, slots) among nodes t CHUNK:(t + 1) CHUNK."""
    t = cuda.grid(1)
    lo = t * CHUNK
    if lo >= all_nodes.size:
        return
    counts[t, 0], counts[t, 1] = count_slots(all_nodes[lo:min(lo + CHUNK, all_nodes.size)], mask)


@cuda.jit
def exclusive_sums(counts, n, total):
    """counts[:n] (each column) become their exclusive prefix sums; the totals go to total
    (one thread: a sum over chunks, not over items)."""
    if cuda.grid(1) != 0:
        return
    for col in range(counts.shape[1]):
        s = 0
        for t in range(n):
            c = counts[t, col]
            counts[t, col] = s
            s += c
        total[col] = s


@cuda.jit
def number_chunks(all_nodes, mask, offsets, node_cn, cn_nodes, cn_ptr, slot_group, slot_node):
    """fields.build_slots for each chunk of nodes from its offsets (contact node, slot)."""
    t = cuda.grid(1)
    lo = t * CHUNK
    if lo >= all_nodes.size:
        return
    build_slots(all_nodes[lo:min(lo + CHUNK, all_nodes.size)], mask, offsets[t, 0], offsets[t, 1], node_cn, cn_nodes,
                cn_ptr, slot_group, slot_node)


@cuda.jit
def assign(nodes, group, node_cn, cn_ptr, slot_group, nn, fidx):
    p = cuda.grid(1)
    if p < fidx.shape[0]:
        assign_particle(p, nodes, group, node_cn, cn_ptr, slot_group, nn, True, fidx)


@cuda.jit
def cloud_entries(nodes, S, node_cn, shape_weights, fill, cursor, idx, w):
    """fields.build_clouds: without fill, count each contact node's entries (cursor: counts);
    with fill, place each entry at its node's cursor (the order fixed by cloud_sort)."""
    p = cuda.grid(1)
    if p >= S.shape[0]:
        return
    for k in range(S.shape[1]):
        if S[p, k] > 0.0:
            c = node_cn[nodes[p, k]]
            if c >= 0:
                q = cuda.atomic.add(cursor, c, 1)
                if fill:
                    idx[q] = p
                    w[q] = S[p, k] if shape_weights else 1.0


@cuda.jit
def chunk_totals(counts, n, sums):
    """sums[t] = the sum of counts[t CHUNK:(t + 1) CHUNK, 0]."""
    t = cuda.grid(1)
    lo = t * CHUNK
    if lo >= n:
        return
    s = 0
    for q in range(lo, min(lo + CHUNK, n)):
        s += counts[q, 0]
    sums[t, 0] = s


@cuda.jit
def chunk_prefix(counts, n, sums, ptr):
    """ptr[q + 1] = ptr[q] + counts[q] within each chunk, from its offset sums[t]."""
    t = cuda.grid(1)
    lo = t * CHUNK
    if lo >= n:
        return
    s = sums[t, 0]
    if t == 0:
        ptr[0] = 0
    for q in range(lo, min(lo + CHUNK, n)):
        s += counts[q, 0]
        ptr[q + 1] = s


@cuda.jit
def cloud_sort(ptr, n_cn, idx, w):
    """Each cloud's entries by particle index (insertion sort: clouds are tens of entries)."""
    c = cuda.grid(1)
    if c >= n_cn:
        return
    for q in range(ptr[c] + 1, ptr[c + 1]):
        key = idx[q]
        wk = w[q]
        r = q - 1
        while r >= ptr[c] and idx[r] > key:
            idx[r + 1] = idx[r]
            w[r + 1] = w[r]
            r -= 1
        idx[r + 1] = key
        w[r + 1] = wk


@cuda.jit
def slot_extras(fidx, S, G, pmass, pvol, x, x0, nn, wants, sums):
    """fields.scatter_slot_extras without interfaces: each slot's sum S V, and as wanted sum
    S m u, sum S m x, sum G V (atomic adds)."""
    p = cuda.grid(1)
    if p >= S.shape[0]:
        return
    dim = x.shape[1]
    for k in range(S.shape[1]):
        f = fidx[p, k]
        if f < nn:
            continue
        sl = f - nn
        w = S[p, k]
        cuda.atomic.add(sums.vol, sl, w * pvol[p])
        for d in range(dim):
            if wants.disp:
                cuda.atomic.add(sums.disp, (sl, d), w * pmass[p] * (x[p, d] - x0[p, d]))
            if wants.pos:
                cuda.atomic.add(sums.pos, (sl, d), w * pmass[p] * x[p, d])
            if wants.grad:
                cuda.atomic.add(sums.grad, (sl, d), G[p, k, d] * pvol[p])


# ---------------------------------------------------------------------- geometry and passes
@cache
def geometry_kernel(normal: int, separation: int):
    """plan.plan_contact_node of one normal method and separation, a thread per contact node."""
    plan = device_function(node_planner(normal, separation, False))

    @cuda.jit
    def kernel(inp, geo, pts, cw, clab, clabels):
        c = cuda.grid(1)
        if c >= inp.nodes.n_cn:
            return
        c0 = inp.clouds.ptr[c]
        c1 = inp.clouds.ptr[c + 1]
        R = Regression(pts[c0:c1], cw[c0:c1], clab[c0:c1], clabels[c0:c1], cuda.local.array((4, 4), float64),
                       cuda.local.array(4, float64), cuda.local.array(4, float64), cuda.local.array(4, float64),
                       cuda.local.array(4, float64), cuda.local.array(4, float64), cuda.local.array((3, 3), float64),
                       cuda.local.array((3, 3), float64), cuda.local.array(3, float64),
                       cuda.local.array((3, 3), float64))
        plan(c, inp, geo, R, cuda.local.array((4, 3), float64), cuda.local.array(3, float64))

    return kernel


@cache
def exchange_kernel(groups: int):
    """passes.exchange_pass (passes 1 and 3), a thread per contact node. (Each kernel makes its
    own NodeScratch: a thread's local arrays must be allocated in the kernel's frame, not in a
    device function that returns them.)"""

    @cuda.jit
    def kernel(mode, nodes, mass, mom, geo, dec, sep_velocity, touch, held_step, dp1):
        c = cuda.grid(1)
        if c >= nodes.n_cn:
            return
        w = NodeScratch(cuda.local.array((groups, 3), float64), cuda.local.array((groups, 3), float64),
                        cuda.local.array(groups, float64), cuda.local.array(3, float64),
                        cuda.local.array(3, float64), cuda.local.array(3, float64), cuda.local.array(3, float64),
                        cuda.local.array((groups, 3), float64))
        exchange_node(c, mode, nodes, mass, mom, geo, dec, sep_velocity, touch, held_step, w, dp1)

    return kernel


@cache
def pass_2_kernel(groups: int):
    """passes.pass_2_kernel, a thread per contact node (no rigid contact materials and no
    interfaces on the GPU: their reaction, work and energy stay zero)."""
    node_pass = device_function(pass_2_node_of(False, ()))

    @cuda.jit
    def kernel(nodes, grid, held, rigid_of_group, mass, vnew, acc, geo, dec, settings, reaction):
        c = cuda.grid(1)
        if c >= nodes.n_cn:
            return
        w = NodeScratch(cuda.local.array((groups, 3), float64), cuda.local.array((groups, 3), float64),
                        cuda.local.array(groups, float64), cuda.local.array(3, float64),
                        cuda.local.array(3, float64), cuda.local.array(3, float64), cuda.local.array(3, float64),
                        cuda.local.array((groups, 3), float64))
        node_pass(c, nodes, grid, held, rigid_of_group, mass, vnew, acc, geo, dec, settings, w, reaction, 0)

    return kernel


@cuda.jit
def pairs(nodes, mass, after, before, weighted, out):
    """passes.pair_changes (one thread: a short loop over the contact nodes into G x G sums)."""
    if cuda.grid(1) == 0:
        pair_changes(nodes, mass, after, before, weighted, out)


@cuda.jit
def settle(step, force, impulse, dt):
    if cuda.grid(1) == 0:
        settle_pairs(step, force, impulse, dt)


@cuda.jit
def copy_rows(src, dst, n):
    """dst[:n] = src[:n] (2D arrays of the same width)."""
    q = cuda.grid(1)
    if q < n:
        for d in range(src.shape[1]):
            dst[q, d] = src[q, d]


class DeviceContact:
    """The contact workspace on the device and the contact tasks of DeviceStep."""

    def __init__(self, step, scene):
        spec = scene.contact.grid
        self.step = step
        self.spec = spec
        self.groups = max(spec.n_groups, 1)
        if self.groups > MAX_SLOTS:  # pragma: no cover - the deck refuses more groups
            raise ValueError("more than 64 contact groups")
        h_min = float(scene.grid.h.min())
        from ..contact.grid import mirror_planes, screen_volume
        from ..shapes import shape_function

        spline = shape_function(scene.settings.shape_function).grid_kind >= 2
        self.method = spec.method(h_min, spline, screen_volume(spec, scene.grid, scene.thickness),
                                  mirror_planes(scene.grid, False))
        self.touch = float(self.method.touch)
        self.sep_velocity = spec.separation == SEP_VELOCITY
        self.recheck = bool(spec.recheck)
        self.advance = advance_rule(spec, int(self.method.separation) == SEP_LR)
        self.pass_3_mode = pass_3_mode(spec)
        upd = scene.settings.update
        self.pass_1_counts = upd.scheme in ("pic", "apic")  # (xpic and fmpm are not on the GPU)
        self.hold_code = hold_rule(spec, self.pass_1_counts)
        self.holds, self.hold_force = self.hold_code != HOLD_NONE, self.hold_code == HOLD_FORCE
        self.plan_kernel = geometry_kernel(int(self.method.normal), int(self.method.separation))
        self.exchange_kernel = exchange_kernel(self.groups)
        self.pass_2_kernel = pass_2_kernel(self.groups)

    # ------------------------------------------------------------------ device arrays
    def bind(self, state) -> None:
        to = cuda.to_device
        cs, dim = state.contact, state.dim
        nn = state.grid.n_nodes
        self.nn, self.dim = nn, dim
        self.d = d = {}
        d["group"] = to(np.ascontiguousarray(cs.group))
        d["mask"] = cuda.device_array(nn, dtype=np.uint64)
        d["node_cn"] = to(np.full(nn, -1, dtype=np.int64))
        d["contact_step"] = to(np.ascontiguousarray(cs.contact_step))
        d["fidx"] = to(np.ascontiguousarray(cs.fidx))
        d["all_nodes"] = to(np.arange(nn, dtype=np.int64))
        n_chunks = (nn + CHUNK - 1) // CHUNK
        d["chunk_counts"] = cuda.device_array((n_chunks, 2), dtype=np.int64)
        d["totals"] = cuda.device_array(2, dtype=np.int64)
        for name in ("pair_step", "pair_force", "pair_impulse"):
            d[name] = to(np.ascontiguousarray(getattr(cs, name)))
        sd = self.step.d  # (without displacement separations x0 is not read: the positions stand in)
        d["x0"] = to(np.ascontiguousarray(state.particles.x0)) if self.spec.needs_displacement else sd["x"]
        spec, M = self.spec, self.method
        d["laws"] = PairLaws(*(to(np.ascontiguousarray(a)) for a in spec.laws()))
        d["method"] = M._replace(normal_vec=to(np.ascontiguousarray(M.normal_vec)), centre=to(np.ascontiguousarray(M.centre)),
                                 mirror=to(np.ascontiguousarray(M.mirror)))
        d["rigid_of_group"] = to(np.ascontiguousarray(spec.rigid_of_group))
        d["no_before"] = to(np.zeros((0, dim)))
        d["reaction"] = to(np.zeros((1, 1, dim)))
        d["warm_phi"] = to(np.zeros((1, 1, 4)))
        self.cap = 0
        self.cloud_cap = 0
        self.n_cn = self.n_slots = 0
        self._grow(64, 256)

    def _grow(self, cap: int, cloud_cap: int) -> None:
        """Slot arrays for cap slots (contact nodes <= slots) and cloud arrays for cloud_cap entries."""
        d, dim = self.d, self.dim
        z = lambda shape, dtype=np.float64: cuda.device_array(shape, dtype=dtype)  # noqa: E731
        if cap > self.cap:
            self.cap = cap
            for name in ("cn_nodes", "slot_group", "slot_node", "role", "partner", "law", "bonded", "contact2"):
                d[name] = z(cap, np.int64)
            d["cn_ptr"] = z(cap + 1, np.int64)
            d["cloud_counts"] = z((cap, 1), np.int64)
            d["cloud_ptr"] = z(cap + 1, np.int64)
            d["cloud_sums"] = z(((cap + CHUNK - 1) // CHUNK + 1, 1), np.int64)
            for name in ("vol", "delta", "area", "mu", "mus", "level", "delta2"):
                d[name] = z(cap)
            for name in ("disp", "pos", "grad", "dp1", "hold", "normal", "open", "stick2", "applied2", "stick_total",
                         "applied_total", "before"):
                d[name] = z((cap, dim))
            d["stiff"] = z((cap, 3))
            self.step.grow_fields(cap)
        if cloud_cap > self.cloud_cap:
            self.cloud_cap = cloud_cap
            d["cloud_idx"] = z(cloud_cap, np.int64)
            d["cloud_w"] = z(cloud_cap)
            d["pts"] = z((cloud_cap, 3))
            for name in ("cw", "clab"):
                d[name] = z(cloud_cap)
            d["clabels"] = z(cloud_cap, np.int64)

    # ------------------------------------------------------------------ bundles
    def nodes(self) -> ContactNodes:
        d = self.d
        return ContactNodes(self.n_cn, d["cn_nodes"], d["cn_ptr"], d["slot_group"], self.spec.n_def_groups, self.nn)

    def slot_map(self) -> SlotMap:
        d = self.d
        return SlotMap(d["node_cn"], d["cn_ptr"], d["slot_group"], d["mask"], self.spec.n_def_groups)

    def targets(self) -> Targets:
        d = self.d
        return Targets(*(d[k] for k in ("role", "partner", "normal", "delta", "area", "open", "bonded", "law", "mu",
                                        "mus", "stiff", "level")))

    def decisions(self) -> Decisions:
        d = self.d
        return Decisions(*(d[k] for k in ("stick2", "applied2", "delta2", "contact2", "stick_total", "applied_total",
                                          "contact_step", "hold")))

    def sums(self) -> SlotSums:
        d = self.d
        return SlotSums(d["vol"], d["disp"], d["pos"], d["grad"], d["disp"], d["stiff"], d["vol"])  # (no interfaces, no axisymmetry: unused)

    # ------------------------------------------------------------------ tasks
    def material_fields(self, state) -> None:
        """Masks, contact nodes and slots in node order, fields of the particle entries, clouds."""
        step, d, sd = self.step, self.d, self.step.d
        n = step.n
        K.zero_int[K.blocks(self.nn)](d["mask"])
        if n:
            group_masks[blocks(n)](sd["nodes"], sd["S"], d["group"], d["mask"])
        n_chunks = d["chunk_counts"].shape[0]
        count_chunks[blocks(n_chunks)](d["all_nodes"], d["mask"], d["chunk_counts"])
        exclusive_sums[1, 1](d["chunk_counts"], n_chunks, d["totals"])
        n_cn, n_slots = (int(v) for v in d["totals"].copy_to_host())
        self._grow(max(2 * n_slots, self.cap), self.cloud_cap)
        number_chunks[blocks(n_chunks)](d["all_nodes"], d["mask"], d["chunk_counts"], d["node_cn"], d["cn_nodes"],
                                        d["cn_ptr"], d["slot_group"], d["slot_node"])
        self.n_cn, self.n_slots = n_cn, n_slots
        step.set_fields(n_slots, d["slot_node"])
        if n:
            assign[blocks(n)](sd["nodes"], d["group"], d["node_cn"], d["cn_ptr"], d["slot_group"], self.nn, d["fidx"])
        if self.spec.needs_cloud:
            self._clouds(n)
        else:  # (no point clouds: every contact node's is empty)
            K.zero_int[K.blocks(n_cn + 1)](d["cloud_ptr"][:n_cn + 1])
        step.sync()

    def _clouds(self, n: int) -> None:
        step, d, sd = self.step, self.d, self.step.d
        n_cn = self.n_cn
        counts, sums = d["cloud_counts"], d["cloud_sums"]
        K.zero_int[K.blocks(counts.size)](counts.reshape(counts.size))
        if n:
            cloud_entries[blocks(n)](sd["nodes"], sd["S"], d["node_cn"], False, False, counts.reshape(counts.size),
                                     d["cloud_idx"], d["cloud_w"])
        n_chunks = max((n_cn + CHUNK - 1) // CHUNK, 1)
        chunk_totals[blocks(n_chunks)](counts, n_cn, sums)
        exclusive_sums[1, 1](sums, n_chunks, d["totals"])
        chunk_prefix[blocks(n_chunks)](counts, n_cn, sums, d["cloud_ptr"])
        if n_cn == 0:
            K.zero_int[1, 1](d["cloud_ptr"][:1])
        total = int(d["totals"][0:1].copy_to_host()[0])
        self._grow(self.cap, max(2 * total, self.cloud_cap))
        cursor = d["cloud_counts"]
        copy_rows[blocks(n_cn)](d["cloud_ptr"].reshape(d["cloud_ptr"].size, 1), cursor, n_cn)
        if n:
            cloud_entries[blocks(n)](sd["nodes"], sd["S"], d["node_cn"], self.spec.shape_weights, True,
                                     cursor.reshape(cursor.size), d["cloud_idx"], d["cloud_w"])
        cloud_sort[blocks(n_cn)](d["cloud_ptr"], n_cn, d["cloud_idx"], d["cloud_w"])

    def extrapolate_extras(self, state) -> None:
        """The slots' contact volumes (and the sums the separation or normal methods read)."""
        step, d, sd = self.step, self.d, self.step.d
        ns = self.n_slots
        for name in ("vol", "disp", "pos", "grad"):
            a = d[name]
            K.zero[K.blocks(a.size)](a.reshape(a.size))
        if step.n and ns:
            slot_extras[blocks(step.n)](d["fidx"], sd["S"], sd["G"], sd["mass"], sd["vol"], sd["x"], d["x0"], self.nn,
                                        self.spec.wants(), self.sums())

    def geometry(self, state) -> None:
        step, d, sd = self.step, self.d, self.step.d
        if not self.n_cn:
            step.sync()
            return
        clouds = Clouds(d["cloud_ptr"], d["cloud_idx"], d["cloud_w"], d["group"], d["group"], step.n, sd["x"],
                        sd["x"], sd["F"], sd["semi"], self.spec.shape_weights)
        inp = GeometryInputs(self.nodes(), step.grid_view, sd["gmass"], self.sums(), clouds, d["laws"], d["method"],
                             d["warm_phi"], float(state.dt_rule))
        self.plan_kernel[blocks(self.n_cn)](inp, self.targets(), d["pts"], d["cw"], d["clab"], d["clabels"])
        step.sync()

    def _exchange(self, mode: int, held_step: int = NO_HOLD) -> None:
        d, sd = self.d, self.step.d
        if self.n_cn:
            self.exchange_kernel[blocks(self.n_cn)](mode, self.nodes(), sd["gmass"], sd["gmom"], self.targets(),
                                                    self.decisions(), self.sep_velocity, self.touch, held_step,
                                                    d["dp1"])

    def pass_1(self, state) -> None:
        d, sd = self.d, self.step.d
        self._exchange(PASS_1, int(state.step) - 1 if self.holds else NO_HOLD)
        if self.pass_1_counts and self.n_cn:
            pairs[1, 1](self.nodes(), sd["gmass"], d["dp1"], d["no_before"], False, d["pair_step"])
        self.step.sync()

    def pass_2(self, state) -> None:
        d, sd, step = self.d, self.step.d, self.step
        nn, ns = self.nn, self.n_slots
        vnew_slots = sd["gvnew"][nn:nn + ns]
        if self.n_cn:
            copy_rows[blocks(ns)](vnew_slots, d["before"], ns)
            held = RigidHold(sd["grigid_vol"], sd["constrain"], sd["rv_end"])
            settings = Pass2Settings(self.sep_velocity, self.advance, int(self.spec.interface_integration), self.touch,
                                     float(state.dt), int(state.step), self.hold_code)
            self.pass_2_kernel[blocks(self.n_cn)](self.nodes(), step.grid_view, held, d["rigid_of_group"], sd["gmass"],
                                           sd["gvnew"], sd["gacc"], self.targets(), self.decisions(), settings,
                                           d["reaction"])
            pairs[1, 1](self.nodes(), sd["gmass"], vnew_slots, d["before"][:ns], True, d["pair_step"])
            if self.hold_force:
                pairs[1, 1](self.nodes(), sd["gmass"], d["hold"], d["no_before"], False, d["pair_step"])
        settle[1, 1](d["pair_step"], d["pair_force"], d["pair_impulse"], float(state.dt))
        step.sync()

    def pass_3(self, state) -> None:
        if self.recheck:
            self.geometry(state)
        self._exchange(self.pass_3_mode)
        self.step.sync()

    def to_host(self, state) -> None:
        """The contact state a later step reads (each node's last contact step: `persist`) to the
        host, so a checkpoint holds it."""
        self.d["contact_step"].copy_to_host(state.contact.contact_step)

    def finish(self, state) -> None:
        """The pair forces and impulses to the host (history columns, checkpoints)."""
        cs, d = state.contact, self.d
        d["pair_force"].copy_to_host(cs.pair_force)
        d["pair_impulse"].copy_to_host(cs.pair_impulse)


