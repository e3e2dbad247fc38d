"""Prescribed rigid motion of held FEM nodes (a constraint's `motion`, docs/bfemp.md): phases of
constant translation velocity v and angular velocity w about an axis through a centre c, one
after another. The motion at time t is a rigid map x = R(t) X + b(t) of the initial positions X;
in a phase that started at t0 with the map (R0, b0), with tau = t - t0 and c0 = R0 c + b0 the
centre carried so far,

    x(t) = Q(w tau) (R0 X + b0 - c0) + c0 + v tau,     dx/dt = w x (x - c0 - v tau) + v,

Q(w tau) the rotation by |w| tau about w / |w| (Rodrigues). After the last phase the map stays.
2D: w is a number (about z). Plain numpy: a few hundred nodes once per step."""

from __future__ import annotations

import numpy as np

from .. import linalg


def rotation(w: np.ndarray, tau: float) -> np.ndarray:
    """Q(w tau): the rotation by the angle |w| tau about w (3,) or, 2D, by w[0] tau about z."""
    if len(w) == 1:
        a = w[0] * tau
        return np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    a = linalg.norm(w) * tau
    if a == 0.0:
        return np.eye(3)
    k = w / linalg.norm(w)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(a) * K + (1.0 - np.cos(a)) * linalg.matmul(K, K)


def cross(w: np.ndarray, r: np.ndarray) -> np.ndarray:
    """w x r for rows r (n, d); 2D: w[0] e_z x r."""
    if len(w) == 1:
        return w[0] * np.stack([-r[:, 1], r[:, 0]], axis=1)
    return np.cross(w, r)


class RigidMotion:
    """The phases of one constraint's `motion` (MotionPhase entries: until, velocity, angular_velocity,
    center) in `dim` dimensions."""

    def __init__(self, phases, dim: int):
        self.dim = dim
        self.until = np.array([p.until for p in phases], float)
        self.v = np.array([p.velocity if p.velocity is not None else [0.0] * dim for p in phases], float)
        w = [p.angular_velocity if p.angular_velocity is not None else 0.0 for p in phases]
        self.w = np.array([[x] if dim == 2 else (x if isinstance(x, list) else [0.0, 0.0, 0.0]) for x in w], float)
        self.c = np.array([p.center if p.center is not None else [0.0] * dim for p in phases], float)

    def _phase(self, t: float):
        """(phase index or -1 after the last, its start map (R0, b0), tau = t - start)."""
        R, b, start = np.eye(self.dim), np.zeros(self.dim), 0.0
        for k, end in enumerate(self.until):
            if t <= end:
                return k, R, b, t - start
            tau = end - start
            c0 = linalg.matvec(R, self.c[k]) + b
            Q = rotation(self.w[k], tau)
            R, b = linalg.matmul(Q, R), linalg.matvec(Q, b - c0) + c0 + self.v[k] * tau
            start = end
        return -1, R, b, 0.0

    def pose(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(R, b): the map x = R X + b at time t."""
        k, R, b, tau = self._phase(t)
        if k < 0:
            return R, b
        c0 = linalg.matvec(R, self.c[k]) + b
        Q = rotation(self.w[k], tau)
        return linalg.matmul(Q, R), linalg.matvec(Q, b - c0) + c0 + self.v[k] * tau

    def positions(self, X: np.ndarray, t: float) -> np.ndarray:
        """x(t) of the initial positions X (n, dim)."""
        R, b = self.pose(t)
        return linalg.matmul(np.ascontiguousarray(X, dtype=np.float64), np.ascontiguousarray(R.T)) + b

    def velocities(self, X: np.ndarray, t: float) -> np.ndarray:
        """dx/dt at t (the phase ending at t counts: its rate), zero after the last phase."""
        k, R, b, tau = self._phase(t)
        if k < 0:
            return np.zeros_like(X)
        c0 = linalg.matvec(R, self.c[k]) + b
        x = self.positions(X, t)
        return cross(self.w[k], x - c0 - self.v[k] * tau) + self.v[k]
