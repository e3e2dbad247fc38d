"""Linear simplex elements: kinematics, hyperelastic materials, energy, internal forces,
local Hessians, Cauchy stress, stable time step and lumped masses (numba kernels).

One kernel serves triangles (2D plane strain) and tetrahedra (3D); the dimension is read from
the array shapes. 2D volumes from reference_geometry are areas (per unit thickness): energies,
forces, Hessians and masses are linear in vol0, so scaling vol0 by the thickness once gives
them all per body.

Kinematics (one-point rule, exact for linear simplices):
  D_m = [X1 - X0, X2 - X0 (, X3 - X0)] (columns), D_s the same at current positions x,
  F_e = D_s D_m^-1, vol0_e = det(D_m) / d!  (cells positively oriented: det(D_m) > 0).
  Shape-function gradients g_n = dN_n/dX: g_n = row n-1 of D_m^-1 for n >= 1, g_0 = -sum.
Energy Psi = sum_e vol0_e psi(F_e) (the BFEMP paper's Psi_FEM); forces f = -dPsi/dx,
  f_{n,a} = -vol0 sum_b P_ab g_{n,b}.

Materials: integer code + property row, the layout of mpmsim.materials (row [lambda, mu, E,
nu, ...]; the models with FEM forms, COMPRESSIBLE_NH and LINEAR_ELASTIC; any other code gives
NaN, and the deck check admits only those two for FEM bodies):
  compressible neo-Hookean  psi = mu/2 (tr F^T F - d) - mu ln J + lambda/2 (ln J)^2,
                            P = mu (F - F^-T) + lambda ln J F^-T  (psi = inf for J <= 0);
  linear elastic            eps = sym(F) - I, psi = mu eps:eps + lambda/2 (tr eps)^2,
                            P = 2 mu eps + lambda tr(eps) I  (small strain: not objective).
In 2D (plane strain) F is 2x2 and d = 2, which equals the 3D energy with F33 = 1.

Flattening conventions:
  F index (a, b) -> a*d + b (row major); the stress tangent C (d*d, d*d) has
  C[a*d + b, c*d + e] = dP_ab / dF_ce.
  Element DOFs are node-major: local node n (0..d), component a -> n*d + a, so a local
  Hessian is ((d+1) d, (d+1) d) and global DOF = node*d + a (see element_dofs).

Parallelism: element loops run over chunks in prange (serially below PARALLEL_MIN elements,
where a thread launch costs more than the work), each chunk body allocating its scratch once;
per-element results go to arrays and every sum over elements (the nodal scatter of forces and
masses, the total energy) is a serial loop in element order, so results do not depend on the
thread count. A colouring of the scatter is not worth it: it is one add per element node.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..linalg import svd3, symmetric_eigen
from ..materials import compressible_neo_hookean as cnh, linear_elastic as linear
from ..materials.kernels import det_minus_one, det_small, inv_small  # noqa: F401  (det_small: part of this API)
from ..materials.model import COMPRESSIBLE_NH, LINEAR_ELASTIC
from ..parallel import specialize

__all__ = [
    "COMPRESSIBLE_NH",
    "LINEAR_ELASTIC",
    "assemble_hessian",
    "cauchy_from_piola",
    "cauchy_stresses",
    "deformation_gradients",
    "element_dofs",
    "element_energies",
    "element_forces",
    "element_hessians",
    "element_time_steps",
    "energy_density",
    "first_piola",
    "internal_forces",
    "lumped_masses",
    "point_energies",
    "point_forces",
    "point_hessians",
    "point_states",
    "project_psd",
    "reference_geometry",
    "stable_time_step",
    "strain_energy",
    "stress_tangent",
]

# PSD projection: a matrix whose eigenvalues are all >= -PSD_TOL * max|eigenvalue| counts as
# PSD (rigid-body zero modes come out as +-1e-16 relative) and is left bit-for-bit unchanged
PSD_TOL = 1e-12

MAX_CHUNKS = 256
PARALLEL_MIN = 2048  # elements; below this a kernel runs serially (no thread launch)


# ----------------------------------------------------------------------------- materials
# The FEM forms live in the material models' modules (mpmsim/materials); these dispatch on the
# type codes of the models that have them (MaterialModel.fem). Any other code gives NaN: the
# deck's checks refuse such materials on FEM bodies, and a NaN stops a run that got one.
@njit(cache=True, inline="always")
def energy_density(code, props, F):
    """psi(F) per reference volume (props: the material's row). Neo-Hookean returns inf for
    J <= 0 (a line search then rejects the step)."""
    if code == COMPRESSIBLE_NH:
        return cnh.fem_energy(props, F)
    if code == LINEAR_ELASTIC:
        return linear.fem_energy(props, F)
    return np.nan


@njit(cache=True, inline="always")
def _fem_form(code, props, F, out, Finv, neo_hookean, linear_elastic):
    """One FEM form (P or its tangent, by the model functions passed) into out; NaN for a
    model without FEM forms."""
    if code == COMPRESSIBLE_NH:
        return neo_hookean(props, F, out, Finv)
    if code == LINEAR_ELASTIC:
        return linear_elastic(props, F, out, Finv)
    out[:, :] = np.nan
    return np.nan


@njit(cache=True, inline="always")
def first_piola(code, props, F, P, Finv):
    """P = dpsi/dF into P (d, d); Finv (d, d) is scratch. Returns J (neo-Hookean P is NaN for
    J <= 0)."""
    return _fem_form(code, props, F, P, Finv, cnh.fem_piola, linear.fem_piola)


@njit(cache=True, inline="always")
def stress_tangent(code, props, F, C, Finv):
    """C[a*d + b, c*d + e] = dP_ab/dF_ce into C (d*d, d*d); Finv (d, d) scratch. Returns J."""
    return _fem_form(code, props, F, C, Finv, cnh.fem_tangent, linear.fem_tangent)


@njit(cache=True, inline="always")
def cauchy_from_piola(code, props, F, P, J, out):
    """Cauchy stress sigma = P F^T / J in Voigt order [xx, yy, zz, xy, yz, xz] (the order of
    mpmsim.materials.kernels), symmetrised (the small-strain P F^T is not exactly symmetric).
    2D plane strain adds sigma_zz (F33 = 1): neo-Hookean lambda ln J / J, linear lambda tr(eps)."""
    d = F.shape[0]
    for k in range(6):
        out[k] = 0.0
    pairs = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))
    for k in range(6):
        a, b = pairs[k]
        if a < d and b < d:
            s = 0.0
            for c in range(d):
                s += 0.5 * (P[a, c] * F[b, c] + P[b, c] * F[a, c])
            out[k] = s / J
    if d == 2:
        if code == COMPRESSIBLE_NH:
            out[2] = cnh.fem_cauchy_zz(props, F, J)
        elif code == LINEAR_ELASTIC:
            out[2] = linear.fem_cauchy_zz(props, F, J)
        else:
            out[2] = np.nan


# ----------------------------------------------------------------------------- element helpers
@njit(cache=True, inline="always")
def element_F(x, cells, Dm_inv, e, F):
    """F = D_s D_m^-1 of element e into F (d, d)."""
    d = x.shape[1]
    i0 = cells[e, 0]
    for a in range(d):
        for b in range(d):
            s = 0.0
            for c in range(d):
                s += (x[cells[e, c + 1], a] - x[i0, a]) * Dm_inv[e, c, b]
            F[a, b] = s


@njit(cache=True, inline="always")
def shape_gradients(Dm_inv, e, g):
    """g[n, b] = dN_n/dX_b of element e (g: (d + 1, d))."""
    d = Dm_inv.shape[1]
    for b in range(d):
        s = 0.0
        for n in range(d):
            g[n + 1, b] = Dm_inv[e, n, b]
            s += Dm_inv[e, n, b]
        g[0, b] = -s


@njit(cache=True, inline="always")
def n_chunks(m):
    """Element chunks of the prange loops: one (a plain serial loop, no thread launch) below
    PARALLEL_MIN elements, else a fixed count (numba.get_num_threads() inside a kernel would
    make it uncacheable) that balances any common thread count."""
    if m < PARALLEL_MIN:
        return 1
    return min(m, MAX_CHUNKS)


@njit(cache=True, inline="always")
def chunk_bounds(c, nchunk, m):
    size = (m + nchunk - 1) // nchunk
    return c * size, min(m, (c + 1) * size)


@njit(cache=True, inline="always")
def first_bad(bad):
    """Smallest non-negative entry of the per-chunk reports (-1 if none)."""
    out = -1
    for c in range(bad.shape[0]):
        if bad[c] >= 0 and (out < 0 or bad[c] < out):
            out = bad[c]
    return out


# ----------------------------------------------------------------------------- chunk bodies
# Each kernel below runs its chunk body once (small meshes) or over chunks in prange; a body
# allocates its scratch once and returns the first element of its range with J <= 0 (-1: none).
@njit(cache=True, inline="always")
def local_forces(P, g, vol, out):
    """out[n, a] = -vol sum_b P_ab g_{n,b}: the nodal forces of one element (or MPM particle)
    with shape-function gradients g (nodes, d) and first Piola stress P."""
    d = P.shape[0]
    for n in range(g.shape[0]):
        for a in range(d):
            s = 0.0
            for b in range(d):
                s += P[a, b] * g[n, b]
            out[n, a] = -vol * s


@njit(cache=True, inline="always")
def local_hessian(C, g, vol, T, H):
    """H[n*d + a, q*d + c] = vol sum_{b,e} g_{n,b} C[a*d+b, c*d+e] g_{q,e}: the Hessian of one
    element's (or MPM particle's) energy, node-major; T (d*d, nodes*d) scratch. The upper
    triangle is computed and mirrored (exactly symmetric; C symmetric up to rounding). The
    dimension is passed as a constant to the loops (unrolled by the compiler: 2.7x faster in 2D
    than with d read from the shape)."""
    if g.shape[1] == 2:
        _local_hessian(C, g, vol, T, H, 2)
    else:
        _local_hessian(C, g, vol, T, H, 3)


@njit(cache=True, inline="always")
def _local_hessian(C, g, vol, T, H, d):
    nn = g.shape[0]
    k = nn * d
    # T[(a,b), (q,c)] = sum_e' C[a*d+b, c*d+e'] g[q, e']
    for r in range(d * d):
        for q in range(nn):
            for c in range(d):
                s = 0.0
                for ep in range(d):
                    s += C[r, c * d + ep] * g[q, ep]
                T[r, q * d + c] = s
    for n in range(nn):
        for a in range(d):
            i = n * d + a
            for col in range(i, k):
                s = 0.0
                for b in range(d):
                    s += g[n, b] * T[a * d + b, col]
                v = vol * s
                H[i, col] = v
                H[col, i] = v


@njit(cache=True)
def _energies_chunk(x, cells, Dm_inv, vol0, cell_mat, code, props, out, start, stop):
    d = x.shape[1]
    F = np.empty((d, d))
    bad = -1
    for e in range(start, stop):
        element_F(x, cells, Dm_inv, e, F)
        mt = cell_mat[e]
        if not (det_minus_one(F) > -1.0) and bad < 0:
            bad = e
        out[e] = vol0[e] * energy_density(code[mt], props[mt], F)
    return bad


@njit(cache=True)
def project_psd(H):
    """Clamp the negative eigenvalues of the symmetric matrix H to zero, in place
    (H <- V diag(max(w, 0)) V^T, the nearest PSD matrix in the Frobenius norm). A matrix with
    all eigenvalues >= -PSD_TOL max|w| is left bit-for-bit unchanged. Returns the smallest
    eigenvalue before projection."""
    n = H.shape[0]
    w = np.empty(n)
    V = np.empty((n, n))
    symmetric_eigen(H, n, np.empty((n, n)), w, V)  # Jacobi, not LAPACK: the same bits on every CPU
    wmin = w.min()
    scale = max(abs(wmin), abs(w.max()))
    if wmin >= -PSD_TOL * scale:
        return wmin
    for i in range(n):
        for j in range(i, n):
            s = 0.0
            for k in range(n):
                if w[k] > 0.0:
                    s += V[i, k] * w[k] * V[j, k]
            H[i, j] = s
            H[j, i] = s
    return wmin


@njit(cache=True, inline="always")
def positive_definite(C, L):
    """Whether the symmetric matrix C is numerically positive definite: its Cholesky
    factorisation (into the scratch L, C's shape) meets only positive pivots. A cheap test
    before project_psd: a matrix that passes has no eigenvalue below -PSD_TOL max|w| (its
    computed eigenvalues are >= -eps |C|), so project_psd would leave it unchanged."""
    n = C.shape[0]
    for j in range(n):
        s = C[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not (s > 0.0):
            return False
        L[j, j] = np.sqrt(s)
        for i in range(j + 1, n):
            t = C[i, j]
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t / L[j, j]
    return True


@njit(cache=True, inline="always")
def tangent_scratch(d):
    """Scratch of project_tangent for dimension d: rows [0, n) the Cholesky factor, [n, 2n) the
    test matrix, [2n, 2n + 3) the twist modes, row 2n + 3 their eigenvalues (n = d^2)."""
    n = d * d
    return np.empty((2 * n + 4, n))


@njit(cache=True, inline="always")
def twist_modes(F, W):
    """The unit twist modes of F into the rows of W; returns their number, d (d - 1) / 2. With
    F = U S V^T, mode (i, j) is U (e_i e_j^T - e_j e_i^T) V^T / sqrt(2): an exact eigenvector of
    the stress tangent of every isotropic energy (in the frame of F's singular vectors the
    tangent is block diagonal, each off-diagonal pair (ij, ji) a block [[a, b], [b, a]];
    Smith, De Goes, Kim 2019, Analytic eigensystems for isotropic distortion energies,
    doi:10.1145/3241041). In 2D U W V^T = W R for the rotation W = [[0, -1], [1, 0]], R the
    polar rotation of F: no SVD."""
    d = F.shape[0]
    r2 = np.sqrt(0.5)
    if d == 2:
        c, s = F[0, 0] + F[1, 1], F[1, 0] - F[0, 1]  # R = [[c, -s], [s, c]] / |(c, s)|
        r = np.hypot(c, s)
        if not (r > 0.0):
            c, s, r = 1.0, 0.0, 1.0
        c, s = c / r * r2, s / r * r2
        W[0, 0], W[0, 1], W[0, 2], W[0, 3] = -s, -c, c, -s
        return 1
    U = np.empty((3, 3))
    V = np.empty((3, 3))
    svd3(F, U, np.empty(3), V)  # one-sided Jacobi, not LAPACK: the same bits on every CPU
    m = 0
    for i in range(d):
        for j in range(i + 1, d):
            for a in range(d):
                for b in range(d):
                    W[m, a * d + b] = r2 * (U[a, i] * V[b, j] - U[a, j] * V[b, i])
            m += 1
    return m


@njit(cache=True)
def project_tangent(code, F, C, work):
    """Make the stress tangent C = dP/dF (d^2 square) PSD in place, as projected Newton needs
    (a Hessian vol G^T C G is then PSD); `work` from tangent_scratch. Linear elasticity's
    constant tangent is PSD already (admissible moduli). A positive definite C is left as it
    is (one Cholesky attempt). Otherwise the negative eigenvalues sit, for an isotropic energy
    under compression, on the twist modes (neo-Hookean: mu - (mu - lambda ln J) / (s_i s_j)),
    whose eigenvectors are known (twist_modes): their Rayleigh quotients are the eigenvalues;
    when the rest of C is positive definite (Cholesky of C with the twist eigenvalues set to
    C's largest diagonal entry), the negative ones are clamped to zero by a rank-one update
    each. Anything else goes to the eigendecomposition (project_psd). Either way the result is
    the nearest PSD matrix; a C whose eigenvalues are >= -PSD_TOL times its scale is not
    changed."""
    if code == LINEAR_ELASTIC:
        return
    n = C.shape[0]
    L, B, W, lam = work[:n], work[n:2 * n], work[2 * n:2 * n + 3], work[2 * n + 3]
    if positive_definite(C, L):
        return
    m = twist_modes(F, W)
    scale = 0.0
    for i in range(n):
        scale = max(scale, abs(C[i, i]))
    for i in range(n):
        for j in range(n):
            B[i, j] = C[i, j]
    negative = False
    for q in range(m):
        s = 0.0
        for i in range(n):
            for j in range(n):
                s += W[q, i] * C[i, j] * W[q, j]
        lam[q] = s
        negative |= s < -PSD_TOL * scale
        for i in range(n):
            for j in range(n):
                B[i, j] += (scale - s) * W[q, i] * W[q, j]
    if not positive_definite(B, L):
        project_psd(C)
        return
    if negative:
        for q in range(m):
            if lam[q] < 0.0:
                for i in range(n):
                    for j in range(n):
                        C[i, j] -= lam[q] * W[q, i] * W[q, j]


@njit(cache=True, inline="always")
def _local_chunk(x, cells, Dm_inv, vol0, cell_mat, code, props, hessian, project, out, start, stop):
    """Each element's nodal forces (out (m, d + 1, d)) or, with `hessian`, its energy's Hessian
    (out (m, (d+1) d, (d+1) d), PSD-projected with `project`)."""
    d = x.shape[1]
    k = (d + 1) * d
    work = np.empty((3, d, d))
    F, P, Finv = work[0], work[1], work[2]
    C = np.empty((d * d, d * d))
    scratch = tangent_scratch(d)
    T = np.empty((d * d, k))
    g = np.empty((d + 1, d))
    bad = -1
    for e in range(start, stop):
        element_F(x, cells, Dm_inv, e, F)
        shape_gradients(Dm_inv, e, g)
        mt = cell_mat[e]
        if hessian:
            J = stress_tangent(code[mt], props[mt], F, C, Finv)
            if project:  # a PSD tangent makes the Hessian g^T C g PSD
                project_tangent(code[mt], F, C, scratch)
            local_hessian(C, g, vol0[e], T, out[e])
        else:
            J = first_piola(code[mt], props[mt], F, P, Finv)
            local_forces(P, g, vol0[e], out[e])
        if not (J > 0.0) and bad < 0:
            bad = e
    return bad


@njit(cache=True)
def _forces_chunk(x, cells, Dm_inv, vol0, cell_mat, code, props, fe, start, stop):
    return _local_chunk(x, cells, Dm_inv, vol0, cell_mat, code, props, False, False, fe, start, stop)


@njit(cache=True)
def _hessians_chunk(x, cells, Dm_inv, vol0, cell_mat, code, props, project, out, start, stop):
    return _local_chunk(x, cells, Dm_inv, vol0, cell_mat, code, props, True, project, out, start, stop)


@njit(cache=True)
def _cauchy_chunk(x, cells, Dm_inv, cell_mat, code, props, out, start, stop):
    d = x.shape[1]
    work = np.empty((3, d, d))
    F, P, Finv = work[0], work[1], work[2]
    bad = -1
    for e in range(start, stop):
        element_F(x, cells, Dm_inv, e, F)
        mt = cell_mat[e]
        J = first_piola(code[mt], props[mt], F, P, Finv)
        if not (J > 0.0) and bad < 0:
            bad = e
        cauchy_from_piola(code[mt], props[mt], F, P, J, out[e])
    return bad


@njit(cache=True)
def _time_steps_chunk(x, cells, cell_mat, props, density, out, start, stop):
    d = x.shape[1]
    work = np.empty((2, d, d))
    Ds, Dinv = work[0], work[1]
    bad = -1
    for e in range(start, stop):
        i0 = cells[e, 0]
        for a in range(d):
            for c in range(d):
                Ds[a, c] = x[cells[e, c + 1], a] - x[i0, a]
        if not (inv_small(Ds, Dinv) > 0.0) and bad < 0:
            bad = e
        # gradients of the barycentric coordinates: the rows of Ds^-1 and minus their sum
        S = 0.0
        for b in range(d):
            g0 = 0.0
            for n in range(d):
                S += Dinv[n, b] * Dinv[n, b]
                g0 -= Dinv[n, b]
            S += g0 * g0
        length = 2.0 / np.sqrt((d + 1) * S) if np.isfinite(S) else 0.0
        mt = cell_mat[e]
        out[e] = length / np.sqrt((props[mt, 0] + 2.0 * props[mt, 1]) / density[mt])
    return bad


@njit(cache=True)
def _gradients_chunk(x, cells, Dm_inv, F, start, stop):
    for e in range(start, stop):
        element_F(x, cells, Dm_inv, e, F[e])
    return -1


# ----------------------------------------------------------------------------- kernels
@njit(cache=True)
def reference_geometry(points, cells):
    """(Dm_inv (m, d, d), vol0 (m,)) of every cell: D_m = [X1 - X0, X2 - X0 (, X3 - X0)] and
    vol0 = det(D_m) / d! (2D: area per unit thickness). Cells must be positively oriented."""
    m = cells.shape[0]
    d = points.shape[1]
    Dm_inv = np.empty((m, d, d))
    vol0 = np.empty(m)
    Dm = np.empty((d, d))
    fact = 2.0 if d == 2 else 6.0
    for e in range(m):
        i0 = cells[e, 0]
        for a in range(d):
            for c in range(d):
                Dm[a, c] = points[cells[e, c + 1], a] - points[i0, a]
        vol0[e] = inv_small(Dm, Dm_inv[e]) / fact
    return Dm_inv, vol0


CHUNK = None  # the chunk function of one `over_elements` copy


def elements_in_chunks(m, *args):
    """CHUNK(*args, start, stop) over the m elements in chunks (in parallel on large meshes);
    the first element it reports bad (-1: none)."""
    nchunk = n_chunks(m)
    if nchunk == 1:
        return CHUNK(*args, 0, m)
    bad = np.full(nchunk, -1, dtype=np.int64)
    for c in prange(nchunk):
        start, stop = chunk_bounds(c, nchunk, m)
        bad[c] = CHUNK(*args, start, stop)
    return first_bad(bad)


def over_elements(chunk, name: str):
    """A parallel kernel running `chunk` over the elements (elements_in_chunks)."""
    return njit(parallel=True, cache=True)(specialize(elements_in_chunks, name, CHUNK=chunk))


_element_energies = over_elements(_energies_chunk, "element_energies")
_element_forces = over_elements(_forces_chunk, "element_forces")
_element_hessians = over_elements(_hessians_chunk, "element_hessians")
_cauchy_stresses = over_elements(_cauchy_chunk, "cauchy_stresses")
_element_time_steps = over_elements(_time_steps_chunk, "element_time_steps")


@njit(parallel=True, cache=True)
def deformation_gradients(x, cells, Dm_inv, F):
    """F[e] = D_s D_m^-1 for every element (F: (m, d, d), overwritten)."""
    m = cells.shape[0]
    nchunk = n_chunks(m)
    if nchunk == 1:
        _gradients_chunk(x, cells, Dm_inv, F, 0, m)
        return
    for c in prange(nchunk):
        start, stop = chunk_bounds(c, nchunk, m)
        _gradients_chunk(x, cells, Dm_inv, F, start, stop)


@njit(cache=True)
def element_energies(x, cells, Dm_inv, vol0, cell_mat, code, props, out):
    """out[e] = vol0_e psi(F_e) (inf for an inverted neo-Hookean element). Returns the first
    element with J <= 0 (-1: none)."""
    return _element_energies(cells.shape[0], x, cells, Dm_inv, vol0, cell_mat, code, props, out)


@njit(cache=True)
def strain_energy(x, cells, Dm_inv, vol0, cell_mat, code, props):
    """Total strain energy sum_e vol0_e psi(F_e) (inf if a neo-Hookean element is inverted)."""
    out = np.empty(cells.shape[0])
    element_energies(x, cells, Dm_inv, vol0, cell_mat, code, props, out)
    total = 0.0
    for e in range(out.shape[0]):
        total += out[e]
    return total


@njit(cache=True)
def element_forces(x, cells, Dm_inv, vol0, cell_mat, code, props, fe):
    """fe[e, n, a] = -d(vol0_e psi(F_e))/dx_{n,a} = -vol0 sum_b P_ab g_{n,b} (fe: (m, d+1, d)).
    Returns the first element with J <= 0 (-1: none; neo-Hookean forces there are NaN)."""
    return _element_forces(cells.shape[0], x, cells, Dm_inv, vol0, cell_mat, code, props, fe)


@njit(cache=True)
def internal_forces(x, cells, Dm_inv, vol0, cell_mat, code, props, f):
    """Internal nodal forces f = -dPsi/dx into f (n, d) (overwritten): element forces (in
    parallel on large meshes), then a serial scatter in element order. Returns the first
    element with J <= 0 (-1: none)."""
    m = cells.shape[0]
    d = x.shape[1]
    fe = np.empty((m, d + 1, d))
    bad = element_forces(x, cells, Dm_inv, vol0, cell_mat, code, props, fe)
    f[:] = 0.0
    for e in range(m):
        for n in range(d + 1):
            i = cells[e, n]
            for a in range(d):
                f[i, a] += fe[e, n, a]
    return bad


@njit(cache=True)
def element_hessians(x, cells, Dm_inv, vol0, cell_mat, code, props, project, out):
    """Local Hessians out[e] = d^2(vol0_e psi(F_e))/dx^2, ((d+1) d, (d+1) d), node-major DOFs
    (local node n, component a -> n*d + a): vol0 sum_{b,e'} g_{n,b} C[a*d+b, c*d+e'] g_{m,e'}.
    With project=True the stress tangent is projected to PSD first (project_tangent), which
    makes each Hessian PSD, as projected Newton needs.
    Returns the first element with J <= 0 (-1: none)."""
    return _element_hessians(cells.shape[0], x, cells, Dm_inv, vol0, cell_mat, code, props, project, out)


@njit(cache=True)
def cauchy_stresses(x, cells, Dm_inv, cell_mat, code, props, out):
    """Cauchy stress of every element, Voigt [xx, yy, zz, xy, yz, xz] (out: (m, 6)); see
    cauchy_from_piola. Returns the first element with J <= 0 (-1: none)."""
    return _cauchy_stresses(cells.shape[0], x, cells, Dm_inv, cell_mat, code, props, out)


@njit(cache=True)
def element_time_steps(x, cells, cell_mat, props, density, out):
    """out[e] = l_e / c_e at positions x: c_e = sqrt((lambda + 2 mu) / rho) the small-strain
    dilatational wave speed, and the element length
        l_e = 2 / sqrt((d + 1) sum_n |grad N_n|^2) = 2 / sqrt((d + 1) sum_n 1 / h_n^2)
    (h_n the altitude over node n): 2 / (d + 1) times the root-mean-square harmonic mean of
    the altitudes; the inscribed circle/sphere diameter of a regular simplex, the element
    length in 1D.
    Why not the smallest altitude: on the Kuhn tetrahedra of `mesh.box` min altitude / c
    exceeds the central-difference limit 2 / omega_max by up to 13 %. l_e / c is a proof:
    with lumped mass m_e = rho V / (d + 1) per node, u^T K_e u = V (2 mu |eps|^2 + lambda
    (tr eps)^2) <= V (lambda + 2 mu) sum_n |g_n|^2 |u|^2, so omega_e^2 <= (d + 1) c^2 sum |g_n|^2
    and omega_max <= max_e omega_e (element eigenvalue inequality): dt = min_e l_e / c <=
    2 / omega_max for linear elasticity and for neo-Hookean at small strain (the same tangent at
    F = I). On the generated meshes it is 0.6-0.75 of the exact limit. Large neo-Hookean
    compression stiffens the tangent: the caller keeps a safety factor.
    Returns the first element with det D_s <= 0 (-1: none)."""
    return _element_time_steps(cells.shape[0], x, cells, cell_mat, props, density, out)


@njit(cache=True)
def stable_time_step(x, cells, cell_mat, props, density):
    """The smallest element_time_steps value (see there)."""
    out = np.empty(cells.shape[0])
    element_time_steps(x, cells, cell_mat, props, density, out)
    return out.min()


@njit(cache=True)
def lumped_masses(cells, vol0, cell_mat, density, n_nodes):
    """Row-sum lumped nodal masses (n_nodes,): each element gives rho vol0 / (d + 1) to each of
    its nodes (2D: per unit thickness)."""
    m, k = cells.shape
    mass = np.zeros(n_nodes)
    for e in range(m):
        share = density[cell_mat[e]] * vol0[e] / k
        for n in range(k):
            mass[cells[e, n]] += share
    return mass


# ----------------------------------------------------------------------------- MPM particles as elements
# An implicit MPM step moves the active grid nodes by u_i with the particles' weights frozen at
# the step's start: F_p = [I + sum_i u_i grad w_ip^T] F_p^n = F_p^n + sum_k u_{node(p,k)} G_pk^T
# with G_pk = F_p^n^T grad w_ip. So a particle is an element whose nodes are its grid nodes and
# whose shape-function gradients are G_pk, with vol0_p its initial volume: the same local
# forces and Hessians as a simplex (local_forces, local_hessian).
@njit(cache=True, inline="always")
def point_F(u, nodes, G, F0, p, F):
    """F = F0_p + sum_k u[nodes[p, k]] G[p, k]^T into F (d, d)."""
    d = F.shape[0]
    for a in range(d):
        for b in range(d):
            s = F0[p, a, b]
            for k in range(nodes.shape[1]):
                s += u[nodes[p, k], a] * G[p, k, b]
            F[a, b] = s


@njit(cache=True)
def point_energies(u, nodes, G, F0, vol0, mat, code, props, out):
    """out[p] = vol0_p psi(F_p(u)) (inf when a neo-Hookean particle inverts). Returns the
    first particle with J <= 0 (-1: none)."""
    d = u.shape[1]
    F = np.empty((d, d))
    bad = -1
    for p in range(nodes.shape[0]):
        point_F(u, nodes, G, F0, p, F)
        if not (det_minus_one(F) > -1.0) and bad < 0:
            bad = p
        out[p] = vol0[p] * energy_density(code[mat[p]], props[mat[p]], F)
    return bad


@njit(cache=True, inline="always")
def _point_form(u, nodes, G, F0, p, code, props, F, out, Finv, tangent):
    """F of particle p (point_F) into F, then its first Piola stress (or, with `tangent`, the
    stress tangent) into out. Returns J."""
    point_F(u, nodes, G, F0, p, F)
    if tangent:
        return stress_tangent(code, props, F, out, Finv)
    return first_piola(code, props, F, out, Finv)


@njit(cache=True)
def point_forces(u, nodes, G, F0, vol0, mat, code, props, f):
    """Grid-node forces f = -d(sum_p vol0_p psi(F_p))/du into f (n_nodes, d) (overwritten),
    summed in particle order. Returns the first particle with J <= 0 (-1: none)."""
    d = u.shape[1]
    K = nodes.shape[1]
    work = np.empty((3, d, d))
    F, P, Finv = work[0], work[1], work[2]
    fe = np.empty((K, d))
    f[:] = 0.0
    bad = -1
    for p in range(nodes.shape[0]):
        J = _point_form(u, nodes, G, F0, p, code[mat[p]], props[mat[p]], F, P, Finv, False)
        if not (J > 0.0) and bad < 0:
            bad = p
        local_forces(P, G[p], vol0[p], fe)
        for k in range(K):
            for a in range(d):
                f[nodes[p, k], a] += fe[k, a]
    return bad


@njit(cache=True)
def _point_hessians_chunk(u, nodes, G, F0, vol0, mat, code, props, project, out, start, stop):
    d = u.shape[1]
    K = nodes.shape[1]
    work = np.empty((2, d, d))
    F, Finv = work[0], work[1]
    C = np.empty((d * d, d * d))
    scratch = tangent_scratch(d)
    T = np.empty((d * d, K * d))
    bad = -1
    for p in range(start, stop):
        J = _point_form(u, nodes, G, F0, p, code[mat[p]], props[mat[p]], F, C, Finv, True)
        if not (J > 0.0) and bad < 0:
            bad = p
        # the tangent, (d d) square, not the (K d) square Hessian: G^T C+ G is PSD
        if project:
            project_tangent(code[mat[p]], F, C, scratch)
        local_hessian(C, G[p], vol0[p], T, out[p])
    return bad


@njit(cache=True, parallel=True)
def point_hessians(u, nodes, G, F0, vol0, mat, code, props, project, out):
    """Local Hessians out[p] (K d, K d) of each particle's energy over its grid nodes
    (node-major). With `project` the stress tangent dP/dF is projected to PSD first
    (project_tangent: d^2 square, not (K d)^2, 4 x 4 against 18 x 18 in 2D), which makes the
    Hessian PSD; it equals the exact Hessian wherever the tangent is already PSD. In chunks over
    the threads from PARALLEL_MIN particles, as the element kernels (each particle's own: the
    same results on any thread count; on the rings deck's 948 particles 2 threads of the shared
    2-core machine were slower, 129 against 55 ms per step). Returns the first particle with
    J <= 0."""
    n = nodes.shape[0]
    nchunk = n_chunks(n)
    if nchunk == 1:
        return _point_hessians_chunk(u, nodes, G, F0, vol0, mat, code, props, project, out, 0, n)
    bad = np.full(nchunk, -1, dtype=np.int64)
    for c in prange(nchunk):
        start, stop = chunk_bounds(c, nchunk, n)
        bad[c] = _point_hessians_chunk(u, nodes, G, F0, vol0, mat, code, props, project, out, start, stop)
    return first_bad(bad)


@njit(cache=True)
def point_states(u, nodes, G, F0, mat, code, props, F_out, cauchy):
    """Each particle's F (into F_out (n, d, d)) and Cauchy stress (Voigt, into cauchy (n, 6))
    after the grid moved by u."""
    d = u.shape[1]
    work = np.empty((2, d, d))
    P, Finv = work[0], work[1]
    for p in range(nodes.shape[0]):
        F = F_out[p]
        point_F(u, nodes, G, F0, p, F)
        mt = mat[p]
        J = first_piola(code[mt], props[mt], F, P, Finv)
        cauchy_from_piola(code[mt], props[mt], F, P, J, cauchy[p])


# ----------------------------------------------------------------------------- assembly (setup / implicit)
def element_dofs(cells: np.ndarray, dim: int) -> np.ndarray:
    """(m, (d+1) d) global DOF numbers node*d + a of each element, in local Hessian order."""
    cells = np.asarray(cells, dtype=np.int64)
    return (cells[:, :, None] * dim + np.arange(dim)[None, None, :]).reshape(len(cells), -1)


def assemble_hessian(cells: np.ndarray, local: np.ndarray, n_nodes: int):
    """Global sparse (CSR) matrix, n_nodes*d square, from the local Hessians (m, k, k)
    (duplicates summed)."""
    import scipy.sparse as sp

    dim = cells.shape[1] - 1
    dofs = element_dofs(cells, dim)
    k = dofs.shape[1]
    rows = np.repeat(dofs, k, axis=1).ravel()
    cols = np.tile(dofs, (1, k)).ravel()
    n = n_nodes * dim
    return sp.csr_matrix((np.asarray(local).ravel(), (rows, cols)), shape=(n, n))
