"""APIC augury contact (Hegarty et al., "A momentum preserving frictional contact algorithm
based on affine particle-in-cell grid transfers"; docs/fem-contact.md):
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

from ...materials.kernels import inv3

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
def particle_entries(x, grid, base, W, lo, extent, node, weight, r):
    """Each particle's K = k^dim grid entries: node index in the box (lo, extent), weight
    N_ip and offset x_i - x_p, from its per-axis base nodes and weights (base, W)."""
    n, dim = x.shape
    k = NODES_PER_AXIS[grid.kernel]
    h = grid.h
    K = node.shape[1]
    for p in range(n):
        for e in range(K):
            a = e % k
            b = (e // k) % k
            c = e // (k * k)
            w = W[p, 0, a] * W[p, 1, b]
            idx = (base[p, 0] + a - lo[0]) + extent[0] * (base[p, 1] + b - lo[1])
            r[p, e, 0] = (base[p, 0] + a) * h - x[p, 0]
            r[p, e, 1] = (base[p, 1] + b) * h - x[p, 1]
            if dim == 3:
                w *= W[p, 2, c]
                idx += extent[0] * extent[1] * (base[p, 2] + c - lo[2])
                r[p, e, 2] = (base[p, 2] + c) * h - x[p, 2]
            node[p, e] = idx
            weight[p, e] = w


@njit(cache=True)
def inertia_inverse(weight, r, Di):
    """D_p^-1 with D_p = sum_i N_ip (x_i - x_p)(x_i - x_p)^T (2D: padded to 3x3)."""
    n, K, dim = r.shape
    D = np.zeros((3, 3))
    for p in range(n):
        for a in range(3):
            for b in range(3):
                D[a, b] = 1.0 if (a == b and a >= dim) else 0.0
        for e in range(K):
            for a in range(dim):
                for b in range(dim):
                    D[a, b] += weight[p, e] * r[p, e, a] * r[p, e, b]
        inv3(D, Di[p])


@njit(cache=True)
def to_grid(m, v, B, apic, node, weight, r, Di, n_nodes):
    """Particles -> grid: node masses and velocities, m_i v_i = sum_p N_ip m_p [v_p + B_p
    D_p^-1 (x_i - x_p)] (PIC without B), through the particles' entries and inertia inverses."""
    n, K, dim = r.shape
    gm = np.zeros(n_nodes)
    gp = np.zeros((n_nodes, dim))
    Bd = np.zeros(3)
    for p in range(n):
        for e in range(K):
            w = weight[p, e]
            if w == 0.0:
                continue
            i = node[p, e]
            wm = w * m[p]
            gm[i] += wm
            for a in range(dim):
                Bd[a] = 0.0
                if apic:  # B D^-1 (x_i - x_p)
                    for b in range(dim):
                        for c in range(dim):
                            Bd[a] += B[p, a, b] * Di[p, b, c] * r[p, e, c]
            for a in range(dim):
                gp[i, a] += wm * (v[p, a] + Bd[a])
    for i in range(n_nodes):
        if gm[i] > 0.0:
            for a in range(dim):
                gp[i, a] /= gm[i]
    return gm, gp


@njit(cache=True)
def transfer(m, v, B, apic, node, weight, r, Di, n_nodes, out_v, out_B):
    """One grid transfer H: particles -> grid -> particles (Eqs. 10, 17-20; PIC without B),
    through the particles' entries (particle_entries) and inertia inverses (inertia_inverse).
    The results go to out_v, out_B (out_B untouched for PIC)."""
    n, K, dim = r.shape
    gm, gp = to_grid(m, v, B, apic, node, weight, r, Di, n_nodes)
    for p in range(n):
        for a in range(dim):
            out_v[p, a] = 0.0
            if apic:
                for b in range(dim):
                    out_B[p, a, b] = 0.0
        for e in range(K):
            w = weight[p, e]
            if w == 0.0:
                continue
            i = node[p, e]
            for a in range(dim):
                out_v[p, a] += w * gp[i, a]
                if apic:
                    for b in range(dim):
                        out_B[p, a, b] += w * gp[i, a] * r[p, e, b]


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


class Entries(NamedTuple):
    """The augury particles' grid entries for one step (particle_entries)."""

    node: np.ndarray  # (n, K) node index in the box
    weight: np.ndarray  # (n, K)
    r: np.ndarray  # (n, K, dim) x_i - x_p
    Di: np.ndarray  # (n, 3, 3) D_p^-1
    n_nodes: int  # nodes in the box


@njit(cache=True)
def grid_entries(x, grid):
    """Weights, offsets and inertia of particles at x on the augury grid (one node box around
    them, on the lattice through the origin), as Entries."""
    n, dim = x.shape
    k = NODES_PER_AXIS[grid.kernel]
    base = np.zeros((n, 3), dtype=np.int64)
    W = np.zeros((n, 3, 4))
    particle_weights(x, grid, base, W)
    lo = np.zeros(3, dtype=np.int64)
    extent = np.ones(3, dtype=np.int64)
    for d in range(dim):
        lo[d] = base[:, d].min()
        extent[d] = base[:, d].max() + k - lo[d]
    K = k**dim
    node, weight, r = np.zeros((n, K), dtype=np.int64), np.zeros((n, K)), np.zeros((n, K, dim))
    particle_entries(x, grid, base, W, lo, extent, node, weight, r)
    Di = np.zeros((n, 3, 3))
    inertia_inverse(weight, r, Di)
    return Entries(node, weight, r, Di, extent[0] * extent[1] * extent[2])


@njit(cache=True)
def apply_h(ent, m, v, B, apic):
    """H V: (v, B) after one transfer (B zeros for PIC)."""
    out_v, out_B = np.zeros_like(v), np.zeros_like(B)
    transfer(m, v, B, apic, ent.node, ent.weight, ent.r, ent.Di, ent.n_nodes, out_v, out_B)
    return out_v, out_B


@njit(cache=True)
def correction(ent, m, vbar, Bbar, normal, mu, grid, iterations, tau, rule):
    """(Â_v, Â_B): the augury acceleration correction of particles with grid entries `ent`,
    masses m, predicted velocities vbar and affine parts Bbar (zero for PIC), outward normals
    and friction coefficients mu, after `iterations` augury iterations (0: bodies stick)."""
    n, dim = vbar.shape
    v_hat, B_hat = apply_h(ent, m, vbar, Bbar, grid.apic)
    w_v = np.zeros((n, dim))
    w_B = np.zeros((n, dim, dim))
    for _ in range(iterations):
        undesired(v_hat - vbar, B_hat - Bbar, normal, mu, rule, grid.apic, w_v, w_B)
        hw_v, hw_B = apply_h(ent, m, w_v, w_B, grid.apic)
        v_hat += hw_v - w_v
        if grid.apic:
            B_hat += hw_B - w_B
    acc_B = (B_hat - Bbar) / tau if grid.apic else np.zeros((n, dim, dim))
    return (v_hat - vbar) / tau, acc_B


def augury_correction(x, m, vbar, Bbar, normal, mu, grid: AuguryGrid, iterations: int, tau: float,
                      rule: int = FRICTION):
    """The augury acceleration correction (Â_v, Â_B) of particles at x (see `correction`)."""
    n, dim = x.shape
    B_in = Bbar if grid.apic else np.zeros((n, dim, dim))
    return correction(grid_entries(x, grid), m, vbar, B_in, normal, mu, grid, iterations, tau, rule)


def kernel_weights(kernel: str, xi: float) -> tuple[int, np.ndarray]:
    """(base node, weights) of one kernel at xi (grid units): for tests and plots."""
    w = np.zeros(4)
    base = weights_1d(KERNELS[kernel], float(xi), w)
    return base, w[: NODES_PER_AXIS[KERNELS[kernel]]]
