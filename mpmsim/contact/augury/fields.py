"""Field contact of augury particles (`contact.augury.method: field`; docs/fem-contact.md): the
FEM boundary nodes and surface particles meet on the augury grid as in multi-velocity-field
grid contact, one velocity field per body, instead of through the augury transfer H.

Per step, with the augury particles' predicted velocities v̄_p (v + τ a), positions x_p and
outward normals n_p (FEM nodes: the length-weighted mean of their facets' normals, not
normalised, so its length says how flat the surface is there: 1 on a face, cos 45° at a
right-angled corner):

1. Each body b deposits its mass, momentum, normal moment and first moment on the nodes its
   particles reach: m_ib = Σ_{p∈b} N_ip m_p, P_ib = Σ N_ip m_p v̄_p, ν_ib = Σ N_ip m_p n_p,
   X_ib = Σ N_ip m_p x_p.
2. At a node that two or more bodies reach, each body's facing moment ν'_ib sums only its
   particles that face the others, n_p · (x̄_rest − x_p) ≥ −0.1 h_c (x̄_rest the others'
   centre of mass at the node): the far face of a body thinner than the kernel's reach does
   not enter. Body a's contact normal is that of the flatter side, |ν'| / m' (its own ν'_a, or
   minus the others' sum), the larger facing mass where they are equally flat: a corner meeting
   a face takes the face's normal, and sliding along the face is not read as approach.
3. Body a's stick change is Δ_a = m_a (v_cm − v_a), v_cm the node's centre-of-mass velocity;
   where it approaches (Δ_a·n_a < 0) the material pair's law acts on it (contact/grid/laws.py
   apply_law, the grid methods' kernel: frictionless, Coulomb with optional static friction,
   stick), elsewhere nothing changes. For two bodies the changes are equal and opposite; with
   more, the remainder of their sum is taken back in proportion to mass, so each node's
   momentum is unchanged.
4. Only these changes go back to the particles: Δv_p = Σ_i N_ip Δ_{i,b(p)} / m_{i,b(p)} and
   Â_p = Δv_p / τ. A body that meets nothing is left exactly alone (sliding is not smoothed
   away), and Σ_p m_p Δv_p = Σ_i Σ_b Δ_ib = 0: linear momentum is exact. Angular momentum is not
   (the impulse pairs act at different points); the affine parts B are not changed (Â_B = 0).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..grid.laws import apply_law

FACING = 0.1  # a particle faces the others when its normal is at most this x h_c away from their side
GAP = 0.5  # contact where the facing particles are at most this x h_c apart along the normal
FLAT_TIE = 1e-6  # flatness (|nu'| / m') this close counts as equal: the larger gap decides


@njit(cache=True, inline="always")
def _deposit(ent, x, m, vbar, normal, body, mat, gm, gp, gn, gx, gmat):
    """Step 1: each body's mass, momentum, normal moment and first moment on the nodes."""
    n, K = ent.node.shape
    dim = vbar.shape[1]
    for p in range(n):
        b = body[p]
        for e in range(K):
            w = ent.weight[p, e]
            if w == 0.0:
                continue
            i = ent.node[p, e]
            wm = w * m[p]
            gm[i, b] += wm
            gmat[i, b] = mat[p]
            for d in range(dim):
                gp[i, b, d] += wm * vbar[p, d]
                gn[i, b, d] += wm * normal[p, d]
                gx[i, b, d] += wm * x[p, d]


@njit(cache=True, inline="always")
def _facing(ent, x, m, normal, body, gm, gx, h, fm, fn, faces):
    """Step 2: which entries face the others (faces (n, K)), and the facing mass fm, normal
    moment fn of each body at nodes two bodies reach."""
    n, K = ent.node.shape
    nn, nb = gm.shape
    dim = x.shape[1]
    count = np.zeros(nn, dtype=np.int64)
    mtot = np.zeros(nn)
    xtot = np.zeros((nn, dim))
    for i in range(nn):
        for b in range(nb):
            if gm[i, b] > 0.0:
                count[i] += 1
                mtot[i] += gm[i, b]
                for d in range(dim):
                    xtot[i, d] += gx[i, b, d]
    for p in range(n):
        b = body[p]
        for e in range(K):
            w = ent.weight[p, e]
            i = ent.node[p, e]
            m_rest = mtot[i] - gm[i, b]
            if w == 0.0 or count[i] < 2 or not m_rest > 0.0:
                continue
            facing = 0.0
            for d in range(dim):
                facing += normal[p, d] * ((xtot[i, d] - gx[i, b, d]) / m_rest - x[p, d])
            if facing >= -FACING * h:
                faces[p, e] = True
                wm = w * m[p]
                fm[i, b] += wm
                for d in range(dim):
                    fn[i, b, d] += wm * normal[p, d]


@njit(cache=True, inline="always")
def _unit(v):
    """v / |v| in place (zero stays zero); returns |v|."""
    size = 0.0
    for d in range(v.shape[0]):
        size += v[d] * v[d]
    size = np.sqrt(size)
    for d in range(v.shape[0]):
        v[d] = v[d] / size if size > 0.0 else 0.0
    return size


@njit(cache=True, inline="always")
def _candidates(i, a, fm, fn, gm, cand):
    """Step 2: body a's two candidate contact normals at node i, its own facing normal and minus
    the others' (cand (2, dim), unit), and which is the flatter side's: 0 own, 1 the others',
    -1 equally flat (the gap decides), -2 a side has no facing particles. Also returns the
    heaviest other body."""
    nb = gm.shape[1]
    dim = cand.shape[1]
    heaviest = -1
    m_rest = 0.0
    for d in range(dim):
        cand[0, d] = fn[i, a, d]
        cand[1, d] = 0.0
    for b in range(nb):
        if b != a and gm[i, b] > 0.0:
            m_rest += fm[i, b]
            for d in range(dim):
                cand[1, d] -= fn[i, b, d]
            if heaviest < 0 or gm[i, b] > gm[i, heaviest]:
                heaviest = b
    if not (fm[i, a] > 0.0 and m_rest > 0.0):
        return -2, heaviest
    flat_own = _unit(cand[0]) / fm[i, a]
    flat_rest = _unit(cand[1]) / m_rest
    if flat_own >= flat_rest * (1.0 - FLAT_TIE) and flat_rest >= flat_own * (1.0 - FLAT_TIE):
        return -1, heaviest
    return (0 if flat_own > flat_rest else 1), heaviest


@njit(cache=True, inline="always")
def _gaps(ent, x, body, faces, gm, cand, fore, rear):
    """Step 2: along each candidate normal of each body, the foremost of its facing particles,
    max x_p . n, and the rearmost of the others', min x_q . n: the surfaces' gap along it is
    rear - fore (the same for both bodies of a pair)."""
    n, K = ent.node.shape
    nb = gm.shape[1]
    dim = x.shape[1]
    for p in range(n):
        b = body[p]
        for e in range(K):
            i = ent.node[p, e]
            if not faces[p, e]:
                continue
            for a in range(nb):
                if gm[i, a] == 0.0:
                    continue
                for c in range(2):
                    proj = 0.0
                    for d in range(dim):
                        proj += x[p, d] * cand[i, a, c, d]
                    if a == b:
                        fore[i, a, c] = max(fore[i, a, c], proj)
                    else:
                        rear[i, a, c] = min(rear[i, a, c], proj)


@njit(cache=True)
def field_correction(ent, x, m, vbar, normal, body, mat, n_bodies, law, mu, mu_static, tau, h):
    """(Â_v, Â_B = 0) of the augury particles with grid entries `ent` (transfers.Entries) at
    x, with masses m, predicted velocities vbar, outward normals, bodies (0..n_bodies-1) and
    materials (rows of the pair tables law, mu, mu_static: contact/grid/spec.py codes)."""
    n, K = ent.node.shape
    dim = vbar.shape[1]
    nn = ent.n_nodes
    gm = np.zeros((nn, n_bodies))
    gp = np.zeros((nn, n_bodies, dim))
    gn = np.zeros((nn, n_bodies, dim))
    gx = np.zeros((nn, n_bodies, dim))
    gmat = np.full((nn, n_bodies), -1, dtype=np.int64)
    _deposit(ent, x, m, vbar, normal, body, mat, gm, gp, gn, gx, gmat)
    fm = np.zeros((nn, n_bodies))
    fn = np.zeros((nn, n_bodies, dim))
    faces = np.zeros((n, K), dtype=np.bool_)
    _facing(ent, x, m, normal, body, gm, gx, h, fm, fn, faces)
    # the candidate normals, the gaps along them, and the contact normal: the flatter side's,
    # or where both are equally flat the one along which the surfaces lie further apart (a
    # side face above a floor is not in contact with it)
    cand = np.zeros((nn, n_bodies, 2, dim))
    pick = np.full((nn, n_bodies), -2, dtype=np.int64)
    other = np.full((nn, n_bodies), -1, dtype=np.int64)
    for i in range(nn):
        present = 0
        for b in range(n_bodies):
            present += gm[i, b] > 0.0
        if present < 2:
            continue
        for a in range(n_bodies):
            if gm[i, a] > 0.0:
                pick[i, a], other[i, a] = _candidates(i, a, fm, fn, gm, cand[i, a])
    fore = np.full((nn, n_bodies, 2), -np.inf)
    rear = np.full((nn, n_bodies, 2), np.inf)
    _gaps(ent, x, body, faces, gm, cand, fore, rear)
    # step 3: the laws where the surfaces touch and approach
    dv = np.zeros((nn, n_bodies, dim))  # the velocity change of each body's field
    change = np.zeros((n_bodies, dim))
    vcm = np.zeros(dim)
    dp = np.zeros(dim)
    total = np.zeros(dim)
    for i in range(nn):
        present = 0
        mass = 0.0
        for d in range(dim):
            vcm[d] = 0.0
            total[d] = 0.0
        for b in range(n_bodies):
            if gm[i, b] > 0.0:
                present += 1
                mass += gm[i, b]
                for d in range(dim):
                    vcm[d] += gp[i, b, d]
        if present < 2:
            continue
        for d in range(dim):
            vcm[d] /= mass
        for a in range(n_bodies):
            ma = gm[i, a]
            for d in range(dim):
                change[a, d] = 0.0
            c = pick[i, a]
            if ma == 0.0 or c == -2:
                continue
            # apart along either candidate normal (a side face above a floor): no contact
            g0, g1 = rear[i, a, 0] - fore[i, a, 0], rear[i, a, 1] - fore[i, a, 1]
            if not max(g0, g1) <= GAP * h:
                continue
            if c == -1:  # equally flat: the one along which they lie further apart
                c = 0 if g0 > g1 else 1
            nrm = cand[i, a, c]
            dotn = 0.0
            for d in range(dim):
                dp[d] = ma * vcm[d] - gp[i, a, d]  # the stick change of a's momentum
                dotn += dp[d] * nrm[d]
            if not dotn < 0.0:  # separating: no contact
                continue
            ka, kb = gmat[i, a], gmat[i, other[i, a]]
            apply_law(law[ka, kb], mu[ka, kb], mu_static[ka, kb], 0, dp, nrm, dotn, True, dim, change[a])
            for d in range(dim):
                total[d] += change[a, d]
        for a in range(n_bodies):
            ma = gm[i, a]
            if ma > 0.0:
                for d in range(dim):
                    dv[i, a, d] = (change[a, d] - total[d] * ma / mass) / ma
    acc = np.zeros((n, dim))
    for p in range(n):
        b = body[p]
        for e in range(K):
            w = ent.weight[p, e]
            if w != 0.0:
                for d in range(dim):
                    acc[p, d] += w * dv[ent.node[p, e], b, d] / tau
    return acc, np.zeros((n, dim, dim))
