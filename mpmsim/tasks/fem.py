"""Tasks of the FEM bodies' explicit step: velocity Verlet with the augury contact correction
(the APIC augury paper's Eq. 32; docs/fem-contact.md):

  fem kick-drift   v^{n+1/2} = v^n + dt/2 A^n (B the same with its rate), x^{n+1} = x^n + dt v^{n+1/2}
  fem forces       a = f(x^{n+1}) / m + g (held components: 0)
  augury contact   boundary nodes: V̄ = (v^{n+1/2} + tau a, B^{n+1/2}), Â from the augury
                   transfers (mpmsim/contact/augury/transfers.py), A^{n+1} = a + Â, Ḃ = Â_B
  fem kick         v^{n+1} = v^{n+1/2} + dt/2 A^{n+1}

Held components take their prescribed velocity at every kick. The work of the contact part
of each kick, m dt/2 Â . (v_before + v_after)/2 (and its affine counterpart), is summed per
body (`contact_work`); gravity's work m g . dx goes to the run's external work.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..fem import elements
from ..fem.explicit import accelerations
from ..loads import ramped_gravity
from .task import Task


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
    full, ramp = scene.settings.gravity, scene.settings.gravity_ramp

    def gravity_at(state, t: float):
        """Gravity at time t: velocity Verlet takes its accelerations at the step's ends (the
        particles' step takes the ramp's value at its middle, state.gravity)."""
        return state.gravity if ramp <= 0.0 else ramped_gravity(full, ramp, t)

    def kick_drift(state) -> None:
        fem = state.fem
        if not fem.started:
            first_accelerations(state, fem, gravity_at(state, state.t))
        half = 0.5 * state.dt
        kick(fem.v, fem.a, fem.a_contact, fem.mass, fem.held, fem.held_velocity, fem.node_body, half, fem.contact_work)
        kick_affine(fem.B, fem.Bdot, fem.Dinv, fem.mass, fem.boundary, fem.node_body, half, fem.contact_work)
        state.work_in += drift_work(fem.x, fem.v, state.dt, fem.mass, state.gravity)

    def forces(state) -> None:
        fem, m = state.fem, state.materials
        fem.bad_element = int(elements.internal_forces(fem.x, fem.cells, fem.Dm_inv, fem.vol0, fem.cell_mat,
                                                       m.type_code, m.props, fem.force))
        accelerations(fem.force, fem.mass, gravity_at(state, state.t + state.dt), fem.held, fem.a)
        fem.a_contact[:] = 0.0

    def final_kick(state) -> None:
        fem = state.fem
        half = 0.5 * state.dt
        kick(fem.v, fem.a, fem.a_contact, fem.mass, fem.held, fem.held_velocity, fem.node_body, half, fem.contact_work)
        kick_affine(fem.B, fem.Bdot, fem.Dinv, fem.mass, fem.boundary, fem.node_body, half, fem.contact_work)

    tasks = [Task("fem kick-drift", kick_drift, "velocity Verlet: half kick, then positions"),
             Task("fem forces", forces, "internal forces of the elements"
                  + (", gravity" if scene.settings.has_gravity else ""))]
    if augury is not None:
        tasks.append(Task("augury contact", augury,
                          f"{scene.contact.augury.describe()}: contact between FEM bodies"
                          + (" and particle bodies' surface particles" if scene.has_particles else "")))
    tasks.append(Task("fem kick", final_kick, "velocity Verlet: second half kick"))
    return tasks
