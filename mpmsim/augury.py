"""APIC augury contact (Hegarty et al., "A momentum preserving frictional contact algorithm
based on affine particle-in-cell grid transfers"; ../shared/papers/apic-augury-contact.txt):
contact between bodies through a background grid of spacing h_c that only their boundary
nodes ("augury particles") see.

Given the augury particles' positions x_p, masses m_p and predicted generalized velocities
V̄_p = (v̄_p, B̄_p) (the velocity a time τ ahead under the mechanical forces alone), the grid
transfer H (particles -> grid -> particles; APIC keeps the affine part B, PIC drops it)
gives the preferred velocity. One transfer makes bodies that share grid cells move
together (they stick); N augury iterations then take back, particle by particle, the part
of the change that a contact law does not allow (Eq. 36-46):

    V̂_0 = H V̄,   V̂_m = V̂_{m-1} + (H - I) W_m,   W_m = undesired part of V̂_{m-1} - V̄,
    Â = (V̂_N - V̄) / τ.

With n_p the particle's outward normal and Δv = v̂ - v̄ its change so far: a change pulling
the particle out of its own body (Δv.n > 0, adhesion) is undesired whole; a change pushing
it in (contact) keeps its normal part and the tangential part up to Coulomb's cone,
s = min(|Δv_t|, -μ Δv.n) (μ = 0: frictionless sliding; law `stick`: the tangential part is
kept whole, the 2.3 rule of the paper); the change of B is always undesired (Eq. 45). Every
H - I application has zero net linear momentum (PIC and APIC) and zero net angular momentum
(APIC, counting the affine part: L = Σ m x × v + Σ m ε:B), so the correction Â conserves
both to round-off.

Kernels (per axis, nodes per axis): `linear` (2; hat functions), `bspline2` (3; the
quadratic B-spline, D_p = h²/4 I), `four_node` (4; the paper's Appendix B kernel with the
partition-of-unity fix of the implementation notes: with t = x/h - i, a = (1-t)²,
b = 1 + 2t - 2t², c = t², weights a/4, (a+b)/4, (b+c)/4, c/4 on nodes i-1..i+2, which sum to
1, reproduce linear fields, and give D_p = h²/2 I). D_p = Σ_i N_ip (x_i - x_p)(x_i - x_p)ᵀ is
computed from the same weights, which is what makes the APIC transfer conserve angular
momentum exactly for every kernel.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

LINEAR, BSPLINE2, FOUR_NODE = 0, 1, 2
KERNELS = {"linear": LINEAR, "bspline2": BSPLINE2, "four_node": FOUR_NODE}
NODES_PER_AXIS = (2, 3, 4)
FRICTION, STICK_SEPARATE = 0, 1  # contact rules: Coulomb cone (mu >= 0), stick-or-separate (Eq. 38)


class AuguryGrid(NamedTuple):
    """The background grid of the augury transfers: spacing h (all axes), lattice through 0."""

    h: float
    kernel: int  # LINEAR, BSPLINE2, FOUR_NODE
    apic: bool  # keep the affine part B (else PIC)


@njit(cache=True, inline="always")
def weights_1d(kernel, xi, w):
    """Weights of the nodes base..base+k-1 along one axis for a particle at xi (grid units);
    returns base."""
    if kernel == LINEAR:
        base = int(np.floor(xi))
        t = xi - base
        w[0] = 1.0 - t
        w[1] = t
        return base
    if kernel == BSPLINE2:
        base = int(np.floor(xi - 0.5))
        f = xi - base  # in [0.5, 1.5)
        w[0] = 0.5 * (1.5 - f) ** 2
        w[1] = 0.75 - (f - 1.0) ** 2
        w[2] = 0.5 * (f - 0.5) ** 2
        return base
    i = int(np.floor(xi))
    t = xi - i
    a = (1.0 - t) ** 2
    b = 1.0 + 2.0 * t - 2.0 * t * t
    c = t * t
    w[0] = 0.25 * a
    w[1] = 0.25 * (a + b)
    w[2] = 0.25 * (b + c)
    w[3] = 0.25 * c
    return i - 1


@njit(cache=True)
def particle_weights(x, grid, base, W):
    """Per particle and axis, the base node and the weights of the kernel's nodes."""
    n, dim = x.shape
    for p in range(n):
        for d in range(dim):
            base[p, d] = weights_1d(grid.kernel, x[p, d] / grid.h, W[p, d])


@njit(cache=True)
def transfer(x, m, v, B, grid, base, W, lo, extent, out_v, out_B):
    """One grid transfer H: particles -> grid -> particles (Eqs. 10, 17-20; PIC without B).
    base/W: the particles' weights (particle_weights); lo, extent: the node box. The results
    go to out_v, out_B (out_B untouched for PIC)."""
    n, dim = x.shape
    k = NODES_PER_AXIS[grid.kernel]
    h = grid.h
    nx, ny = extent[0], extent[1]
    nz = extent[2] if dim == 3 else 1
    gm = np.zeros(nx * ny * nz)
    gp = np.zeros((nx * ny * nz, dim))
    D = np.zeros((3, 3))
    Di = np.zeros((3, 3))
    r = np.zeros(3)
    Bd = np.zeros(3)
    kz = k if dim == 3 else 1
    for p in range(n):
        if grid.apic:
            inertia(p, x, base, W, h, k, dim, D, Di, r)
        for a in range(k):
            for b in range(k):
                for c in range(kz):
                    w = W[p, 0, a] * W[p, 1, b] * (W[p, 2, c] if dim == 3 else 1.0)
                    if w == 0.0:
                        continue
                    i = base[p, 0] + a - lo[0]
                    j = base[p, 1] + b - lo[1]
                    kk = (base[p, 2] + c - lo[2]) if dim == 3 else 0
                    node = i + nx * (j + ny * kk)
                    wm = w * m[p]
                    gm[node] += wm
                    if grid.apic:
                        r[0] = (base[p, 0] + a) * h - x[p, 0]
                        r[1] = (base[p, 1] + b) * h - x[p, 1]
                        if dim == 3:
                            r[2] = (base[p, 2] + c) * h - x[p, 2]
                        # B D^-1 (x_i - x_p)
                        for e in range(dim):
                            Bd[e] = 0.0
                            for f in range(dim):
                                for g in range(dim):
                                    Bd[e] += B[p, e, f] * Di[f, g] * r[g]
                        for e in range(dim):
                            gp[node, e] += wm * (v[p, e] + Bd[e])
                    else:
                        for e in range(dim):
                            gp[node, e] += wm * v[p, e]
    for node in range(gm.size):
        if gm[node] > 0.0:
            for e in range(dim):
                gp[node, e] /= gm[node]
    for p in range(n):
        for e in range(dim):
            out_v[p, e] = 0.0
            if grid.apic:
                for f in range(dim):
                    out_B[p, e, f] = 0.0
        for a in range(k):
            for b in range(k):
                for c in range(kz):
                    w = W[p, 0, a] * W[p, 1, b] * (W[p, 2, c] if dim == 3 else 1.0)
                    if w == 0.0:
                        continue
                    i = base[p, 0] + a - lo[0]
                    j = base[p, 1] + b - lo[1]
                    kk = (base[p, 2] + c - lo[2]) if dim == 3 else 0
                    node = i + nx * (j + ny * kk)
                    r[0] = (base[p, 0] + a) * h - x[p, 0]
                    r[1] = (base[p, 1] + b) * h - x[p, 1]
                    if dim == 3:
                        r[2] = (base[p, 2] + c) * h - x[p, 2]
                    for e in range(dim):
                        out_v[p, e] += w * gp[node, e]
                        if grid.apic:
                            for f in range(dim):
                                out_B[p, e, f] += w * gp[node, e] * r[f]


@njit(cache=True)
def inertia(p, x, base, W, h, k, dim, D, Di, r):
    """D_p = sum_i N_ip (x_i - x_p)(x_i - x_p)^T of particle p and its inverse (Di)."""
    for a in range(3):
        for b in range(3):
            D[a, b] = 0.0
    kz = k if dim == 3 else 1
    for a in range(k):
        for b in range(k):
            for c in range(kz):
                w = W[p, 0, a] * W[p, 1, b] * (W[p, 2, c] if dim == 3 else 1.0)
                r[0] = (base[p, 0] + a) * h - x[p, 0]
                r[1] = (base[p, 1] + b) * h - x[p, 1]
                r[2] = ((base[p, 2] + c) * h - x[p, 2]) if dim == 3 else 0.0
                for e in range(dim):
                    for f in range(dim):
                        D[e, f] += w * r[e] * r[f]
    if dim == 2:
        det = D[0, 0] * D[1, 1] - D[0, 1] * D[1, 0]
        Di[0, 0] = D[1, 1] / det
        Di[0, 1] = -D[0, 1] / det
        Di[1, 0] = -D[1, 0] / det
        Di[1, 1] = D[0, 0] / det
    else:
        det = (D[0, 0] * (D[1, 1] * D[2, 2] - D[1, 2] * D[2, 1]) - D[0, 1] * (D[1, 0] * D[2, 2] - D[1, 2] * D[2, 0])
               + D[0, 2] * (D[1, 0] * D[2, 1] - D[1, 1] * D[2, 0]))
        Di[0, 0] = (D[1, 1] * D[2, 2] - D[1, 2] * D[2, 1]) / det
        Di[0, 1] = (D[0, 2] * D[2, 1] - D[0, 1] * D[2, 2]) / det
        Di[0, 2] = (D[0, 1] * D[1, 2] - D[0, 2] * D[1, 1]) / det
        Di[1, 0] = (D[1, 2] * D[2, 0] - D[1, 0] * D[2, 2]) / det
        Di[1, 1] = (D[0, 0] * D[2, 2] - D[0, 2] * D[2, 0]) / det
        Di[1, 2] = (D[0, 2] * D[1, 0] - D[0, 0] * D[1, 2]) / det
        Di[2, 0] = (D[1, 0] * D[2, 1] - D[1, 1] * D[2, 0]) / det
        Di[2, 1] = (D[0, 1] * D[2, 0] - D[0, 0] * D[2, 1]) / det
        Di[2, 2] = (D[0, 0] * D[1, 1] - D[0, 1] * D[1, 0]) / det


@njit(cache=True)
def undesired(dv, dB, normal, mu, rule, apic, w_v, w_B):
    """W_p of Eqs. 38 and 44-46 for each particle from its change so far (dv, dB)."""
    n, dim = dv.shape
    for p in range(n):
        dn = 0.0
        for e in range(dim):
            dn += dv[p, e] * normal[p, e]
        if dn > 0.0:  # pulls the particle out of its own body: adhesion, undesired
            for e in range(dim):
                w_v[p, e] = dv[p, e]
        elif rule == STICK_SEPARATE:
            for e in range(dim):
                w_v[p, e] = 0.0
        else:  # contact: keep the normal part and the tangential part within the cone
            tn = 0.0
            for e in range(dim):
                tn += (dv[p, e] - dn * normal[p, e]) ** 2
            tn = np.sqrt(tn)
            s = min(tn, -mu[p] * dn)
            scale = (1.0 - s / tn) if tn > 0.0 else 0.0
            for e in range(dim):
                w_v[p, e] = (dv[p, e] - dn * normal[p, e]) * scale
        if apic:
            for e in range(dim):
                for f in range(dim):
                    w_B[p, e, f] = dB[p, e, f]


def node_box(x: np.ndarray, grid: AuguryGrid):
    """The particles' weights and the node box they touch: (base, W, lo, extent)."""
    n, dim = x.shape
    base = np.zeros((n, 3), dtype=np.int64)
    W = np.zeros((n, 3, 4))
    W[:, 2, 0] = 1.0  # 2D: one node layer in z
    particle_weights(x, grid, base, W)
    k = NODES_PER_AXIS[grid.kernel]
    lo = np.zeros(3, dtype=np.int64)
    extent = np.ones(3, dtype=np.int64)
    lo[:dim] = base[:, :dim].min(axis=0)
    extent[:dim] = base[:, :dim].max(axis=0) + k - lo[:dim]
    return base, W, lo, extent


def augury_correction(x, m, vbar, Bbar, normal, mu, grid: AuguryGrid, iterations: int, tau: float,
                      rule: int = FRICTION):
    """The augury acceleration correction (Â_v, Â_B) of particles at x with masses m, predicted
    velocities vbar and affine parts Bbar (ignored for PIC), outward normals and friction
    coefficients mu, after `iterations` augury iterations (0: the bodies stick)."""
    n, dim = x.shape
    base, W, lo, extent = node_box(x, grid)
    B_in = Bbar if grid.apic else np.zeros((n, dim, dim))
    v_hat = np.zeros((n, dim))
    B_hat = np.zeros((n, dim, dim))
    transfer(x, m, vbar, B_in, grid, base, W, lo, extent, v_hat, B_hat)
    hw_v = np.zeros((n, dim))
    hw_B = np.zeros((n, dim, dim))
    w_v = np.zeros((n, dim))
    w_B = np.zeros((n, dim, dim))
    for _ in range(iterations):
        undesired(v_hat - vbar, B_hat - B_in, normal, mu, rule, grid.apic, w_v, w_B)
        transfer(x, m, w_v, w_B, grid, base, W, lo, extent, hw_v, hw_B)
        v_hat += hw_v - w_v
        if grid.apic:
            B_hat += hw_B - w_B
    acc_B = (B_hat - B_in) / tau if grid.apic else np.zeros((n, dim, dim))
    return (v_hat - vbar) / tau, acc_B


def kernel_weights(kernel: str, xi: float) -> tuple[int, np.ndarray]:
    """(base node, weights) of one kernel at xi (grid units): for tests and plots."""
    w = np.zeros(4)
    base = weights_1d(KERNELS[kernel], float(xi), w)
    return base, w[: NODES_PER_AXIS[KERNELS[kernel]]]
