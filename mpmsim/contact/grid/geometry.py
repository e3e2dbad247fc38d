"""Contact geometry at one node: normals, separations, h-perpendicular and contact area.

Point-cloud methods (LR paper §3.1 and appendix; notes §2):
  coordinates x~ = (X_p - X_c, 1) relative to the cloud's centroid X_c, classes c = -1 (material a) and +1
  (material b), penalty lambda = 1e-7 h_min^2 on the normal components and 0 on the offset.
  Linear regression solves (X^T X + L) phi = X^T c. Logistic regression starts from twice that
  (one Gauss-Newton step from phi = 0) and iterates
      f = 2/E - 1,  psi = 2(E - 1)/E^2,  E = 1 + exp(-x~.phi)
      (sum psi^2 x~ x~^T + L) dphi = sum psi (c - f) x~ - L phi
  until 1 - n_k . n_(k-1) < 1e-5 or 15 iterations; NaN falls back to the linear normal.
  The normal points from a to b. The paper measures coordinates from the node; with the
  offset unpenalised the fit is translation-invariant, so the centroid gives the same optimum
  in exact arithmetic, and it decouples the offset from the normal.
Unresolved directions: a node beside a column's bulging side sees a single column of
  particles (spread 0.02 mm across, 12 mm along). Along the column's width the data say
  nothing, but least squares gives that direction a coefficient inversely proportional to
  its tiny spread, and the paper's penalty (1e-7 h^2) is too weak to stop it: the fit
  returned a normal along x where the answer is (0, 1), and the blocks slid at those nodes
  (0.6-1.9% stress error on the two-block column). Directions in which the labelled points'
  spread is below 5% of a cell get a penalty that pins the normal's component along them to
  zero; ordinary clouds (spread ~0.7 cell) keep the paper's penalty only.
Separation d_LR = min_b(X.n - R_p) - max_a(X.n + R_p), with R_p the distance from the centre
to the particle's deformed inscribed ellipse along n: 1/R_p = |diag(1/a) F^-1 n| (Eq. 25).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ...linalg import symmetric_eigen

LR_TOL = 1e-5
LR_MAX_ITER = 15
LR_PENALTY = 1e-7  # times h_min^2
UNRESOLVED_SPREAD = 0.05  # cloud spread (std, in cells) below which a direction carries no information
UNRESOLVED_PENALTY = 1e3  # times N h^2: pins the normal's component along such directions to zero


@njit(cache=True, inline="always")
def solve_small(A, b, n, x):
    """Solve A x = b (n <= 4) by Gaussian elimination with partial pivoting; A, b are
    destroyed. Returns False if singular."""
    for col in range(n):
        piv = col
        big = abs(A[col, col])
        for r in range(col + 1, n):
            if abs(A[r, col]) > big:
                big = abs(A[r, col])
                piv = r
        if big == 0.0 or not np.isfinite(big):
            return False
        if piv != col:
            for c in range(n):
                t = A[col, c]
                A[col, c] = A[piv, c]
                A[piv, c] = t
            t = b[col]
            b[col] = b[piv]
            b[piv] = t
        for r in range(col + 1, n):
            f = A[r, col] / A[col, col]
            for c in range(col, n):
                A[r, c] -= f * A[col, c]
            b[r] -= f * b[col]
    for r in range(n - 1, -1, -1):
        s = b[r]
        for c in range(r + 1, n):
            s -= A[r, c] * x[c]
        x[r] = s / A[r, r]
    return True


class Regression(NamedTuple):
    """Scratch of one regression: the gathered cloud (points, weights, labels) and the small
    systems' arrays."""

    pts: np.ndarray  # (max_cloud, 3)
    w: np.ndarray  # (max_cloud,)
    lab: np.ndarray  # (max_cloud,)
    labels: np.ndarray  # (max_cloud,) int64: labels of a node's cloud entries (-1 a, +1 b, 0 other)
    A: np.ndarray  # (4, 4)
    b: np.ndarray  # (4,)
    phi: np.ndarray  # (4,)
    dphi: np.ndarray  # (4,)
    xt: np.ndarray  # (4,)
    phi0: np.ndarray  # (4,) warm start
    cov: np.ndarray  # (3, 3)
    pen: np.ndarray  # (3, 3)
    evals: np.ndarray  # (3,) eigenvalues of cov (unresolved directions)
    evecs: np.ndarray  # (3, 3) its eigenvectors (columns)


@njit(cache=True)
def regression_scratch(max_cloud):
    m = max(max_cloud, 1)
    return Regression(np.zeros((m, 3)), np.zeros(m), np.zeros(m), np.zeros(m, dtype=np.int64), np.zeros((4, 4)),
                      np.zeros(4), np.zeros(4), np.zeros(4), np.zeros(4), np.zeros(4), np.zeros((3, 3)),
                      np.zeros((3, 3)), np.zeros(3), np.zeros((3, 3)))


@njit(cache=True, inline="always")
def particle_position(idx, clouds, d):
    return clouds.x[idx, d] if idx < clouds.n_def else clouds.rx[idx - clouds.n_def, d]


@njit(cache=True)
def gather_cloud(clouds, start, stop, dim, R):
    """Copy the labelled points of cloud entries start:stop (labels in R.labels) into
    R.pts/w/lab, positions relative to their weighted centroid. With `clouds.balance`, each
    class's weights are scaled to sum to half the point count, so a class of barely-touching
    particles still defines its side. Returns (count, total weight); count 0 if either class
    is empty."""
    cloud, weight, balance, labels = clouds.idx, clouds.w, clouds.balance, R.labels
    pts, w, lab = R.pts, R.w, R.lab
    wa = 0.0
    wb = 0.0
    m = 0
    for q in range(start, stop):
        c = labels[q - start]
        if c == 0:
            continue
        if c < 0:
            wa += weight[q]
        else:
            wb += weight[q]
        lab[m] = c
        w[m] = weight[q]
        for d in range(dim):
            pts[m, d] = particle_position(cloud[q], clouds, d)
        if dim == 2:
            pts[m, 2] = 0.0  # (logistic_system reads it; the GPU's scratch is not zeroed)
        m += 1
    if not (wa > 0.0 and wb > 0.0):
        return 0, 0.0
    scale_a = 0.5 * m / wa if balance else 1.0
    scale_b = 0.5 * m / wb if balance else 1.0
    cx = cy = cz = 0.0  # the weighted centroid (scalars: the GPU step calls this too)
    wsum = 0.0
    for q in range(m):
        w[q] *= scale_a if lab[q] < 0 else scale_b
        wsum += w[q]
        cx += w[q] * pts[q, 0]
        cy += w[q] * pts[q, 1]
        if dim == 3:
            cz += w[q] * pts[q, 2]
    for q in range(m):
        pts[q, 0] -= cx / wsum
        pts[q, 1] -= cy / wsum
        if dim == 3:
            pts[q, 2] -= cz / wsum
    return m, wsum


@njit(cache=True, inline="always")
def add_unresolved_penalty(cov, dim, thresh, big, pen, work, evals, evecs):
    """pen += big e e^T for every eigenvector e of cov whose eigenvalue is below thresh.
    Most clouds are spread in every direction; a bound on the smallest eigenvalue (det over
    the largest possible product of the others) skips the eigen-solve for them. work, evals,
    evecs: scratch (3 x 3, 3, 3 x 3)."""
    if dim == 2:
        tr = cov[0, 0] + cov[1, 1]
        det = cov[0, 0] * cov[1, 1] - cov[0, 1] * cov[1, 0]
        if tr > 0.0 and det >= thresh * tr:
            return
    else:
        tr = cov[0, 0] + cov[1, 1] + cov[2, 2]
        det = (cov[0, 0] * (cov[1, 1] * cov[2, 2] - cov[1, 2] * cov[2, 1])
               - cov[0, 1] * (cov[1, 0] * cov[2, 2] - cov[1, 2] * cov[2, 0])
               + cov[0, 2] * (cov[1, 0] * cov[2, 1] - cov[1, 1] * cov[2, 0]))
        if tr > 0.0 and det >= thresh * 0.25 * tr * tr:
            return
    symmetric_eigen(cov, dim, work, evals, evecs)
    for e in range(dim):
        if evals[e] < thresh:
            for r in range(dim):
                for c in range(dim):
                    pen[r, c] += big * evecs[r, e] * evecs[c, e]


@njit(cache=True, inline="always")
def logistic_system(pts, w, lab, m, phi, dim, A, b):
    """The Gauss-Newton system of one logistic iteration: A = sum w psi^2 x~ x~^T and
    b = sum w psi (c - f) x~, x~ = (x, y, [z,] 1). The sums are scalars (x~ padded to four
    components, unused ones zero) so they stay in registers: the cloud loop is the LR cost."""
    off2 = 1.0 if dim == 2 else 0.0  # x~[2] is the offset in 2D ...
    off3 = 1.0 - off2  # ... x~[3] in 3D
    p0, p1 = phi[0], phi[1]
    pz = phi[2] * off3  # z coefficient (3D)
    offset = phi[dim]
    a00 = a01 = a02 = a03 = a11 = a12 = a13 = a22 = a23 = a33 = 0.0
    b0 = b1 = b2 = b3 = 0.0
    for q in range(m):
        u0 = pts[q, 0]
        u1 = pts[q, 1]
        u2 = pts[q, 2] * off3 + off2
        u3 = off3
        s = offset + u0 * p0  # the order of the original loop: offset, x, y, z
        s += u1 * p1
        s += pts[q, 2] * pz
        s = min(50.0, max(-50.0, s))
        E = 1.0 + np.exp(-s)
        f = 2.0 / E - 1.0
        psi = 2.0 * (E - 1.0) / (E * E)
        wr = w[q] * psi * (lab[q] - f)
        wa = w[q] * psi * psi
        b0 += wr * u0
        b1 += wr * u1
        b2 += wr * u2
        b3 += wr * u3
        a00 += wa * u0 * u0
        a01 += wa * u0 * u1
        a02 += wa * u0 * u2
        a03 += wa * u0 * u3
        a11 += wa * u1 * u1
        a12 += wa * u1 * u2
        a13 += wa * u1 * u3
        a22 += wa * u2 * u2
        a23 += wa * u2 * u3
        a33 += wa * u3 * u3
    A[0, 0], A[0, 1], A[0, 2], A[0, 3] = a00, a01, a02, a03
    A[1, 0], A[1, 1], A[1, 2], A[1, 3] = a01, a11, a12, a13
    A[2, 0], A[2, 1], A[2, 2], A[2, 3] = a02, a12, a22, a23
    A[3, 0], A[3, 1], A[3, 2], A[3, 3] = a03, a13, a23, a33
    b[0], b[1], b[2], b[3] = b0, b1, b2, b3


@njit(cache=True)
def regression_normal(R, m, wsum, dim, h_min, logistic, out_n):
    """Normal (class -1 -> class +1) of the gathered cloud R.pts[:m] (centroid-relative,
    weights R.w, labels R.lab). `R.phi0` (length dim+1, zeros if none) warm-starts the
    logistic iterations. Returns the number of logistic iterations (0 for linear), -1 if the
    fit failed; the fit is left in R.phi."""
    pts, w, lab, phi0, A, b, phi, dphi, xt, cov, pen = R.pts, R.w, R.lab, R.phi0, R.A, R.b, R.phi, R.dphi, R.xt, R.cov, R.pen
    nu = dim + 1
    lam = LR_PENALTY * h_min * h_min
    # covariance of the points -> extra penalty on unresolved directions (module doc)
    for r in range(dim):
        for c in range(dim):
            cov[r, c] = 0.0
            pen[r, c] = lam if (r == c and logistic) else 0.0
    for q in range(m):
        for r in range(dim):
            for c in range(dim):
                cov[r, c] += w[q] * pts[q, r] * pts[q, c] / wsum
    add_unresolved_penalty(cov, dim, (UNRESOLVED_SPREAD * h_min) ** 2, UNRESOLVED_PENALTY * wsum * h_min * h_min,
                           pen, A, R.evals, R.evecs)  # (A: scratch until the linear regression below)
    # linear regression
    for r in range(nu):
        b[r] = 0.0
        for c in range(nu):
            A[r, c] = 0.0
    for q in range(m):
        for d in range(dim):
            xt[d] = pts[q, d]
        xt[dim] = 1.0
        for r in range(nu):
            b[r] += w[q] * lab[q] * xt[r]
            for c in range(nu):
                A[r, c] += w[q] * xt[r] * xt[c]
    for r in range(dim):
        for c in range(dim):
            A[r, c] += pen[r, c]
    if not solve_small(A, b, nu, phi):
        return -1
    nrm = 0.0
    for d in range(dim):
        nrm += phi[d] * phi[d]
    nrm = np.sqrt(nrm)
    if not (nrm > 0.0):
        return -1
    for d in range(dim):
        out_n[d] = phi[d] / nrm
    if not logistic:
        return 0
    # logistic regression: start from the warm start, else twice the linear solution
    warm = 0.0
    for r in range(nu):
        warm += abs(phi0[r])
    for r in range(nu):
        phi[r] = phi0[r] if warm > 0.0 else 2.0 * phi[r]
    prev0 = 0.0
    prev1 = 0.0
    prev2 = 0.0
    nrm = 0.0
    for d in range(dim):
        nrm += phi[d] * phi[d]
    nrm = np.sqrt(nrm)
    if nrm > 0.0:
        prev0 = phi[0] / nrm
        prev1 = phi[1] / nrm
        prev2 = phi[2] / nrm if dim == 3 else 0.0
    it = 0
    while it < LR_MAX_ITER:
        it += 1
        logistic_system(pts, w, lab, m, phi, dim, A, b)
        for r in range(dim):
            for c in range(dim):
                A[r, c] += pen[r, c]
                b[r] -= pen[r, c] * phi[c]
        if not solve_small(A, b, nu, dphi):
            break
        for r in range(nu):
            phi[r] += dphi[r]
        nrm = 0.0
        for d in range(dim):
            nrm += phi[d] * phi[d]
        nrm = np.sqrt(nrm)
        if not (nrm > 0.0) or not np.isfinite(nrm):
            break
        n0 = phi[0] / nrm
        n1 = phi[1] / nrm
        n2 = phi[2] / nrm if dim == 3 else 0.0
        for d in range(dim):
            out_n[d] = phi[d] / nrm
        done = 1.0 - (n0 * prev0 + n1 * prev1 + n2 * prev2) < LR_TOL
        prev0, prev1, prev2 = n0, n1, n2
        if done:
            break
    return it


@njit(cache=True)
def cloud_direction(clouds, labels, start, stop, dim, out_n):
    """Fallback normal when the regression fails: from material a's centroid to the other
    side's. False if either side is empty or they coincide."""
    cloud = clouds.idx
    na = 0
    nb = 0
    for q in range(start, stop):
        if labels[q - start] < 0:
            na += 1
        elif labels[q - start] > 0:
            nb += 1
    if na == 0 or nb == 0:
        return False
    for d in range(dim):  # (a sum per component: no scratch arrays, as on the GPU)
        sa = 0.0
        sb = 0.0
        for q in range(start, stop):
            lab = labels[q - start]
            if lab < 0:
                sa += particle_position(cloud[q], clouds, d)
            elif lab > 0:
                sb += particle_position(cloud[q], clouds, d)
        out_n[d] = sb / nb - sa / na
    nrm = 0.0
    for d in range(dim):
        nrm += out_n[d] * out_n[d]
    if not (nrm > 0.0):
        return False
    nrm = np.sqrt(nrm)
    for d in range(dim):
        out_n[d] /= nrm
    return True


@njit(cache=True, inline="always")
def deformed_radius(idx, clouds, n, dim):
    """Distance from the particle centre to its deformed inscribed ellipse along n (Eq. 25);
    rigid particles are undeformed."""
    F, semi = clouds.F, clouds.semi
    if idx >= clouds.n_def:
        s = 0.0
        for d in range(dim):
            s += (n[d] / semi[d]) ** 2
        return 1.0 / np.sqrt(s)
    p = idx
    if dim == 2:
        a, b, c, e = F[p, 0, 0], F[p, 0, 1], F[p, 1, 0], F[p, 1, 1]
        det = a * e - b * c
        n0 = (e * n[0] - b * n[1]) / det
        n1 = (-c * n[0] + a * n[1]) / det
        return 1.0 / np.sqrt((n0 / semi[0]) ** 2 + (n1 / semi[1]) ** 2)
    # 3D: F^-1 n by cofactors
    f = F[p]
    det = (f[0, 0] * (f[1, 1] * f[2, 2] - f[1, 2] * f[2, 1]) - f[0, 1] * (f[1, 0] * f[2, 2] - f[1, 2] * f[2, 0])
           + f[0, 2] * (f[1, 0] * f[2, 1] - f[1, 1] * f[2, 0]))
    i00 = (f[1, 1] * f[2, 2] - f[1, 2] * f[2, 1]) / det
    i01 = (f[0, 2] * f[2, 1] - f[0, 1] * f[2, 2]) / det
    i02 = (f[0, 1] * f[1, 2] - f[0, 2] * f[1, 1]) / det
    i10 = (f[1, 2] * f[2, 0] - f[1, 0] * f[2, 2]) / det
    i11 = (f[0, 0] * f[2, 2] - f[0, 2] * f[2, 0]) / det
    i12 = (f[0, 2] * f[1, 0] - f[0, 0] * f[1, 2]) / det
    i20 = (f[1, 0] * f[2, 1] - f[1, 1] * f[2, 0]) / det
    i21 = (f[0, 1] * f[2, 0] - f[0, 0] * f[2, 1]) / det
    i22 = (f[0, 0] * f[1, 1] - f[0, 1] * f[1, 0]) / det
    n0 = i00 * n[0] + i01 * n[1] + i02 * n[2]
    n1 = i10 * n[0] + i11 * n[1] + i12 * n[2]
    n2 = i20 * n[0] + i21 * n[1] + i22 * n[2]
    return 1.0 / np.sqrt((n0 / semi[0]) ** 2 + (n1 / semi[1]) ** 2 + (n2 / semi[2]) ** 2)


@njit(cache=True)
def cloud_separation(clouds, labels, start, stop, n, xnode, dim):
    """(d_LR, d_a, d_b): the gap between the two materials' deformed edges along n, and each
    edge's signed distance from the node (for the contact area)."""
    cloud = clouds.idx
    sup_a = -1e300
    sup_b = 1e300
    for q in range(start, stop):
        lab = labels[q - start]
        if lab == 0:
            continue
        idx = cloud[q]
        xn = 0.0
        for d in range(dim):
            xn += particle_position(idx, clouds, d) * n[d]
        R = deformed_radius(idx, clouds, n, dim)
        if lab < 0:
            sup_a = max(sup_a, xn + R)
        else:
            sup_b = min(sup_b, xn - R)
    xin = 0.0
    for d in range(dim):
        xin += xnode[d] * n[d]
    return sup_b - sup_a, sup_a - xin, sup_b - xin


@njit(cache=True, inline="always")
def h_perp(n, h, dim):
    """Cell size perpendicular to the contact plane ([P2] Eq. 22, method 1)."""
    if dim == 2:
        return np.sqrt((n[0] * h[0]) ** 2 + (n[1] * h[1]) ** 2)
    # tangents t1, t2 orthogonal to n
    if abs(n[0]) < 0.9:
        t1x, t1y, t1z = 0.0, -n[2], n[1]
    else:
        t1x, t1y, t1z = n[2], 0.0, -n[0]
    m = np.sqrt(t1x * t1x + t1y * t1y + t1z * t1z)
    t1x, t1y, t1z = t1x / m, t1y / m, t1z / m
    t2x = n[1] * t1z - n[2] * t1y
    t2y = n[2] * t1x - n[0] * t1z
    t2z = n[0] * t1y - n[1] * t1x
    s1 = (t1x / h[0]) ** 2 + (t1y / h[1]) ** 2 + (t1z / h[2]) ** 2
    s2 = (t2x / h[0]) ** 2 + (t2y / h[1]) ** 2 + (t2z / h[2]) ** 2
    return h[0] * h[1] * h[2] * np.sqrt(s1 * s2)


@njit(cache=True, inline="always")
def spline_weight(d):
    if d < 0.5:
        return 0.75 - d * d
    return max(0.0, 0.5 * (1.5 - d) ** 2)


@njit(cache=True, inline="always")
def contact_area(omega_a, omega_b, hp, d_edge, use_edge, spline):
    """Contact area at a node. Point-cloud methods weight the node's volume by the distance of
    the nearer material edge (notes §3.5); grid methods use [P2] Eq. 20."""
    total = omega_a + omega_b
    if use_edge:
        d = d_edge / hp
        w = spline_weight(d) if spline else max(0.0, 1.0 - d)
        return total * w / hp
    return np.sqrt(2.0 * min(omega_a, omega_b) * total) / hp
