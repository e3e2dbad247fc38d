"""MPM particles in the implicit step (BFEMP, arXiv:2108.03349; docs/bfemp.md): the
unknowns of a particle body are the positions y_i of the active grid nodes, with the particles'
weights w_ip and gradients grad w_ip frozen at the step's start (their positions x_p^n).

    grid mass       m_i = sum_p w_ip m_p
    grid velocity   m_i v_i = sum_p w_ip m_p [v_p + B_p D_p^-1 (X_i - x_p)]   (APIC; PIC/FLIP: no B)
    grid accel.     m_i a_i = sum_p w_ip m_p a_p                               (Newmark's a^n)
    particle        x_p(y) = x_p^n + sum_i w_ip (y_i - X_i),
                    F_p(y) = F_p^n + sum_i (y_i - X_i) (F_p^nT grad w_ip)^T   (fem.elements point_*)

with D_p = sum_i w_ip (X_i - x_p)(X_i - x_p)^T from the same weights, so the APIC transfers
conserve angular momentum for any tensor shape function.

Quadrature: with quadratic B-splines the weights and gradients are the averages of N_i and
grad N_i over each particle's domain (domain_weights), not their values at x_p. The particle
sums then integrate every row exactly over the body, including the rows of basis functions cut
off by a body's end, where the point values miss the kink of N_i' inside a domain that
contains a knot (3 particles per cell direction: first-order convergence; docs/bfemp.md,
"Refinement"). A domain containing a knot reaches 4 nodes along that axis.
After the Newton solve the grid's new velocity and acceleration go back to the particles:
PIC v_p = sum w v_i; FLIP v_p += sum w (v_i - v_i^n); APIC also B_p = sum w v_i (X_i - x_p)^T;
a_p = sum w a_i; positions and F follow the grid's motion.

Walls: the constrained faces of grid.boundaries hold the active nodes on and beyond their grid
line (`held`): a fixed face every component, a roller (slip) face the normal one. Those
components keep zero displacement (the integrator eliminates them); unlike the explicit step
there is no ghost mirroring, so with B-splines the material at the wall line moves by the
small weight of the first free node (the wall acts half a cell or so inside the face).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import linalg
from ..contact.augury.transfers import inertia_inverse, to_grid
from ..errors import InstabilityError
from ..fem import elements
from ..shapes import ShapeData
from ..shapes.cpdi import corner_signs
from ..shapes.grid_functions import BSPLINE2, _bspline2

WEIGHT_FLOOR = 1e-10  # grid weights below this are dropped (begin)
KNOT_TOLERANCE = 1e-9  # a domain end this close to a B-spline knot (cell units) ends on it
SLIVER_WEIGHT = 1e-8  # a domain's 1D weight on a 4th node below this is folded into the others


@njit(cache=True, inline="always")
def _bspline2_integral(r):
    """int_{-inf}^r N(s) ds of the quadratic B-spline N (knots at +-1/2, +-3/2)."""
    if r <= -1.5:
        return 0.0
    if r < -0.5:
        t = r + 1.5
        return t * t * t / 6.0
    if r < 0.5:
        return 0.5 + 0.75 * r - r * r * r / 3.0
    if r < 1.5:
        t = 1.5 - r
        return 1.0 - t * t * t / 6.0
    return 1.0


@njit(cache=True)
def domain_weights(x, F, semi, origin, h, shape, nodes, S, G, wide):
    """Quadratic B-splines averaged over each particle's domain (GIMP's integration, Bardenhagen
    & Kober 2004, doi:10.3970/cmes.2004.005.477, applied to B-splines): along axis a the domain is
    [x_a - l_a, x_a + l_a], l_a = semi_a |F_aa| (the undeformed half-length stretched by F's
    diagonal; at most half a cell), and

        w_i = (M(r+) - M(r-)) / (2 l),   dw_i/dx = (N(r+) - N(r-)) / (2 l h),   r+- = (x +- l)/h - i

    (M the integral of N): the exact averages of N_i and N_i' over the domain. A domain that
    contains a knot reaches 4 nodes along that axis (the point rule's 3 miss the kink). Fills
    nodes, S (n, 4^d) and G (n, 4^d, d) (the tensor products: the exact domain averages of N_i and
    grad N_i over the box), and wide[p, a] (the 4th node along a carries weight); returns the
    first particle whose nodes leave the grid, or -1."""
    n, d = x.shape
    w = np.zeros((3, 4))
    dw = np.zeros((3, 4))
    base = np.zeros(3, np.int64)
    bad = -1
    for p in range(n):
        out = False
        for a in range(3):
            for k in range(4):
                w[a, k] = 1.0 if a >= d and k == 0 else 0.0
                dw[a, k] = 0.0
            base[a] = 0
        for a in range(d):
            xi = (x[p, a] - origin[a]) / h[a]
            ln = min(semi[a] * abs(F[p, a, a]) / h[a], 0.5)
            lo = int(np.floor(xi - ln - 1.5 + KNOT_TOLERANCE)) + 1  # first node whose support meets the domain
            hi = int(np.ceil(xi + ln + 1.5 - KNOT_TOLERANCE)) - 1
            base[a] = lo
            for k in range(min(hi - lo + 1, 4)):
                r = xi - (lo + k)
                if ln > 1e-12:
                    w[a, k] = (_bspline2_integral(r + ln) - _bspline2_integral(r - ln)) / (2.0 * ln)
                    dw[a, k] = (_bspline2(r + ln)[0] - _bspline2(r - ln)[0]) / (2.0 * ln * h[a])
                else:  # a collapsed domain: the point values
                    w[a, k], dw[a, k] = _bspline2(r)
                    dw[a, k] /= h[a]
            if hi - lo >= 3:  # four nodes: the domain contains a knot
                # a node that only a sliver of the domain reaches (its support ends within
                # about 0.01 cell of the domain's end: weight ~ s^3, gradient ~ s^2) would be an
                # almost free unknown, pulled by stresses and held by a stiffness ~ s^4: its
                # weight and gradient go to the next two nodes by linear extrapolation (2, -1),
                # which keeps sum w = 1, sum w X = x, sum dw = 0 and sum dw X = 1 exact
                for e, n1, n2 in ((0, 1, 2), (3, 2, 1)):
                    if w[a, e] < SLIVER_WEIGHT:
                        w[a, n1] += 2.0 * w[a, e]
                        w[a, n2] -= w[a, e]
                        dw[a, n1] += 2.0 * dw[a, e]
                        dw[a, n2] -= dw[a, e]
                        w[a, e] = 0.0
                        dw[a, e] = 0.0
                if w[a, 0] == 0.0:  # the first node folded away: shift the stencil
                    for k in range(3):
                        w[a, k] = w[a, k + 1]
                        dw[a, k] = dw[a, k + 1]
                    w[a, 3] = 0.0
                    dw[a, 3] = 0.0
                    base[a] += 1
            wide[p, a] = w[a, 3] != 0.0
            if base[a] < 0 or base[a] + (3 if wide[p, a] else 2) >= shape[a]:
                out = True
        if out and bad < 0:
            bad = p
        k = 0
        for c in range(4 if d == 3 else 1):
            for b in range(4):
                for a in range(4):
                    if out:
                        nodes[p, k] = 0
                    else:
                        i0 = min(base[0] + a, shape[0] - 1)
                        i1 = min(base[1] + b, shape[1] - 1)
                        i2 = min(base[2] + c, shape[2] - 1)
                        nodes[p, k] = i0 + shape[0] * (i1 + shape[1] * i2)
                    S[p, k] = 0.0 if out else w[0, a] * w[1, b] * w[2, c]
                    G[p, k, 0] = 0.0 if out else dw[0, a] * w[1, b] * w[2, c]
                    G[p, k, 1] = 0.0 if out else w[0, a] * dw[1, b] * w[2, c]
                    if d == 3:
                        G[p, k, 2] = 0.0 if out else w[0, a] * w[1, b] * dw[2, c]
                    k += 1
    return bad


def averaged_shape_data(x, F, semi, view) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """(nodes, S, G, first particle off the grid or -1) of domain_weights, with the 4th node of
    an axis kept only where some particle's domain reaches it (4 per axis for the particles of
    a body with an odd count per cell on the grid's lattice; 3, the point rule's stencil, with
    an even count, where no domain contains a knot)."""
    n, d = x.shape
    K = 4**d
    nodes = np.zeros((n, K), np.int64)
    S, G = np.zeros((n, K)), np.zeros((n, K, d))
    wide = np.zeros((n, 3), np.bool_)
    shape = np.asarray(view.shape, np.int64)
    bad = domain_weights(x, F, np.asarray(semi, float), np.asarray(view.origin, float), np.asarray(view.h, float),
                         shape, nodes, S, G, wide)
    keep = tuple(slice(None) if wide[:, a].any() else slice(0, 3) for a in reversed(range(d)))
    box = (n,) + (4,) * d
    nodes = nodes.reshape(box)[(slice(None),) + keep].reshape(n, -1)
    S = S.reshape(box)[(slice(None),) + keep].reshape(n, -1)
    G = G.reshape(box + (d,))[(slice(None),) + keep].reshape(n, -1, d)
    return nodes, S, G, bad


def kept_weights(S: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """The weights S (n, K) with the entries not kept zeroed and each row rescaled to sum 1."""
    out = np.where(keep, S, 0.0)
    out /= out.sum(axis=1, keepdims=True)
    return out


@njit(cache=True)
def reference_gradients(S, G, F):
    """The weight gradients over the step's reference (the configuration at its start):
    F^T grad w (n, K, d), with the gradients of dropped entries (S = 0) zeroed and the rest
    corrected by - S_k sum_k grad w_k, which restores sum_k grad w_k = 0 (rigid motions
    strain-free) with sum_k w_k = 1."""
    n, K, d = G.shape
    out = np.empty((n, K, d))
    g = np.empty((K, d))
    s = np.empty(d)
    for p in range(n):
        s[:] = 0.0
        for k in range(K):
            for b in range(d):
                g[k, b] = G[p, k, b] if S[p, k] != 0.0 else 0.0
                s[b] += g[k, b]
        for k in range(K):
            for b in range(d):
                g[k, b] -= S[p, k] * s[b]
            for a in range(d):
                t = 0.0
                for b in range(d):
                    t += F[p, b, a] * g[k, b]
                out[p, k, a] = t
    return out


@njit(cache=True)
def particle_update(nodes, S, x, X, u, v_new, v_old, a_new, flip, apic, xp, vp, Bp, ap):
    """Grid -> particle after the solve: positions follow the grid's motion u, velocities by
    PIC / FLIP / APIC, accelerations by interpolation."""
    n, K = S.shape
    d = x.shape[1]
    for p in range(n):
        for c in range(d):
            dx = 0.0
            vi = 0.0
            dv = 0.0
            ai = 0.0
            for k in range(K):
                i = nodes[p, k]
                w = S[p, k]
                dx += w * u[i, c]
                vi += w * v_new[i, c]
                dv += w * (v_new[i, c] - v_old[i, c])
                ai += w * a_new[i, c]
                if apic:
                    if k == 0:
                        for e in range(d):
                            Bp[p, c, e] = 0.0
                    for e in range(d):
                        Bp[p, c, e] += w * v_new[i, c] * (X[i, e] - x[p, e])
            xp[p, c] = x[p, c] + dx
            vp[p, c] = vp[p, c] + dv if flip else vi
            ap[p, c] = ai


@njit(cache=True)
def point_deformation(u, nodes, G, F0):
    """F_p = F0_p + sum_k u[nodes[p, k]] G[p, k]^T (n, d, d), the sum in k order (numpy's einsum
    "pka,pkb->pab" of u[nodes] and G to the bit, without the gather)."""
    n, K = nodes.shape
    d = u.shape[1]
    out = np.empty((n, d, d))
    for p in range(n):
        for a in range(d):
            for b in range(d):
                s = 0.0
                for k in range(K):
                    s += u[nodes[p, k], a] * G[p, k, b]
                out[p, a, b] = F0[p, a, b] + s
    return out


def walls(ijk: np.ndarray, face_type: np.ndarray, wall_index: np.ndarray, d: int) -> np.ndarray:
    """(n, d) bool: components of the nodes (i, j, k) held by a constrained face (on and beyond
    its grid line; FIXED all components, ROLLER the normal one)."""
    from ..scene.grid import FIXED, ROLLER

    held = np.zeros((len(ijk), d), bool)
    for f in range(2 * d):
        t = int(face_type[f])
        if t not in (FIXED, ROLLER):
            continue
        axis = f // 2
        on = ijk[:, axis] <= wall_index[f] if f % 2 == 0 else ijk[:, axis] >= wall_index[f]
        if t == FIXED:
            held[on] = True
        else:
            held[on, axis] = True
    return held


class GridUnknowns:
    """The particle bodies' share of one implicit step: set up by `begin` (shape functions,
    active nodes, grid masses and velocities), read by the integrator's energy, and closed by
    `finish` (particles updated from the solved grid motion)."""

    def __init__(self, transfer: str, quadrature: str = "domain"):
        self.transfer = transfer
        self.quadrature = quadrature  # domain: B-splines averaged over the particles' domains; points: at centres
        self.a = None  # (n, d) particle accelerations (Newmark's a^n, interpolated back each step)
        self._hessians = None  # the particles' local Hessians, overwritten each Newton iteration

    def begin(self, state) -> None:
        P = state.particles
        shape = state.shape
        grid = state.grid
        (_, _), (bad, _) = shape.compute(P.x, P.F, P.semi, grid, state.nchunk, state.sd)
        if bad >= 0:
            raise InstabilityError(
                f"stopped at step {state.step + 1}, t = {state.t:.6g}: a particle of "
                f"'{P.infos[P.local_body[bad]].name}' at {np.round(P.x[bad], 6).tolist()} left the grid "
                "(make grid.domain larger)", state.t, state.step)
        sd = state.sd
        nodes, S, G = sd.nodes, sd.S, sd.G
        if shape.grid_kind == BSPLINE2 and self.quadrature == "domain":
            nodes, S, G, bad = averaged_shape_data(P.x, P.F, P.semi, grid.view)
            if bad >= 0:
                raise InstabilityError(
                    f"stopped at step {state.step + 1}, t = {state.t:.6g}: a particle of "
                    f"'{P.infos[P.local_body[bad]].name}' at {np.round(P.x[bad], 6).tolist()} reaches past the grid "
                    "(make grid.domain larger)", state.t, state.step)
        # entries of negligible weight (a particle almost 1.5 cells from a B-spline node) would
        # make nodes of ~zero mass and an ill-conditioned Newton system: drop them, then restore
        # sum_k w = 1 and sum_k grad w = 0 (momentum and rigid motions stay exact)
        S = kept_weights(S, S > WEIGHT_FLOOR)
        flat = nodes
        active = np.unique(flat[S != 0.0])
        local = np.searchsorted(active, flat)
        local[S == 0.0] = 0
        self.active = active
        d = P.x.shape[1]
        sx, sy = int(grid.view.shape[0]), int(grid.view.shape[1])
        ijk = np.stack([active % sx, (active // sx) % sy, active // (sx * sy)], axis=1).astype(float)
        origin, h = np.asarray(grid.view.origin, dtype=float), np.asarray(grid.view.h, dtype=float)
        self.X = origin[None, :d] + ijk[:, :d] * h[None, :d]
        self.held = walls(ijk.astype(np.int64), np.asarray(grid.view.face_type), np.asarray(grid.view.wall_index), d)
        self.nodes, self.S = local, S
        self.G = reference_gradients(S, G, P.F)
        self.F0 = P.F.copy()
        self.vol0, self.mat = P.vol0, P.mat
        self.x0 = P.x.copy()
        n_g = len(active)
        apic = self.transfer == "apic" and P.affine
        r = self.X[local] - P.x[:, None, :]
        Dinv = np.zeros((P.n, 3, 3))
        if apic:
            inertia_inverse(S, r, Dinv)
        B = P.B if P.affine else np.zeros((P.n, d, d))
        if self.a is None:
            self.a = np.zeros_like(P.x)
        self.mass, self.v = to_grid(P.mass, P.v, B, apic, local, S, r, Dinv, n_g)
        _, self.a_grid = to_grid(P.mass, self.a, B, False, local, S, r, Dinv, n_g)

    @property
    def n(self) -> int:
        return len(self.mass)

    def corners(self, state) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Contact points on the particles' deformed domains, 2^d per particle: the corners
        x_p + F_p (+-l) at the step's start, carried by the shape functions at the corners over
        the active nodes (frozen like the particles' own). Returns (particle, nodes, weights,
        offsets), the offsets making the start positions exact when a corner's stencil reaches
        past the active nodes (those weights are dropped and the rest rescaled to sum 1)."""
        P = state.particles
        d = P.x.shape[1]
        signs = corner_signs(d)
        x = (P.x[:, None, :] + np.einsum("pab,cb->pca", P.F, signs * P.semi[:d])).reshape(-1, d)
        F = np.repeat(P.F, len(signs), axis=0)
        sd = ShapeData.empty(len(x), state.sd.S.shape[1], d)
        (_, _), (bad, _) = state.shape.compute(x, F, P.semi, state.grid, state.nchunk, sd)
        owner = np.repeat(np.arange(P.n), len(signs))
        if bad >= 0:
            q = owner[bad]
            raise InstabilityError(
                f"stopped at step {state.step + 1}, t = {state.t:.6g}: a particle of "
                f"'{P.infos[P.local_body[q]].name}' at {np.round(P.x[q], 6).tolist()} reaches past the grid "
                "(make grid.domain larger)", state.t, state.step)
        local = np.minimum(np.searchsorted(self.active, sd.nodes), len(self.active) - 1)
        S = kept_weights(sd.S, (sd.S > WEIGHT_FLOOR) & (self.active[local] == sd.nodes))
        local[S == 0.0] = 0
        pad = self.S.shape[1] - S.shape[1]  # as wide as the particles' own entries (zero weights)
        if pad > 0:
            local, S = np.pad(local, ((0, 0), (0, pad))), np.pad(S, ((0, 0), (0, pad)))
        offset = x - np.einsum("qk,qkc->qc", S, self.X[local])
        return owner, local, S, offset

    # --- energy pieces (u: grid displacement y - X)
    def energy(self, u, materials) -> float:
        out = np.empty(len(self.S))
        elements.point_energies(u, self.nodes, self.G, self.F0, self.vol0, self.mat, materials.type_code,
                                materials.props, out)
        return float(out.sum())

    def forces(self, u, materials) -> np.ndarray:
        f = np.zeros_like(u)
        elements.point_forces(u, self.nodes, self.G, self.F0, self.vol0, self.mat, materials.type_code,
                              materials.props, f)
        return f

    def hessians(self, u, materials, project: bool = True) -> np.ndarray:
        K, d = self.S.shape[1], u.shape[1]
        shape = (len(self.S), K * d, K * d)
        if self._hessians is None or self._hessians.shape != shape:  # kept: no fresh pages each iteration
            self._hessians = np.empty(shape)
        out = self._hessians  # every entry written; read by the assembly before the next call
        elements.point_hessians(u, self.nodes, self.G, self.F0, self.vol0, self.mat, materials.type_code,
                                materials.props, project, out)
        return out

    def positions(self, u) -> np.ndarray:
        """Particle positions x_p(y)."""
        return self.x0 + np.einsum("pk,pkc->pc", self.S, u[self.nodes])

    def deformation(self, u) -> np.ndarray:
        """F_p(y) (n, d, d)."""
        return point_deformation(u, self.nodes, self.G, self.F0)

    def finish(self, state, u, v_new, a_new) -> None:
        P = state.particles
        apic = self.transfer == "apic" and P.affine
        B = P.B if P.affine else np.zeros((P.n, u.shape[1], u.shape[1]))
        particle_update(self.nodes, self.S, self.x0, self.X, u, v_new, self.v, a_new, self.transfer == "flip", apic,
                        P.x, P.v, B, self.a)
        m = state.materials
        elements.point_states(u, self.nodes, self.G, self.F0, P.mat, m.type_code, m.props, P.F, P.stress)
        P.vol[:] = P.vol0 * linalg.det(P.F)
