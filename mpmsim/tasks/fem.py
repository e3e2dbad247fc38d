"""Tasks of the FEM bodies' explicit step: velocity Verlet with the augury contact correction
(the APIC augury paper's Eq. 32; docs/fem-contact.md):

  fem kick-drift   v^{n+1/2} = v^n + dt/2 A^n (B the same with its rate), x^{n+1} = x^n + dt v^{n+1/2}
  fem forces       a = f(x^{n+1}) / m + g (held components: 0)
  augury contact   boundary nodes: V̄ = (v^{n+1/2} + tau a, B^{n+1/2}), Â from the augury
                   transfers (mpmsim/augury.py), A^{n+1} = a + Â, Ḃ = Â_B
  fem kick         v^{n+1} = v^{n+1/2} + dt/2 A^{n+1}

Held components take their prescribed velocity at every kick. The work of the contact part
of each kick, m dt/2 Â . (v_before + v_after)/2 (and its affine counterpart), is summed per
body (`contact_work`); gravity's work m g . dx goes to the run's external work.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ..augury import FRICTION, KERNELS, STICK_SEPARATE, AuguryGrid, correction, grid_entries
from ..fem import elements
from ..fem.explicit import accelerations
from ..fem.mesh import node_normal_kernel


class AugurySpec(NamedTuple):
    grid: AuguryGrid
    iterations: int
    tau: float | None  # None: the time step
    mu: np.ndarray  # (nb,) friction of each FEM boundary node
    mu_of_material: np.ndarray  # (n_materials,) friction of an augury particle of each material
    rule: int  # augury.FRICTION or STICK_SEPARATE


def augury_spec(scene, fem, particle_mats=()) -> AugurySpec | None:
    """The deck's augury contact (None without contact.augury). The augury particles are the
    FEM boundary nodes and the surface particles of particle bodies; each takes the law between
    its material and the other participating material when there are two, else contact.default."""
    c = scene.deck.contact
    if c.augury is None:
        return None
    a = c.augury
    mats = scene.materials
    default = c.default
    rule = STICK_SEPARATE if default.law == "stick" else FRICTION
    node_mat = np.zeros(fem.n, dtype=np.int64)
    node_mat[fem.cells.ravel()] = np.repeat(fem.cell_mat, fem.cells.shape[1])
    used = sorted(set(int(m) for m in fem.cell_mat) | set(int(m) for m in particle_mats))
    mu_of = np.full(len(mats.deformable), default.friction if default.law == "coulomb" else 0.0)
    if len(used) == 2:
        names = [mats.deformable[m] for m in used]
        for pair in c.pairs:
            if set(pair.between) == set(names):
                mu_of[used] = pair.friction if pair.law == "coulomb" else 0.0
                if pair.law == "stick":
                    rule = STICK_SEPARATE
    grid = AuguryGrid(float(a.cell_size), KERNELS[a.kernel], a.transfer == "apic")
    return AugurySpec(grid, int(a.iterations), a.tau, mu_of[node_mat[fem.boundary]], mu_of, rule)


@njit(cache=True)
def kick(v, a, a_contact, mass, held, held_velocity, node_body, half_dt, work):
    """v += dt/2 a on free components (held ones: their prescribed velocity); the contact
    part's work m dt/2 a_c . (v_before + v_after)/2 added per body."""
    n, dim = v.shape
    for i in range(n):
        for d in range(dim):
            if held[i, d]:
                v[i, d] = held_velocity[i, d]
                continue
            before = v[i, d]
            v[i, d] = before + half_dt * a[i, d]
            if a_contact[i, d] != 0.0:
                work[node_body[i]] += mass[i] * half_dt * a_contact[i, d] * 0.5 * (before + v[i, d])


@njit(cache=True)
def kick_affine(B, Bdot, Dinv, mass, boundary, node_body, half_dt, work):
    """B += dt/2 Ḃ of the boundary nodes, with the work of that change on the affine kinetic
    energy 1/2 m tr(B D^-1 B^T) added per body."""
    nb, dim = B.shape[0], B.shape[1]
    for q in range(nb):
        w = 0.0
        for a in range(dim):
            for c in range(dim):
                before = B[q, a, c]
                B[q, a, c] = before + half_dt * Bdot[q, a, c]
                mid = 0.5 * (before + B[q, a, c])
                for b in range(dim):  # Ḃ_ab D^-1_bc B_ac
                    w += Bdot[q, a, b] * Dinv[q, b, c] * mid
        i = boundary[q]
        work[node_body[i]] += mass[i] * half_dt * w


@njit(cache=True)
def drift_work(x, v, dt, mass, gravity):
    """x += dt v; returns the work of gravity over the move, sum m g . dx (exact for a
    constant body force)."""
    n, dim = x.shape
    work = 0.0
    for i in range(n):
        for d in range(dim):
            dx = dt * v[i, d]
            x[i, d] += dx
            work += mass[i] * gravity[d] * dx
    return work


def first_accelerations(state, fem, gravity) -> None:
    """A^0 before the first step: the mechanical accelerations at the initial positions."""
    m = state.materials
    bad = elements.internal_forces(fem.x, fem.cells, fem.Dm_inv, fem.vol0, fem.cell_mat, m.type_code, m.props,
                                   fem.force)
    accelerations(fem.force, fem.mass, gravity, fem.held, fem.a)
    fem.bad_element = int(bad)
    fem.started = True


def fem_tasks(scene, augury=None):
    """[(name, function, why)] of the FEM part of the explicit step; `augury`: the scene's
    AuguryContact task (None: no augury contact)."""
    from . import Task

    def kick_drift(state) -> None:
        fem = state.fem
        if not fem.started:
            first_accelerations(state, fem, state.gravity)
        half = 0.5 * state.dt
        kick(fem.v, fem.a, fem.a_contact, fem.mass, fem.held, fem.held_velocity, fem.node_body, half, fem.contact_work)
        kick_affine(fem.B, fem.Bdot, fem.Dinv, fem.mass, fem.boundary, fem.node_body, half, fem.contact_work)
        state.work_in += drift_work(fem.x, fem.v, state.dt, fem.mass, state.gravity)

    def forces(state) -> None:
        fem, m = state.fem, state.materials
        fem.bad_element = int(elements.internal_forces(fem.x, fem.cells, fem.Dm_inv, fem.vol0, fem.cell_mat,
                                                       m.type_code, m.props, fem.force))
        accelerations(fem.force, fem.mass, state.gravity, fem.held, fem.a)
        fem.a_contact[:] = 0.0

    def final_kick(state) -> None:
        fem = state.fem
        half = 0.5 * state.dt
        kick(fem.v, fem.a, fem.a_contact, fem.mass, fem.held, fem.held_velocity, fem.node_body, half, fem.contact_work)
        kick_affine(fem.B, fem.Bdot, fem.Dinv, fem.mass, fem.boundary, fem.node_body, half, fem.contact_work)

    tasks = [Task("fem kick-drift", kick_drift, "velocity Verlet: half kick, then positions"),
             Task("fem forces", forces, "internal forces of the elements" + (", gravity" if scene.deck.gravity else ""))]
    if augury is not None:
        a = scene.deck.contact.augury
        tasks.append(Task("augury contact", augury,
                          f"{a.transfer.upper()} augury, {a.iterations} iteration(s), {a.kernel} grid of "
                          f"{a.cell_size:g}: contact between FEM bodies"
                          + (" and particle bodies' surface particles" if scene.has_particles else "")))
    tasks.append(Task("fem kick", final_kick, "velocity Verlet: second half kick"))
    return tasks


@njit(cache=True)
def surface_particles(x, mass, body, grid, threshold):
    """(indices, outward normals) of the particles on their body's surface, seen on the augury
    grid: with m_i the body's own mass on node i, the first moment Σ_i N_ip m_i (x_i - x_p) is
    D_p ∇m, which points into the body and vanishes inside it. A particle is on the surface when
    that moment exceeds `threshold` x (Σ_i N_ip m_i) x h_c; its normal is minus the moment,
    normalized."""
    ent = grid_entries(x, grid)
    n, K = ent.node.shape
    dim = x.shape[1]
    nb = body.max() + 1 if n else 0
    gm = np.zeros((nb, ent.n_nodes))
    for p in range(n):
        for e in range(K):
            gm[body[p], ent.node[p, e]] += ent.weight[p, e] * mass[p]
    keep = np.zeros(n, dtype=np.bool_)
    normals = np.zeros((n, dim))
    mom = np.zeros(dim)
    for p in range(n):
        total = 0.0
        mom[:] = 0.0
        for e in range(K):
            wm = ent.weight[p, e] * gm[body[p], ent.node[p, e]]
            total += wm
            for d in range(dim):
                mom[d] += wm * ent.r[p, e, d]
        size = np.sqrt(np.sum(mom * mom))
        if size > threshold * total * grid.h:
            keep[p] = True
            for d in range(dim):
                normals[p, d] = -mom[d] / size
    idx = np.flatnonzero(keep)
    return idx, normals[idx]


@njit(cache=True)
def gather_boundary(x, v, a, mass, facets, boundary, tau):
    """Positions, masses, predicted velocities v + tau a and outward normals of the FEM
    boundary nodes."""
    normals = np.zeros_like(x)
    node_normal_kernel(x, facets, normals)
    nb = boundary.size
    dim = x.shape[1]
    xb = np.empty((nb, dim))
    vbar = np.empty((nb, dim))
    mb = np.empty(nb)
    nrm = np.empty((nb, dim))
    for q in range(nb):
        i = boundary[q]
        mb[q] = mass[i]
        for d in range(dim):
            xb[q, d] = x[i, d]
            vbar[q, d] = v[i, d] + tau * a[i, d]
            nrm[q, d] = normals[i, d]
    return xb, mb, vbar, nrm


@njit(cache=True)
def scatter_boundary(acc, boundary, held, a, a_contact):
    """Â of the boundary nodes into a (and a_contact); held components keep their motion."""
    a_contact[:] = 0.0
    dim = a.shape[1]
    for q in range(boundary.size):
        i = boundary[q]
        for d in range(dim):
            if not held[i, d]:
                a_contact[i, d] = acc[q, d]
                a[i, d] += acc[q, d]


@njit(cache=True)
def boundary_contact(x, v, a, mass, held, facets, boundary, B, mu, grid, iterations, tau, rule, a_contact, Bdot,
                     Dinv):
    """The augury correction of the boundary nodes (FEM bodies only): predicted
    V̄ = (v + tau a, B), Â added to a (held components: none) and kept in a_contact,
    Ḃ = Â_B, D^-1 of the transfer kept."""
    xb, mb, vbar, nrm = gather_boundary(x, v, a, mass, facets, boundary, tau)
    ent = grid_entries(xb, grid)
    acc, acc_B = correction(ent, mb, vbar, B if grid.apic else np.zeros_like(B), nrm, mu, grid, iterations, tau, rule)
    scatter_boundary(acc, boundary, held, a, a_contact)
    Bdot[:] = acc_B
    Dinv[:] = ent.Di


SURFACE_THRESHOLD = 0.05  # surface particles: |first moment| > 0.05 (local mass) h_c (surface_particles)


class AuguryContact:
    """The augury contact task: the correction Â of the FEM boundary nodes' accelerations and,
    when the scene has particle bodies, of their surface particles' velocities (particles take
    part as augury particles; their current velocity is their prediction). A particle's change
    over a step, dt Â (and dt Â_B to B for APIC particles with APIC transfers), is given as the
    FEM nodes get theirs, half at the end of this step and half at the start of the next
    (`carry`, before the particles' momenta go to the grid): at every output time both sides have
    received the same half, so the total momentum is exact then too. The laws are resolved at the
    first step (they need the state's arrays)."""

    def __init__(self, scene):
        self.scene = scene
        self.spec = None
        self.particles = scene.has_particles
        self.pending = None  # (particle indices, Â, Â_B) whose second half the next step gives

    def carry(self, state) -> None:
        """The second half of the previous step's particle corrections."""
        if self.pending is not None:
            idx, acc, acc_B = self.pending
            P = state.particles
            half = 0.5 * state.dt  # this step's dt, as the FEM nodes' first half kick uses
            P.v[idx] += half * acc
            if acc_B is not None:
                P.B[idx] += half * acc_B
            self.pending = None

    def __call__(self, state) -> None:
        fem = state.fem
        P = state.particles if self.particles else None
        if self.spec is None:
            self.spec = augury_spec(self.scene, fem, np.unique(P.mat) if P is not None else ())
        spec = self.spec
        tau = spec.tau if spec.tau is not None else state.dt
        if P is None or P.n == 0:
            boundary_contact(fem.x, fem.v, fem.a, fem.mass, fem.held, fem.facets, fem.boundary, fem.B, spec.mu,
                             spec.grid, spec.iterations, tau, spec.rule, fem.a_contact, fem.Bdot, fem.Dinv)
            return
        self.with_particles(state, fem, P, spec, tau)

    def with_particles(self, state, fem, P, spec, tau) -> None:
        grid = spec.grid
        idx, pn = surface_particles(P.x, P.mass, P.local_body, grid, SURFACE_THRESHOLD)
        xb, mb, vbar, nrm = gather_boundary(fem.x, fem.v, fem.a, fem.mass, fem.facets, fem.boundary, tau)
        nb, dim = xb.shape
        apic_particles = grid.apic and len(P.B) == P.n
        B = np.zeros((nb + idx.size, dim, dim))
        if grid.apic:
            B[:nb] = fem.B
            if apic_particles:
                B[nb:] = P.B[idx]
        x = np.concatenate([xb, P.x[idx]])
        ent = grid_entries(x, grid)
        acc, acc_B = correction(ent, np.concatenate([mb, P.mass[idx]]), np.concatenate([vbar, P.v[idx]]), B,
                                np.concatenate([nrm, pn]), np.concatenate([spec.mu, spec.mu_of_material[P.mat[idx]]]),
                                grid, spec.iterations, tau, spec.rule)
        scatter_boundary(acc[:nb], fem.boundary, fem.held, fem.a, fem.a_contact)
        fem.Bdot[:] = acc_B[:nb]
        fem.Dinv[:] = ent.Di[:nb]
        half = 0.5 * state.dt
        acc_p = acc[nb:]
        acc_pB = acc_B[nb:] if apic_particles else None
        P.v[idx] += half * acc_p
        if acc_pB is not None:
            P.B[idx] += half * acc_pB
        self.pending = (idx, acc_p, acc_pB)
