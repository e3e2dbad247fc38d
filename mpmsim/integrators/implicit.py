"""Implicit integration of FEM bodies with barrier contact: one step minimises the incremental
potential of the BFEMP paper (../shared/papers/bfemp-barrier-mpm-fem.txt; formulas in
../shared/notes/fem-coupling-implementation.md, "BFEMP"):

    E(x) = 1/2 (x - x~)^T M (x - x~) + c [Psi(x) + Phi(x) - sum_i m_i g . x_i],   c = 2 zeta beta dt^2,
    x~ = x^n + dt v^n + zeta (1 - 2 beta) dt^2 a^n,

then a^{n+1} = (x - x~) / c and v^{n+1} = v^n + dt [(1 - gamma) a^n + gamma a^{n+1}]. Presets
(zeta, beta, gamma): backward Euler (1, 1/2, 1) and midpoint Newmark (1/2, 1/4, 1/2).

Psi is the FEM strain energy (mpmsim/fem/elements.py); Phi the log barrier between every
boundary node of one FEM body and every boundary edge of another,
Phi = sum_pairs w_p b(d_pe), b(d) = -kappa dhat (u - 1)^2 ln u, u = d / dhat (mpmsim/barrier),
with w_p the node's share of its body's boundary length (half the lengths of its two boundary
edges), so kappa is a pressure. The pairs come from a spatial hash of the step's swept boxes,
never from an all-pairs loop. A node near a corner of the other body counts the corner through
both of its edges (the paper's (deg - 1) point-point correction is not applied): the barrier is
stiffer there, never weaker.

Friction (Coulomb mu from contact.default / contact.pairs) is lagged and smoothed as in IPC:
at the step's start each contact within dhat fixes its normal force lambda = w_p (-b'(d)), its
sliding direction and closest-point parameter; the step adds D = sum mu lambda f0(|u|), u the
tangential slip over the step, f0 the mollifier with eps = friction_velocity * dt (below which
friction is smoothed static friction). One lag per step.

Projected Newton: element and pair Hessians projected to PSD, H = M + c (K + B) on the free
degrees of freedom (held components move to their target and are eliminated), solved with
scipy's sparse LU (splu). Line search: alpha = min(1, alpha_CCD, alpha_inversion) (additive CCD
keeps every node at least 10% of its distance from every edge; the inversion bound keeps
det F > 0), then halved until E decreases. Stop when max |p| / dt < newton_tolerance. Because
every accepted position lies on the feasible side of the CCD bound, bodies never interpenetrate,
whatever the time step. 2D (plane strain triangles); the elastic part also in 3D without
contact.
"""

from __future__ import annotations

import time as wallclock

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from numba import njit

from ..barrier import (barrier_normal_force, point_edge_barrier_pairs, point_edge_candidates, point_edge_ccd_pairs,
                       point_edge_distance, point_edge_friction, point_edge_friction_frame, triangle_step_bound)
from ..deck.schema import Implicit
from ..errors import InstabilityError
from ..fem import elements
from . import Integrator

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


def check_initial_gaps(scene, dhat: float) -> None:
    """Deck error when two FEM bodies start closer than dhat (the barrier would start infinite
    or already pushing)."""
    from ..deck.loader import raise_at
    from ..fem.probes import boundary_gap

    fem = scene.fem
    if fem.points.shape[1] != 2:
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
    if problems:
        raise_at(problems, scene.loaded)


class ImplicitFEM(Integrator):
    """`integrator: implicit`: the incremental-potential step above, for scenes of FEM bodies."""

    name = "implicit"

    def __init__(self, scene):
        super().__init__()
        deck = scene.deck
        imp = deck.implicit if deck.implicit is not None else Implicit()
        self.zeta, self.beta, self.gamma = SCHEMES[imp.scheme]
        self.tolerance = imp.newton_tolerance
        self.max_iterations = imp.max_newton_iterations
        self.dhat = imp.dhat
        mats = scene.materials
        used = sorted(set(int(c) for c in scene.fem.cell_mat))
        young = max(float(deck.materials[mats.deformable[m]].E) for m in used)
        self.kappa = imp.kappa if imp.kappa is not None else 1e-3 * young
        if self.dhat is not None:
            check_initial_gaps(scene, self.dhat)
        self.eps_v = imp.friction_velocity
        c = deck.contact
        self.mu = np.full((len(mats.deformable),) * 2, c.default.friction if c.default.law == "coulomb" else 0.0)
        index = {name: k for k, name in enumerate(mats.deformable)}
        for pair in c.pairs:
            if all(m in index for m in pair.between):
                a, b = (index[m] for m in pair.between)
                self.mu[a, b] = self.mu[b, a] = pair.friction if pair.law == "coulomb" else 0.0
        self.dt = deck.time.dt
        self.gravity = np.zeros(scene.dim)
        if deck.gravity:
            self.gravity[:] = deck.gravity
        self.timers = {p: 0.0 for p in PARTS}
        self.stats: list[tuple[int, int, int]] = []  # per step: Newton iterations, halvings, CCD-limited
        self.plan = [("newton", f"{imp.scheme} incremental potential, projected Newton, sparse LU"),
                     ("barrier contact", f"log barrier between FEM bodies, dhat {self.dhat:g}, kappa {self.kappa:g}"
                      if self.dhat else "one FEM body: no contact")]
        self.started = False
        self.friction = None
        self.spring = None  # (moving components, their targets, stiffness) during a step

    # ----------------------------------------------------------------------------- pieces
    def stable_dt(self, state) -> float:
        return self.dt

    def _setup(self, state) -> None:
        fem, m = state.fem, state.materials
        dim = fem.x.shape[1]
        self.dim = dim
        self.M = np.repeat(fem.mass, dim)
        self.contact = self.dhat is not None and len(fem.infos) > 1 and dim == 2
        if self.contact:
            self.weights = boundary_weights(fem.X, fem.facets, fem.boundary)
            self.edge_body = fem.node_body[fem.facets[:, 0]]
            node_mat = np.zeros(fem.n, dtype=np.int64)
            node_mat[fem.cells.ravel()] = np.repeat(fem.cell_mat, fem.cells.shape[1])
            self.node_mat = node_mat
        # a^0: the mechanical acceleration at the initial state
        f = np.zeros_like(fem.x)
        elements.internal_forces(fem.x, fem.cells, fem.Dm_inv, fem.vol0, fem.cell_mat, m.type_code, m.props, f)
        fem.a[:] = f / fem.mass[:, None] + self.gravity
        fem.a[fem.held] = 0.0
        self.started = True

    def _pairs(self, fem, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Point-edge pairs of different bodies whose swept boxes over x -> x + p come within dhat."""
        b = fem.boundary
        pairs = point_edge_candidates(x[b], p[b], x, p, fem.facets, self.dhat, b)
        if len(pairs):
            keep = fem.node_body[b[pairs[:, 0]]] != self.edge_body[pairs[:, 1]]
            pairs = pairs[keep]
        return pairs

    def _energy(self, state, x, xt, pairs, want_derivatives):
        """E(x) (inf if an element inverted or a pair touched), and when asked its gradient
        (n*d,) and PSD-projected Hessian (CSR)."""
        fem, m = state.fem, state.materials
        c = self.c
        dx = (x - xt).ravel()
        e_int = np.empty(len(fem.cells))
        elements.element_energies(x, fem.cells, fem.Dm_inv, fem.vol0, fem.cell_mat, m.type_code, m.props, e_int)
        psi = float(e_int.sum())
        grav = float(np.sum(fem.mass[:, None] * self.gravity[None, :] * x))
        k = len(pairs)
        gb = np.zeros((k, 6))
        Hb = np.zeros((k, 6, 6))
        phi = 0.0
        if k:
            phi = point_edge_barrier_pairs(x[fem.boundary], x, fem.facets, pairs, self.dhat, self.kappa,
                                           self.weights, gb, Hb, True)
        fr = self.friction
        nf = len(fr[0]) if fr is not None else 0
        gf = np.zeros((nf, 6))
        Hf = np.zeros((nf, 6, 6))
        dfr = 0.0
        if nf:
            fpairs, tau, r, mu_lambda = fr
            dfr = friction_pairs(x, self.x_start, fem.boundary, fem.facets, fpairs, tau, r, mu_lambda,
                                 self.eps_v * self.dt_step, gf, Hf)
        E = 0.5 * float(dx @ (self.M * dx)) + c * (psi + phi + dfr - grav)
        spring = self.spring
        if spring is not None:
            moving, target, ks = spring
            off = np.where(moving, x - target, 0.0).ravel()
            E += 0.5 * ks * float(off @ (self.M * off))
        if not want_derivatives or not np.isfinite(E):
            return E, None, None
        n, d = x.shape
        f = np.zeros_like(x)
        elements.internal_forces(x, fem.cells, fem.Dm_inv, fem.vol0, fem.cell_mat, m.type_code, m.props, f)
        g = self.M * dx + c * (-f - fem.mass[:, None] * self.gravity[None, :]).ravel()
        local = np.zeros((len(fem.cells), (d + 1) * d, (d + 1) * d))
        elements.element_hessians(x, fem.cells, fem.Dm_inv, fem.vol0, fem.cell_mat, m.type_code, m.props,
                                  True, local)
        H = elements.assemble_hessian(fem.cells, c * local, n)
        for prs, gl, Hl in ((pairs, gb, Hb), (fr[0] if nf else pairs[:0], gf, Hf)):
            if not len(prs):
                continue
            nodes = np.stack([fem.boundary[prs[:, 0]], fem.facets[prs[:, 1], 0], fem.facets[prs[:, 1], 1]], 1)
            dofs = (nodes[:, :, None] * 2 + np.arange(2)[None, None, :]).reshape(len(prs), 6)
            np.add.at(g, dofs.ravel(), c * gl.ravel())
            rows = np.repeat(dofs, 6, axis=1).ravel()
            cols = np.tile(dofs, (1, 6)).ravel()
            H = H + sp.csr_matrix((c * Hl.ravel(), (rows, cols)), shape=H.shape)
        H = H + sp.diags(self.M)
        if spring is not None:
            g += ks * self.M * off
            H = H + sp.diags(ks * self.M * moving.ravel())
        return E, g, H.tocsr()

    def _lag(self, fem, x):
        """(pairs, tau, r, mu lambda) of the contacts within dhat at the step's start (lagged
        friction: frames and normal forces held through the step's Newton solve)."""
        pairs = self._pairs(fem, x, np.zeros_like(x))
        k = len(pairs)
        if not k:
            return None
        mu = self.mu[self.node_mat[fem.boundary[pairs[:, 0]]], self.node_mat[fem.facets[pairs[:, 1], 0]]]
        tau, r, mu_lambda = np.zeros((k, 2)), np.zeros(k), np.zeros(k)
        lag_friction(x, fem.boundary, fem.facets, pairs, self.weights, mu, self.dhat, self.kappa, tau, r, mu_lambda)
        return pairs, tau, r, mu_lambda

    def _step_bound(self, fem, x, p, pairs) -> tuple[float, bool]:
        """Largest alpha in (0, 1] keeping every node 10% of its distance off every edge (CCD)
        and every triangle's det F > 0; and whether CCD limited it."""
        alpha = 1.0
        if len(fem.cells) and self.dim == 2:
            alpha = min(alpha, triangle_step_bound(x, p, fem.cells))
        limited = False
        if len(pairs):
            b = fem.boundary
            a_ccd = point_edge_ccd_pairs(x[b], p[b], x, p, fem.facets, pairs)
            if a_ccd < alpha:
                alpha, limited = a_ccd, True
        return alpha, limited

    # ----------------------------------------------------------------------------- the step
    def _newton(self, state, x, xt, free, dt):
        """Projected Newton from x on the free DOFs; returns (x, iterations, halvings, CCD-limited)."""
        fem = state.fem
        halvings = 0
        ccd_limited = False
        for it in range(1, self.max_iterations + 1):
            t0 = wallclock.perf_counter()
            pairs = self._pairs(fem, x, np.zeros_like(x)) if self.contact else np.zeros((0, 2), np.int64)
            E, g, H = self._energy(state, x, xt, pairs, True)
            self.timers["assemble"] += wallclock.perf_counter() - t0
            t0 = wallclock.perf_counter()
            p = np.zeros(x.size)
            Hf = H[free][:, free].tocsc()
            p[free] = splu(Hf).solve(-g[free])
            p = p.reshape(x.shape)
            self.timers["solve"] += wallclock.perf_counter() - t0
            if np.abs(p).max() / dt < self.tolerance:
                return x, it, halvings, ccd_limited
            t0 = wallclock.perf_counter()
            swept = self._pairs(fem, x, p) if self.contact else pairs
            alpha, limited = self._step_bound(fem, x, p, swept)
            ccd_limited |= limited
            self.timers["ccd"] += wallclock.perf_counter() - t0
            t0 = wallclock.perf_counter()
            while True:
                trial = x + alpha * p
                E_trial, _, _ = self._energy(state, trial, xt, swept, False)
                if E_trial <= E or alpha < 1e-12:
                    break
                alpha *= 0.5
                halvings += 1
            self.timers["line search"] += wallclock.perf_counter() - t0
            x = trial
        names = " and ".join(f"'{b.name}'" for b in fem.infos)
        raise InstabilityError(
            f"stopped at step {state.step + 1}, t = {state.t + dt:.6g}: Newton did not converge in "
            f"{self.max_iterations} iterations (bodies {names}; last max|p|/dt = {np.abs(p).max() / dt:.3g}); "
            "try a smaller time.dt or a larger implicit.newton_tolerance", state.t, state.step)

    def advance(self, state, dt: float) -> float:
        """One step. Fixed components stay put (eliminated). Components moving at a prescribed
        velocity are not moved to their target by fiat (that could push them through another
        body): a spring 1/2 k m |x - target|^2 pulls them there inside the Newton solve, with the
        CCD line search watching, and k grows tenfold until they are within 1e-6 of their move
        (or of newton_tolerance x dt, what Newton resolves)."""
        fem = state.fem
        if not self.started:
            self._setup(state)
        self.c = 2.0 * self.zeta * self.beta * dt * dt
        xn, vn, an = fem.x.copy(), fem.v.copy(), fem.a.copy()
        xt = xn + dt * vn + self.zeta * (1.0 - 2.0 * self.beta) * dt * dt * an
        moving = fem.held & (fem.held_velocity != 0.0)
        fixed = fem.held & ~moving
        target = xn + dt * fem.held_velocity
        free = ~fixed.ravel()
        self.x_start, self.dt_step = xn, dt
        self.friction = self._lag(fem, xn) if self.contact and self.mu.any() else None
        x = xn.copy()
        its = halvings = 0
        ccd_limited = False
        k = SPRING_START
        # reached: within 1e-6 of the move, or of what Newton's tolerance resolves
        reach = max(1e-6 * (float(np.abs(target - xn)[moving].max()) if moving.any() else 0.0),
                    self.tolerance * dt)
        while True:
            self.spring = (moving, target, k) if moving.any() else None
            x, n_it, n_half, limited = self._newton(state, x, xt, free, dt)
            its, halvings, ccd_limited = its + n_it, halvings + n_half, ccd_limited or limited
            if self.spring is None or np.abs(x - target)[moving].max() <= reach:
                break
            if k >= SPRING_MAX:
                names = ", ".join(f"'{fem.infos[b].name}'" for b in np.unique(fem.node_body[moving.any(axis=1)]))
                raise InstabilityError(
                    f"stopped at step {state.step + 1}, t = {state.t + dt:.6g}: the prescribed motion of {names} "
                    f"could not be reached (off by {np.abs(x - target)[moving].max():.3g}; something blocks it)",
                    state.t, state.step)
            k *= 10.0
        self.spring = None
        if moving.any():  # work of the prescribed motion: the constraint force (gradient / c) times the move
            pairs = self._pairs(fem, x, np.zeros_like(x)) if self.contact else np.zeros((0, 2), np.int64)
            _, g, _ = self._energy(state, x, xt, pairs, True)
            force = g.reshape(x.shape) / self.c
            state.work_in += float(np.sum(np.where(moving, force * (x - xn), 0.0)))
        a_new = (x - xt) / self.c
        a_new[fem.held] = 0.0
        fem.v[:] = vn + dt * ((1.0 - self.gamma) * an + self.gamma * a_new)
        fem.v[fem.held] = fem.held_velocity[fem.held]
        fem.a[:] = a_new
        state.work_in += float(np.sum(fem.mass[:, None] * self.gravity[None, :] * (x - xn)))
        fem.x[:] = x
        self.stats.append((its, halvings, int(ccd_limited)))
        return dt

    def report(self) -> list[str]:
        """The Newton table: steps, iterations per step (mean, max), line-search halvings and
        CCD-limited steps."""
        if not self.stats:
            return []
        its = np.array([s[0] for s in self.stats])
        halv = sum(s[1] for s in self.stats)
        ccd = sum(s[2] for s in self.stats)
        return [f"Newton: {len(its)} steps, {its.mean():.2f} iterations per step (max {its.max()}), "
                f"{halv} line-search halvings, {ccd} CCD-limited steps"]

