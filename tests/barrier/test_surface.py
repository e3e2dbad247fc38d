"""3D barrier contact of a point against an FEM boundary surface (mpmsim/contact/barrier/surface.py):
the paper's potential sum_t b(d_pt) - sum_e (deg_e - 1) b(d_pe) + sum_v b(d_pv) (BFEMP Eq. 32)
against the exact distance where it must reduce to one barrier (a flat surface, the outside of a
convex box), against the IPC toolkit's "improved max approximator" collision set (the same
inclusion-exclusion, ipctk 1.6) on a convex box and a concave trough, and its grouped gradient
and projected Hessian against finite differences."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.contact.barrier.potential import barrier, barrier_first_derivative
from mpmsim.contact.barrier.surface import group_bounds, group_terms, surface_barrier_groups, surface_topology
from mpmsim.fem import mesh as femmesh
from tests.barrier.fd import fd_gradient, fd_jacobian, rel_err

pytestmark = pytest.mark.implicit


def grid_surface(nx: int, nz: int, lx: float, lz: float, height) -> tuple[np.ndarray, np.ndarray]:
    """An open triangulated surface y = height(x) over [0, lx] x [0, lz], outward normal +y."""
    xs, zs = np.linspace(0.0, lx, nx + 1), np.linspace(0.0, lz, nz + 1)
    X, Z = np.meshgrid(xs, zs, indexing="ij")
    V = np.c_[X.ravel(), height(X.ravel()), Z.ravel()]
    F = []
    for i in range(nx):
        for j in range(nz):
            a, b, c, d = i * (nz + 1) + j, (i + 1) * (nz + 1) + j, (i + 1) * (nz + 1) + j + 1, i * (nz + 1) + j + 1
            F += [[a, c, b], [a, d, c]]
    return V, np.array(F, dtype=np.int64)


class Point:
    """The grouped barrier of one point p (weight 1) against a whole surface."""

    def __init__(self, V, F, dhat, kappa=1.0):
        self.V, self.F, self.dhat, self.kappa = V, F, dhat, kappa
        self.S = surface_topology(F, len(V))

    def terms(self, p):
        pairs = np.array([[0, t] for t in range(len(self.F))], dtype=np.int64)
        S = self.S
        return group_terms(pairs, group_bounds(pairs[:, 0]), self.F, S.triangle_edges, S.edges, S.edge_coef,
                           S.vertex_coef)

    def __call__(self, p, V=None, project=True):
        """(Phi, gradient over (p, group nodes), Hessian (projected to PSD), group nodes)."""
        V = self.V if V is None else V
        pt, st, sp, co, nd = self.terms(p)
        s = nd.shape[1]
        g, H = np.zeros((1, 3 * (1 + s))), np.zeros((1, 3 * (1 + s), 3 * (1 + s)))
        phi = surface_barrier_groups(np.asarray(p, float)[None], V, pt, st, sp, co, nd, self.dhat, self.kappa,
                                     np.ones(1), g, H, project)
        return phi, g[0], H[0], nd[0]


def ipctk_sum(V, F, p, dhat):
    """sum_c weight_c b(d_c) over ipctk's improved-max-approximator collisions of the point p."""
    ipctk = pytest.importorskip("ipctk")
    Vall = np.ascontiguousarray(np.vstack([V, p]), float)
    F = np.ascontiguousarray(F, np.int32)
    E = ipctk.edges(F)
    mesh = ipctk.CollisionMesh(Vall, E, F)
    cs = ipctk.NormalCollisions()
    cs.collision_set_type = ipctk.NormalCollisions.CollisionSetType.IMPROVED_MAX_APPROX
    cs.build(mesh, Vall, dhat)
    total = 0.0
    for i in range(len(cs)):
        c = cs[i]  # a view into cs: dropped before cs is (else ipctk frees it twice)
        if len(V) in c.vertex_ids(E, F):  # the point's collisions (not the surface's own)
            total += c.weight * barrier(np.sqrt(c.compute_distance(c.dof(Vall, E, F))), dhat, 1.0)
        del c
    return total


def test_a_flat_surface_gives_one_barrier_of_the_height_however_many_triangles_are_near():
    """dhat = 2.5 triangle sizes: up to ~50 triangles, their edges and vertices are within reach;
    the corrections cancel all but one barrier: Phi = b(h), dPhi/dp = b'(h) e_y (1e-12)."""
    V, F = grid_surface(8, 8, 1.0, 1.0, lambda x: 0.0 * x)
    dhat = 0.3
    P = Point(V, F, dhat)
    rng = np.random.default_rng(0)
    for _ in range(50):
        h = rng.uniform(0.01, 0.29)
        phi, g, _, _ = P([rng.uniform(0.35, 0.65), h, rng.uniform(0.35, 0.65)])
        assert phi == pytest.approx(barrier(h, dhat, 1.0), rel=1e-12)
        assert g[:3] == pytest.approx([0.0, barrier_first_derivative(h, dhat, 1.0), 0.0], abs=1e-12 * abs(g[1]))


def test_outside_a_convex_box_the_potential_is_the_barrier_of_the_exact_distance_and_ipctks():
    """150 points within dhat of a tetrahedralised unit box (faces, edges, corners): Phi = b(d) with
    d the exact distance to the box and Phi = ipctk's improved max approximator sum (1e-12);
    the force on the point is b'(d) along p - q, q its closest point."""
    m = femmesh.box(np.zeros(3), np.ones(3), 0.5)
    dhat = 0.2
    P = Point(m.points, m.facets, dhat)
    rng = np.random.default_rng(1)
    n = 0
    while n < 150:
        p = rng.uniform(-0.25, 1.25, 3)
        q = np.clip(p, 0.0, 1.0)
        d = np.linalg.norm(p - q)
        if not 1e-3 < d < 0.99 * dhat:
            continue
        n += 1
        phi, g, _, _ = P(p)
        assert phi == pytest.approx(barrier(d, dhat, 1.0), rel=1e-12)
        assert phi == pytest.approx(ipctk_sum(m.points, m.facets, p, dhat), rel=1e-12)
        assert rel_err(g[:3], barrier_first_derivative(d, dhat, 1.0) * (p - q) / d) < 1e-10


def test_inside_a_concave_trough_the_potential_is_ipctks():
    """A V-shaped open surface (sides at +-26.6 degrees): points over the crease see both sides;
    the inclusion-exclusion sum agrees with ipctk's collision set to 1e-12 on 150 points."""
    V, F = grid_surface(8, 4, 2.0, 1.0, lambda x: 0.5 * np.abs(x - 1.0))
    dhat = 0.2
    P = Point(V, F, dhat)
    rng = np.random.default_rng(2)
    checked = 0
    for _ in range(150):
        p = np.array([rng.uniform(0.6, 1.4), rng.uniform(0.02, 0.35), rng.uniform(0.35, 0.65)])
        phi = P(p)[0]
        ref = ipctk_sum(V, F, p, dhat)
        if ref != 0.0:
            checked += 1
            assert phi == pytest.approx(ref, rel=1e-12)
        else:
            assert phi == 0.0
    assert checked > 100


@pytest.mark.parametrize("where", ["face", "edge", "corner", "trough"])
def test_grouped_gradient_and_hessian_are_the_potentials_derivatives(where):
    """Over the whole stencil (the point and every surface node of its group): the gradient
    against central differences of Phi (1e-6) and the summed Hessian before projection against
    differences of the gradient (1e-5); the projected one is PSD."""
    if where == "trough":
        V, F = grid_surface(8, 4, 2.0, 1.0, lambda x: 0.5 * np.abs(x - 1.0))
        p = np.array([1.03, 0.08, 0.47])
    else:
        m = femmesh.box(np.zeros(3), np.ones(3), 0.5)
        V, F = m.points, m.facets
        p = {"face": [0.3, 0.6, 1.07], "edge": [0.4, -0.05, 1.06], "corner": [-0.05, 1.04, 1.06]}[where]
        p = np.asarray(p, float)
    dhat = 0.2
    P = Point(V, F, dhat)
    phi, g, H, nodes = P(p, project=False)
    assert phi > 0.0

    def unpack(y):
        W = V.copy()
        W[nodes] = y[3:].reshape(-1, 3)
        return y[:3], W

    y0 = np.r_[p, V[nodes].ravel()]
    assert rel_err(g, fd_gradient(lambda y: P(*unpack(y))[0], y0, 1e-6)) < 1e-6
    J = fd_jacobian(lambda y: P(*unpack(y))[1], y0, 1e-6)
    assert rel_err(H, 0.5 * (J + J.T)) < 1e-5
    Hp = P(p)[2]
    w = np.linalg.eigvalsh(Hp)
    assert w.min() >= -1e-10 * w.max()
    assert np.linalg.eigvalsh(H).min() < -1e-6 * w.max()  # the projection had work to do
