"""MPM particles in the implicit step (BFEMP, arXiv:2108.03349; docs/bfemp.md): the
unknowns of a particle body are the positions y_i of the active grid nodes, with the particles'
weights w_ip and gradients grad w_ip frozen at the step's start (their positions x_p^n).

    grid mass       m_i = sum_p w_ip m_p
    grid velocity   m_i v_i = sum_p w_ip m_p [v_p + B_p D_p^-1 (X_i - x_p)]   (APIC; PIC/FLIP: no B)
    grid accel.     m_i a_i = sum_p w_ip m_p a_p                               (Newmark's a^n)
    particle        x_p(y) = x_p^n + sum_i w_ip (y_i - X_i),
                    F_p(y) = F_p^n + sum_i (y_i - X_i) (F_p^nT grad w_ip)^T   (fem.elements point_*)

with D_p = sum_i w_ip (X_i - x_p)(X_i - x_p)^T from the same weights (h^2/4 I for quadratic
B-splines), so the APIC transfers conserve angular momentum for any tensor shape function.
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

from ..contact.augury.transfers import inertia_inverse, to_grid
from ..errors import InstabilityError
from ..fem import elements
from ..shapes import ShapeData
from ..shapes.cpdi import corner_signs

WEIGHT_FLOOR = 1e-10  # grid weights below this are dropped (begin)


def kept_weights(S: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """The weights S (n, K) with the entries not kept zeroed and each row rescaled to sum 1."""
    out = np.where(keep, S, 0.0)
    out /= out.sum(axis=1, keepdims=True)
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

    def __init__(self, transfer: str):
        self.transfer = transfer
        self.a = None  # (n, d) particle accelerations (Newmark's a^n, interpolated back each step)

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
        # entries of negligible weight (a particle almost 1.5 cells from a B-spline node) would
        # make nodes of ~zero mass and an ill-conditioned Newton system: drop them, then restore
        # sum_k w = 1 and sum_k grad w = 0 (momentum and rigid motions stay exact)
        S = kept_weights(sd.S, sd.S > WEIGHT_FLOOR)
        grad = np.where(S[:, :, None] != 0.0, sd.G, 0.0)
        grad -= S[:, :, None] * grad.sum(axis=1, keepdims=True)
        flat = sd.nodes
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
        self.G = np.einsum("pba,pkb->pka", P.F, grad)  # F^nT grad w
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
        sd = ShapeData.empty(len(x), self.S.shape[1], d)
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

    def hessians(self, u, materials) -> np.ndarray:
        K, d = self.S.shape[1], u.shape[1]
        out = np.zeros((len(self.S), K * d, K * d))
        elements.point_hessians(u, self.nodes, self.G, self.F0, self.vol0, self.mat, materials.type_code,
                                materials.props, True, out)
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
        P.vol[:] = P.vol0 * np.linalg.det(P.F)
