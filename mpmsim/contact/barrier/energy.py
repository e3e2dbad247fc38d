"""Barrier contact and lagged friction as energy terms of the implicit step (mpmsim/energy.py:
the interface; docs/bfemp.md: formulas and measurements).

Contact points (ContactPoints) are the FEM boundary nodes and the MPM particles (or, with
`particle_contact: corners`, the 2^d corners of each particle's deformed domain, each carrying
half a face). A point's position is linear in the unknowns: sum_k w_qk y_node(q,k) + offset_q
(an FEM node: itself; a particle: its grid weights frozen at the step's start), so pair
gradients and Hessians reach the unknowns through the weights (J^T H J stays PSD).

BarrierContact: Phi = sum_pairs w_p b(d_pe), b(d) = -kappa dhat (u - 1)^2 ln u, u = d / dhat,
between the points and the boundary edges of other bodies, w_p the point's contact area (the
node's share of its body's boundary length, or the particle's width, times the thickness: kappa
is a pressure), minus the (deg - 1) correction w_p (deg_v - 1) b(|p - v|) at boundary vertices
v within dhat (its Hessian PSD(H1 + H2 - Hv) - H1 - H2: potential.point_node_barrier_pairs).
Pairs come from a spatial hash of the swept boxes (broadphase), never an all-pairs loop. Step
bound: additive CCD keeps every point 10% of its distance off every edge (ccd).

LaggedFriction: at the step's start (and again on each outer friction iteration) each contact
within dhat fixes its normal force lambda = w_p (-b'(d)) (less the correction's share where the
closest point is an edge's end), its sliding direction and closest-point parameter; the term is
D = sum mu lambda f0(|u|), u the tangential slip over the step, f0 IPC's mollifier with
eps = friction_velocity * dt.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ...energy import Blocks, Derivatives, Potential, Scatter, StepStart
from .broadphase import correction_nodes, point_edge_candidates, point_node_candidates
from .ccd import CCD_ETA, point_edge_ccd_pairs
from .closest import point_triangle_distance
from .distance import point_edge_distance, point_edge_friction_frame
from .friction import point_edge_friction
from .potential import barrier_normal_force, point_edge_barrier_pairs, point_node_barrier_pairs, vertex_edges


class Pairs(NamedTuple):
    """Barrier pairs of one evaluation."""

    edge: np.ndarray  # (k, 2) (contact point, FEM boundary edge)
    node: np.ndarray  # (k, 2) (contact point, FEM boundary vertex) of the (deg - 1) correction


NO_PAIRS = Pairs(np.zeros((0, 2), np.int64), np.zeros((0, 2), np.int64))


@njit(cache=True)
def interpolate(w, node, y):
    """out[q] = sum_k w[q, k] y[node[q, k]] (n, d), summed in k order (numpy's einsum
    "qk,qkc->qc" of y[node] to the bit, without the (n, K, d) gather)."""
    n, K = w.shape
    d = y.shape[1]
    out = np.empty((n, d))
    for q in range(n):
        for c in range(d):
            s = 0.0
            for k in range(K):
                s += w[q, k] * y[node[q, k], c]
            out[q, c] = s
    return out


class ContactPoints(NamedTuple):
    """The points that meet FEM boundary edges through the barrier, for one step. A point's
    position is sum_k w[q, k] y[node[q, k]] + offset[q] over the unknowns y."""

    node: np.ndarray  # (n, K) unknown (row of y) of each entry
    w: np.ndarray  # (n, K)
    offset: np.ndarray  # (n, d)
    body: np.ndarray  # (n,) body (FEM rows in infos; particle bodies after them)
    vertex: np.ndarray  # (n,) the point's FEM node index (-1 for particles): no pair with its own edges
    weight: np.ndarray  # (n,) barrier weight w_p (boundary length share; particle width)
    mat: np.ndarray  # (n,) material (friction)

    def positions(self, y: np.ndarray) -> np.ndarray:
        return interpolate(self.w, self.node, y) + self.offset

    def moves(self, p: np.ndarray) -> np.ndarray:
        return interpolate(self.w, self.node, p)

    def pair_terms(self, point, others, gl, Hl, d) -> tuple[Scatter, object]:
        """Local gradients gl (k, (1 + s) d) and Hessians Hl over (point, s FEM nodes `others`
        (k, s)), the point's part mapped to the unknowns through its weights: (Scatter, Blocks)."""
        K = self.node.shape[1]
        k, s = others.shape
        nodes = np.concatenate([self.node[point], others], axis=1)  # (k, K + s)
        wts = np.concatenate([self.w[point], np.ones((k, s))], axis=1)
        block = np.r_[np.zeros(K, np.int64), 1 + np.arange(s)]
        G = gl.reshape(k, 1 + s, d)[:, block, :] * wts[:, :, None]
        return Scatter(nodes, G), Blocks(nodes, Hl, wts, block)


def boundary_weights(x: np.ndarray, facets: np.ndarray, boundary: np.ndarray) -> np.ndarray:
    """(nb,) half the summed length of each boundary node's boundary edges (2D)."""
    length = np.linalg.norm(x[facets[:, 1]] - x[facets[:, 0]], axis=1)
    w = np.zeros(len(x))
    np.add.at(w, facets[:, 0], 0.5 * length)
    np.add.at(w, facets[:, 1], 0.5 * length)
    return w[boundary]


class BarrierContact(Potential):
    """The log barrier between the contact points and the FEM boundary edges of other bodies."""

    name = "barrier contact"
    contact = True
    ccd = True

    def __init__(self, fem, grid, dhat: float, kappa: float, thickness: float, particle_contact: str):
        self.fem, self.grid = fem, grid
        self.dhat, self.kappa = dhat, kappa
        self.thickness = thickness
        self.particle_contact = particle_contact
        self.n_fem_bodies = len(fem.infos)
        self.edge_body = fem.node_body[fem.facets[:, 0]]
        # contact areas: boundary length share x thickness (2D)
        self.boundary_weight = boundary_weights(fem.X, fem.facets, fem.boundary) * thickness
        # the (deg - 1) correction at boundary vertices
        nodes, deg_minus_one = correction_nodes(fem.facets, fem.n)
        self.corr_nodes = nodes
        self.node_weight = np.zeros(fem.n)
        self.node_weight[nodes] = deg_minus_one
        self.node_edges = vertex_edges(fem.facets, fem.n)
        self.points = None
        self.current = NO_PAIRS
        self._local = None

    def begin(self, step: StepStart):
        """This step's contact points (FEM boundary nodes, then particles)."""
        fem, d = self.fem, step.y.shape[1]
        b = fem.boundary
        grid = self.grid
        K = grid.S.shape[1] if grid is not None else 1
        nb = len(b)
        node = np.zeros((nb, K), np.int64)
        w = np.zeros((nb, K))
        node[:, 0], w[:, 0] = b, 1.0
        parts = [(node, w, np.zeros((nb, d)), fem.node_body[b], b, self.boundary_weight, fem.node_mat[b])]
        if grid is not None:
            P = step.state.particles
            corners = self.particle_contact == "corners"
            if corners:
                owner, nodes, S, off = grid.corners(step.state)
            else:
                owner, nodes, S = np.arange(P.n), grid.nodes, grid.S
                off = grid.x0 - np.einsum("pk,pkc->pc", S, grid.X[nodes])
            width = self.particle_weights(P.vol0, owner, corners)
            parts.append((fem.n + nodes, S, off, self.n_fem_bodies + np.zeros(len(owner), np.int64),
                          np.full(len(owner), -1, np.int64), width, P.mat[owner]))
        self.points = ContactPoints(*(np.concatenate([q[k] for q in parts]) for k in range(7)))

    def particle_weights(self, vol0: np.ndarray, owner: np.ndarray, corners: bool) -> np.ndarray:
        """Barrier weight of each contact point on a particle: its width x thickness (2D), each
        corner half of that (it carries half of a face)."""
        t = self.thickness
        width = np.sqrt(vol0 / t) * t
        return 0.5 * width[owner] if corners else width

    def pairs(self, y: np.ndarray, p: np.ndarray) -> Pairs:
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

    def sweep(self, y, p):
        self.current = self.pairs(y, p)

    @property
    def in_contact(self) -> bool:
        """Whether the last sweep found pairs."""
        return len(self.current.edge) > 0

    def min_distance(self, y) -> float:
        """The smallest point-edge distance over the pairs of the last sweep, taken at y (inf if
        none)."""
        pairs = self.current.edge
        return min_pair_distance(self.points.positions(y), y[:self.fem.n], self.fem.facets, pairs) if len(pairs) \
            else np.inf

    def value(self, y):
        phi, self._local = self._pairs_at(y, True)
        return phi

    def _pairs_at(self, y, project):
        """The barrier at y and each pair's gradient and Hessian (PSD-projected with `project`)."""
        fem, pts = self.fem, self.points
        yf = y[:fem.n]
        pe, pn = self.current
        gb, Hb = np.zeros((len(pe), 6)), np.zeros((len(pe), 6, 6))
        gn, Hn, vn = np.zeros((len(pn), 8)), np.zeros((len(pn), 8, 8)), np.zeros((len(pn), 3), np.int64)
        phi = 0.0
        if len(pe):
            z = pts.positions(y)
            phi = point_edge_barrier_pairs(z, yf, fem.facets, pe, self.dhat, self.kappa, pts.weight, gb, Hb, project)
            if len(pn):
                phi += point_node_barrier_pairs(z, yf, fem.facets, self.node_edges, pn, self.dhat, self.kappa,
                                                pts.weight, self.node_weight, vn, gn, Hn, project)
        return phi, ((pe, self.fem.facets[pe[:, 1]], gb, Hb), (pn, vn, gn, Hn))

    def derivatives(self, y, force, exact=False):
        if exact:  # the unprojected Hessians (the value's are projected)
            self._local = self._pairs_at(y, False)[1]
        scatters, hessians = [], []
        for prs, others, gl, Hl in self._local:
            if len(prs):
                s, h = self.points.pair_terms(prs[:, 0], others, gl, Hl, y.shape[1])
                scatters.append(s)
                hessians.append(h)
        return Derivatives(tuple(scatters), tuple(hessians))

    def step_bound(self, y, p):
        pe = self.current.edge
        if not len(pe):
            return 1.0
        pts, nf = self.points, self.fem.n
        return point_edge_ccd_pairs(pts.positions(y), pts.moves(p), y[:nf], p[:nf], self.fem.facets, pe, CCD_ETA,
                                    1.0)  # every argument given: numba's dispatch of defaults is slow

    def corrected_share(self, z, x, pairs) -> np.ndarray:
        """The (deg - 1) correction in the friction's normal forces: a pair whose closest point
        is an edge's end v shares that vertex's barrier with the point's other m_v pairs that
        see v as an end, and the correction takes deg_v - 1 of them away: each keeps
        (m_v - deg_v + 1) / m_v of its normal force (0 on a straight face, 1/2 at a convex
        corner). Pairs that see their edge from the middle keep all of it."""
        facets = self.fem.facets
        e0, e1 = x[facets[pairs[:, 1], 0]], x[facets[pairs[:, 1], 1]]
        e = e1 - e0
        t = np.einsum("kc,kc->k", z[pairs[:, 0]] - e0, e) / np.einsum("kc,kc->k", e, e)
        end = np.where(t < 0.0, facets[pairs[:, 1], 0], np.where(t > 1.0, facets[pairs[:, 1], 1], -1))
        share = np.ones(len(pairs))
        at_end = end >= 0
        if at_end.any():
            key = pairs[at_end, 0] * (self.fem.n + 1) + end[at_end]
            _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
            m = counts[inverse].astype(float)
            share[at_end] = np.maximum(m - self.node_weight[end[at_end]], 0.0) / m
        return share


@njit(cache=True)
def min_pair_distance(points, verts, simplices, pairs):
    """The smallest distance over (point, simplex) pairs: edges (2D) or triangles (3D)."""
    k = simplices.shape[1]
    y = np.empty(3 * (k + 1)) if k == 3 else np.empty(6)
    dim = points.shape[1]
    best = np.inf
    for q in range(pairs.shape[0]):
        i = pairs[q, 0]
        for a in range(dim):
            y[a] = points[i, a]
            for c in range(k):
                y[dim * (c + 1) + a] = verts[simplices[pairs[q, 1], c], a]
        d = point_triangle_distance(y) if k == 3 else point_edge_distance(y)
        best = min(best, d)
    return best


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


class Lag(NamedTuple):
    pairs: np.ndarray  # (k, 2) (contact point, FEM boundary edge)
    tau: np.ndarray  # (k, 2) sliding directions
    r: np.ndarray  # (k,) closest-point parameters
    mu_lambda: np.ndarray  # (k,) mu times the normal force


class LaggedFriction(Potential):
    """IPC's lagged, smoothed Coulomb friction on the barrier's contacts (mu per material pair)."""

    name = "lagged friction"
    contact = True
    lagged = True

    def __init__(self, contact: BarrierContact, mu: np.ndarray, friction_velocity: float):
        self.contact = contact
        self.mu = mu
        self.eps_v = friction_velocity
        self.lag = None
        self.eps = 0.0
        self.start = None
        self._local = None

    @property
    def active(self) -> bool:
        return self.lag is not None

    def _extended(self, y):
        """(FEM nodes then contact points) now, and the points' rows: the layout the friction
        kernels read (points by row, edges by FEM node)."""
        nf = self.contact.fem.n
        pts = self.contact.points
        return np.concatenate([y[:nf], pts.positions(y)]), nf + np.arange(len(pts.node))

    def begin(self, step: StepStart):
        self.eps = self.eps_v * step.dt
        self.start = self._extended(step.y)[0]
        self.relag(step.y)

    def relag(self, y):
        """(pairs, tau, r, mu lambda) of the contacts within dhat at y."""
        c = self.contact
        pairs = c.pairs(y, np.zeros_like(y)).edge
        k = len(pairs)
        if not k:
            self.lag = None
            return False
        fem, pts = c.fem, c.points
        mu = self.mu[pts.mat[pairs[:, 0]], fem.node_mat[fem.facets[pairs[:, 1], 0]]]
        tau, r, mu_lambda = np.zeros((k, 2)), np.zeros(k), np.zeros(k)
        ext, ids = self._extended(y)
        lag_friction(ext, ids, fem.facets, pairs, pts.weight, mu, c.dhat, c.kappa, tau, r, mu_lambda)
        mu_lambda *= c.corrected_share(ext[ids], ext, pairs)
        self.lag = Lag(pairs, tau, r, mu_lambda)
        return True

    def _friction(self, ext, ids, gf, Hf) -> float:
        """The lagged friction of every contact at positions ext (FEM nodes, then the points at
        rows ids), with its local gradients gf and Hessians Hf over (point, edge nodes)."""
        lag = self.lag
        return friction_pairs(ext, self.start, ids, self.contact.fem.facets, lag.pairs, lag.tau, lag.r,
                              lag.mu_lambda, self.eps, gf, Hf)

    def _stencils(self):
        """(contact points, their FEM nodes) of the lagged contacts."""
        pairs = self.lag.pairs
        return pairs[:, 0], self.contact.fem.facets[pairs[:, 1]]

    def value(self, y):
        if self.lag is None:
            self._local = None
            return 0.0
        point, others = self._stencils()
        n = (1 + others.shape[1]) * y.shape[1]
        gf, Hf = np.zeros((len(point), n)), np.zeros((len(point), n, n))
        ext, ids = self._extended(y)
        total = self._friction(ext, ids, gf, Hf)
        self._local = (gf, Hf)
        return total

    def derivatives(self, y, force, exact=False):  # its Hessian is exact either way
        if self._local is None:
            return Derivatives((), ())
        s, h = self.contact.points.pair_terms(*self._stencils(), *self._local, y.shape[1])
        return Derivatives((s,), (h,))
