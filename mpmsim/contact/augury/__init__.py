"""APIC augury contact (the APIC augury paper; docs/fem-contact.md): FEM boundary nodes and the
surface particles of particle bodies meet through grid transfers on a background grid of
their own. `transfers.py` holds the transfers (grid entries, transfer H, the undesired part,
the correction); this module the task of the explicit step that gathers the augury
particles, applies the correction and scatters it back. Its settings and each material's
friction come from the scene's contact model (`ContactModel.augury`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ...fem.mesh import node_normal_kernel
from .fields import field_correction
from .transfers import correction, grid_entries


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
def gather_boundary(x, v, a, mass, facets, boundary, tau, unit=True):
    """Positions, masses, predicted velocities v + tau a and outward normals of the FEM
    boundary nodes (unit=False: of length the facets' agreement, node_normal_kernel)."""
    normals = np.zeros_like(x)
    node_normal_kernel(x, facets, normals, unit)
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


SURFACE_THRESHOLD = 0.05  # surface particles: |first moment| > 0.05 (local mass) h_c (surface_particles)


class AuguryContact:
    """The augury contact task: the correction Â of the FEM boundary nodes' accelerations and,
    when the scene has particle bodies, of their surface particles' velocities (particles take
    part as augury particles; their current velocity is their prediction). A particle's change
    over a step, dt Â (and dt Â_B to B for APIC particles with APIC transfers), is given as the
    FEM nodes get theirs, half at the end of this step and half at the start of the next
    (`carry`, before the particles' momenta go to the grid): at every output time both sides have
    received the same half, so the total momentum is exact then too. The settings and each
    augury particle's friction come from the scene's contact model."""

    def __init__(self, scene):
        self.spec = scene.contact.augury
        fem = scene.fem
        boundary = np.unique(fem.facets)
        self.mu = self.spec.mu_of_material[fem.node_mat[boundary]]  # (nb,) per boundary node
        self.particles = scene.has_particles
        self.pending = None  # (particle indices, Â, Â_B) whose second half the next step gives
        # field method: each augury particle's body (FEM bodies, then particle bodies) and material
        self.node_body, self.node_mat = fem.node_body[boundary], fem.node_mat[boundary]
        self.n_fem_bodies = len(fem.infos)
        self.n_bodies = self.n_fem_bodies  # and the particle bodies (set by `correct`)

    def _correction(self, ent, x, m, vbar, B, normal, mu, body, mat, tau):
        """(Â, Â_B) of the augury particles by the deck's method."""
        spec = self.spec
        if spec.method == "field":
            return field_correction(ent, x, m, vbar, normal, body, mat, self.n_bodies, spec.law, spec.mu,
                                    spec.mu_static, tau, spec.grid.h)
        return correction(ent, m, vbar, B, normal, mu, spec.grid, spec.iterations, tau, spec.rule)

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
        spec = self.spec
        tau = spec.tau if spec.tau is not None else state.dt
        self.correct(state, fem, P, spec, tau)

    def correct(self, state, fem, P, spec, tau) -> None:
        """The correction of the FEM boundary nodes and of the particle bodies' surface
        particles (P None or empty: the FEM bodies alone)."""
        grid = spec.grid
        xb, mb, vbar, nrm = gather_boundary(fem.x, fem.v, fem.a, fem.mass, fem.facets, fem.boundary, tau,
                                            spec.method == "augury")
        nb, dim = xb.shape
        if P is not None and P.n:
            idx, pn = surface_particles(P.x, P.mass, P.local_body, grid, SURFACE_THRESHOLD)
        else:
            idx, pn = np.zeros(0, np.int64), np.zeros((0, dim))
        apic_particles = grid.apic and P is not None and len(P.B) == P.n
        B = np.zeros((nb + idx.size, dim, dim))
        if grid.apic:
            B[:nb] = fem.B
            if apic_particles:
                B[nb:] = P.B[idx]
        self.n_bodies = self.n_fem_bodies + (len(P.infos) if P is not None else 0)
        x = np.concatenate([xb, P.x[idx]]) if idx.size else xb
        ent = grid_entries(x, grid)
        if idx.size:
            body = np.concatenate([self.node_body, self.n_fem_bodies + P.local_body[idx]])
            mat = np.concatenate([self.node_mat, P.mat[idx]])
            acc, acc_B = self._correction(ent, x, np.concatenate([mb, P.mass[idx]]),
                                          np.concatenate([vbar, P.v[idx]]), B, np.concatenate([nrm, pn]),
                                          np.concatenate([self.mu, spec.mu_of_material[P.mat[idx]]]), body, mat, tau)
        else:
            acc, acc_B = self._correction(ent, x, mb, vbar, B, nrm, self.mu, self.node_body, self.node_mat, tau)
        scatter_boundary(acc[:nb], fem.boundary, fem.held, fem.a, fem.a_contact)
        fem.Bdot[:] = acc_B[:nb]
        fem.Dinv[:] = ent.Di[:nb]
        if not idx.size:
            return
        half = 0.5 * state.dt
        acc_p = acc[nb:]
        acc_pB = acc_B[nb:] if apic_particles else None
        P.v[idx] += half * acc_p
        if acc_pB is not None:
            P.B[idx] += half * acc_pB
        self.pending = (idx, acc_p, acc_pB)
