"""Implicit integration of FEM bodies and MPM particle bodies with barrier contact: one step
minimises the incremental potential of the BFEMP paper (Li, Fang, Li, Jiang, arXiv:2108.03349;
the formulas and what is measured in docs/bfemp.md):

    E(y) = 1/2 (y - y~)^T M (y - y~) + c [Psi(y) + Phi(y) - sum_i m_i g . y_i],   c = 2 zeta beta dt^2,
    y~ = y^n + dt v^n + zeta (1 - 2 beta) dt^2 a^n,

then a^{n+1} = (y - y~) / c and v^{n+1} = v^n + dt [(1 - gamma) a^n + gamma a^{n+1}]. Presets
(zeta, beta, gamma): backward Euler (1, 1/2, 1) and midpoint Newmark (1/2, 1/4, 1/2).

The unknowns y are the FEM vertices followed by the active grid nodes of the particle bodies
(implicit_mpm.GridUnknowns: the particles' weights frozen at the step's start, their masses,
velocities and accelerations transferred to the grid, and back after the solve). Psi is the
FEM strain energy plus the particles' (mpmsim/fem/elements.py: a particle is an element over its
grid nodes). Phi is the log barrier between contact points (FEM boundary nodes and particles,
ContactPoints) and the boundary edges of other bodies,
Phi = sum_pairs w_p b(d_pe), b(d) = -kappa dhat (u - 1)^2 ln u, u = d / dhat (mpmsim/barrier),
with w_p the contact area of the point: the node's share of its body's boundary length (half
the lengths of its two boundary edges) or the particle's width (the square root of its
initial area), times the thickness; so kappa is a pressure. With `particle_contact: corners`
the particle's points are the 2^d corners of its deformed domain instead, each carrying half a
face (the contact load then enters at the body's surface, not half a particle inside it). A
particle's points are linear in its grid nodes, so their pair gradients and Hessians reach them
through the weights (J^T H J stays PSD). The pairs come from a spatial hash of the step's swept boxes, never
from an all-pairs loop. The paper's (deg - 1) correction subtracts w_p (deg_v - 1) b(|p - v|) for each
boundary vertex v within dhat of the point (pairs from the same hash): where the point sees v
as an end of its edges (a straight or convex boundary) the barrier is then exactly b(distance
to the boundary), not twice it. Its Hessian is PSD(H1 + H2 - Hv) - H1 - H2 (H1, H2 the projected
Hessians of the two point-edge terms at v): exact where the sum is already PSD, and it keeps
Newton's matrix PSD where an inward-bent boundary lets the point see both edges from their
middles (barrier.potential.point_node_barrier_pairs).

Friction (Coulomb mu from contact.default / contact.pairs) is lagged and smoothed as in IPC:
at the step's start each contact within dhat fixes its normal force lambda = w_p (-b'(d)) (less
the correction's share where the contact's closest point is a vertex: _corrected_share), its
sliding direction and closest-point parameter; the step adds D = sum mu lambda f0(|u|), u the
tangential slip over the step (a particle's: the interpolated grid motion), f0 the mollifier
with eps = friction_velocity * dt (below which friction is smoothed static friction). One lag
per step.

Projected Newton: element, particle and pair Hessians projected to PSD, H = M + c (K + B) on the
free degrees of freedom (held components move to their target and are eliminated; the local
Hessians' triplets go straight into CSC over the free unknowns, free_csc), solved with scipy's
sparse LU (splu). Line search: alpha = min(1, alpha_CCD, alpha_inversion) (additive CCD
keeps every point at least 10% of its distance from every edge; the inversion bound keeps
det F > 0 for triangles and particles), then halved until E decreases. Stop when the largest
move of an FEM node or a particle, max |p| / dt, is below newton_tolerance; that last step is
taken when it is feasible whole (it squares the residual, so momentum is conserved to round-off,
not to the tolerance). Because every accepted position lies on the feasible side of the CCD
bound, no point ever crosses an edge, whatever the time step. 2D (plane strain); the elastic
parts also in 3D without contact.
"""

from __future__ import annotations

import time as wallclock
from types import SimpleNamespace
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from numba import njit

from ..contact.barrier import (barrier_normal_force, box_pairs, correction_nodes, det_step_bound, point_boxes,
                       point_edge_barrier_pairs, point_edge_candidates, point_edge_ccd_pairs, point_edge_distance,
                       point_edge_friction, point_edge_friction_frame, point_node_candidates, simplex_boxes,
                       triangle_step_bound)
from ..contact.barrier.potential import point_node_barrier_pairs, vertex_edges
from ..errors import InstabilityError
from ..fem import elements
from . import Integrator
from .implicit_mpm import GridUnknowns, corner_signs

SCHEMES = {"backward_euler": (1.0, 0.5, 1.0), "newmark": (0.5, 0.25, 0.5)}
PARTS = ("assemble", "solve", "ccd", "line search")
SPRING_START, SPRING_MAX = 1e2, 1e12  # prescribed-motion spring stiffness relative to the inertia term


def boundary_weights(x: np.ndarray, facets: np.ndarray, boundary: np.ndarray) -> np.ndarray:
    """(nb,) half the summed length of each boundary node's boundary edges (2D)."""
    length = np.linalg.norm(x[facets[:, 1]] - x[facets[:, 0]], axis=1)
    w = np.zeros(len(x))
    np.add.at(w, facets[:, 0], 0.5 * length)
    np.add.at(w, facets[:, 1], 0.5 * length)
    return w[boundary]


@njit(cache=True)
def lag_friction(x, boundary, facets, pairs, weights, pair_mu, dhat, kappa, tau, r, mu_lambda):
    """Lagged friction frames at the step's start: for each pair, the sliding direction tau,
    the closest-point parameter r and mu lambda, lambda = w_p (-b'(d)) the pair's normal force."""
    y = np.empty(6)
    t = np.empty(2)
    for k in range(pairs.shape[0]):
        i = boundary[pairs[k, 0]]
        a = facets[pairs[k, 1], 0]
        b = facets[pairs[k, 1], 1]
        y[0], y[1], y[2], y[3], y[4], y[5] = x[i, 0], x[i, 1], x[a, 0], x[a, 1], x[b, 0], x[b, 1]
        d = point_edge_distance(y)
        r[k] = point_edge_friction_frame(y, t)
        tau[k, 0], tau[k, 1] = t[0], t[1]
        mu_lambda[k] = pair_mu[k] * weights[pairs[k, 0]] * barrier_normal_force(d, dhat, kappa) if d < dhat else 0.0


@njit(cache=True)
def friction_pairs(x, x0, boundary, facets, pairs, tau, r, mu_lambda, eps, grads, hessians):
    """Lagged friction pseudo-potential sum_k mu lambda_k f0(|u_k|) of the step's slips (x - x0),
    with each pair's gradient (6,) and PSD Hessian (6, 6)."""
    dz = np.empty(6)
    total = 0.0
    for k in range(pairs.shape[0]):
        if mu_lambda[k] == 0.0:
            grads[k, :] = 0.0
            hessians[k, :, :] = 0.0
            continue
        i = boundary[pairs[k, 0]]
        a = facets[pairs[k, 1], 0]
        b = facets[pairs[k, 1], 1]
        for c in range(2):
            dz[c] = x[i, c] - x0[i, c]
            dz[2 + c] = x[a, c] - x0[a, c]
            dz[4 + c] = x[b, c] - x0[b, c]
        total += point_edge_friction(dz, tau[k], r[k], mu_lambda[k], eps, grads[k], hessians[k])
    return total


def check_initial_gaps(scene, dhat: float, corners: bool = False) -> None:
    """Deck error when two FEM bodies, or a particle (its domain's corners with `corners`) and
    an FEM body, start closer than dhat (the barrier would start infinite or already pushing)."""
    from ..deck.loader import raise_at
    from ..fem.probes import boundary_gap

    fem = scene.fem
    if fem is None or fem.points.shape[1] != 2:
        return
    problems = []
    n = len(fem.infos)
    for a in range(n):
        for b in range(a + 1, n):
            gap = boundary_gap(fem.points, fem.facets, fem.node_body, a, b)
            if gap <= dhat:
                problems.append((("implicit", "dhat"), f"bodies '{fem.infos[a].name}' and '{fem.infos[b].name}' "
                                 f"start {gap:.4g} apart, not farther than dhat = {dhat:g}: move them apart "
                                 "or lower dhat"))
    seed = scene.deformable if scene.has_particles else None
    if seed is not None and len(seed.x) and len(fem.cells):
        inside = particles_inside(seed.x, fem.points, fem.cells)
        if len(inside):
            q, e = inside[0]
            problems.append((("bodies",), f"{len(inside)} particle(s) of '{_body_name(scene, seed.body[q])}' start "
                             f"inside FEM body '{fem.infos[fem.cell_body[e]].name}' (first at "
                             f"{seed.x[q].round(6).tolist()}): the bodies overlap"))
    if seed is not None and len(seed.x):
        x, owner = seed.x, np.arange(len(seed.x))
        if corners:  # the corners of the particles' domains
            d = x.shape[1]
            signs = corner_signs(d)
            x = (x[:, None, :] + signs * np.asarray(scene.semi_size)[:d]).reshape(-1, d)
            owner = np.repeat(owner, len(signs))
        pairs = point_edge_candidates(x, np.zeros_like(x), fem.points, np.zeros_like(fem.points), fem.facets, dhat,
                                      np.full(len(x), -1, np.int64))
        y = np.empty(6)
        for q, e in pairs:
            a, b = fem.facets[e]
            y[:] = (*x[q], *fem.points[a], *fem.points[b])
            d = point_edge_distance(y)
            if d <= dhat:
                what = "a particle's corner" if corners else "a particle"
                problems.append((("implicit", "dhat"), f"{what} of '{_body_name(scene, seed.body[owner[q]])}' at "
                                 f"{x[q].round(6).tolist()} starts {d:.4g} from the boundary of "
                                 f"'{fem.infos[fem.node_body[a]].name}', not farther than dhat = {dhat:g}: move "
                                 "the bodies apart or lower dhat"))
                break
    if problems:
        raise_at(problems, scene.loaded)


def _body_name(scene, body: int) -> str:
    return next(b.name for b in scene.deformable_bodies if b.index == body)


def particles_inside(x: np.ndarray, verts: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(particle, triangle) pairs (k, 2) with the particle strictly inside the triangle (2D),
    candidates from the spatial hash of their boxes."""
    z = np.zeros_like(x)
    lo, hi = point_boxes(x, z)
    tlo, thi = simplex_boxes(verts, np.zeros_like(verts), cells, 0.0)
    pairs = box_pairs(lo, hi, tlo, thi, np.full(len(x), -1, np.int64), cells)
    if not len(pairs):
        return pairs
    a, b, c = (verts[cells[pairs[:, 1], k]] for k in range(3))
    v0, v1, r = b - a, c - a, x[pairs[:, 0]] - a
    det = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]
    s = (r[:, 0] * v1[:, 1] - r[:, 1] * v1[:, 0]) / det
    t = (v0[:, 0] * r[:, 1] - v0[:, 1] * r[:, 0]) / det
    return pairs[(s > 0.0) & (t > 0.0) & (s + t < 1.0)]


def triplets(nodes: np.ndarray, local: np.ndarray, dim: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(rows, cols, values) of local node-major Hessians local (m, k d, k d) over node lists
    nodes (m, k), for one sparse matrix built from all of them (duplicates summed)."""
    m, k = nodes.shape
    dofs = (nodes[:, :, None] * dim + np.arange(dim)[None, None, :]).reshape(m, k * dim)
    return (np.repeat(dofs, k * dim, axis=1).ravel(), np.tile(dofs, (1, k * dim)).ravel(),
            np.asarray(local).ravel())


@njit(cache=True)
def free_csc(rows, cols, vals, index, n):
    """The sparse matrix of the triplets (rows, cols, vals) (duplicates summed) restricted to
    the unknowns k with index[k] >= 0 and renumbered by index, n of them, as canonical CSC
    arrays (indptr, indices, data): rows sorted within each column, no duplicates. One pass
    buckets the entries by column, a second sums each column's duplicates through a row
    marker and sorts its (few) distinct rows."""
    start = np.zeros(n + 1, np.int64)
    for k in range(len(rows)):
        i, j = index[rows[k]], index[cols[k]]
        if i >= 0 and j >= 0:
            start[j + 1] += 1
    for j in range(n):
        start[j + 1] += start[j]
    fill = start[:n].copy()
    r = np.empty(start[n], np.int32)
    v = np.empty(start[n])
    for k in range(len(rows)):
        i, j = index[rows[k]], index[cols[k]]
        if i >= 0 and j >= 0:
            r[fill[j]] = i
            v[fill[j]] = vals[k]
            fill[j] += 1
    where = np.full(n, -1, np.int64)  # slot of row i in the column being built (stale: < first)
    indptr = np.zeros(n + 1, np.int32)
    indices = np.empty(start[n], np.int32)
    data = np.empty(start[n])
    nnz = 0
    for j in range(n):
        first = nnz
        for q in range(start[j], start[j + 1]):
            i = r[q]
            if where[i] < first:
                where[i] = nnz
                indices[nnz] = i
                data[nnz] = v[q]
                nnz += 1
            else:
                data[where[i]] += v[q]
        order = np.argsort(indices[first:nnz])
        indices[first:nnz] = indices[first:nnz][order]
        data[first:nnz] = data[first:nnz][order]
        indptr[j + 1] = nnz
    return indptr, indices[:nnz].copy(), data[:nnz].copy()


def empty_fem(dim: int) -> SimpleNamespace:
    """A scene without FEM bodies, as the implicit step reads one."""
    z = np.zeros((0, dim))
    return SimpleNamespace(X=z, x=z.copy(), v=z.copy(), a=z.copy(), mass=np.zeros(0), held=np.zeros((0, dim), bool),
                           held_velocity=z.copy(), cells=np.zeros((0, dim + 1), np.int64),
                           Dm_inv=np.zeros((0, dim, dim)), vol0=np.zeros(0), cell_mat=np.zeros(0, np.int64),
                           facets=np.zeros((0, dim), np.int64), boundary=np.zeros(0, np.int64),
                           node_body=np.zeros(0, np.int64), node_mat=np.zeros(0, np.int64), infos=[], n=0)


class Pairs(NamedTuple):
    """Barrier pairs of one evaluation."""

    edge: np.ndarray  # (k, 2) (contact point, FEM boundary edge)
    node: np.ndarray  # (k, 2) (contact point, FEM boundary vertex) of the (deg - 1) correction


class ContactPoints(NamedTuple):
    """The points that meet FEM boundary edges through the barrier, for one step: FEM boundary
    nodes and MPM particles. A point's position is sum_k w[q, k] y[node[q, k]] + offset[q] over
    the unknowns y (an FEM node: itself; a particle: its frozen grid weights)."""

    node: np.ndarray  # (n, K) unknown (row of y) of each entry
    w: np.ndarray  # (n, K)
    offset: np.ndarray  # (n, d)
    body: np.ndarray  # (n,) body (FEM rows in infos; particle bodies after them)
    vertex: np.ndarray  # (n,) the point's FEM node index (-1 for particles): no pair with its own edges
    weight: np.ndarray  # (n,) barrier weight w_p (boundary length share; particle width)
    mat: np.ndarray  # (n,) material (friction)

    def positions(self, y: np.ndarray) -> np.ndarray:
        return np.einsum("qk,qkc->qc", self.w, y[self.node]) + self.offset

    def moves(self, p: np.ndarray) -> np.ndarray:
        return np.einsum("qk,qkc->qc", self.w, p[self.node])


class ImplicitStep(Integrator):
    """`integrator: implicit`: the incremental-potential step above, for FEM bodies and MPM
    particle bodies (implicit_mpm.GridUnknowns)."""

    name = "implicit"

    def __init__(self, scene):
        super().__init__()
        run = scene.settings
        imp = run.implicit
        barrier = scene.contact.barrier
        self.zeta, self.beta, self.gamma = SCHEMES[imp.scheme]
        self.tolerance = imp.newton_tolerance
        self.max_iterations = imp.max_newton_iterations
        self.dhat = barrier.dhat
        self.kappa = barrier.kappa
        self.eps_v = barrier.friction_velocity
        self.friction_lags = barrier.friction_lags
        self.particle_contact = barrier.particle_contact
        self.mu = scene.contact.friction  # Coulomb friction between materials
        self.dt = run.time.dt
        self.thickness = float(scene.thickness) if scene.dim == 2 else 1.0
        self.gravity = run.gravity.copy()
        self.timers = {p: 0.0 for p in PARTS}
        self.stats: list[tuple[int, int, int, int]] = []  # per step: Newton iterations, halvings, CCD-limited, lags
        n_fem = len(scene.fem.infos) if scene.fem is not None else 0
        self.grid = GridUnknowns(run.update.scheme) if scene.has_particles else None
        bodies = n_fem + (1 if self.grid is not None else 0)
        self.contact = self.dhat is not None and n_fem >= 1 and bodies > 1 and scene.dim == 2
        if self.dhat is not None:
            check_initial_gaps(scene, self.dhat, self.particle_contact == "corners")
        what = "FEM bodies" if self.grid is None else ("particle bodies" if not n_fem else "FEM and particle bodies")
        self.plan = [("newton", f"{imp.scheme} incremental potential of the {what}, projected Newton, sparse LU"),
                     ("barrier contact", f"log barrier on FEM boundary edges, dhat {self.dhat:g}, kappa {self.kappa:g}"
                      + (f", particles at their {self.particle_contact}" if self.grid is not None else "")
                      if self.contact else "no contact")]
        if self.grid is not None:
            self.plan.insert(0, ("grid unknowns", f"particles -> active grid nodes ({run.update.scheme} transfers), "
                                                  "weights frozen over the step"))
        self.started = False
        self.friction = None
        self.spring = None  # (moving components, their targets, stiffness) during a step

    # ----------------------------------------------------------------------------- pieces
    def stable_dt(self, state) -> float:
        return self.dt

    def _setup(self, state) -> None:
        dim = state.dim
        self.dim = dim
        fem = state.fem if state.fem is not None else empty_fem(dim)
        self.fem = fem
        m = state.materials
        self.n_fem_bodies = len(fem.infos)
        if self.contact:
            self.edge_body = fem.node_body[fem.facets[:, 0]]
            self.node_mat = fem.node_mat
            # contact areas: boundary length share x thickness (2D)
            self.boundary_weight = boundary_weights(fem.X, fem.facets, fem.boundary) * self.thickness
            # the (deg - 1) correction at boundary vertices
            nodes, deg_minus_one = correction_nodes(fem.facets, fem.n)
            self.corr_nodes = nodes
            self.node_weight = np.zeros(fem.n)
            self.node_weight[nodes] = deg_minus_one
            self.node_edges = vertex_edges(fem.facets, fem.n)
        # a^0: the mechanical acceleration at the initial state
        f = np.zeros_like(fem.x)
        elements.internal_forces(fem.x, fem.cells, fem.Dm_inv, fem.vol0, fem.cell_mat, m.type_code, m.props, f)
        fem.a[:] = f / fem.mass[:, None] + self.gravity if fem.n else 0.0
        fem.a[fem.held] = 0.0
        if self.grid is not None:
            grid = self.grid
            grid.begin(state)
            fg = grid.forces(np.zeros_like(grid.X), m)
            a_grid = np.where(grid.mass[:, None] > 0.0, fg / np.maximum(grid.mass, 1e-300)[:, None], 0.0) + self.gravity
            grid.a = np.einsum("pk,pkc->pc", grid.S, a_grid[grid.nodes])
            grid.begin(state)  # the grid's a^n from these
        self.started = True

    def _points(self, state) -> ContactPoints | None:
        """This step's contact points (FEM boundary nodes, then particles)."""
        if not self.contact:
            return None
        fem, d = self.fem, self.dim
        b = fem.boundary
        grid = self.grid
        K = grid.S.shape[1] if grid is not None else 1
        nb = len(b)
        node = np.zeros((nb, K), np.int64)
        w = np.zeros((nb, K))
        node[:, 0], w[:, 0] = b, 1.0
        parts = [(node, w, np.zeros((nb, d)), fem.node_body[b], b, self.boundary_weight, self.node_mat[b])]
        if grid is not None:
            P = state.particles
            t = self.thickness
            width = np.sqrt(P.vol0 / t) * t  # the particle's width x thickness (2D)
            if self.particle_contact == "corners":  # each corner carries half of a face
                owner, nodes, S, off = grid.corners(state)
                width = 0.5 * width[owner]
            else:
                owner, nodes, S = np.arange(P.n), grid.nodes, grid.S
                off = grid.x0 - np.einsum("pk,pkc->pc", S, grid.X[nodes])
            parts.append((fem.n + nodes, S, off, self.n_fem_bodies + np.zeros(len(owner), np.int64),
                          np.full(len(owner), -1, np.int64), width, P.mat[owner]))
        return ContactPoints(*(np.concatenate([q[k] for q in parts]) for k in range(7)))

    def _pairs(self, y: np.ndarray, p: np.ndarray) -> Pairs:
        """Point-edge pairs, and point-vertex pairs of the (deg - 1) correction, of different
        bodies whose swept boxes over y -> y + p come within dhat."""
        fem, pts = self.fem, self.points
        nf = fem.n
        z, dz = pts.positions(y), pts.moves(p)
        edges = point_edge_candidates(z, dz, y[:nf], p[:nf], fem.facets, self.dhat, pts.vertex)
        if len(edges):
            edges = edges[pts.body[edges[:, 0]] != self.edge_body[edges[:, 1]]]
        nodes = point_node_candidates(z, dz, y[:nf], p[:nf], self.corr_nodes, self.dhat, pts.vertex)
        if len(nodes):
            nodes = nodes[pts.body[nodes[:, 0]] != fem.node_body[nodes[:, 1]]]
        return Pairs(edges, nodes)

    def _pair_terms(self, point, others, gl, Hl, g):
        """Add c times pair terms to g and return their Hessian (triplets): local gradients gl
        (k, (1 + s) d) and Hessians Hl over (point, s FEM nodes `others` (k, s)), the point's
        part mapped to the unknowns through its weights."""
        pts, d, c = self.points, self.dim, self.c
        K = pts.node.shape[1]
        k, s = others.shape
        nodes = np.concatenate([pts.node[point], others], axis=1)  # (k, K + s)
        wts = np.concatenate([pts.w[point], np.ones((k, s))], axis=1)
        block = np.r_[np.zeros(K, np.int64), 1 + np.arange(s)]
        G = gl.reshape(k, 1 + s, d)[:, block, :] * wts[:, :, None]
        np.add.at(g.reshape(-1, d), nodes, c * G)
        H4 = Hl.reshape(k, 1 + s, d, 1 + s, d)[:, block][:, :, :, block]  # (k, K+s, d, K+s, d)
        H4 = H4 * (wts[:, :, None, None, None] * wts[:, None, None, :, None])
        return triplets(nodes, c * H4.reshape(k, (K + s) * d, (K + s) * d), d)

    def _energy(self, state, y, yt, pairs, want_derivatives):
        """E(y) (inf if an element or particle inverted or a pair touched), and when asked its
        gradient (n*d,) and PSD-projected Hessian (triplets rows, cols, values; duplicates to
        be summed: free_csc)."""
        fem, m, grid = self.fem, state.materials, self.grid
        c, nf, d = self.c, self.fem.n, self.dim
        yf = y[:nf]
        dx = (y - yt).ravel()
        e_int = np.empty(len(fem.cells))
        elements.element_energies(yf, fem.cells, fem.Dm_inv, fem.vol0, fem.cell_mat, m.type_code, m.props, e_int)
        psi = float(e_int.sum())
        if grid is not None:
            psi += grid.energy(y[nf:] - grid.X, m)
        grav = float(np.sum(self.mass[:, None] * self.gravity[None, :] * y))
        pe, pn = pairs
        gb, Hb = np.zeros((len(pe), 6)), np.zeros((len(pe), 6, 6))
        gn, Hn, vn = np.zeros((len(pn), 8)), np.zeros((len(pn), 8, 8)), np.zeros((len(pn), 3), np.int64)
        phi = 0.0
        pts = self.points
        if len(pe):
            z = pts.positions(y)
            phi = point_edge_barrier_pairs(z, yf, fem.facets, pe, self.dhat, self.kappa, pts.weight, gb, Hb, True)
            if len(pn):
                phi += point_node_barrier_pairs(z, yf, fem.facets, self.node_edges, pn, self.dhat, self.kappa,
                                                pts.weight, self.node_weight, vn, gn, Hn)
        fr = self.friction
        nf_pairs = len(fr[0]) if fr is not None else 0
        gf, Hf = np.zeros((nf_pairs, 6)), np.zeros((nf_pairs, 6, 6))
        dfr = 0.0
        if nf_pairs:
            fpairs, tau, r, mu_lambda = fr
            ext, ext0, ids = self._extended(y)
            dfr = friction_pairs(ext, ext0, ids, fem.facets, fpairs, tau, r, mu_lambda, self.eps_v * self.dt_step,
                                 gf, Hf)
        E = 0.5 * float(dx @ (self.M * dx)) + c * (psi + phi + dfr - grav)
        spring = self.spring
        if spring is not None:
            moving, target, ks = spring
            off = np.where(moving, y - target, 0.0).ravel()
            E += 0.5 * ks * float(off @ (self.M * off))
        if not want_derivatives or not np.isfinite(E):
            return E, None, None
        n_y = len(y)
        f = np.zeros_like(y)
        elements.internal_forces(yf, fem.cells, fem.Dm_inv, fem.vol0, fem.cell_mat, m.type_code, m.props, f[:nf])
        blocks = []
        if len(fem.cells):
            local = np.zeros((len(fem.cells), (d + 1) * d, (d + 1) * d))
            elements.element_hessians(yf, fem.cells, fem.Dm_inv, fem.vol0, fem.cell_mat, m.type_code, m.props,
                                      True, local)
            blocks.append(triplets(fem.cells, c * local, d))
        if grid is not None:
            u = y[nf:] - grid.X
            f[nf:] = grid.forces(u, m)
            blocks.append(triplets(nf + grid.nodes, c * grid.hessians(u, m), d))
        g = self.M * dx + c * (-f - self.mass[:, None] * self.gravity[None, :]).ravel()
        terms = [(pe, fem.facets[pe[:, 1]], gb, Hb), (pn, vn, gn, Hn)]
        if nf_pairs:
            terms.append((fr[0], fem.facets[fr[0][:, 1]], gf, Hf))
        for prs, others, gl, Hl in terms:
            if len(prs):
                blocks.append(self._pair_terms(prs[:, 0], others, gl, Hl, g))
        diag = self.M + (ks * self.M * moving.ravel() if spring is not None else 0.0)
        if spring is not None:
            g += ks * self.M * off
        n = n_y * d
        every = np.arange(n)
        blocks.append((every, every, diag))
        return E, g, tuple(np.concatenate([b[i] for b in blocks]) for i in range(3))

    def _extended(self, y):
        """(FEM nodes then contact points) now and at the step's start (kept by `advance`), and
        the points' rows: the layout the friction kernels read (points by row, edges by FEM node)."""
        nf = self.fem.n
        ext = np.concatenate([y[:nf], self.points.positions(y)])
        return ext, self.ext_start, nf + np.arange(len(self.points.node))

    def _lag(self, y):
        """(pairs, tau, r, mu lambda) of the contacts within dhat at the step's start (lagged
        friction: frames and normal forces held through the step's Newton solve)."""
        pairs = self._pairs(y, np.zeros_like(y)).edge
        k = len(pairs)
        if not k:
            return None
        fem, pts = self.fem, self.points
        mu = self.mu[pts.mat[pairs[:, 0]], self.node_mat[fem.facets[pairs[:, 1], 0]]]
        tau, r, mu_lambda = np.zeros((k, 2)), np.zeros(k), np.zeros(k)
        ext, _, ids = self._extended(y)
        lag_friction(ext, ids, fem.facets, pairs, pts.weight, mu, self.dhat, self.kappa, tau, r, mu_lambda)
        mu_lambda *= self._corrected_share(ext[ids], ext, pairs)
        return pairs, tau, r, mu_lambda

    def _corrected_share(self, z, x, pairs) -> np.ndarray:
        """The (deg - 1) correction in the friction's normal forces: a pair whose closest point
        is an edge's end v shares that vertex's barrier with the point's other m_v pairs that
        see v as an end, and the correction takes deg_v - 1 of them away: each keeps
        (m_v - deg_v + 1) / m_v of its normal force (0 on a straight face, 1/2 at a convex
        corner). Pairs that see their edge from the middle keep all of it."""
        e0, e1 = x[self.fem.facets[pairs[:, 1], 0]], x[self.fem.facets[pairs[:, 1], 1]]
        e = e1 - e0
        t = np.einsum("kc,kc->k", z[pairs[:, 0]] - e0, e) / np.einsum("kc,kc->k", e, e)
        end = np.where(t < 0.0, self.fem.facets[pairs[:, 1], 0], np.where(t > 1.0, self.fem.facets[pairs[:, 1], 1], -1))
        share = np.ones(len(pairs))
        at_end = end >= 0
        if at_end.any():
            key = pairs[at_end, 0] * (self.fem.n + 1) + end[at_end]
            _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
            m = counts[inverse].astype(float)
            share[at_end] = np.maximum(m - self.node_weight[end[at_end]], 0.0) / m
        return share

    def _step_bound(self, y, p, pairs) -> tuple[float, bool]:
        """Largest alpha in (0, 1] keeping every point 10% of its distance off every edge (CCD)
        and every triangle's and particle's det F > 0; and whether CCD limited it."""
        fem, grid, nf = self.fem, self.grid, self.fem.n
        alpha = 1.0
        if len(fem.cells) and self.dim == 2:
            alpha = min(alpha, triangle_step_bound(y[:nf], p[:nf], fem.cells))
        if grid is not None:
            A = grid.deformation(y[nf:] - grid.X)
            B = grid.deformation(p[nf:]) - grid.F0
            alpha = min(alpha, det_step_bound(A, B))
        limited = False
        if len(pairs.edge):
            pts = self.points
            a_ccd = point_edge_ccd_pairs(pts.positions(y), pts.moves(p), y[:nf], p[:nf], fem.facets, pairs.edge)
            if a_ccd < alpha:
                alpha, limited = a_ccd, True
        return alpha, limited

    def _step_size(self, p: np.ndarray) -> float:
        """max |p| over the FEM nodes and over the particles (a particle moves by sum_i w_ip p_i;
        a grid node's own move means nothing where it weighs little)."""
        nf, grid = self.fem.n, self.grid
        size = float(np.abs(p[:nf]).max()) if nf else 0.0
        if grid is not None:
            size = max(size, float(np.abs(np.einsum("pk,pkc->pc", grid.S, p[nf:][grid.nodes])).max()))
        return size

    # ----------------------------------------------------------------------------- the step
    def _newton(self, state, y, yt, free, dt):
        """Projected Newton from y on the free DOFs; returns (y, iterations, halvings, CCD-limited)."""
        halvings = 0
        ccd_limited = False
        none = Pairs(np.zeros((0, 2), np.int64), np.zeros((0, 2), np.int64))
        m = int(free.sum())
        index = np.full(free.size, -1, np.int64)  # DOF -> free unknown (-1: eliminated)
        index[free] = np.arange(m)
        for it in range(1, self.max_iterations + 1):
            t0 = wallclock.perf_counter()
            pairs = self._pairs(y, np.zeros_like(y)) if self.contact else none
            E, g, H = self._energy(state, y, yt, pairs, True)
            indptr, indices, data = free_csc(*H, index, m)
            Hf = sp.csc_matrix((data, indices, indptr), shape=(m, m))
            self.timers["assemble"] += wallclock.perf_counter() - t0
            t0 = wallclock.perf_counter()
            p = np.zeros(y.size)
            p[free] = splu(Hf).solve(-g[free])
            p = p.reshape(y.shape)
            self.timers["solve"] += wallclock.perf_counter() - t0
            if self._step_size(p) / dt < self.tolerance:
                # converged: the last Newton step is below the tolerance; take it when it is
                # feasible as a whole (it squares the residual: momentum to round-off)
                swept = self._pairs(y, p) if self.contact else pairs
                if self._step_bound(y, p, swept)[0] >= 1.0:
                    y = y + p
                return y, it, halvings, ccd_limited
            t0 = wallclock.perf_counter()
            swept = self._pairs(y, p) if self.contact else pairs
            alpha, limited = self._step_bound(y, p, swept)
            ccd_limited |= limited
            self.timers["ccd"] += wallclock.perf_counter() - t0
            t0 = wallclock.perf_counter()
            while True:
                trial = y + alpha * p
                E_trial, _, _ = self._energy(state, trial, yt, swept, False)
                if E_trial <= E or alpha < 1e-12:
                    break
                alpha *= 0.5
                halvings += 1
            self.timers["line search"] += wallclock.perf_counter() - t0
            y = trial
        names = self._body_names(state)
        raise InstabilityError(
            f"stopped at step {state.step + 1}, t = {state.t + dt:.6g}: Newton did not converge in "
            f"{self.max_iterations} iterations (bodies {names}; last max|p|/dt = {self._step_size(p) / dt:.3g}); "
            "try a smaller time.dt or a larger implicit.newton_tolerance", state.t, state.step)

    def _body_names(self, state) -> str:
        infos = list(self.fem.infos) + (list(state.particles.infos) if self.grid is not None else [])
        return " and ".join(f"'{b.name}'" for b in infos)

    def advance(self, state, dt: float) -> float:
        """One step. Fixed components stay put (eliminated). Components moving at a prescribed
        velocity are not moved to their target by fiat (that could push them through another
        body): a spring 1/2 k m |x - target|^2 pulls them there inside the Newton solve, with the
        CCD line search watching, and k grows tenfold until they are within 1e-6 of their move
        (or of newton_tolerance x dt, what Newton resolves)."""
        if not self.started:
            self._setup(state)
        elif self.grid is not None:
            self.grid.begin(state)
        fem, grid, d = self.fem, self.grid, self.dim
        nf = fem.n
        self.c = 2.0 * self.zeta * self.beta * dt * dt
        h2 = self.zeta * (1.0 - 2.0 * self.beta) * dt * dt
        # the unknowns: FEM nodes, then the particles' active grid nodes
        if grid is not None:
            yn = np.concatenate([fem.x, grid.X])
            vn = np.concatenate([fem.v, grid.v])
            an = np.concatenate([fem.a, grid.a_grid])
            self.mass = np.concatenate([fem.mass, grid.mass])
            held = np.concatenate([fem.held, np.zeros((grid.n, d), bool)])
            held_velocity = np.concatenate([fem.held_velocity, np.zeros((grid.n, d))])
        else:
            yn, vn, an = fem.x.copy(), fem.v.copy(), fem.a.copy()
            self.mass, held, held_velocity = fem.mass, fem.held, fem.held_velocity
        self.M = np.repeat(self.mass, d)
        yt = yn + dt * vn + h2 * an
        moving = held & (held_velocity != 0.0)
        fixed = held & ~moving
        target = yn + dt * held_velocity
        free = ~fixed.ravel()
        self.dt_step = dt
        self.points = self._points(state)
        if self.points is not None:
            self.ext_start = np.concatenate([yn[:nf], self.points.positions(yn)])
        self.friction = self._lag(yn) if self.contact and self.mu.any() else None
        y = yn.copy()
        its = halvings = 0
        ccd_limited = False
        k = SPRING_START
        reach = max(1e-6 * (float(np.abs(target - yn)[moving].max()) if moving.any() else 0.0),
                    self.tolerance * dt)
        lags = 0
        while True:
            self.spring = (moving, target, k) if moving.any() else None
            y, n_it, n_half, limited = self._newton(state, y, yt, free, dt)
            its, halvings, ccd_limited = its + n_it, halvings + n_half, ccd_limited or limited
            if self.friction is not None and lags + 1 < self.friction_lags and not (lags and n_it == 1):
                # the outer friction loop: normal forces and frames again at the new positions,
                # until Newton converges at once under them
                lags += 1
                self.friction = self._lag(y)
                if self.friction is not None:
                    continue
            if self.spring is None or np.abs(y - target)[moving].max() <= reach:
                break
            if k >= SPRING_MAX:
                names = ", ".join(f"'{fem.infos[b].name}'" for b in np.unique(fem.node_body[moving[:nf].any(axis=1)]))
                raise InstabilityError(
                    f"stopped at step {state.step + 1}, t = {state.t + dt:.6g}: the prescribed motion of {names} "
                    f"could not be reached (off by {np.abs(y - target)[moving].max():.3g}; something blocks it)",
                    state.t, state.step)
            k *= 10.0
        self.spring = None
        if moving.any():  # work of the prescribed motion: the constraint force (gradient / c) times the move
            pairs = self._pairs(y, np.zeros_like(y)) if self.contact else Pairs(np.zeros((0, 2), np.int64),
                                                                                 np.zeros((0, 2), np.int64))
            _, g, _ = self._energy(state, y, yt, pairs, True)
            force = g.reshape(y.shape) / self.c
            state.work_in += float(np.sum(np.where(moving, force * (y - yn), 0.0)))
        a_new = (y - yt) / self.c
        a_new[held] = 0.0
        v_new = vn + dt * ((1.0 - self.gamma) * an + self.gamma * a_new)
        v_new[held] = held_velocity[held]
        # gravity's work on the FEM nodes and the particles
        state.work_in += float(np.sum(fem.mass[:, None] * self.gravity[None, :] * (y[:nf] - yn[:nf])))
        fem.v[:], fem.a[:], fem.x[:] = v_new[:nf], a_new[:nf], y[:nf]
        if grid is not None:
            P = state.particles
            x_before = P.x.copy()
            grid.finish(state, y[nf:] - grid.X, v_new[nf:], a_new[nf:])
            state.work_in += float(np.sum(P.mass[:, None] * self.gravity[None, :] * (P.x - x_before)))
        self.stats.append((its, halvings, int(ccd_limited), lags + 1))
        return dt

    def report(self) -> list[str]:
        """The Newton table: steps, iterations per step (mean, max), line-search halvings and
        CCD-limited steps."""
        if not self.stats:
            return []
        its = np.array([s[0] for s in self.stats])
        halv = sum(s[1] for s in self.stats)
        ccd = sum(s[2] for s in self.stats)
        line = (f"Newton: {len(its)} steps, {its.mean():.2f} iterations per step (max {its.max()}), "
                f"{halv} line-search halvings, {ccd} CCD-limited steps")
        lags = np.array([s[3] for s in self.stats])
        if self.friction_lags > 1:
            line += f", {lags.mean():.2f} friction lags per step (max {lags.max()})"
        return [line]
