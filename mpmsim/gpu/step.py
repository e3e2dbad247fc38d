"""The explicit MPM step with the scene's state on one CUDA device (numba-cuda).

`DeviceStep` holds device copies of the particle arrays, their shape data and the grid
fields; the step's tasks (the CPU task list's names, in its order: mpmsim/tasks) launch the
kernels of mpmsim/gpu/kernels.py on them. The host state is brought up to date only when
something reads it (`to_host`: history rows, VTU frames, checkpoints, the energy check every
`stability.check_every` steps, the rigid-penetration watch), and what a step reports on the
host (wave speed for the CFL step, reactions, work, fault flags) comes back as a few scalars
at the end of each step. Grid passes run on every node of the grid (the CPU path keeps an
active box); nodes outside the particles' reach have zero mass and stay zero.

Each task ends with a device synchronisation so the run's timers hold the GPU time of each
task, as the CPU timers hold CPU time. With multimaterial contact the grid fields are the
nodes and this step's material slots, and the contact tasks run on the device too
(mpmsim/gpu/contact.py).

Scatter (particle to grid: mass, momentum, forces), float64 atomic adds in one of two orders:
`scatter="atomic"`, thread t takes particle t (storage order); `scatter="sorted"`, thread t
takes particle order[t], the particles grouped by cell by a counting sort on the device every
`sort_every` steps, so the threads of a warp add into the same few nodes. Which is faster is
to be measured on a device (bench/gpu.py --scatter); the results differ only in the order of
the sums.
"""

from __future__ import annotations

import time as wallclock

import numpy as np

from ..contact.grid.workspace import SlotMap
from ..faults import BAD_NONE
from ..shapes import BAD_SUPPORT
from ..tasks.particle_update import POSITIONS, SCHEMES, move_rigid
from ..views import GridView
from . import kernels as K

SCATTERS = ("atomic", "sorted")
ON_DEVICE = ("time step", "shape functions", "extrapolate", "update stress first", "forces", "grid update",
             "particle update", "move rigid", "re-extrapolate", "update stress last")
STRESS_FIRST, STRESS_LAST = K.STRESS, K.N_SLOTS  # fault slots of the two stress updates
N_FAULT_SLOTS = K.N_SLOTS + 1


class DeviceStep:
    """The scene's explicit MPM step on the CUDA device (bound to a state by `bind`)."""

    checkpoint_skip = True  # device arrays are not saved: a checkpoint holds the host state

    def __init__(self, scene, scatter: str = "atomic", sort_every: int = 10):
        from numba import cuda

        if scatter not in SCATTERS:
            raise ValueError(f"scatter {scatter!r}: one of {', '.join(SCATTERS)}")
        self.cuda = cuda
        self.scatter = scatter
        self.sort_every = sort_every
        self.since_sort = sort_every  # steps since the particles were last grouped by cell
        run = scene.settings
        upd = run.update
        self.dim = scene.dim
        self.scheme = SCHEMES[upd.scheme]
        self.position = POSITIONS[upd.position]
        self.fraction = 0.5 if upd.stress == "usavg" else 1.0
        self.reextrapolate = upd.reextrapolate
        self.damping = run.damping  # grid damping alpha (1/time), 0: none
        self.models = [int(m) for m in np.unique(np.asarray(scene.materials.type_code))]
        self.state = None
        self.host_stale = False  # the host's particle arrays lag the device's
        self.contact = None
        if scene.contact.grid is not None:
            from .contact import DeviceContact

            self.contact = DeviceContact(self, scene)

    # ------------------------------------------------------------------ data movement
    def bind(self, state) -> None:
        """Copy the state to the device (a new run, or the host state changed: a restart)."""
        cuda, dim = self.cuda, self.dim
        to = cuda.to_device
        P, R, sd, g = state.particles, state.rigid, state.sd, state.grid
        nn = g.n_nodes
        self.n, self.nr = P.n, R.n
        self.d = d = {}
        for name in ("x", "v", "F", "stress", "vol", "vol0", "mass", "mat", "B", "C"):
            d[name] = to(np.ascontiguousarray(getattr(P, name)))
        d["semi"] = to(np.asarray(P.semi, dtype=np.float64))
        # APIC: the positions the step's shape functions and affine terms refer to (the
        # re-extrapolation after the particle update still uses them), else the positions
        d["xref"] = to(np.ascontiguousarray(P.xref)) if P.affine else d["x"]
        for name in ("nodes", "S", "G", "lowest"):
            d[name] = to(getattr(sd, name))
            d["r" + name] = to(getattr(state.rigid_sd, name))
        for name in ("x", "v", "vol", "mat"):
            d["r" + name] = to(np.ascontiguousarray(getattr(R, name)))
        nrm = max(len(state.materials.rigid), 1)
        d["grigid_vol"] = cuda.device_array((nn, nrm), dtype=np.float64)
        d["flat_rigid_vol"] = d["grigid_vol"].reshape(d["grigid_vol"].size)
        self.nn = nn
        self.slots_cap = -1
        self.grow_fields(0)
        self.set_fields(0, to(np.zeros(1, dtype=np.int64)))
        view = g.view
        d["shape"], d["origin"], d["h"] = to(np.asarray(view.shape)), to(view.origin), to(view.h)
        d["face_type"], d["wall_index"] = to(np.asarray(view.face_type)), to(np.asarray(view.wall_index))
        self.grid_view = GridView(d["shape"], d["origin"], d["h"], d["face_type"], d["wall_index"])
        d["offs"] = to(state.entry_offsets)
        d["gravity"] = to(np.asarray(state.gravity, dtype=np.float64))
        lo, hi = state.particle_bounds
        d["lo"], d["hi"] = to(np.asarray(lo, dtype=np.float64)), to(np.asarray(hi, dtype=np.float64))
        M = state.materials
        d["code"], d["props"] = to(np.asarray(M.type_code)), to(np.ascontiguousarray(M.props))
        d["density"] = to(np.asarray(M.density, dtype=np.float64))
        d["constrain"] = to(np.ascontiguousarray(M.constrain))
        d["rv_start"] = to(np.ascontiguousarray(R.v_start))
        d["rv_end"] = to(np.ascontiguousarray(R.v_end))
        d["reaction"] = to(np.zeros(state.reaction.shape))
        d["scalars"] = to(np.zeros(3))
        d["faults"] = to(np.full(N_FAULT_SLOTS, P.n + R.n + 1, dtype=np.int64))
        d["order"] = to(np.arange(max(P.n, 1), dtype=np.int64))
        self.since_sort = self.sort_every
        d["fcode"] = to(np.zeros(max(P.n, 1), dtype=np.int64))
        d["fvalue"] = to(np.zeros(max(P.n, 1)))
        self.walls = bool(np.any(g.face_type[: 2 * dim] != 0))
        self.reaches_ghosts = state.shape.reaches_ghosts
        self.kind, self.per_axis = state.shape.grid_kind, state.shape.per_axis
        self.has_gravity = bool(np.any(state.gravity))
        if R.n and P.n and R.watch_penetration:
            R.find_inside = self.find_inside
        if P.n:
            P.device_sums = self.energy_sums
        self.lattices = {}  # device copies of the rigid lattices
        i1 = to(np.zeros(1, dtype=np.int64))
        self.no_slots = SlotMap(to(np.full(1, -1, dtype=np.int64)), i1, i1, to(np.zeros(1, dtype=np.uint64)), 0)
        if self.contact is not None:
            self.contact.bind(state)
        self.state = state
        self.host_stale = False
        cuda.synchronize()

    def grow_fields(self, slots: int) -> None:
        """Grid field arrays for the nodes and `slots` material slots (contents not kept)."""
        if slots <= self.slots_cap:
            return
        cuda, d, dim = self.cuda, self.d, self.dim
        self.slots_cap = slots
        nf = self.nn + slots
        for name, shape in (("mass", (nf,)), ("mom", (nf, dim)), ("force", (nf, dim)), ("vel", (nf, dim)),
                            ("vnew", (nf, dim)), ("acc", (nf, dim)), ("vstart", (nf, dim))):
            d["g" + name] = cuda.device_array(shape, dtype=np.float64)
            d["flat_" + name] = d["g" + name].reshape(d["g" + name].size)
        for name in ("vel", "vnew", "acc", "vstart"):
            K.zero[K.blocks(d["flat_" + name].size)](d["flat_" + name])
        d["gsrc"] = cuda.to_device(np.full((nf, dim), -1, dtype=np.int64))
        d["gface"] = cuda.to_device(np.full((nf, dim), -1, dtype=np.int64))

    def set_fields(self, slots: int, slot_node) -> None:
        """This step's fields: the nodes and `slots` material slots at slot_node."""
        self.fm = K.FieldMap(self.nn + slots, self.nn, slot_node)

    @property
    def fields(self):
        """Each particle entry's field (its node, or its material's slot where materials meet)."""
        return self.d["nodes"] if self.contact is None else self.contact.d["fidx"]

    def to_host(self, state) -> None:
        """Bring the host state's particle arrays up to date (history, output, checks)."""
        if not self.host_stale or self.state is not state:
            return
        P, d = state.particles, self.d
        for name in ("x", "v", "F", "stress", "vol") + (("B", "C") if P.affine else ()):
            d[name].copy_to_host(getattr(P, name))
        if P.affine:  # the positions the APIC affine terms refer to: the step's start
            d["xref"].copy_to_host(P.xref)
        if self.contact is not None:
            self.contact.to_host(state)
        self.host_stale = False

    # ------------------------------------------------------------------ the tasks
    def tasks(self, cpu_tasks) -> dict:
        """{task name: device version} for the CPU task list's names."""
        runs = {
            "time step": self._time_step(dict((t.name, t.run) for t in cpu_tasks)["time step"]),
            "shape functions": self.shape_functions,
            "extrapolate": self.extrapolate,
            "update stress first": self.stress_first,
            "forces": self.forces,
            "grid update": self.grid_update,
            "particle update": self.particle_update,
            "move rigid": self.move_rigid,
            "re-extrapolate": self.reextrapolate_task,
            "update stress last": self.stress_last,
        }
        if self.contact is not None:
            c = self.contact
            runs.update({"material fields": c.material_fields, "contact geometry": c.geometry, "contact pass 1": c.pass_1,
                         "contact pass 2": c.pass_2, "contact pass 3": c.pass_3})
        return {t.name: runs[t.name] for t in cpu_tasks}

    def sync(self) -> None:
        self.cuda.synchronize()

    def _time_step(self, host_run):
        def run(state) -> None:
            if self.state is not state:
                self.bind(state)
            host_run(state)  # prescribed rigid velocities (host), then their device copies
            d = self.d
            if state.n_rigid_materials:
                d["rv_start"].copy_to_device(np.ascontiguousarray(state.rigid.v_start))
                d["rv_end"].copy_to_device(np.ascontiguousarray(state.rigid.v_end))
            d["scalars"].copy_to_device(np.zeros(3))
            d["reaction"].copy_to_device(np.zeros(state.reaction.shape))
            d["faults"].copy_to_device(np.full(N_FAULT_SLOTS, self.n + self.nr + 1, dtype=np.int64))
            self.host_stale = True
        return run

    def shape_functions(self, state) -> None:
        d = self.d
        kernel = K.shape_kernel(self.dim, self.kind, self.per_axis)
        if self.n and self.scheme == K.APIC:
            d["xref"].copy_to_device(d["x"])
        if self.n:
            kernel[K.blocks(self.n)](d["x"], d["origin"], d["h"], d["shape"], d["semi"], d["nodes"], d["S"], d["G"],
                                     d["lowest"], d["faults"], K.SHAPE)
        if self.nr:
            kernel[K.blocks(self.nr)](d["rx"], d["origin"], d["h"], d["shape"], d["semi"], d["rnodes"], d["rS"],
                                      d["rG"], d["rlowest"], d["faults"], K.RIGID_SHAPE)
        if self.scatter == "sorted" and self.n:
            self.since_sort += 1
            if self.since_sort >= self.sort_every:
                self._sort_by_cell()
                self.since_sort = 0
        self.sync()

    def _sort_by_cell(self) -> None:
        """order: the particles grouped by cell (their lowest node), a counting sort."""
        cuda, d = self.cuda, self.d
        nn = self.nn
        count = cuda.to_device(np.zeros(nn, dtype=np.int64))
        K.count_cells[K.blocks(self.n)](d["nodes"], count)
        start = np.zeros(nn, dtype=np.int64)
        np.cumsum(count.copy_to_host()[:-1], out=start[1:])
        K.place_by_cell[K.blocks(self.n)](d["nodes"], cuda.to_device(start), d["order"])

    def _zero(self, *names) -> None:
        for name in names:
            a = self.d["flat_" + name]
            K.zero[K.blocks(a.size)](a)

    def _scatter_momentum(self, with_mass: bool) -> None:
        d, dim = self.d, self.dim
        affine = self.scheme == K.APIC
        if not self.n:
            return
        if affine:
            K.affine_kernel(dim)[K.blocks(self.n)](d["S"], d["lowest"], d["offs"], d["origin"], d["h"], d["xref"],
                                                   d["B"], d["C"])
        K.p2g_kernel(dim, affine, self.scatter == "sorted")[K.blocks(self.n)](
            d["mass"], d["v"], self.fields, d["S"], with_mass, d["gmass"], d["gmom"], d["C"], d["lowest"], d["offs"],
            d["origin"], d["h"], d["xref"], d["order"])

    def extrapolate(self, state) -> None:
        d = self.d
        self._zero("mass", "mom")
        self._scatter_momentum(True)
        if self.contact is not None:
            self.contact.extrapolate_extras(state)
        if self.nr:
            self._zero("rigid_vol")
            K.rigid_volume[K.blocks(self.nr)](d["rnodes"], d["rS"], d["rvol"], d["rmat"], d["grigid_vol"])
        if self.walls:  # which field each ghost mirrors (a material's slot mirrors its slot or node)
            slots = self.no_slots if self.contact is None else self.contact.slot_map()
            ghosts = K.node_kernels(self.dim)[0]
            ghosts[K.blocks(self.fm.n_fields)](self.fm, d["shape"], d["face_type"], d["wall_index"], d["grigid_vol"],
                                               d["constrain"], slots, d["gsrc"], d["gface"])
        self.sync()

    def reextrapolate_task(self, state) -> None:
        self._zero("mom")
        self._scatter_momentum(False)
        self.sync()

    def _grid_velocity(self, rig_vel) -> None:
        d = self.d
        _, velocity, mirror, _, _, _ = K.node_kernels(self.dim)
        nb = K.blocks(self.fm.n_fields)
        velocity[nb](self.fm, d["shape"], d["face_type"], d["wall_index"], d["grigid_vol"], d["constrain"], rig_vel,
                     d["gmass"], d["gmom"], d["gvel"])
        if self.walls:
            mirror[nb](self.fm, d["gsrc"], d["gvel"])

    def _stress(self, state, dt, gvel, slot) -> None:
        d = self.d
        d["scalars"][K.WAVE:K.WAVE + 1].copy_to_device(np.zeros(1))
        faults = d["faults"]
        for model in self.models:
            K.stress_kernel(model, self.dim)[K.blocks(self.n)](
                self.fields, d["G"], gvel, dt, d["v"], d["F"], d["stress"], d["vol"], d["vol0"], d["mat"], d["code"],
                d["props"], d["density"], d["scalars"], faults, slot, d["fcode"], d["fvalue"])

    def stress_first(self, state) -> None:
        if self.n:
            self._grid_velocity(self.d["rv_start"])
            self._stress(state, self.fraction * state.dt, self.d["gvel"], STRESS_FIRST)
        self.sync()

    def stress_last(self, state) -> None:
        if self.n:
            if self.reextrapolate:
                self._grid_velocity(self.d["rv_end"])
                gvel = self.d["gvel"]
            else:
                gvel = self.d["gvnew"]
            self._stress(state, self.fraction * state.dt, gvel, STRESS_LAST)
        self.sync()

    def forces(self, state) -> None:
        d = self.d
        self._zero("force")
        if self.n:
            K.forces_kernel(self.dim, self.has_gravity, self.scatter == "sorted")[K.blocks(self.n)](
                self.fields, d["S"], d["G"], d["vol"], d["stress"], d["mass"], d["gravity"], d["gforce"], d["order"])
        if self.reaches_ghosts and self.walls:
            fold = K.node_kernels(self.dim)[3]
            fold[K.blocks(self.fm.n_fields)](self.fm, d["gsrc"], d["gface"], d["gforce"])
        if self.damping > 0.0:
            K.damp[K.blocks(d["gmass"].size)](d["gmom"], self.damping, d["gforce"])
        self.sync()

    def grid_update(self, state) -> None:
        d = self.d
        _, _, _, _, update, mirror_update = K.node_kernels(self.dim)
        nb = K.blocks(self.fm.n_fields)
        update[nb](self.fm, d["shape"], d["face_type"], d["wall_index"], d["grigid_vol"], d["constrain"], d["rv_start"],
                   d["rv_end"], d["gmass"], d["gmom"], d["gforce"], d["gvnew"], d["gacc"], d["gvstart"], state.dt,
                   d["reaction"], d["scalars"])
        if self.walls:
            mirror_update[nb](self.fm, d["gsrc"], d["gface"], d["gmass"], d["gmom"], d["gvnew"], d["gacc"], d["gvstart"],
                              state.dt, d["reaction"])
        self.sync()

    def particle_update(self, state) -> None:
        d = self.d
        if self.position == K.UPDATED and self.contact is not None and self.walls:
            # contact pass 2 changed v+ after the grid update mirrored it: the ghosts follow again
            K.node_kernels(self.dim)[2][K.blocks(self.fm.n_fields)](self.fm, d["gsrc"], d["gvnew"])
        if self.n:
            K.particle_kernel(self.scheme, self.position, self.dim)[K.blocks(self.n)](
                self.fields, d["S"], d["lowest"], d["offs"], d["origin"], d["h"], d["gvnew"], d["gacc"],
                d["gvstart"], state.dt, d["x"], d["v"], d["B"], d["mass"], d["gravity"], d["lo"], d["hi"],
                d["scalars"], d["faults"], K.UPDATE, d["fcode"])
        self.sync()

    def move_rigid(self, state) -> None:
        """On the device and, with the same arithmetic, on the host (the rigid checks read it)."""
        d = self.d
        K.move_rigid[K.blocks(self.nr)](d["rx"], d["rv"], d["rmat"], d["rv_start"], d["rv_end"], state.dt)
        move_rigid(state)
        self.sync()

    # ------------------------------------------------------------------ the step's report
    def finish(self, state) -> None:
        """What the step reports on the host: wave speed, reactions, work, faults."""
        d = self.d
        scal = d["scalars"].copy_to_host()
        state.wave_max = float(scal[K.WAVE]) if self.n else state.wave_max
        state.work_in += float(scal[K.GRID_WORK])  # (in the CPU path's order: walls, then gravity)
        state.work_in += float(scal[K.GRAVITY_WORK])
        state.reaction[:] = d["reaction"].copy_to_host()
        faults = d["faults"].copy_to_host()
        for slot in (K.SHAPE, STRESS_FIRST, K.UPDATE, STRESS_LAST):
            p = int(faults[slot])
            if p < self.n:
                if slot == K.SHAPE:
                    code, value = BAD_SUPPORT, 0.0
                else:
                    code = int(d["fcode"][p:p + 1].copy_to_host()[0])
                    value = float(d["fvalue"][p:p + 1].copy_to_host()[0]) if slot != K.UPDATE else 0.0
                state.flags.set(p, code if code != BAD_NONE else BAD_SUPPORT, value)
        if int(faults[K.RIGID_SHAPE]) < self.nr:
            state.flags.set_rigid(int(faults[K.RIGID_SHAPE]), BAD_SUPPORT)
        if self.contact is not None:
            self.contact.finish(state)

    def energy_sums(self, state):
        """The particles' kinetic and strain energy (bodies.Sums; the other entries zero) from
        the device's arrays: the energy check needs no copy of the particles."""
        from ..bodies import NSUMS, Sums

        d = self.d
        out = self.cuda.to_device(np.zeros(NSUMS))
        K.energy_kernel(tuple(self.models))[K.blocks(self.n)](d["v"], d["mass"], d["vol"], d["F"], d["stress"],
                                                             d["mat"], d["code"], d["props"], out)
        return Sums(out.copy_to_host(), np.zeros((0, NSUMS)))

    def find_inside(self, x, rigid, origin, spacing, lattices) -> tuple[int, int]:
        """bodies.rigid.inside_rigid on the device's positions (x, the host's, is not read)."""
        cuda, d = self.cuda, self.d
        if "inside" not in d:
            d["inside"] = cuda.device_array(max(self.n, 1), dtype=np.int64)
        for r, lo, span, owner in lattices:
            if r not in self.lattices:
                self.lattices[r] = tuple(cuda.to_device(np.ascontiguousarray(a)) for a in (lo, span, owner))
            dlo, dspan, downer = self.lattices[r]
            first = cuda.to_device(np.array([self.n], dtype=np.int64))
            K.inside_rigid[K.blocks(self.n)](d["x"], cuda.to_device(origin + rigid.disp[r]), cuda.to_device(spacing),
                                             dlo, dspan, downer, first, d["inside"])
            p = int(first.copy_to_host()[0])
            if p < self.n:
                self.to_host(self.state)  # (the message names the particle and where it is)
                return p, int(d["inside"][p:p + 1].copy_to_host()[0])
        return -1, -1


def timed_step(device: DeviceStep, tasks, timers: dict, state) -> None:
    """One step of the device tasks, each timed (each ends with a device synchronisation)."""
    for task in tasks:
        t0 = wallclock.perf_counter()
        task.run(state)
        timers[task.name] += wallclock.perf_counter() - t0
    t0 = wallclock.perf_counter()
    device.finish(state)
    timers[tasks[0].name] += wallclock.perf_counter() - t0
