"""FEM element kernels (mpmsim/fem/elements.py): patch tests, stresses and tangents against
finite differences, element forces and Hessians against finite differences, PSD projection,
Cauchy stress, masses and the stable time step."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.fem import elements as E
from mpmsim.fem.mesh import box, disk, rectangle

pytestmark = pytest.mark.fem

NH, LIN = E.COMPRESSIBLE_NH, E.LINEAR_ELASTIC
MATERIALS = [NH, LIN]


def material_table(code, young=3.0, nu=0.3, rho=2.0):
    lam = young * nu / ((1 + nu) * (1 - 2 * nu))
    mu = young / (2 * (1 + nu))
    props = np.zeros((1, 72))
    props[0, :4] = lam, mu, young, nu
    return np.array([code], dtype=np.int64), props, np.array([rho])


def closed_form_P(code, props, A):
    lam, mu = props[0], props[1]
    d = A.shape[0]
    if code == NH:
        J = np.linalg.det(A)
        Ait = np.linalg.inv(A).T
        return mu * (A - Ait) + lam * np.log(J) * Ait
    eps = 0.5 * (A + A.T) - np.eye(d)
    return 2 * mu * eps + lam * np.trace(eps) * np.eye(d)


def random_F(rng, d, size):
    while True:
        F = np.eye(d) + size * rng.uniform(-1.0, 1.0, (d, d))
        if np.linalg.det(F) > 0.2:
            return F


def setup(mesh, code):
    c, props, rho = material_table(code)
    Dm_inv, vol0 = E.reference_geometry(mesh.points, mesh.cells)
    mat = np.zeros(mesh.n_cells, dtype=np.int64)
    return dict(cells=mesh.cells, Dm_inv=Dm_inv, vol0=vol0, cell_mat=mat, code=c, props=props), rho


def forces(x, g):
    f = np.zeros_like(x)
    bad = E.internal_forces(x, g["cells"], g["Dm_inv"], g["vol0"], g["cell_mat"], g["code"], g["props"], f)
    return f, bad


def energy(x, g):
    return E.strain_energy(x, g["cells"], g["Dm_inv"], g["vol0"], g["cell_mat"], g["code"], g["props"])


def hessians(x, g, project=False):
    k = x.shape[1] * (x.shape[1] + 1)
    H = np.zeros((len(g["cells"]), k, k))
    bad = E.element_hessians(x, g["cells"], g["Dm_inv"], g["vol0"], g["cell_mat"], g["code"], g["props"],
                             project, H)
    return H, bad


MESHES = {2: lambda: rectangle((0.0, 0.0), (2.0, 1.0), 0.25), 3: lambda: box((0.0, 0.0, 0.0), (1.0, 0.5, 0.75), 0.25)}


# ----------------------------------------------------------------------------- patch test
@pytest.mark.parametrize("code", MATERIALS)
@pytest.mark.parametrize("d", [2, 3])
def test_patch_affine_motion(d, code):
    rng = np.random.default_rng(10 * d + code)
    mesh = MESHES[d]()
    g, _ = setup(mesh, code)
    assert np.all(g["vol0"] > 0) and g["vol0"].sum() == pytest.approx(np.prod(np.ptp(mesh.points, axis=0)))
    A = random_F(rng, d, 0.3)
    x = mesh.points @ A.T + rng.uniform(-1, 1, d)
    F = np.zeros((mesh.n_cells, d, d))
    E.deformation_gradients(x, mesh.cells, g["Dm_inv"], F)
    assert np.abs(F - A).max() < 1e-12
    # P of the kernel's material function at each element's F equals the closed form at A
    props = g["props"][0]
    P_exact = closed_form_P(code, props, A)
    P, Finv = np.zeros((d, d)), np.zeros((d, d))
    for e in range(0, mesh.n_cells, 7):
        E.first_piola(code, props, F[e], P, Finv)
        assert np.abs(P - P_exact).max() < 1e-12 * np.abs(P_exact).max()
    # nodal forces: -sum over the node's facets of P N dA / d; so zero at interior nodes
    f, bad = forces(x, g)
    assert bad == -1
    N, area = mesh.facet_normals(), mesh.facet_areas()
    expect = np.zeros_like(x)
    traction = -(N @ P_exact.T) * area[:, None] / d
    for j in range(d):
        np.add.at(expect, mesh.facets[:, j], traction)
    scale = np.abs(f).max()
    assert scale > 0
    assert np.abs(f - expect).max() < 1e-10 * scale
    interior = np.setdiff1d(np.arange(mesh.n_nodes), mesh.boundary_nodes)
    assert len(interior) > 0 and np.abs(f[interior]).max() < 1e-10 * scale
    # energy is vol * psi(A), Cauchy stress P A^T / J
    V = g["vol0"].sum()
    assert energy(x, g) == pytest.approx(V * E.energy_density(code, props, A), rel=1e-12)
    sig = np.zeros((mesh.n_cells, 6))
    assert E.cauchy_stresses(x, mesh.cells, g["Dm_inv"], g["cell_mat"], g["code"], g["props"], sig) == -1
    J = np.linalg.det(A)
    s = P_exact @ A.T / J
    s = 0.5 * (s + s.T)
    voigt = [(0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2)]
    for k, (a, b) in enumerate(voigt):
        if a < d and b < d:
            assert np.allclose(sig[:, k], s[a, b], rtol=1e-12, atol=1e-12 * np.abs(s).max())
    if d == 2:  # plane strain sigma_zz
        lam = props[0]
        zz = lam * np.log(J) / J if code == NH else lam * (np.trace(A) - 2) / J
        assert np.allclose(sig[:, 2], zz, rtol=1e-12)
    else:
        assert code != NH or np.abs(s - s.T).max() < 1e-12 * np.abs(s).max()


def test_rigid_rotation_is_stress_free_for_neo_hookean():
    mesh = MESHES[2]()
    g, _ = setup(mesh, NH)
    t = 0.7
    x = mesh.points @ np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]]).T
    f, _ = forces(x, g)
    assert np.abs(f).max() < 1e-13
    assert abs(energy(x, g)) < 1e-13


# ----------------------------------------------------------------------------- material derivatives
def fd_gradient(fun, F, h):
    d = F.shape[0]
    G = np.zeros((d, d))
    for a in range(d):
        for b in range(d):
            Fp, Fm = F.copy(), F.copy()
            Fp[a, b] += h
            Fm[a, b] -= h
            G[a, b] = (fun(Fp) - fun(Fm)) / (2 * h)
    return G


@pytest.mark.parametrize("code", MATERIALS)
@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("size", [0.02, 0.5])
def test_stress_and_tangent_against_finite_differences(d, code, size):
    rng = np.random.default_rng(int(100 * size) + 7 * d + code)
    _, props, _ = material_table(code)
    props = props[0]
    scratch = np.zeros((d, d))
    for _ in range(5):
        F = random_F(rng, d, size)
        P = np.zeros((d, d))
        E.first_piola(code, props, F, P, scratch)
        Pfd = fd_gradient(lambda G: E.energy_density(code, props, G), F, 1e-6)
        assert np.abs(P - Pfd).max() < 1e-6 * np.abs(P).max()
        C = np.zeros((d * d, d * d))
        E.stress_tangent(code, props, F, C, scratch)
        Cfd = np.zeros_like(C)
        for c in range(d):
            for e in range(d):
                Fp, Fm = F.copy(), F.copy()
                Fp[c, e] += 1e-6
                Fm[c, e] -= 1e-6
                Pp, Pm = np.zeros((d, d)), np.zeros((d, d))
                E.first_piola(code, props, Fp, Pp, scratch)
                E.first_piola(code, props, Fm, Pm, scratch)
                Cfd[:, c * d + e] = ((Pp - Pm) / 2e-6).ravel()  # row-major flattening a*d + b
        assert np.abs(C - Cfd).max() < 1e-5 * np.abs(C).max()
        assert np.abs(C - C.T).max() < 1e-12 * np.abs(C).max()  # hyperelastic: major symmetry


def test_neo_hookean_energy_is_inf_when_inverted():
    _, props, _ = material_table(NH)
    F = np.diag([1.0, -0.5])
    assert E.energy_density(NH, props[0], F) == np.inf


# ----------------------------------------------------------------------------- element forces and Hessians
def small_mesh(d):
    return rectangle((0.0, 0.0), (1.0, 1.0), 0.5) if d == 2 else box((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), 1.0)


@pytest.mark.parametrize("code", MATERIALS)
@pytest.mark.parametrize("d", [2, 3])
def test_forces_and_hessian_against_finite_differences(d, code):
    rng = np.random.default_rng(3 + d + code)
    mesh = small_mesh(d)
    g, _ = setup(mesh, code)
    x = mesh.points @ random_F(rng, d, 0.2).T + 0.05 * rng.uniform(-1, 1, mesh.points.shape)
    f, bad = forces(x, g)
    assert bad == -1
    h = 1e-6
    fd = np.zeros_like(x)
    K_fd = np.zeros((x.size, x.size))
    for i in range(mesh.n_nodes):
        for a in range(d):
            xp, xm = x.copy(), x.copy()
            xp[i, a] += h
            xm[i, a] -= h
            fd[i, a] = -(energy(xp, g) - energy(xm, g)) / (2 * h)
            K_fd[:, i * d + a] = -(forces(xp, g)[0] - forces(xm, g)[0]).ravel() / (2 * h)
    assert np.abs(f - fd).max() < 1e-6 * np.abs(f).max()
    H, bad = hessians(x, g)
    assert bad == -1
    K = E.assemble_hessian(mesh.cells, H, mesh.n_nodes).toarray()
    assert np.abs(K - K_fd).max() < 1e-5 * np.abs(K).max()
    assert np.array_equal(H, np.transpose(H, (0, 2, 1)))
    # a translation is a zero mode of every element Hessian
    for He in H:
        t = np.tile(rng.uniform(-1, 1, d), d + 1)
        assert np.abs(He @ t).max() < 1e-12 * np.abs(He).max()


def projected_tangent(code, props, F):
    """The stress tangent C (d^2 square) of F and its eigen-projection to PSD (numpy)."""
    d = F.shape[0]
    C = np.empty((d * d, d * d))
    E.stress_tangent(code, props, F, C, np.empty((d, d)))
    w, V = np.linalg.eigh(C)
    return C, V @ np.diag(np.maximum(w, 0.0)) @ V.T


def test_psd_projection():
    """Projected element Hessians are vol G^T C+ G, C+ the eigen-projection of the stress
    tangent (what project_tangent computes without an eigensolver where only twist modes are
    negative): PSD, symmetric, and equal to the exact Hessians where C is PSD."""
    d = 2
    mesh = small_mesh(d)
    g, _ = setup(mesh, NH)
    # strong uniaxial compression: the geometric stiffness makes the element Hessians indefinite
    x = mesh.points @ np.diag([0.5, 1.0]).T
    H, _ = hessians(x, g)
    w = np.linalg.eigvalsh(H)
    assert w.min() < -1e-3 * np.abs(w).max()
    Hp, _ = hessians(x, g, project=True)
    F = np.empty((len(mesh.cells), d, d))
    E.deformation_gradients(x, mesh.cells, g["Dm_inv"], F)
    for e, (He, Hpe) in enumerate(zip(H, Hp)):
        grad = np.vstack([-g["Dm_inv"][e].sum(axis=0), g["Dm_inv"][e]])  # (d + 1, d) shape-function gradients
        G = np.einsum("ac,nb->abnc", np.eye(d), grad).reshape(d * d, (d + 1) * d)  # vec F = G x
        C, Cp = projected_tangent(g["code"][0], g["props"][0], F[e])
        assert np.allclose(g["vol0"][e] * G.T @ C @ G, He, rtol=0, atol=1e-12 * np.abs(He).max())
        scale = np.abs(He).max()
        assert np.abs(Hpe - g["vol0"][e] * G.T @ Cp @ G).max() < 1e-12 * scale
        assert np.linalg.eigvalsh(Hpe).min() > -1e-12 * scale
        assert np.array_equal(Hpe, Hpe.T)
    # project_psd on its own: returns the smallest eigenvalue
    A = H[0].copy()
    assert E.project_psd(A) == pytest.approx(np.linalg.eigvalsh(H[0]).min(), rel=1e-10)
    # an already PSD matrix is left unchanged, bit for bit (linear elastic Hessians, with their
    # rigid-body zero modes; and NH at rest)
    for code in MATERIALS:
        gl, _ = setup(mesh, code)
        x = mesh.points @ np.array([[1.05, 0.1], [0.0, 0.97]]).T if code == LIN else mesh.points.copy()
        H, _ = hessians(x, gl)
        Hp, _ = hessians(x, gl, project=True)
        assert np.array_equal(H, Hp)
    B = np.array([[2.0, 1.0], [1.0, 2.0]])
    E.project_psd(B)
    assert np.array_equal(B, [[2.0, 1.0], [1.0, 2.0]])


@pytest.mark.parametrize("d", [2, 3])
def test_tangent_projection_matches_the_eigendecomposition(d):
    """project_tangent against numpy's eigen-projection of the neo-Hookean tangent over random
    F (near rest, compressed, stretched; rotated): twist modes removed by rank-one updates
    where only they are negative, the eigensolver where more is (a large stretch, J = 9, makes
    a scaling eigenvalue negative). Agreement to 1e-13 of the tangent's size."""
    rng = np.random.default_rng(d)
    code, props, _ = material_table(NH)
    work = E.tangent_scratch(d)
    n_twist = 0
    cases = [np.eye(d) + rng.normal(scale=s, size=(d, d)) for s in (1e-7, 0.02, 0.1, 0.3) for _ in range(200)]
    cases += [3.0 * np.eye(d), np.diag([0.5] + [1.0] * (d - 1))]
    worst = 0.0
    for F in cases:
        if np.linalg.det(F) <= 0.0:
            continue
        C, Cp = projected_tangent(code[0], props[0], F)
        n_twist += np.linalg.eigvalsh(C).min() < -1e-12 * np.abs(C).max()
        got = C.copy()
        E.project_tangent(code[0], F, got, work)
        worst = max(worst, np.abs(got - Cp).max() / np.abs(C).max())
    assert worst < 1e-13
    assert n_twist > 100  # the compressed half of the cases needed a projection


# ----------------------------------------------------------------------------- masses and time step
@pytest.mark.parametrize("d", [2, 3])
def test_lumped_masses(d):
    mesh = MESHES[d]()
    g, rho = setup(mesh, LIN)
    m = E.lumped_masses(mesh.cells, g["vol0"], g["cell_mat"], rho, mesh.n_nodes)
    assert m.sum() == pytest.approx(rho[0] * np.prod(np.ptp(mesh.points, axis=0)), rel=1e-13)
    assert m.min() > 0
    # the first moment is exact for row-sum lumping of linear elements: sum m x = rho int X dV
    centroid = mesh.points.min(axis=0) + 0.5 * np.ptp(mesh.points, axis=0)
    assert np.allclose(m @ mesh.points / m.sum(), centroid, rtol=1e-12)


@pytest.mark.parametrize("make", [lambda: rectangle((0.0, 0.0), (1.0, 0.5), 0.125), lambda: disk((0.0, 0.0), 1.0, 0.25),
                                  lambda: box((0.0, 0.0, 0.0), (1.0, 1.0, 0.5), 0.25)])
@pytest.mark.parametrize("nu", [0.0, 0.3, 0.45])
def test_stable_time_step_is_below_the_central_difference_limit(make, nu):
    """dt = min_e l_e / c_p never exceeds 2 / omega_max of the lumped-mass system (it is a
    proven bound), and is not far below it on the generated meshes (0.6-0.75 of it)."""
    import scipy.linalg

    mesh = make()
    d = mesh.dim
    code, props, rho = material_table(LIN, young=5.0, nu=nu, rho=3.0)
    Dm_inv, vol0 = E.reference_geometry(mesh.points, mesh.cells)
    mat = np.zeros(mesh.n_cells, dtype=np.int64)
    H = np.zeros((mesh.n_cells, d * (d + 1), d * (d + 1)))
    E.element_hessians(mesh.points, mesh.cells, Dm_inv, vol0, mat, code, props, False, H)
    K = E.assemble_hessian(mesh.cells, H, mesh.n_nodes).toarray()
    m = np.repeat(E.lumped_masses(mesh.cells, vol0, mat, rho, mesh.n_nodes), d)
    w2 = scipy.linalg.eigvalsh(K / np.sqrt(np.outer(m, m)))
    limit = 2.0 / np.sqrt(w2.max())
    dt = E.stable_time_step(mesh.points, mesh.cells, mat, props, rho)
    assert dt <= limit
    assert dt > 0.55 * limit
    per = np.zeros(mesh.n_cells)
    E.element_time_steps(mesh.points, mesh.cells, mat, props, rho, per)
    assert per.min() == dt


@pytest.mark.parametrize("d", [2, 3])
def test_parallel_kernels_match_the_serial_chunk(d):
    """Above PARALLEL_MIN elements the kernels run in chunks over threads: the results are
    bit-identical to one serial pass (every sum over elements is serial, in element order)."""
    mesh = rectangle((0.0, 0.0), (1.0, 1.0), 1 / 33) if d == 2 else box((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), 1 / 8)
    assert mesh.n_cells >= E.PARALLEL_MIN
    g, _ = setup(mesh, NH)
    rng = np.random.default_rng(5)
    x = mesh.points @ random_F(rng, d, 0.1).T + 0.002 * rng.uniform(-1, 1, mesh.points.shape)
    args = (x, g["cells"], g["Dm_inv"], g["vol0"], g["cell_mat"], g["code"], g["props"])
    m = mesh.n_cells
    fe_par, fe_ser = np.zeros((m, d + 1, d)), np.zeros((m, d + 1, d))
    assert E.element_forces(*args, fe_par) == -1
    assert E._forces_chunk(*args, fe_ser, 0, m) == -1
    assert np.array_equal(fe_par, fe_ser)
    f, _ = forces(x, g)
    ref = np.zeros_like(x)
    for e in range(m):  # the scatter in element order
        ref[mesh.cells[e]] += fe_ser[e]
    assert np.array_equal(f, ref)
    e_par, e_ser = np.zeros(m), np.zeros(m)
    E.element_energies(*args, e_par)
    E._energies_chunk(*args, e_ser, 0, m)
    assert np.array_equal(e_par, e_ser)
    k = d * (d + 1)
    H_par, H_ser = np.zeros((m, k, k)), np.zeros((m, k, k))
    E.element_hessians(*args, True, H_par)
    E._hessians_chunk(*args, True, H_ser, 0, m)
    assert np.array_equal(H_par, H_ser)
    # an inverted element is reported (the first one, whichever chunk finds it)
    x2 = x.copy()
    for e in (m - 3, m // 2 + 1):
        c = mesh.cells[e]
        x2[c[-1]] = x2[c[:-1]].mean(axis=0) - (x2[c[-1]] - x2[c[:-1]].mean(axis=0))  # reflect through the facet
    bad = E.element_forces(x2, *args[1:], fe_par)
    assert 0 <= bad <= m // 2 + 1
    Fs = np.zeros((m, d, d))
    E.deformation_gradients(x2, mesh.cells, g["Dm_inv"], Fs)
    assert bad == np.flatnonzero(np.linalg.det(Fs) <= 0)[0]
