"""Benchmark: where the explicit step's time goes, in bytes moved and bandwidth.

For the benchmark column (bench/column.yaml) and the two-block LR contact column
(bench/two_blocks.yaml), one thread, warm kernels: per task the time per step, its share,
the bytes it streams per particle-step (a static accounting of the arrays each task's
kernels read and write, `TRAFFIC` below; grid rows are counted once per pass over the active
fields, the grid gathers and scatters of the particle loops apart), the bandwidth that makes,
and that bandwidth as a share of this machine's, measured in the same run by a STREAM-like
triad (a[i] = b[i] + s c[i], counted as 3 x 8 bytes per element: no write-allocate, as the
task bytes count a written array once). Two triads: arrays far larger than the caches
(memory), and arrays whose total is the deck's state (where the step's data lives: a
16 000-particle deck fits in the last-level cache). Three floors per task: memory (its bytes
at the state-size triad), overhead (its time on the same deck shrunk to 64 particles), core
(the task's real kernels replayed on the first 128 and 2048 particles, whose data then sits
in L2: the time per particle of the fit, i.e. arithmetic, divides, cube roots and dependent
loads with no memory traffic). A task is `<floor>-bound` when that floor explains at least
half its time. For the stress update also: its flops against the rate of multiply-add
chains of a tiny loop, and the same kernel with the neo-Hookean model stubbed out.

Then (unless --skip-256k) the column at 1/4 the cell size (256 000 particles): the rate of
`mpmsim run` (from its run log's task table) against Simulation.step() on the same deck,
and 1 against 2 threads. Timings alternate between the variants and keep the best of
--rounds rounds (the machine may be shared: ratios within one run are what to read).

    python bench/traffic.py [--steps 100] [--rounds 5] [--skip-256k] [--big-steps 30] [--big-rounds 3]
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import NamedTuple

import numba
import numpy as np
import yaml
from numba import njit, prange

ROOT = Path(__file__).resolve().parents[1]
for folder in (ROOT, ROOT / "bench"):  # the package beside it, and bench/column.py
    if str(folder) not in sys.path:
        sys.path.insert(0, str(folder))

from machine import steps_wall  # noqa: E402
from mpmsim.cli import busy_cores  # noqa: E402
from mpmsim.deck import load_deck_text  # noqa: E402
from mpmsim.materials import NEO_HOOKEAN  # noqa: E402
from mpmsim.materials.kernels import cube_root  # noqa: E402
from mpmsim.parallel import specialize  # noqa: E402
from mpmsim.scene import build_scene  # noqa: E402
from mpmsim.solver import Simulation  # noqa: E402
from mpmsim.stability import total_sums  # noqa: E402
from mpmsim.tasks.boundary import has_walls  # noqa: E402
from mpmsim.tasks.extrapolate import p2g_momentum  # noqa: E402
from mpmsim.tasks.forces import p2g_forces  # noqa: E402
from mpmsim.tasks.particle_update import FLIP, MIDPOINT, GridVelocities, particle_update_kernel  # noqa: E402
from mpmsim.tasks.stress import update_stress_kernel  # noqa: E402
from mpmsim.views import Faults, Scatter  # noqa: E402

DECKS = {"column": ROOT / "bench" / "column.yaml", "two_blocks": ROOT / "bench" / "two_blocks.yaml"}
GOAL = {"column": 3.3e6, "two_blocks": 2.6e6}  # particle-steps/s on one thread (4x the C++ reference)


class Term(NamedTuple):
    """One array a task streams: `path` in the State (a dotted attribute path; "tmp:..." is a
    temporary the task allocates), rows touched `per` particle, rigid particle, active field,
    contact slot, contact node or cloud entry (or `entry`: per particle-node entry, a grid
    gather or scatter), `elems` per row and `itemsize` bytes each, `passes` (1: read or
    written, 2: read and written), `count` (an expression: how often per step), `when` (a
    scene condition, or None)."""

    path: str
    per: str
    elems: str
    itemsize: int
    passes: int
    note: str
    count: str = "1"
    when: str | None = None


def T(path, per, elems, itemsize, passes, note, count="1", when=None) -> Term:
    return Term(path, per, elems, itemsize, passes, note, count, when)


P_, R_, F_, E_ = "particle", "rigid", "field", "entry"
# the ghost table and the mirrors of tasks/boundary.py (walls with velocity conditions)
_GRID_VELOCITY = [  # set_grid_velocity: vel = p/m on every active field, conditions imposed
    T("box.fields", F_, "1", 8, 1, "active field list"),
    T("box.fnodes", F_, "1", 8, 1, "node of each field (node_ijk, node_bc)"),
    T("fields.mass", F_, "1", 8, 1, "m"),
    T("fields.mom", F_, "dim", 8, 1, "p"),
    T("fields.rigid_vol", F_, "nr", 8, 1, "rigid volume per node: node_bc asks if a rigid body holds it",
      when="rigid"),
    T("fields.vel", F_, "dim", 8, 1, "v = p/m written"),
    T("box.fields", F_, "1", 8, 1, "mirror_ghosts: field list again", when="walls"),
    T("fields.ghost_src", F_, "dim", 8, 1, "mirror_ghosts: the mirrored field of each component", when="walls"),
]
_STRESS = [  # update_stress_kernel (neo-Hookean, no internal energy)
    T("particles.mat", P_, "1", 8, 1, "material -> model check"),
    T("entries.nodes", P_, "K", 8, 1, "field of each entry (gvel gather index)"),
    T("sd.G", P_, "K*dim", 8, 1, "gradients: L = sum v_i (x) G_ip"),
    T("particles.F", P_, "dim*dim", 8, 2, "F <- (I + dt L) F"),
    T("particles.vol", P_, "1", 8, 2, "J0 = vol/vol0 read, vol = vol0 J written"),
    T("particles.vol0", P_, "1", 8, 1, "initial volume"),
    T("particles.stress", P_, "6", 8, 1, "stress written (the finite check re-reads it from cache)"),
    T("particles.v", P_, "dim", 8, 1, "|v| for the wave speed"),
    T("fields.vel", E_, "dim", 8, 1, "gather of the grid velocity at each entry"),
]
TRAFFIC: dict[str, list[Term]] = {
    # the CFL rule reads state.wave_max and the rigid velocities: scalars only
    "time step": [],
    "shape functions": [  # tensor_shape_functions + ActiveBox.update (one thread)
        T("particles.x", P_, "dim", 8, 1, "positions"),
        T("sd.nodes", P_, "K", 8, 1, "flat node index of each entry written (int64)"),
        T("sd.S", P_, "K", 8, 1, "weights written"),
        T("sd.G", P_, "K*dim", 8, 1, "weight gradients written"),
        T("sd.lowest", P_, "3", 8, 1, "lowest node (i, j, k) written: rows of 3 int64"),
        T("rigid.x", R_, "dim", 8, 1, "rigid particles: positions", when="rigid"),
        T("rigid_sd.nodes", R_, "K", 8, 1, "rigid: node indices", when="rigid"),
        T("rigid_sd.S", R_, "K", 8, 1, "rigid: weights", when="rigid"),
        T("rigid_sd.G", R_, "K*dim", 8, 1, "rigid: gradients (unused later, still written)", when="rigid"),
        T("rigid_sd.lowest", R_, "3", 8, 1, "rigid: lowest node", when="rigid"),
        T("box.fields", F_, "1", 8, 1, "box_nodes: the box's node list rewritten"),
        # (one thread: the order stays 0, 1, ..., n - 1 from step to step, not rewritten)
    ],
    "material fields": [  # contact/__init__.material_fields (contact scenes)
        T("box.fields", F_, "1", 8, 2, "box node list copied (read, copy written)"),
        T("contact.mask", F_, "1", 8, 1, "group masks of the box nodes cleared (uint64)"),
        T("box.order", P_, "1", 8, 1, "scatter_group_masks: particle order"),
        T("contact.group", P_, "1", 8, 1, "scatter_group_masks: group of each particle"),
        T("sd.S", P_, "K", 8, 1, "scatter_group_masks: S > 0 test"),
        T("sd.nodes", P_, "K", 8, 1, "scatter_group_masks: nodes"),
        T("contact.mask", E_, "1", 8, 2, "scatter_group_masks: mask |= bit at each entry"),
        T("contact.mask", F_, "1", 8, 1, "count_slots and build_slots read the masks", count="2"),
        T("contact.node_cn", F_, "1", 8, 1, "build_slots: contact node of each box node written"),
        T("contact.group", P_, "1", 8, 1, "assign_fields: group"),
        T("sd.nodes", P_, "K", 8, 1, "assign_fields: nodes"),
        T("contact.node_cn", E_, "1", 8, 1, "assign_fields: contact node of each entry's node"),
        T("contact.fidx", P_, "K", 8, 1, "assign_fields: field of each entry written"),
        T("tmp:slotted", P_, "1", 1, 1, "assign_fields: whether an entry is a slot, written"),
        T("box.order", P_, "1", 8, 1, "slab_subset: particle order (the particles with a slot entry kept)"),
        T("tmp:slotted", P_, "1", 1, 1, "slab_subset: the flag read"),
        T("rigid_sd.nodes", R_, "K", 8, 1, "rigid masks, then rigid assign_fields", count="2", when="rigid"),
        T("rigid_sd.S", R_, "K", 8, 1, "scatter_rigid_masks: S > 0 test", when="rigid"),
        T("contact.rgroup", R_, "1", 8, 1, "rigid group", count="2", when="rigid"),
        T("contact.rfidx", R_, "K", 8, 1, "rigid slot of each entry written", when="rigid"),
        T("box.fields", F_, "1", 8, 2, "box.fields, box.fnodes rebuilt by concatenation", count="2"),
        T("box.skip", F_, "1", 1, 2, "box.skip rebuilt by concatenation"),
        T("tmp:slotted", P_, "1", 1, 1, "flatnonzero: the candidates (touch_contact_nodes and build_clouds' two "
          "passes then walk only the particles with a slot entry: not counted)", when="cloud"),
        T("rigid_sd.nodes", R_, "K", 8, 1, "build_clouds: rigid entries, both passes", count="2",
          when="cloud rigid"),
        T("rigid_sd.S", R_, "K", 8, 1, "build_clouds: rigid, both passes", count="2", when="cloud rigid"),
        T("contact.cloud_idx", "cloud", "1", 8, 1, "cloud entries written", when="cloud"),
        T("contact.cloud_w", "cloud", "1", 8, 1, "their regression weights written", when="cloud"),
    ],
    "extrapolate": [  # zero_fields x2, p2g_momentum, rigid volumes, ghost table, contact slot sums
        T("box.fields", F_, "1", 8, 1, "zero_fields (mass, mom)", count="2"),
        T("fields.mass", F_, "1", 8, 1, "zeroed"),
        T("fields.mom", F_, "dim", 8, 1, "zeroed"),
        T("box.order", P_, "1", 8, 1, "p2g_momentum: particle order"),
        T("particles.mass", P_, "1", 8, 1, "m_p"),
        T("particles.v", P_, "dim", 8, 1, "v_p"),
        T("entries.nodes", P_, "K", 8, 1, "field of each entry"),
        T("sd.S", P_, "K", 8, 1, "weights"),
        T("fields.mass", E_, "1", 8, 2, "scatter m_i += S m_p"),
        T("fields.mom", E_, "dim", 8, 2, "scatter p_i += S m_p v_p"),
        T("fields.rigid_vol", F_, "nr", 8, 1, "rigid volumes zeroed on the box nodes", when="rigid"),
        T("rigid_sd.nodes", R_, "K", 8, 1, "p2g_rigid_volume: nodes", when="rigid"),
        T("rigid_sd.S", R_, "K", 8, 1, "p2g_rigid_volume: weights", when="rigid"),
        T("rigid.vol", R_, "1", 8, 1, "p2g_rigid_volume: volume", when="rigid"),
        T("rigid.mat", R_, "1", 8, 1, "p2g_rigid_volume: material", when="rigid"),
        T("box.fields", F_, "1", 8, 1, "ghost_table: field list", when="walls"),
        T("box.fnodes", F_, "1", 8, 1, "ghost_table: nodes", when="walls"),
        T("fields.rigid_vol", F_, "nr", 8, 1, "ghost_table: rigid_holds", when="walls rigid"),
        T("fields.ghost_src", F_, "dim", 8, 1, "ghost_table: mirrored field written", when="walls"),
        T("fields.ghost_face", F_, "dim", 8, 1, "ghost_table: face written", when="walls"),
        # (scatter_slot_extras walks only the particles with a slot entry: not counted)
        T("contact.rfidx", R_, "K", 8, 1, "scatter_rigid_slots: rigid slot entries", when="contact rigid"),
    ],
    # the geometry works on contact nodes: a logistic fit per node and group over its cloud
    # (iterations re-read the cloud from cache; counted once)
    "contact geometry": [
        T("contact.cloud_idx", "cloud", "1", 8, 1, "cloud particle index"),
        T("contact.cloud_w", "cloud", "1", 8, 1, "regression weight"),
        T("particles.x", "cloud", "dim", 8, 1, "position of each cloud particle (gathered)"),
        T("fields.mass", "slot", "1", 8, 1, "slot masses"),
        T("contact.normal", "slot", "dim", 8, 1, "normal written"),
        T("contact.delta", "slot", "1", 8, 1, "separation written"),
        T("contact.area", "slot", "1", 8, 1, "area written"),
        T("contact.role", "slot", "1", 8, 1, "role written"),
        T("contact.partner", "slot", "1", 8, 1, "partner written"),
        T("contact.warm_phi", "cn", "G*4", 8, 2, "last fit per node and group (warm start)", when="warm"),
    ],
    "contact pass 1": [  # exchange_pass on the extrapolated momenta
        T("fields.mass", "slot", "1", 8, 1, "slot masses"),
        T("fields.mom", "slot", "dim", 8, 2, "slot momenta changed"),
        T("contact.normal", "slot", "dim", 8, 1, "normal"),
        T("contact.role", "slot", "1", 8, 1, "role"),
        T("contact.partner", "slot", "1", 8, 1, "partner"),
        T("contact.delta", "slot", "1", 8, 1, "separation"),
        T("contact.dp1", "slot", "dim", 8, 1, "change written"),
        T("contact.contact_step", "cn", "1", 8, 1, "each node's last contact step (the hold)", when="hold"),
        T("contact.hold", "slot", "dim", 8, 1, "holding change written", when="hold"),
    ],
    "update stress first": _GRID_VELOCITY + _STRESS,
    "forces": [  # zero_fields, p2g_forces
        T("box.fields", F_, "1", 8, 1, "zero_fields"),
        T("fields.force", F_, "dim", 8, 1, "zeroed"),
        T("box.order", P_, "1", 8, 1, "particle order"),
        T("entries.nodes", P_, "K", 8, 1, "field of each entry"),
        T("sd.S", P_, "K", 8, 1, "weights (loaded at the loop's top; used only for gravity)"),
        T("sd.G", P_, "K*dim", 8, 1, "gradients: f_i -= V sigma . G"),
        T("particles.vol", P_, "1", 8, 1, "V_p"),
        T("particles.stress", P_, "6", 8, 1, "sigma_p"),
        T("particles.mass", P_, "1", 8, 1, "m_p (gravity)"),
        T("fields.force", E_, "dim", 8, 2, "scatter f_i"),
    ],
    "grid update": [  # grid_update_kernel, mirror_update
        T("box.fields", F_, "1", 8, 1, "field list"),
        T("box.fnodes", F_, "1", 8, 1, "node of each field"),
        T("box.skip", F_, "1", 1, 1, "rigid slots skipped (bool)"),
        T("fields.mass", F_, "1", 8, 1, "m"),
        T("fields.mom", F_, "dim", 8, 1, "p"),
        T("fields.force", F_, "dim", 8, 1, "f"),
        T("fields.rigid_vol", F_, "nr", 8, 1, "node_bc: held by a rigid body?", when="rigid"),
        T("fields.vnew", F_, "dim", 8, 1, "v+ written"),
        T("fields.acc", F_, "dim", 8, 1, "a written"),
        T("fields.vstart", F_, "dim", 8, 1, "start velocity written"),
        T("box.fields", F_, "1", 8, 1, "mirror_update: field list", when="walls"),
        T("fields.ghost_src", F_, "dim", 8, 1, "mirror_update: mirrored field", when="walls"),
        T("fields.mass", F_, "1", 8, 1, "mirror_update: m", when="walls"),
    ],
    "contact pass 2": [  # contact_pass_2 on the updated velocities, pair sums
        T("fields.mass", "slot", "1", 8, 1, "slot masses"),
        T("fields.vnew", "slot", "dim", 8, 2, "slot velocities changed (and a copy before)", count="2"),
        T("fields.acc", "slot", "dim", 8, 2, "slot accelerations changed"),
        T("contact.normal", "slot", "dim", 8, 1, "normal"),
        T("contact.role", "slot", "1", 8, 1, "role"),
        T("contact.partner", "slot", "1", 8, 1, "partner"),
        T("contact.delta", "slot", "1", 8, 1, "separation"),
        T("contact.area", "slot", "1", 8, 1, "area"),
        T("contact.law", "slot", "1", 8, 1, "law"),
        T("contact.mu", "slot", "1", 8, 1, "friction"),
        T("contact.stick2", "slot", "dim", 8, 1, "decisions written"),
        T("contact.applied2", "slot", "dim", 8, 1, "decisions written"),
        T("contact.hold", "slot", "dim", 8, 1, "pass 1's holding change, into a (FLIP)", when="hold"),
    ],
    "particle update": [  # particle_update_kernel(FLIP)
        T("entries.nodes", P_, "K", 8, 1, "field of each entry"),
        T("sd.S", P_, "K", 8, 1, "weights"),
        T("particles.x", P_, "dim", 8, 2, "x += dt S (v + v+)/2"),
        T("particles.v", P_, "dim", 8, 2, "V += dt S a"),
        T("particles.mass", P_, "1", 8, 1, "m_p (work of gravity)"),
        T("fields.acc", E_, "dim", 8, 1, "gather a"),
        T("fields.vnew", E_, "dim", 8, 1, "gather v+"),
        T("fields.vstart", E_, "dim", 8, 1, "gather v"),
    ],
    "move rigid": [  # numpy on the rigid particles
        T("rigid.mat", R_, "1", 8, 1, "material of each rigid particle (two fancy indexings)", count="2"),
        T("tmp:rigid", R_, "dim", 8, 2, "temporaries mean[mat], dt * it, v_end[mat]: written, read", count="3"),
        T("rigid.x", R_, "dim", 8, 2, "x += dt mean"),
        T("rigid.v", R_, "dim", 8, 1, "v = v_end written"),
    ],
    "re-extrapolate": [  # zero_fields, p2g_momentum without masses
        T("box.fields", F_, "1", 8, 1, "zero_fields"),
        T("fields.mom", F_, "dim", 8, 1, "zeroed"),
        T("box.order", P_, "1", 8, 1, "particle order"),
        T("particles.mass", P_, "1", 8, 1, "m_p"),
        T("particles.v", P_, "dim", 8, 1, "v_p (updated)"),
        T("entries.nodes", P_, "K", 8, 1, "field of each entry"),
        T("sd.S", P_, "K", 8, 1, "weights"),
        T("fields.mom", E_, "dim", 8, 2, "scatter p_i"),
        T("contact.rfidx", R_, "K", 8, 1, "scatter_rigid_slots: rigid slot entries", when="contact rigid"),
    ],
    "contact pass 3": [  # exchange_pass: pass 2's decisions on the re-extrapolated momenta
        T("fields.mass", "slot", "1", 8, 1, "slot masses"),
        T("fields.mom", "slot", "dim", 8, 2, "slot momenta changed"),
        T("contact.normal", "slot", "dim", 8, 1, "normal"),
        T("contact.role", "slot", "1", 8, 1, "role"),
        T("contact.partner", "slot", "1", 8, 1, "partner"),
        T("contact.contact2", "slot", "1", 8, 1, "pass 2's contact flag"),
        T("contact.dp1", "slot", "dim", 8, 1, "change written"),
        T("contact.contact_step", "cn", "1", 8, 1, "each node's last contact step (the hold)", when="hold"),
        T("contact.hold", "slot", "dim", 8, 1, "holding change written", when="hold"),
    ],
    "update stress last": _GRID_VELOCITY + _STRESS,
    "check stability": [  # every step: rigid bodies in the grid, particles inside rigid bodies
        T("rigid.x", R_, "dim", 8, 1, "rigid positions against the domain (two comparisons)", count="2",
          when="rigid"),
        T("particles.x", P_, "dim", 8, 1, "_first_inside: particle positions against the rigid lattices",
          when="rigid"),
        # every check_every steps: particle_sums (energy balance)
        T("particles.vol", P_, "1", 8, 1, "particle_sums", count="1/every"),
        T("particles.stress", P_, "6", 8, 1, "particle_sums", count="1/every"),
        T("particles.v", P_, "dim", 8, 1, "particle_sums", count="1/every"),
        T("particles.mass", P_, "1", 8, 1, "particle_sums", count="1/every"),
        T("particles.F", P_, "dim*dim", 8, 1, "particle_sums", count="1/every"),
        T("particles.mat", P_, "1", 8, 1, "particle_sums", count="1/every"),
    ],
}


# ------------------------------------------------------------------------------- the accounting
def scene_numbers(sim) -> dict:
    """The numbers the accounting's expressions use, from the scene (not from the arrays, so
    the test can check the one against the other)."""
    st = sim.state
    cs = st.contact
    return {"K": st.shape.nodes_per_particle(st.dim), "dim": st.dim, "nr": max(len(st.materials.rigid), 1),
            "every": sim.check.every, "G": cs.spec.n_groups if cs is not None else 1}


def conditions(sim) -> set[str]:
    st = sim.state
    on = set()
    if st.rigid.n:
        on.add("rigid")
    if has_walls(st):
        on.add("walls")
    if st.contact is not None:
        on.add("contact")
        if st.contact.spec.needs_cloud:
            on.add("cloud")
        if st.contact.spec.warm_start:
            on.add("warm")
        if st.contact.spec.persist and st.contact.spec.passes == 2:
            on.add("hold")  # (pass 2 reads the holding change only under FLIP: counted for every update)
    return on


def rows_per_particle(sim) -> dict[str, float]:
    """Rows of each kind touched per deformable particle, measured from the state now."""
    st = sim.state
    n = st.particles.n
    cs = st.contact
    return {P_: 1.0, R_: st.rigid.n / n, F_: st.box.fields.size / n,
            "slot": (cs.n_slots / n) if cs is not None else 0.0, "cn": (cs.n_cn / n) if cs is not None else 0.0,
            "cloud": (cs.cloud_idx.size / n) if cs is not None and cs.cloud_idx is not None else 0.0}


def term_bytes(term: Term, numbers: dict) -> float:
    """Bytes of one term per row."""
    return eval(term.elems, {}, numbers) * term.itemsize * term.passes * eval(term.count, {}, numbers)


def resolve(state, path: str):
    obj = state
    for part in path.split("."):
        obj = getattr(obj, part)
    return obj


def task_bytes(sim, task: str) -> tuple[float, float]:
    """(bytes streamed per particle-step, bytes of grid gathers and scatters per particle-step)
    of one task, from TRAFFIC and the state's row counts."""
    numbers, on, rows = scene_numbers(sim), conditions(sim), rows_per_particle(sim)
    streamed = gathered = 0.0
    for term in TRAFFIC[task]:
        if term.when is not None and not set(term.when.split()) <= on:
            continue
        b = term_bytes(term, numbers)
        if term.per == E_:
            gathered += b * numbers["K"]
        else:
            streamed += b * rows[term.per]
    return streamed, gathered


SHAPE_DATA = ("sd.nodes", "sd.S", "sd.G", "entries.nodes", "contact.fidx", "sd.lowest")


def shape_data_bytes(sim) -> float:
    """Bytes per particle-step of the deformable particles' shape data (node or field
    indices, S, G, lowest node) over every task of the step."""
    numbers, on = scene_numbers(sim), conditions(sim)
    return sum(term_bytes(t, numbers) for task in sim.integrator.timers if task in TRAFFIC
               for t in TRAFFIC[task] if t.path in SHAPE_DATA and t.per == P_
               and (t.when is None or set(t.when.split()) <= on))


def used_terms(sim, task: str) -> list[Term]:
    """The terms of a task that apply to this scene."""
    on = conditions(sim)
    return [t for t in TRAFFIC[task] if t.when is None or set(t.when.split()) <= on]


# ---------------------------------------------------------------------------- machine numbers
@njit(cache=True)
def triad(a, b, c, s):
    for i in range(a.size):
        a[i] = b[i] + s * c[i]


@njit(cache=True, parallel=True)
def triad_threads(a, b, c, s):
    for i in prange(a.size):
        a[i] = b[i] + s * c[i]


def triad_gbs(n: int, repeats: int, kernel=triad) -> float:
    """Best triad bandwidth (GB/s, 3 x 8 bytes per element) over arrays of n elements."""
    a, b, c = np.zeros(n), np.random.rand(n), np.random.rand(n)
    kernel(a, b, c, 3.0)
    inner = max(1, int(2e7 // n))  # short arrays: repeat inside one timing
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(inner):
            kernel(a, b, c, 3.0)
        best = min(best, (time.perf_counter() - t0) / inner)
    return 24.0 * n / best / 1e9


@njit(cache=True)
def mul_add_chains(n, a, b):
    """12 independent chains of x = x a + b (numba does not contract to FMA without fastmath:
    a multiply and an add each)."""
    x0 = x1 = x2 = x3 = x4 = x5 = 1.0
    y0 = y1 = y2 = y3 = y4 = y5 = 2.0
    for _ in range(n):
        x0 = x0 * a + b
        x1 = x1 * a + b
        x2 = x2 * a + b
        x3 = x3 * a + b
        x4 = x4 * a + b
        x5 = x5 * a + b
        y0 = y0 * a + b
        y1 = y1 * a + b
        y2 = y2 * a + b
        y3 = y3 * a + b
        y4 = y4 * a + b
        y5 = y5 * a + b
    return x0 + x1 + x2 + x3 + x4 + x5 + y0 + y1 + y2 + y3 + y4 + y5


def flop_rate(repeats: int = 5) -> float:
    """Best rate of scalar floating-point operations (a multiply or an add) per second."""
    n = 5_000_000
    mul_add_chains(10, 0.999999, 1e-7)
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        mul_add_chains(n, 0.999999, 1e-7)
        best = min(best, time.perf_counter() - t0)
    return 24.0 * n / best


def stress_flops(K: int, dim: int) -> dict[str, int]:
    """Floating-point operations of one particle's neo-Hookean stress update (2D plane strain
    on 3x3 algebra), counted from tasks/stress.py and materials/neo_hookean.neo_hookean_stress_2d; a
    multiply, add, compare or abs is one, a divide, sqrt or cbrt is listed apart (each costs
    several multiplies' time)."""
    return {
        "L = sum v_i (x) G_ip": 2 * K * dim * dim,  # a multiply and an add per term
        "F <- F + dt L F": dim * dim * dim * 3,  # dt * L * F + s per term
        "det3 (twice: kernel and model)": 2 * 14,
        "b = F F^T (6 components of 3x3)": 6 * 5,
        "trace, pressure, c, stress": 3 + 3 + 2 + 9,
        "wave modulus (Gershgorin bound)": 6 + 6 + 2 + 6,
        "J0, volume, |v|, c + |v|, finite checks": 2 + 2 * dim + 3 + 6,
        "divides": 5,  # vol/vol0, 1/J twice, G/(J cj cj), modulus J / density
        "sqrt and cbrt": 3,  # sqrt twice, cbrt once
    }


@njit(cache=True, inline="always")
def no_model(pr, L, dt, F3, J, f00, f01, f10, f11, s, W, A, Ai, Q, eos, hs):
    """A stand-in for the neo-Hookean model costing next to nothing (stress from F11 only), in
    the models' stress signature (mpmsim/materials/model.py)."""
    for a in range(6):
        s[a] = pr[0] * f00
    return pr[0] + pr[1]


def without_model():
    """The neo-Hookean stress kernel with the model replaced by `no_model` (the rest as is):
    its in-cache time against the real kernel's is the model's cost."""
    kernel = update_stress_kernel(NEO_HOOKEAN, False, 2)
    return njit(cache=True, error_model="numpy")(specialize(kernel.py_func, "no_model_2d", STRESS=no_model))


def replays(sim) -> dict:
    """For the per-particle kernels: task -> a function running the task's kernel(s) as the step
    does, on the first m particles only (a leading slice of every particle array). With dt = 0
    the particles are left as they were; the scatters add into grid rows the next step zeroes."""
    st = sim.state
    P, sd, f, g = st.particles, st.entries, st.fields, st.grid
    view = P.view()
    stress = update_stress_kernel(NEO_HOOKEAN, False, 2)
    flip = particle_update_kernel(FLIP, MIDPOINT, 2)
    M = st.materials.view()
    gv = GridVelocities(f.vnew, f.acc, f.vstart, f.vstar)
    lo, hi = st.particle_bounds

    def cut(m):
        pm = view._replace(**{k: getattr(view, k)[:m] for k in view._fields if len(getattr(view, k)) == P.n})
        em = sd._replace(**{k: getattr(sd, k)[:m] for k in sd._fields})
        sc = Scatter(st.box.order[:m], np.array([0, m], dtype=np.int64), em.nodes, em.S)
        return pm, em, sc

    def shape(m):
        pm, em, _ = cut(m)
        st.shape.compute(pm.x, pm.F, P.semi, g, 1, st.sd._replace(**{k: getattr(st.sd, k)[:m] for k in st.sd._fields}))

    def extrapolate(m):
        pm, em, sc = cut(m)
        p2g_momentum(sc, pm.mass, pm.v, True, f.mass, f.mom, False, P.C, em.lowest, st.entry_offsets, g.view, pm.x)

    def reextrapolate(m):
        pm, em, sc = cut(m)
        p2g_momentum(sc, pm.mass, pm.v, False, f.mass, f.mom, False, P.C, em.lowest, st.entry_offsets, g.view, pm.x)

    def forces(m):
        pm, em, sc = cut(m)
        p2g_forces(sc, em.G, em.T, pm, st.gravity, bool(st.gravity.any()), f.force)

    def update_stress(m):
        pm, em, _ = cut(m)
        stress(em, f.vel, 0.0, pm, M, 1.0, 1, np.zeros(1), Faults.empty(1))

    stub = without_model()

    def stress_without_model(m):
        pm, em, _ = cut(m)
        stub(em, f.vel, 0.0, pm, M, 1.0, 1, np.zeros(1), Faults.empty(1))

    def particle_update(m):
        pm, em, _ = cut(m)
        flip(em, st.entry_offsets, g.view, gv, 0.0, pm, st.gravity, lo, hi, 1, np.zeros(1), Faults.empty(1))

    out = {"shape functions": shape, "extrapolate": extrapolate, "forces": forces, "re-extrapolate": reextrapolate,
           "update stress first": update_stress, "update stress last": update_stress}
    out["stress without the model"] = stress_without_model  # (not a task: the model's cost)
    if sim.scene.deck.update.scheme == "flip":
        out["particle update"] = particle_update
    return out


SIZES = (128, 2048)  # particles of an in-cache replay (2048: about 0.8 MB of particle data, in L2)


def replay_times(run, best: list, repeats: int = 10) -> None:
    """Best seconds per call of a kernel on the first m particles (m in SIZES, data already in
    L2), folded into `best` (one entry per size); many short timings, so that on a shared
    machine some of them run undisturbed."""
    for j, m in enumerate(SIZES):
        run(m)
        for _ in range(10):
            t0 = time.perf_counter()
            for _ in range(repeats):
                run(m)
            best[j] = min(best[j], (time.perf_counter() - t0) / repeats)


def per_particle(best: list) -> float:
    """t(m) = a + b m through the two sizes: b, the in-cache time per particle (a: the call's
    fixed cost)."""
    return (best[1] - best[0]) / (SIZES[1] - SIZES[0])


@njit(cache=True)
def cube_roots(a, out, inline):
    for i in range(a.size):
        out[i] = cube_root(a[i]) if inline else np.cbrt(a[i])


def cbrt_seconds(inline: bool = False) -> float:
    """Seconds per cube root in a compiled loop over volume ratios in [0.5, 1.5]: np.cbrt (a
    libm call: never vectorized) or, `inline`, materials.kernels.cube_root (the neo-Hookean
    update's: the same bits in line)."""
    a = np.random.rand(4096) + 0.5
    out = np.empty_like(a)
    cube_roots(a, out, inline)
    best = np.inf
    for _ in range(20):
        t0 = time.perf_counter()
        for _ in range(20):
            cube_roots(a, out, inline)
        best = min(best, (time.perf_counter() - t0) / 20 / a.size)
    return best


# ------------------------------------------------------------------------------------ decks
def deck_text(path: Path, edit=None) -> str:
    data = yaml.safe_load(path.read_text())
    if edit is not None:
        edit(data)
    return yaml.safe_dump(data, sort_keys=False)


def simulation(path: Path, threads: int = 1, edit=None) -> Simulation:
    numba.set_num_threads(threads)
    loaded = load_deck_text(deck_text(path, edit), path)
    return Simulation(build_scene(loaded), out_dir=None, threads=threads)


def shrink(data: dict) -> None:
    """The deck cut to a 4 x 4 mm body (64 particles; the two-block deck: two 4 x 2 mm
    blocks) under a 4 x 2 mm platen: the same tasks and kernels, nearly no work."""
    deformable = [b for b in data["bodies"] if data["materials"][b["material"]]["type"] != "rigid"]
    rigid = [b for b in data["bodies"] if data["materials"][b["material"]]["type"] == "rigid"]
    height = 4.0 / len(deformable)
    for i, body in enumerate(deformable):
        body["min"], body["max"] = [0.0, i * height], [4.0, (i + 1) * height]
    for body in rigid:
        body["min"], body["max"] = [0.0, 4.0], [4.0, 6.0]


def timed(sim, steps: int, warmup: int) -> tuple[float, dict[str, float]]:
    """(seconds per step, seconds per step of each task) over `steps` warm steps."""
    wall = steps_wall(sim, steps, warmup)
    return wall / steps, {k: v / steps for k, v in sim.timers.items() if k != "output"}


def best_of(runs: list[tuple[float, dict]]) -> tuple[float, dict]:
    """The fastest step of several runs, and per task its fastest time."""
    wall = min(r[0] for r in runs)
    tasks = {k: min(r[1][k] for r in runs) for k in runs[0][1]}
    return wall, tasks


def state_bytes(sim) -> int:
    """What the step cycles through: the particles' arrays, their shape data, the active grid rows."""
    st = sim.state
    P = st.particles
    arrays = [P.x, P.v, P.mass, P.vol, P.vol0, P.F, P.stress, P.mat, *st.sd, st.box.order]
    total = sum(a.nbytes for a in arrays)
    rows = st.box.fields.size
    f = st.fields
    total += sum(a[:rows].nbytes for a in (f.mass, f.mom, f.force, f.vel, f.vnew, f.acc, f.vstart))
    return total


# ------------------------------------------------------------------------------------ report
def classify(t: float, floors: dict[str, float]) -> str:
    """The floor (fixed cost, memory, in-cache core time) that explains most of a task's time:
    `<floor>-bound` when it explains at least half."""
    kind, floor = max(floors.items(), key=lambda kv: kv[1])
    if t <= 0 or floor >= 0.5 * t:
        return f"{kind}-bound"
    return f"mixed ({kind} {100 * floor / t:.0f}%)"


def deck_report(name: str, steps: int, rounds: int, bw_mem: float) -> dict:
    path = DECKS[name]
    sims = {"full": simulation(path), "tiny": simulation(path, edit=shrink)}
    runs = {"full": [], "tiny": []}
    warm = sims["full"].check.every + 2  # the first energy check's kernels loaded before timing
    sim = sims["full"]
    kernels, best = None, {}
    for r in range(rounds):  # alternate the two scenes and the in-cache replays
        runs["full"].append(timed(sims["full"], steps, warm if r == 0 else 2))
        runs["tiny"].append(timed(sims["tiny"], 10 * steps, warm if r == 0 else 2))
        kernels = kernels or replays(sim)
        for task, run in kernels.items():
            if task != "update stress last":  # the same kernel as the first
                replay_times(run, best.setdefault(task, [np.inf, np.inf]))
    n = sim.state.particles.n
    wall, tasks = best_of(runs["full"])
    _, tiny = best_of(runs["tiny"])
    ws = state_bytes(sim)
    bw_ws = triad_gbs(max(ws // 24, 1000), 5)
    in_l2 = {task: per_particle(b) for task, b in best.items()}
    if "update stress first" in in_l2:
        in_l2["update stress last"] = in_l2["update stress first"]
    numbers = scene_numbers(sim)
    rows = rows_per_particle(sim)
    total = sum(tasks.values())
    print(f"\n## {name}: {n} particles, {sim.state.rigid.n} rigid, {sim.state.box.fields.size} active fields "
          f"({rows[F_]:.3f} per particle), K = {numbers['K']}, 1 thread; best of {rounds} x {steps} steps")
    print(f"step {wall * 1e6:.0f} us = {n / wall / 1e6:.2f} M particle-steps/s (goal {GOAL[name] / 1e6:.1f} M/s: "
          f"step {n / GOAL[name] * 1e6:.0f} us); state {ws / 1e6:.1f} MB; triad at that size {bw_ws:.1f} GB/s, "
          f"in memory {bw_mem:.1f} GB/s")
    print("| task | us/step | % | B/particle-step | GB/s | % of triad (state size) | % of triad (memory) | "
          "gather+scatter B/p | in-L2 us/step | fixed us (64 p) | bound |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    out = {"n": n, "wall": wall, "tasks": {}, "bw_ws": bw_ws, "bw_mem": bw_mem, "in_l2": in_l2, "K": numbers["K"],
           "dim": numbers["dim"]}
    sums = np.zeros(3)
    for task, t in tasks.items():
        streamed, gathered = task_bytes(sim, task) if task in TRAFFIC else (float("nan"), float("nan"))
        gbs = streamed * n / t / 1e9 if t > 0 else 0.0
        floors = {"overhead": tiny.get(task, 0.0), "memory": streamed * n / (bw_ws * 1e9)}
        if task in in_l2:
            floors["core"] = in_l2[task] * n
        bound = classify(t, floors)
        sums += [streamed, in_l2.get(task, 0.0) * n, tiny.get(task, 0.0)]
        out["tasks"][task] = {"t": t, "bytes": streamed, "gbs": gbs, "fixed": tiny.get(task, 0.0), "bound": bound,
                              "l2": in_l2.get(task, np.nan) * n}
        l2 = f"{in_l2[task] * n * 1e6:.0f}" if task in in_l2 else "-"
        print(f"| {task} | {t * 1e6:.0f} | {100 * t / total:.1f} | {streamed:.0f} | {gbs:.2f} | "
              f"{100 * gbs / bw_ws:.0f} | {100 * gbs / bw_mem:.0f} | {gathered:.0f} | {l2} | {tiny.get(task, 0.0) * 1e6:.0f} | {bound} |")
    gbs = sums[0] * n / total / 1e9
    print(f"| whole step | {total * 1e6:.0f} | 100 | {sums[0]:.0f} | {gbs:.2f} | {100 * gbs / bw_ws:.0f} | "
          f"{100 * gbs / bw_mem:.0f} | | {sums[1] * 1e6:.0f} | {sums[2] * 1e6:.0f} | |")
    out["bytes"] = sums[0]
    goal = n / GOAL[name]
    print(f"gap to the goal: {(total - goal) * 1e6:.0f} us/step of {total * 1e6:.0f} ({100 * (1 - goal / total):.0f}% "
          f"of the step); all bytes at the state-size triad: {sums[0] * n / bw_ws / 1e3:.0f} us, at the memory "
          f"triad: {sums[0] * n / bw_mem / 1e3:.0f} us; in-cache replays sum to {sums[1] * 1e6:.0f} us, fixed "
          f"costs to {sums[2] * 1e6:.0f} us")
    sdb = shape_data_bytes(sim)
    print(f"shape data (indices, S, G, lowest) over the step: {sdb:.0f} B/particle-step; float32 weights and "
          f"int32 indices halve it: {sdb / 2:.0f} B less, at most {sdb / 2 * n / bw_ws / 1e3:.0f} us/step at the "
          f"state-size triad, {sdb / 2 * n / bw_mem / 1e3:.0f} us/step at the memory triad")
    return out


def flops_report(results: dict, rate: float, cbrt: float) -> None:
    """The stress update against the machine's multiply/add rate."""
    print(f"\nscalar multiply/add rate (12 chains, numba): {rate / 1e9:.2f} Gflop/s; np.cbrt: {cbrt * 1e9:.1f} ns "
          f"per call, the inlined cube_root the update uses: {cbrt_seconds(inline=True) * 1e9:.1f} ns (one per "
          "particle per neo-Hookean update)")
    for name, res in results.items():
        if "update stress first" not in res["in_l2"]:
            continue
        flops = stress_flops(res["K"], res["dim"])
        nflop = sum(v for k, v in flops.items() if k not in ("divides", "sqrt and cbrt"))
        t = res["tasks"]["update stress first"]["t"] / res["n"]
        l2 = res["in_l2"]["update stress first"]
        print(f"{name}, stress update per particle: in the step {t * 1e9:.1f} ns, in L2 {l2 * 1e9:.1f} ns; "
              f"{nflop} flops + {flops['divides']} divides + {flops['sqrt and cbrt']} sqrt/cbrt: "
              f"{nflop / rate * 1e9:.1f} ns at that rate ({100 * nflop / rate / l2:.0f}% of the in-L2 time)")
        rest = res["in_l2"].get("stress without the model")
        if rest is not None:
            print(f"  the neo-Hookean model (b = F F^T, cube root, stress, wave modulus) is {(l2 - rest) * 1e9:.1f} "
                  f"ns of the {l2 * 1e9:.1f} (kernel without it: {rest * 1e9:.1f} ns)")


# ---------------------------------------------------------------------------- 256k particles
def big_deck(folder: Path, steps: int) -> Path:
    """The column at 1/4 the cell size (16x the particles: 256 000), run for about `steps`
    steps; output intervals as in the deck (a frame or history row only at the start and end)."""
    base = DECKS["column"]

    def edit(data):
        data["grid"]["cell_size"] = data["grid"]["cell_size"] / 4

    sim = simulation(base, 1, edit)
    dt = sim.integrator.stable_dt(sim.state)
    data = yaml.safe_load(deck_text(base, edit))
    data["time"]["end"] = steps * dt
    data["output"]["checkpoint_interval"] = "off"
    path = folder / "column256k.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def cli_rate(deck: Path, out: Path, threads: int) -> tuple[float, float, float]:
    """(M particle-steps/s of the run log's task table, output seconds, wall seconds of the run)."""
    cmd = [sys.executable, "-m", "mpmsim", "run", str(deck), "--out", str(out), "--quiet", "--threads", str(threads)]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    subprocess.run(cmd, check=True, capture_output=True, text=True, env=env)
    log = " ".join((out / f"{deck.stem}_run.log").read_text().split())
    rate = float(re.search(r"([\d.]+) M particle-steps/s", log).group(1))
    wall = float(re.search(r"([\d.]+) s wall", log).group(1))
    output = float(re.search(r"│ output │ ([\d.]+) │", log).group(1)) if "│ output │" in log else float("nan")
    return rate, output, wall


def big_report(steps: int, rounds: int, bw_mem: float) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        deck = big_deck(folder, steps + 1)
        sims = {th: simulation(deck, th) for th in (1, 2) if th <= numba.config.NUMBA_NUM_THREADS}
        n = sims[1].state.particles.n
        for th, sim in sims.items():  # load (or compile) both kernel forms
            numba.set_num_threads(th)
            total_sums(sim.state)  # (the energy check's kernel)
            sim.step()
        cli_rate(deck, folder / "warm", 1)
        rows: dict[str, list[tuple[float, float]]] = {}
        task_runs: dict[int, list] = {}
        outputs = []
        cpus = os.sched_getaffinity(0)
        for _ in range(rounds):
            for th in sims:
                numba.set_num_threads(th)
                fresh = simulation(deck, th)
                busy = busy_cores(cpus)
                run = timed(fresh, steps - 2, 2)
                task_runs.setdefault(th, []).append(run)
                rows.setdefault(f"Simulation.step(), {th} thread(s)", []).append((n / run[0] / 1e6, busy))
            busy = busy_cores(cpus)
            rate, output, run_wall = cli_rate(deck, folder / "run", 1)
            rows.setdefault("mpmsim run --threads 1 (log's rate)", []).append((rate, busy))
            outputs.append((output, run_wall))
        sim = fresh
    print(f"\n## column at 0.25 mm cells: {n} particles, about {steps} steps per measurement, best of {rounds}")
    print("| variant | M particle-steps/s each round (other processes' busy cores just before) | best |")
    print("|---|---|---|")
    best = {}
    for label, rates in rows.items():
        best[label] = max(r for r, _ in rates)
        print(f"| {label} | {', '.join(f'{r:.2f} ({b:.1f})' for r, b in rates)} | {best[label]:.2f} |")
    one = best["Simulation.step(), 1 thread(s)"]
    cli = best["mpmsim run --threads 1 (log's rate)"]
    print(f"mpmsim run / Simulation.step() on 1 thread: {cli / one:.3f} (goal >= 0.9)")
    output, run_wall = min(outputs)
    print(f"mpmsim run: output (first and last frame and history) {output:.2f} s of a {run_wall:.1f} s run "
          "(outside the log's rate)")
    two = best.get("Simulation.step(), 2 thread(s)")
    if two is not None:
        print(f"speed-up 1 -> 2 threads: {two / one:.2f} (goal >= 1.8)")
    if 2 in sims:
        numba.set_num_threads(2)
        busy = busy_cores(os.sched_getaffinity(0))
        print(f"triad in memory on 2 threads: {triad_gbs(1 << 24, 7, triad_threads):.2f} GB/s (1 thread: "
              f"{bw_mem:.2f}; other processes kept {busy:.1f} cores busy just before)")
        numba.set_num_threads(1)
    per = {th: best_of(r)[1] for th, r in task_runs.items()}
    print("| task | 1 thread us/step | B/particle-step | GB/s | % of triad (memory) | 2 threads us/step | speed-up |")
    print("|---|---|---|---|---|---|---|")
    for task, t1 in per[1].items():
        streamed = task_bytes(sim, task)[0] if task in TRAFFIC else float("nan")
        gbs = streamed * n / t1 / 1e9 if t1 > 0 else 0.0
        t2 = per.get(2, {}).get(task)
        two_cols = f"{t2 * 1e6:.0f} | {t1 / t2:.2f}" if t2 else "- | -"
        print(f"| {task} | {t1 * 1e6:.0f} | {streamed:.0f} | {gbs:.2f} | {100 * gbs / bw_mem:.0f} | {two_cols} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=100, help="timed steps per round (16 000-particle decks)")
    ap.add_argument("--rounds", type=int, default=5, help="alternating rounds at 16 000 particles (best kept)")
    ap.add_argument("--big-rounds", type=int, default=3, help="alternating rounds at 256 000 particles")
    ap.add_argument("--skip-256k", action="store_true", help="leave out the 256 000-particle part (slow)")
    ap.add_argument("--big-steps", type=int, default=30, help="steps per measurement at 256 000 particles")
    args = ap.parse_args()
    t0 = time.perf_counter()
    print(f"# {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, {platform.node()} "
          f"({platform.processor() or platform.machine()}), {len(os.sched_getaffinity(0))} cores; "
          f"timings: best of {args.rounds} alternating rounds")
    numba.set_num_threads(1)
    print(f"other processes kept {busy_cores(os.sched_getaffinity(0)):.1f} cores busy at the start")
    bw_mem = triad_gbs(1 << 24, 7)
    print(f"triad over 3 x {8 * (1 << 24) / 2**20:.0f} MiB arrays (3 x 8 bytes per element, no write-allocate): "
          f"{bw_mem:.2f} GB/s")
    results = {name: deck_report(name, args.steps, args.rounds, bw_mem) for name in DECKS}
    flops_report(results, flop_rate(), cbrt_seconds())
    if not args.skip_256k:
        big_report(args.big_steps, args.big_rounds, bw_mem)
    print(f"\n(traffic.py took {time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
