"""A converged reference for the Hertz cylinder of bench/hertz.py: the same body and load solved
by plane-strain finite elements with exact (Signorini) frictionless contact on a rigid flat.

    python bench/hertz_reference.py run [--levels 0 1 2 3] [--model linear|neo_hookean|svk|hencky|hypo_log]
                                        [--a 2.0] [--gap circle|parabola] [--direction normal|vertical]
    python bench/hertz_reference.py run --pair --direction vertical [--model hypo_log [--segment]] [--levels ...]
    python bench/hertz_reference.py run --axisymmetric --a 1.0 [--direction vertical | --model hypo_log]  # sphere
    python bench/hertz_reference.py table     # results/bench_hertz_reference/*.json: table and p(x)/p0

The body: a half-disk (R = 10 mm, E = 1000 MPa, nu = 0.3, plane strain, thickness 1 mm; the
symmetry u_x = 0 on x = 0) resting at the origin on the rigid flat y = 0 and loaded by a uniform
body force (gravity) of total P per unit thickness over the whole disk, P chosen so that the
Hertz half-width is `a` (2 mm: P = 345.2 N, the MPM scene of bench/hertz.py; 0.5 mm: a/R = 0.05).
Six-node (quadratic, isoparametric: midside nodes of the circle on the circle) triangles on a
Delaunay mesh of arcs centred on the contact point: spacing h0 = a/(20 2^level) within 1.25 a of
it (surface nodes h0/2 apart), growing linearly beyond to R/(10 2^level); a level halves every
element size (about 4 times the nodes).

Contact: every surface node of the lower half is a candidate; active nodes are held on the
flat (frictionless: their tangential motion free), and a primal-dual active-set iteration adds
the free nodes that penetrate and releases the held ones whose reaction (K u - f, the flat's
push on the body) is tensile, until the set does not change. Nothing else holds the body
vertically: the active nodes fix its rigid motion.

Models (--model): linear, small strain, one solve per active set, with the contact either along
the body's normal (--direction normal: the classical Kikuchi-Oden form, u . nu <= g, g the
distance to the flat along the outward normal nu, no tangential traction on the surface) or
vertical (--direction vertical: u_y >= -g, a vertical reaction; the linearisation of the rigid
flat's y >= 0 about the undeformed body, as the FEM bodies' linear_elastic with contact on the
deformed positions solves it); the gap g from the circle, or Hertz's parabola x^2 / (2R) with
--gap parabola (the same body). The two contact forms agree with Hertz to first order and
differ from each other by O(a/R). Finite strain (total Lagrangian, 5 load steps, Newton, the
body force per reference area, contact y = Y + u_y >= 0 on the deformed position): neo_hookean,
psi = mu/2 (tr C - 3) - mu ln J + lambda/2 (ln J)^2 (the project's compressible_neo_hookean,
plane strain); svk, St Venant-Kirchhoff; hencky, tau = lambda tr(ln V) I + 2 mu ln V (Kirchhoff);
hypo_log, the same with sigma (Cauchy) in place of tau: the exact integral of the hypoelastic law
sigma' = lambda tr(D) I + 2 mu D with the logarithmic rate, the finite-strain counterpart of the
MPM's linear_elastic (Hughes-Winget, a Jaumann-type rate; the rates differ only where the
principal axes turn).

Measured per level: the load carried (the active nodes' reactions, 2 x the half model's); the
half-width a_edge where the contact ends (between the last active and the first free node: the
zero of g^(2/3), linear in x beyond the edge as Hertz's gap (x - a)^(3/2) is, through the first
two free nodes' gaps), and the MPM bench's two estimates: a_moment = 2 sqrt(sum x^2 F / sum F)
over the nodal reactions and a_fit, Hertz's ellipse p^2 = p0^2 (1 - x^2/a^2) fitted to the
nodes above a tenth of the peak; the pressure p(x) from the reactions through the surface's
consistent (P2 edge) mass matrix, M p = F, on the deformed surface; the centre pressure p(0);
p(x)/p0 against Hertz. Richardson extrapolation over the last three levels.

The sphere (--axisymmetric): the same half-disk is the r-z section of a sphere of radius R
(x = r, the symmetry line its axis), per radian (weight r, the hoop strain u_r / r; at finite
strain, hencky and hypo_log, the hoop stretch 1 + u_r / R), loaded by the whole sphere's weight
P (Hertz's contact radius `a`); Hertz's sphere a = (3 P R / 4 E*)^(1/3), p0 = 3 P / (2 pi a^2);
the pressure from the per-radian reactions through the surface's r-weighted P2 mass matrix; the
moment radius from <r^2> = 2 a^2 / 5.

Two cylinders (--pair; the MPM's pair scene of bench/hertz.py): the lower disk (centre (0, R))
on the flat, the upper one (centre (0, 3R)) on it, both under one cylinder's weight P; the
lower's mesh is graded to both its contacts (its lower half's points mirrored in y = R), the
upper's is the single disk's moved up by 2R, so that the upper's bottom surface nodes and the
lower's top ones pair up at the same x. Frictionless node-to-node contact between the pairs
(small strain: u_y(upper) - u_y(lower) >= -(Y(upper) - Y(lower)), the two circles' gap
2 (R - sqrt(R^2 - x^2)); finite strain: y(upper) >= y(lower) on the deformed positions, with
--segment the lower surface's height taken at the upper node's deformed x instead, to a fixed
point), the flat's contact as above, the active constraints eliminated, the same active-set
iteration on both contacts. Measured: the pair contact against Hertz for two identical
cylinders (R* = R/2, E* = E / (2 (1 - nu^2)): the same a for the same P as one cylinder on the
flat), the flat's (load 2P) against Hertz for 2P, and at finite strain the paired nodes'
relative sliding.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.spatial import Delaunay

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results" / "bench_hertz_reference"

R, E, NU = 10.0, 1000.0, 0.3  # mm, MPa; plane strain, thickness 1 mm
E_STAR = E / (1.0 - NU**2)
LAM = E * NU / ((1 + NU) * (1 - 2 * NU))
MU = E / (2 * (1 + NU))

try:  # CHOLMOD when scikit-sparse is there (the project's optional `cholmod` extra), else SuperLU
    from sksparse.cholmod import CholmodError, cholesky as _cholesky
except ImportError:  # pragma: no cover - depends on the environment
    _cholesky = None


def hertz(P: float, sphere: bool = False) -> tuple[float, float]:
    """Hertz (a, p0) for a load P per unit thickness on the rigid flat (the cylinder), or for a
    total load P (the sphere: contact radius and centre pressure)."""
    if sphere:
        a = (3.0 * P * R / (4.0 * E_STAR)) ** (1.0 / 3.0)
        return a, 3.0 * P / (2.0 * math.pi * a * a)
    a = math.sqrt(4.0 * P * R / (math.pi * E_STAR))
    return a, 2.0 * P / (math.pi * a)


def load_for(a: float, sphere: bool = False) -> float:
    """The load P per unit thickness (the cylinder) or total (the sphere) whose Hertz half-width
    or contact radius is a."""
    if sphere:
        return 4.0 * E_STAR * a**3 / (3.0 * R)
    return math.pi * a**2 * E_STAR / (4.0 * R)


# ---------------------------------------------------------------- mesh

def arc_points(a_ref: float, level: int, n0: int = 20, core: float = 1.25, beta0: float = 0.25,
               hmax0: float = 1.0) -> np.ndarray:
    """Points of the half-disk x >= 0 (centre (0, R)) with the spacing s(r) = h0 within
    r <= core a_ref of the contact point (0, 0), h0 + beta (r - core a_ref) beyond, up to hmax.
    The surface: points along the circle, s(r) apart in arc length from the contact point to the
    top (0, 2R). Inside: arcs r = const centred on the contact point, s(r) apart, each with points
    as evenly spaced as a whole number of segments allows from the symmetry line to the surface,
    less those within s/2 of the surface (near the top the arcs run almost along it)."""
    f = 2.0**level
    h0, beta, hmax = a_ref / (n0 * f), beta0 / f, hmax0 / f
    rc = core * a_ref

    def s(r):
        return h0 if r <= rc else min(h0 + beta * (r - rc), hmax)

    phi = [0.0]  # the surface: C + R (sin phi, -cos phi), r = 2R sin(phi/2)
    while phi[-1] + s(2 * R * math.sin(phi[-1] / 2)) / R < math.pi - 0.5 * s(2 * R * math.sin(phi[-1] / 2)) / R:
        phi.append(phi[-1] + s(2 * R * math.sin(phi[-1] / 2)) / R)
    phi = np.array(phi + [math.pi])
    pts = [np.stack([R * np.sin(phi), R - R * np.cos(phi)], 1)]
    pts[0][-1] = (0.0, 2 * R)
    r = s(0.0)
    while r < 2 * R:
        tmax = math.acos(r / (2 * R))
        n = max(1, int(round(r * tmax / s(r))))
        t = np.linspace(0.0, tmax, n + 1)[:-1]
        q = np.stack([r * np.sin(t), r * np.cos(t)], 1)
        inside = R - np.hypot(q[:, 0], q[:, 1] - R)
        pts.append(q[inside > 0.5 * s(r)])
        r += s(r)
    p = np.concatenate(pts)
    p[:, 0] = np.maximum(p[:, 0], 0.0)
    return p


class Mesh:
    """Six-node triangles: X (N, 2) reference coordinates, tri (M, 6) (vertices, then midsides
    12, 23, 31, counter-clockwise), sym (nodes on x = 0), surf (the circle's nodes of the lower
    half, sorted by x), sedges (the surface's P2 edges among them: node ids a, mid, b)."""

    def __init__(self, a_ref: float, level: int, pts: np.ndarray | None = None, **kw):
        if pts is None:
            pts = arc_points(a_ref, level, **kw)
        tri = Delaunay(pts).simplices
        v = pts[tri]
        area = 0.5 * ((v[:, 1, 0] - v[:, 0, 0]) * (v[:, 2, 1] - v[:, 0, 1])
                      - (v[:, 2, 0] - v[:, 0, 0]) * (v[:, 1, 1] - v[:, 0, 1]))
        tri = tri[np.abs(area) > 1e-12 * (a_ref / 20 / 2**level) ** 2]  # no flat hull slivers
        area = area[np.abs(area) > 1e-12 * (a_ref / 20 / 2**level) ** 2]
        tri[area < 0] = tri[area < 0][:, [0, 2, 1]]
        nv = len(pts)
        edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
        key = np.sort(edges, 1)
        uniq, inv, count = np.unique(key, axis=0, return_inverse=True, return_counts=True)
        inv = inv.ravel()
        mid = 0.5 * (pts[uniq[:, 0]] + pts[uniq[:, 1]])
        on_circle = np.abs(np.hypot(pts[:, 0], pts[:, 1] - R) - R) < 1e-9 * R
        bnd = (count == 1) & on_circle[uniq[:, 0]] & on_circle[uniq[:, 1]]
        d = mid[bnd] - np.array([0.0, R])
        mid[bnd] = np.array([0.0, R]) + R * d / np.linalg.norm(d, axis=1)[:, None]
        self.X = np.concatenate([pts, mid])
        m = len(tri)
        self.tri = np.concatenate([tri, nv + inv.reshape(3, m).T], 1)
        self.sym = np.flatnonzero(self.X[:, 0] < 1e-12 * R)
        circle_nodes = np.concatenate([np.flatnonzero(on_circle), nv + np.flatnonzero(bnd)])
        low = circle_nodes[self.X[circle_nodes, 1] < 0.5 * R]
        self.surf = low[np.argsort(self.X[low, 0])]
        se = uniq[bnd]
        se = np.stack([se[:, 0], nv + np.flatnonzero(bnd), se[:, 1]], 1)
        se = se[(self.X[se[:, 0], 1] < 0.5 * R) & (self.X[se[:, 2], 1] < 0.5 * R)]
        flip = self.X[se[:, 0], 0] > self.X[se[:, 2], 0]
        se[flip] = se[flip][:, ::-1]
        self.sedges = se[np.argsort(self.X[se[:, 0], 0])]
        # the same on the upper half (the circle's nodes above y = 1.5 R, sorted by x): the top
        # contact of the lower disk of a pair
        high = circle_nodes[self.X[circle_nodes, 1] > 1.5 * R]
        self.top = high[np.argsort(self.X[high, 0])]
        te = uniq[bnd]
        te = np.stack([te[:, 0], nv + np.flatnonzero(bnd), te[:, 1]], 1)
        te = te[(self.X[te[:, 0], 1] > 1.5 * R) & (self.X[te[:, 2], 1] > 1.5 * R)]
        flip = self.X[te[:, 0], 0] > self.X[te[:, 2], 0]
        te[flip] = te[flip][:, ::-1]
        self.tedges = te[np.argsort(self.X[te[:, 0], 0])]
        self.h0 = a_ref / (20 * 2**level)
        # minimum angle of the vertex triangles (mesh quality, reported)
        v = pts[tri]
        ang = []
        for i in range(3):
            e1 = v[:, (i + 1) % 3] - v[:, i]
            e2 = v[:, (i + 2) % 3] - v[:, i]
            c = (e1 * e2).sum(1) / np.linalg.norm(e1, axis=1) / np.linalg.norm(e2, axis=1)
            ang.append(np.degrees(np.arccos(np.clip(c, -1, 1))))
        self.min_angle = float(np.min(ang))


# ---------------------------------------------------------------- elements

_A, _B = 0.445948490915965, 0.091576213509771
QP = np.array([[_A, _A], [1 - 2 * _A, _A], [_A, 1 - 2 * _A], [_B, _B], [1 - 2 * _B, _B], [_B, 1 - 2 * _B]])
QW = 0.5 * np.array([0.223381589678011] * 3 + [0.109951743655322] * 3)  # degree 4


def p2_shape(xi: np.ndarray, eta: np.ndarray):
    """P2 shape functions and their (xi, eta) derivatives at the points (xi, eta)."""
    l1, l2, l3 = 1 - xi - eta, xi, eta
    N = np.stack([l1 * (2 * l1 - 1), l2 * (2 * l2 - 1), l3 * (2 * l3 - 1), 4 * l1 * l2, 4 * l2 * l3, 4 * l3 * l1], -1)
    z = np.zeros_like(xi)
    dxi = np.stack([-(4 * l1 - 1), 4 * l2 - 1, z, 4 * (l1 - l2), 4 * l3, -4 * l3], -1)
    deta = np.stack([-(4 * l1 - 1), z, 4 * l3 - 1, -4 * l2, 4 * l2, 4 * (l1 - l3)], -1)
    return N, np.stack([dxi, deta], -1)  # (Q, 6), (Q, 6, 2)


class Model:
    """The discrete problem on a mesh: reference gradients, weights, body force, assembly."""

    def __init__(self, mesh: Mesh, P: float):
        self.mesh = mesh
        N, dN = p2_shape(QP[:, 0], QP[:, 1])
        Xe = mesh.X[mesh.tri]  # (M, 6, 2)
        J = np.einsum("mai,qaj->mqij", Xe, dN)
        det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
        if (det <= 0).any():
            raise ValueError("inverted element in the mesh")
        Jinv = np.stack([np.stack([J[..., 1, 1], -J[..., 0, 1]], -1),
                         np.stack([-J[..., 1, 0], J[..., 0, 0]], -1)], -2) / det[..., None, None]
        self.G = np.einsum("qaj,mqji->mqai", dN, Jinv)  # dN_a/dX_i
        self.w = det * QW  # (M, Q)
        ndof = 2 * len(mesh.X)
        self.ndof = ndof
        self.area = float(self.w.sum())  # of the half-disk (curved edges: pi R^2 / 2 to O(h^6))
        # body force per unit area: the discrete half-disk (its area pi R^2 / 2 to 1e-7 at level
        # 0) carries exactly P / 2, as the MPM disk's particles carry exactly m g
        b = 0.5 * P / float(self.w.sum())
        fe = -b * np.einsum("mq,qa->ma", self.w, N)
        self.f = np.zeros(ndof)
        np.add.at(self.f, 2 * mesh.tri + 1, fe)
        dofs = np.stack([2 * mesh.tri, 2 * mesh.tri + 1], -1).reshape(len(mesh.tri), 12)
        self.rows = np.repeat(dofs, 12, axis=1).ravel()
        self.cols = np.tile(dofs, (1, 12)).ravel()
        self.dofs = dofs

    def forces(self, u: np.ndarray, law: str, tangent: bool = True):
        """Internal forces and (tangent) stiffness at displacement u for law linear (u ignored for
        the stiffness), neo_hookean or svk. Returns (f_int, K, min J)."""
        G, w = self.G, self.w
        ue = u[self.dofs].reshape(-1, 6, 2)
        H = np.einsum("mai,mqaj->mqij", ue, G, optimize=True)  # grad u
        I2 = np.eye(2)
        if law == "linear":
            eps = 0.5 * (H + np.swapaxes(H, -1, -2))
            tr = eps[..., 0, 0] + eps[..., 1, 1]
            P = LAM * tr[..., None, None] * I2 + 2 * MU * eps
            A = (LAM * np.einsum("ij,kl->ijkl", I2, I2) + MU * (np.einsum("ik,jl->ijkl", I2, I2)
                                                                 + np.einsum("il,jk->ijkl", I2, I2)))
            A = np.broadcast_to(A, H.shape[:2] + (2, 2, 2, 2))
            Jmin = 1.0
        else:
            F = I2 + H
            J = F[..., 0, 0] * F[..., 1, 1] - F[..., 0, 1] * F[..., 1, 0]
            Jmin = float(J.min())
            if Jmin <= 0:
                return None, None, Jmin
            if law == "neo_hookean":
                Fi = np.stack([np.stack([F[..., 1, 1], -F[..., 0, 1]], -1),
                               np.stack([-F[..., 1, 0], F[..., 0, 0]], -1)], -2) / J[..., None, None]
                FiT = np.swapaxes(Fi, -1, -2)
                lnJ = np.log(J)
                P = MU * (F - FiT) + (LAM * lnJ)[..., None, None] * FiT
                # A_iJkL = mu d_ik d_JL + (mu - lam lnJ) Fi_Jk Fi_Li + lam Fi_Ji Fi_Lk
                A = (MU * np.einsum("ik,JL->iJkL", I2, I2)
                     + (MU - LAM * lnJ)[..., None, None, None, None] * np.einsum("...Jk,...Li->...iJkL", Fi, Fi)
                     + LAM * np.einsum("...Ji,...Lk->...iJkL", Fi, Fi))
            elif law == "svk":
                C = np.einsum("...kI,...kJ->...IJ", F, F)
                Eg = 0.5 * (C - I2)
                trE = Eg[..., 0, 0] + Eg[..., 1, 1]
                S = LAM * trE[..., None, None] * I2 + 2 * MU * Eg
                P = np.einsum("...iK,...KJ->...iJ", F, S)
                Cm = (LAM * np.einsum("IJ,KL->IJKL", I2, I2)
                      + MU * (np.einsum("IK,JL->IJKL", I2, I2) + np.einsum("IL,JK->IJKL", I2, I2)))
                A = (np.einsum("ik,...JL->...iJkL", I2, S)
                     + np.einsum("...iI,IJKL,...kK->...iJkL", F, Cm, F))
            elif law in ("hencky", "hypo_log"):
                P = log_piola(F, law)
                if tangent:  # central differences of P (the closed form is long; Newton stays quadratic)
                    A = np.empty(F.shape[:2] + (2, 2, 2, 2))
                    eps = 1e-6
                    for k in range(2):
                        for L in range(2):
                            dF = np.zeros((2, 2))
                            dF[k, L] = eps
                            A[..., k, L] = (log_piola(F + dF, law) - log_piola(F - dF, law)) / (2 * eps)
            else:
                raise ValueError(f"model: unknown law {law!r}")
        fe = np.einsum("mqaJ,mqiJ->mai", G * w[..., None, None], P, optimize=True)
        fint = np.zeros(self.ndof)
        np.add.at(fint, self.dofs.ravel(), fe.reshape(-1))
        if not tangent:
            return fint, None, Jmin
        # K_e = sum_q w B^T D B, B (4 x 12): grad u (iJ) from the nodal (a, k); D = A as 4 x 4
        m = len(G)
        Ke = np.zeros((m, 12, 12))
        B = np.zeros((m, 4, 12))
        for q in range(G.shape[1]):
            for i in range(2):
                B[:, 2 * i:2 * i + 2, i::2] = np.swapaxes(G[:, q], 1, 2)  # B[(i,J),(a,i)] = G_aJ
            Dq = np.ascontiguousarray(A[:, q]).reshape(m, 4, 4) * w[:, q, None, None]
            Ke += np.swapaxes(B, 1, 2) @ (Dq @ B)
        K = sp.csr_matrix((Ke.reshape(-1), (self.rows, self.cols)), shape=(self.ndof, self.ndof))
        return fint, K, Jmin


class AxisymmetricModel(Model):
    """The same half-disk as the r-z section of the sphere (x = r, the symmetry line the axis),
    small strain or the logarithmic laws at finite strain (forces): every integral per radian
    (weight r), the hoop strain u_r / r, the body force of the whole sphere's weight P spread
    over its volume (the discrete section's integral of r, 2 pi of it the sphere's 4/3 pi R^3
    to O(h^6))."""

    def __init__(self, mesh: Mesh, P: float):
        super().__init__(mesh, P)
        N, _ = p2_shape(QP[:, 0], QP[:, 1])
        self.N = N
        self.r = np.einsum("qa,ma->mq", N, mesh.X[mesh.tri][..., 0])  # radius at the quadrature points
        self.w = self.w * self.r  # per radian
        self.volume = float(self.w.sum())  # of the sphere, per radian
        b = P / (2.0 * math.pi * self.volume)
        fe = -b * np.einsum("mq,qa->ma", self.w, N)
        self.f = np.zeros(self.ndof)
        np.add.at(self.f, 2 * mesh.tri + 1, fe)

    def forces(self, u: np.ndarray, law: str, tangent: bool = True):
        """Internal forces and the stiffness. linear: K u, strains (rr, zz, rz engineering,
        theta-theta) from B (4 x 12) per quadrature point. hencky, hypo_log: total Lagrangian per
        radian, the in-plane F and the hoop stretch f = 1 + u_r / R (R the reference radius),
        generalised strain (F_rr, F_rz, F_zr, F_zz, f) and stress (P_rr, P_rz, P_zr, P_zz,
        P_tt); the tangent by central differences of P."""
        G, w, N, r = self.G, self.w, self.N, self.r
        if law in ("hencky", "hypo_log"):
            ue = u[self.dofs].reshape(-1, 6, 2)
            F = np.eye(2) + np.einsum("mai,mqaj->mqij", ue, G, optimize=True)
            f = 1.0 + np.einsum("qa,ma->mq", N, ue[..., 0]) / r
            J = (F[..., 0, 0] * F[..., 1, 1] - F[..., 0, 1] * F[..., 1, 0]) * f
            Jmin = float(J.min())
            if Jmin <= 0 or f.min() <= 0:
                return None, None, Jmin
            Pv = log_piola_rz(F, f, law)  # (m, Q, 5)
            m, Q = w.shape
            B = np.zeros((m, Q, 5, 12))
            B[..., 0, 0::2] = G[..., 0]  # F_rr = 1 + dN/dr u_r
            B[..., 1, 0::2] = G[..., 1]  # F_rz = dN/dz u_r
            B[..., 2, 1::2] = G[..., 0]  # F_zr = dN/dr u_z
            B[..., 3, 1::2] = G[..., 1]  # F_zz = 1 + dN/dz u_z
            B[..., 4, 0::2] = N[None] / r[..., None]  # f = 1 + N u_r / R
            fe = np.einsum("mq,mqkc,mqk->mc", w, B, Pv, optimize=True)
            fint = np.zeros(self.ndof)
            np.add.at(fint, self.dofs.ravel(), fe.reshape(-1))
            if not tangent:
                return fint, None, Jmin
            A = np.empty((m, Q, 5, 5))
            eps = 1e-6
            for k in range(5):
                Fp, Fm, fp, fm = F.copy(), F.copy(), f.copy(), f.copy()
                if k < 4:
                    Fp[..., k // 2, k % 2] += eps
                    Fm[..., k // 2, k % 2] -= eps
                else:
                    fp += eps
                    fm -= eps
                A[..., k] = (log_piola_rz(Fp, fp, law) - log_piola_rz(Fm, fm, law)) / (2 * eps)
            Ke = np.einsum("mq,mqkc,mqkl,mqld->mcd", w, B, A, B, optimize=True)
            K = sp.csr_matrix((Ke.reshape(-1), (self.rows, self.cols)), shape=(self.ndof, self.ndof))
            return fint, K, Jmin
        if law != "linear":
            raise ValueError("the axisymmetric reference: linear, hencky or hypo_log")
        m, Q = w.shape
        D = np.array([[LAM + 2 * MU, LAM, 0.0, LAM], [LAM, LAM + 2 * MU, 0.0, LAM],
                      [0.0, 0.0, MU, 0.0], [LAM, LAM, 0.0, LAM + 2 * MU]])
        Ke = np.zeros((m, 12, 12))
        for q in range(Q):
            B = np.zeros((m, 4, 12))
            B[:, 0, 0::2] = G[:, q, :, 0]  # eps_rr = dN/dr u_r
            B[:, 1, 1::2] = G[:, q, :, 1]  # eps_zz = dN/dz u_z
            B[:, 2, 0::2] = G[:, q, :, 1]  # gamma_rz = dN/dz u_r + dN/dr u_z
            B[:, 2, 1::2] = G[:, q, :, 0]
            B[:, 3, 0::2] = N[q][None, :] / r[:, q, None]  # eps_tt = N u_r / r
            Ke += np.swapaxes(B, 1, 2) @ (D[None] * w[:, q, None, None]) @ B
        K = sp.csr_matrix((Ke.reshape(-1), (self.rows, self.cols)), shape=(self.ndof, self.ndof))
        return K @ u, (K if tangent else None), 1.0


def log_piola(F: np.ndarray, law: str) -> np.ndarray:
    """First Piola stress of the logarithmic-strain laws, plane strain (ln V33 = 0):
    s = lambda tr(ln V) I + 2 mu ln V, V the left stretch; hencky takes s as the Kirchhoff stress
    (hyperelastic, psi = mu |ln V|^2 + lambda/2 (tr ln V)^2), hypo_log as the Cauchy stress: the
    exact integral of the hypoelastic law sigma' = lambda tr(D) I + 2 mu D with the logarithmic
    rate (the MPM's linear_elastic integrates it with the Hughes-Winget rotation, a Jaumann-type
    rate; the two differ only where the principal axes turn). P = J sigma F^-T = tau F^-T."""
    return log_stress(F, 1.0, law)[0]


def log_piola_rz(F: np.ndarray, f: np.ndarray, law: str) -> np.ndarray:
    """log_piola's laws in r-z: the in-plane F and the hoop stretch f. Returns (P_rr, P_rz,
    P_zr, P_zz, P_tt)."""
    P, P_tt = log_stress(F, f, law)
    return np.stack([P[..., 0, 0], P[..., 0, 1], P[..., 1, 0], P[..., 1, 1], P_tt], -1)


def log_stress(F: np.ndarray, f, law: str) -> tuple:
    """The logarithmic laws with ln V block diagonal: the in-plane block of F (..., 2, 2) and the
    out-of-plane stretch f (1 in plane strain, the hoop stretch in r-z). Returns the in-plane
    P = tau F^-T and the out-of-plane P_33 = tau_33 / f."""
    b = np.einsum("...iK,...jK->...ij", F, F)
    m = 0.5 * (b[..., 0, 0] + b[..., 1, 1])
    r = np.sqrt((0.5 * (b[..., 0, 0] - b[..., 1, 1])) ** 2 + b[..., 0, 1] ** 2)
    x = r / m
    small = x < 1e-6
    beta = np.where(small, (1 + x**2 / 3) / m, np.arctanh(np.where(small, 0.5, x)) / np.where(small, 1.0, r))
    alpha = 0.5 * np.log(m * m - r * r)  # (ln l1 + ln l2) / 2
    I2 = np.eye(2)
    lnb = alpha[..., None, None] * I2 + beta[..., None, None] * (b - m[..., None, None] * I2)
    lnV = 0.5 * lnb
    lnf = np.log(f)
    tr = lnV[..., 0, 0] + lnV[..., 1, 1] + lnf
    s = LAM * tr[..., None, None] * I2 + 2 * MU * lnV
    s_33 = LAM * tr + 2 * MU * lnf
    J = F[..., 0, 0] * F[..., 1, 1] - F[..., 0, 1] * F[..., 1, 0]
    if law == "hypo_log":
        s = s * (J * f)[..., None, None]
        s_33 = s_33 * J * f
    FiT = np.stack([np.stack([F[..., 1, 1], -F[..., 1, 0]], -1),
                    np.stack([-F[..., 0, 1], F[..., 0, 0]], -1)], -2) / J[..., None, None]
    return np.einsum("...ik,...kJ->...iJ", s, FiT), s_33 / f


def solve_spd(K: sp.csr_matrix, b: np.ndarray, symmetric: bool = True) -> np.ndarray:
    """K x = b: CHOLMOD for a symmetric positive definite K if available, else SuperLU."""
    if symmetric and _cholesky is not None:
        try:
            return _cholesky(K.tocsc())(b)
        except CholmodError:
            pass
    return spla.splu(K.tocsc(), permc_spec="MMD_AT_PLUS_A").solve(b)


# ---------------------------------------------------------------- contact solve

def _block_diag(blk: np.ndarray) -> sp.csr_matrix:
    """The block-diagonal matrix of the (n, 2, 2) blocks."""
    n = len(blk)
    rows = np.repeat(np.arange(2 * n).reshape(n, 2), 2, axis=1).ravel()
    cols = np.tile(np.arange(2 * n).reshape(n, 2), (1, 2)).ravel()
    return sp.csr_matrix((blk.reshape(-1), (rows, cols)), shape=(2 * n, 2 * n))


def solve_contact(mesh: Mesh, P: float, law: str = "linear", gap: str = "circle", direction: str = "normal",
                  steps: int = 5, tol: float = 1e-10, verbose: bool = False, axisymmetric: bool = False) -> dict:
    """Frictionless Signorini contact of the half-disk on the flat y = 0. Returns u, the
    candidates' reactions (the flat's push on each surface node along the contact direction,
    half model), the contact directions d and gaps g0, and the iteration counts.

    linear: direction normal is the classical (Kikuchi-Oden) Signorini condition, u . nu <= g
    with nu the body's outward normal, g the distance to the flat along it (Y / cos theta on the
    circle; x^2 / (2R) with gap parabola, Hertz's) and the reaction along -nu (no tangential
    traction on the body's surface); direction vertical holds u_y >= -g and takes a vertical
    reaction on the reference surface, a tangential traction p x / R on it (the flat's push on a
    surface that the linear theory does not rotate): an O(a/R) departure from Hertz of its own.
    Finite strain: y = Y + u_y >= 0 on the deformed position, the reaction vertical (exact).
    axisymmetric: the sphere (AxisymmetricModel, P its whole weight, reactions per radian)."""
    model = AxisymmetricModel(mesh, P) if axisymmetric else Model(mesh, P)
    X = mesh.X
    cand = mesh.surf
    ydof = 2 * cand + 1
    nu_out = (X[cand] - np.array([0.0, R])) / R  # outward unit normals of the circle
    if law == "linear" and direction == "normal":
        d = -nu_out
        g0 = X[cand, 1] / d[:, 1] if gap == "circle" else X[cand, 0] ** 2 / (2 * R)
    elif law == "linear" and direction == "vertical":
        d = np.tile([0.0, 1.0], (len(cand), 1))
        g0 = X[cand, 1] if gap == "circle" else X[cand, 0] ** 2 / (2 * R)
    elif law == "linear":
        raise ValueError(f"direction: normal or vertical, not {direction!r}")
    else:
        if gap != "circle":
            raise ValueError("gap: the finite-strain models take the body's own surface (circle)")
        d = np.tile([0.0, 1.0], (len(cand), 1))
        g0 = X[cand, 1]
    # nodal bases (t, d) at the candidates: u = T u', u' = (u_t, u_d) there, (u_x, u_y) elsewhere
    nn = len(X)
    blk = np.tile(np.eye(2), (nn, 1, 1))
    blk[cand, :, 0] = np.stack([d[:, 1], -d[:, 0]], 1)
    blk[cand, :, 1] = d
    T = _block_diag(blk)
    fixed_x = 2 * mesh.sym
    u = np.zeros(model.ndof)
    a_guess = hertz(P, axisymmetric)[0]
    counts = {"active_set": 0, "newton": 0, "factorisations": 0}
    loads = [1.0] if law == "linear" else list(np.linspace(0, 1, steps + 1)[1:])
    active = X[cand, 0] <= 0.9 * a_guess * math.sqrt(loads[0])
    active[0] = True
    fext_full = model.f
    if law != "linear":
        return _solve_finite(model, mesh, law, cand, g0, d, fixed_x, active, loads, tol, counts, verbose)
    _, K0, _ = model.forces(u, "linear")
    Ks = (T.T @ K0 @ T).tocsr()  # the stiffness in the nodal bases
    fext = T.T @ fext_full
    seen = set()
    for it in range(60):
        counts["active_set"] += 1
        fixed = np.concatenate([fixed_x, ydof[active]])
        free = np.ones(model.ndof, bool)
        free[fixed] = False
        u = np.zeros(model.ndof)
        u[ydof[active]] = -g0[active]
        u[free] = solve_spd(Ks[free][:, free], fext[free] - Ks[free][:, fixed] @ u[fixed])
        counts["factorisations"] += 1
        r = Ks @ u - fext
        new = np.where(active, r[ydof] > 0.0, g0 + u[ydof] < -1e-12 * R)
        if verbose:
            print(f"  active set {it}: {active.sum()} active, {int((new != active).sum())} changes")
        if (new == active).all():
            break
        key = new.tobytes()
        if key in seen:
            raise RuntimeError("active set cycles")
        seen.add(key)
        active = new
    else:
        raise RuntimeError("active set did not settle")
    react = np.where(active, r[ydof], 0.0)
    gap_final = g0 + u[ydof]
    if law == "linear":
        u = T @ u
    return {"law": law, "u": u, "cand": cand, "active": active, "react": react, "g0": g0, "gap": gap_final, "d": d,
            "counts": counts, "load_carried_half": float((react * d[:, 1]).sum()),
            "load_half": P / (2 * math.pi) if axisymmetric else P / 2, "residual_free": float(np.abs(r[free]).max()),
            "area": model.area, "axisymmetric": axisymmetric,
            "volume": 2 * math.pi * model.volume if axisymmetric else None}


def _solve_finite(model: Model, mesh: Mesh, law: str, cand, g0, d, fixed_x, active, loads, tol, counts,
                  verbose) -> dict:
    """Load steps; in each, Newton on the displacement with the active nodes held on the flat
    (prescribed parts of the increment included, so that a node joining the contact moves with
    its neighbours), the active set updated (penetration in, tension out) whenever the residual
    is below 1e-6 of the load, until the set holds and the residual is below tol of the load."""
    ydof = 2 * cand + 1
    fnorm = np.linalg.norm(model.f)
    u = np.zeros(model.ndof)
    history = [(0.0, u.copy())]

    def sets(active):
        fixed = np.concatenate([fixed_x, ydof[active]])
        free = np.ones(model.ndof, bool)
        free[fixed] = False
        target = np.zeros(model.ndof)
        target[ydof[active]] = -g0[active]
        return fixed, free, target

    for t in loads:
        fext = t * model.f
        if len(history) >= 2:  # secant predictor, kept only if admissible
            (t1, u1), (t2, u2) = history[-2:]
            guess = u2 + (u2 - u1) * (t - t2) / (t2 - t1)
            if model.forces(guess, law, tangent=False)[2] > 0.05:
                u = guess
        if len(history) >= 2:  # the contact grows as sqrt(load) (Hertz): the set's first guess
            xa = mesh.X[cand[active], 0].max() * math.sqrt(t / history[-1][0])
            active = mesh.X[cand, 0] <= xa
        fixed, free, target = sets(active)
        seen = {active.tobytes()}
        last_du = np.inf
        for nit in range(80):
            fint, K, jmin = model.forces(u, law)
            if fint is None:
                raise RuntimeError(f"inverted element at load {t:.2f} (min J {jmin})")
            res = fint - fext
            rn = np.linalg.norm(res[free]) / fnorm
            dp = target[fixed] - u[fixed]
            if verbose:
                print(f"    t={t:.2f} newton {nit}: |res| {rn:.3e}, |dp| {np.abs(dp).max():.1e}, "
                      f"{active.sum()} active, min J {jmin:.4f}")
            if rn < 1e-6 and np.abs(dp).max() == 0.0:
                new = np.where(active, res[ydof] > 0.0, g0 + u[ydof] < -1e-12 * R)
                if (new == active).all():
                    # converged: the residual below tol of the load, or (small loads, where
                    # round-off floors it near 1e-10) below 1e-8 with a Newton step at round-off
                    if rn < tol or (rn < 1e-8 and last_du < 1e-10 * np.abs(u).max()):
                        break
                else:
                    counts["active_set"] += 1
                    key = new.tobytes()
                    if key in seen:
                        raise RuntimeError("active set cycles")
                    seen.add(key)
                    active = new
                    fixed, free, target = sets(active)
                    dp = target[fixed] - u[fixed]
            du = np.zeros(model.ndof)
            du[fixed] = dp
            rhs = -res[free] - K[free][:, fixed] @ dp
            du[free] = solve_spd(K[free][:, free], rhs, symmetric=law != "hypo_log")
            counts["factorisations"] += 1
            counts["newton"] += 1
            step = 1.0
            for _ in range(30):  # keep J > 0 (a line search on admissibility only)
                jm = model.forces(u + step * du, law, tangent=False)[2]
                if jm > 0.05:
                    break
                step *= 0.5
            u = u + step * du  # (a shortened step leaves part of dp to the next iteration)
            last_du = float(np.abs(step * du).max())
        else:
            raise RuntimeError(f"Newton did not converge at load {t:.2f}: |res| {rn:.3e}")
        history.append((t, u.copy()))
    r = fint - fext
    react = np.where(active, r[ydof], 0.0)
    return {"law": law, "u": u, "cand": cand, "active": active, "react": react, "g0": g0, "gap": g0 + u[ydof],
            "d": d, "counts": counts, "load_carried_half": float((react * d[:, 1]).sum()),
            "residual_free": float(np.abs(r[free]).max()), "area": model.area,
            "axisymmetric": isinstance(model, AxisymmetricModel),
            "volume": 2 * math.pi * model.volume if isinstance(model, AxisymmetricModel) else None}


# ---------------------------------------------------------------- two cylinders

def pair_points(a_ref: float, level: int, **kw) -> np.ndarray:
    """Points of the lower disk of a pair: those of `arc_points` below y = R - hmax/2 (graded to
    the contact with the flat), their mirror images in y = R (graded to the contact with the
    upper disk, the circle's points the mirror of the bottom's, so that they pair up with the
    upper disk's), and a row on y = R about hmax apart."""
    hmax = kw.get("hmax0", 1.0) / 2.0**level
    p = arc_points(a_ref, level, **kw)
    p = p[p[:, 1] < R - 0.5 * hmax]
    n = max(1, int(round(R / hmax)))
    mid = np.stack([np.linspace(0.0, R, n + 1), np.full(n + 1, R)], 1)
    return np.concatenate([p, mid, np.stack([p[:, 0], 2 * R - p[:, 1]], 1)])


def pair_meshes(a_ref: float, level: int, **kw) -> tuple[Mesh, Mesh, np.ndarray]:
    """The lower disk (centre (0, R), graded at both contacts) and the upper one (centre (0, 3R),
    the single disk's mesh moved up by 2R: graded at its bottom), and the pairs: index j of the
    upper's bottom surface nodes (mesh.surf) and the lower's top ones (mesh.top) at the same x."""
    kw.setdefault("core", 1.25 * math.sqrt(2.0))  # the flat's contact: the load 2P, its half-width sqrt(2) a
    lower = Mesh(a_ref, level, pts=pair_points(a_ref, level, **kw))
    upper = Mesh(a_ref, level, **kw)
    upper.X = upper.X + np.array([0.0, 2 * R])
    xu, xl = upper.X[upper.surf, 0], lower.X[lower.top, 0]
    if len(xu) != len(xl) or np.abs(xu - xl).max() > 1e-9 * R:
        raise RuntimeError("the two disks' contact surface nodes do not pair up")
    return lower, upper


def _pair_transform(ndof: int, fixed_x, yf, g0f, act_f, yup, ylo, g0p, act_p):
    """The active constraints of the pair eliminated: u = C w + c, w the free dofs; the
    symmetry's u_x = 0, the held flat nodes' u_y = -g0f, an active pair's upper u_y = its lower
    partner's u_y - g0p. Returns C, c and the mask of the free dofs."""
    dep = np.concatenate([fixed_x, yf[act_f], yup[act_p]])
    free = np.ones(ndof, bool)
    free[dep] = False
    col = -np.ones(ndof, int)
    col[free] = np.arange(free.sum())
    c = np.zeros(ndof)
    c[yf[act_f]] = -g0f[act_f]
    c[yup[act_p]] = -g0p[act_p]
    rows = np.concatenate([np.flatnonzero(free), yup[act_p]])
    cols = np.concatenate([col[free], col[ylo[act_p]]])
    C = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(ndof, int(free.sum())))
    return C, c, free


def _pair_dofs(lower: Mesh, upper: Mesh, nl: int):
    """The pair's constrained unknowns (the lower disk's nl dofs first): the symmetry-plane x dofs
    of both; the lower's flat candidates (nodes cf, their y dofs yf, initial gaps g0f); the
    contact pairs (lower top nodes lo, upper bottom nodes up, their y dofs ylo, yup, and the
    initial vertical gaps g0p between them)."""
    fixed_x = np.concatenate([2 * lower.sym, nl + 2 * upper.sym])
    cf = lower.surf
    yf = 2 * cf + 1
    g0f = lower.X[cf, 1]
    lo, up = lower.top, upper.surf
    ylo, yup = 2 * lo + 1, nl + 2 * up + 1
    g0p = upper.X[up, 1] - lower.X[lo, 1]
    return fixed_x, cf, yf, g0f, lo, up, ylo, yup, g0p


def solve_pair(lower: Mesh, upper: Mesh, P: float, verbose: bool = False) -> dict:
    """Small strain, contact linearised about the undeformed bodies (vertical gaps and
    reactions, the circles' gaps): the lower disk on the flat (u_y >= -Y at its bottom surface
    nodes) and the upper one on the lower (u_y(upper_j) - u_y(lower_j) >= -g_j, g_j = Y(upper_j)
    - Y(lower_j) = 2 (R - sqrt(R^2 - x_j^2)) for the pairs j at the same x), both under the body
    force of one cylinder's weight P (P/2 per half-disk). The active constraints are eliminated
    (a held node's u_y prescribed; an active pair's upper u_y = its lower partner's - g_j), the
    reduced system solved; the reactions are the residuals K u - f at the held dofs (the flat's
    push on the lower disk; the lower's push on the upper one, equal and opposite on the lower
    node). Primal-dual active sets on both contacts: tensile ones released, penetrating ones
    added, until neither set changes."""
    ml, mu = Model(lower, P), Model(upper, P)
    nl = ml.ndof
    ndof = nl + mu.ndof
    K = sp.block_diag([ml.forces(np.zeros(nl), "linear")[1], mu.forces(np.zeros(mu.ndof), "linear")[1]]).tocsr()
    f = np.concatenate([ml.f, mu.f])
    fixed_x, cf, yf, g0f, lo, up, ylo, yup, g0p = _pair_dofs(lower, upper, nl)
    a_guess = hertz(P)[0]
    act_f = lower.X[cf, 0] <= 0.9 * a_guess * math.sqrt(2.0)
    act_p = upper.X[up, 0] <= 0.9 * a_guess
    act_f[0] = act_p[0] = True
    counts = {"active_set": 0, "newton": 0, "factorisations": 0}
    seen = set()
    for it in range(60):
        counts["active_set"] += 1
        C, c, free = _pair_transform(ndof, fixed_x, yf, g0f, act_f, yup, ylo, g0p, act_p)
        w = solve_spd((C.T @ K @ C).tocsr(), C.T @ (f - K @ c))
        counts["factorisations"] += 1
        u = C @ w + c
        r = K @ u - f
        gap_f = g0f + u[yf]
        gap_p = g0p + u[yup] - u[ylo]
        new_f = np.where(act_f, r[yf] > 0.0, gap_f < -1e-12 * R)
        new_p = np.where(act_p, r[yup] > 0.0, gap_p < -1e-12 * R)
        if verbose:
            print(f"  active sets {it}: flat {act_f.sum()}, pair {act_p.sum()} active, "
                  f"{int((new_f != act_f).sum() + (new_p != act_p).sum())} changes", flush=True)
        if (new_f == act_f).all() and (new_p == act_p).all():
            break
        key = new_f.tobytes() + new_p.tobytes()
        if key in seen:
            raise RuntimeError("active sets cycle")
        seen.add(key)
        act_f, act_p = new_f, new_p
    else:
        raise RuntimeError("active sets did not settle")
    react_f = np.where(act_f, r[yf], 0.0)
    react_p = np.where(act_p, r[yup], 0.0)
    other = np.ones(ndof, bool)
    other[np.concatenate([fixed_x, yf[act_f], yup[act_p], ylo[act_p]])] = False
    d = np.tile([0.0, 1.0], (len(up), 1))
    common = {"law": "linear", "counts": counts, "deformed": False}
    flat = {**common, "u": u[:nl], "cand": cf, "active": act_f, "react": react_f, "g0": g0f, "gap": gap_f,
            "d": np.tile([0.0, 1.0], (len(cf), 1)), "load_carried_half": float(react_f.sum()), "area": ml.area}
    pair = {**common, "u": u[nl:], "cand": up, "active": act_p, "react": react_p, "g0": g0p, "gap": gap_p, "d": d,
            "load_carried_half": float(react_p.sum()), "area": mu.area,
            # equal and opposite on the lower node (the eliminated pair's residual)
            "action_reaction": float(np.abs(r[ylo[act_p]] + r[yup[act_p]]).max()),
            "residual_free": float(np.abs(r[other]).max())}
    return {"flat": flat, "pair": pair}


def solve_pair_finite(lower: Mesh, upper: Mesh, P: float, law: str, steps: int = 5, tol: float = 1e-10,
                      segment_passes: int = 0, verbose: bool = False) -> dict:
    """The pair at finite strain (total Lagrangian, load steps, Newton): the lower disk's bottom
    nodes on the flat (y = Y + u_y >= 0) and node-to-node contact between the paired surface
    nodes on their deformed positions, y(upper_j) - y(lower_j) >= 0, vertical reactions. Valid
    while the paired nodes stay above one another, i.e. their relative sliding (measured,
    `slide`) is small against the surface node spacing: for two identical bodies Hertz's
    tangential surface displacements are equal (no relative slip), only the bodies' different
    far fields (the lower one carries the upper's weight at its top) make them differ. The
    constraints are linear in u, so they are eliminated as in the small-strain solve; Newton on
    the reduced unknowns, the active sets updated whenever the residual is below 1e-6 of the load."""
    ml, mu = Model(lower, P), Model(upper, P)
    nl = ml.ndof
    ndof = nl + mu.ndof
    f = np.concatenate([ml.f, mu.f])
    fnorm = np.linalg.norm(f)
    fixed_x, cf, yf, g0f, lo, up, ylo, yup, g0p = _pair_dofs(lower, upper, nl)
    a_guess = hertz(P)[0]
    counts = {"active_set": 0, "newton": 0, "factorisations": 0}

    def forces(u, tangent=True):
        fa, Ka, ja = ml.forces(u[:nl], law, tangent)
        fb, Kb, jb = mu.forces(u[nl:], law, tangent)
        if fa is None or fb is None:
            return None, None, min(ja, jb)
        K = sp.block_diag([Ka, Kb]).tocsr() if tangent else None
        return np.concatenate([fa, fb]), K, min(ja, jb)

    def transform(act_f, act_p):
        return _pair_transform(ndof, fixed_x, yf, g0f, act_f, yup, ylo, g0p, act_p)

    def newton(t, act_f, act_p):
        """Newton at load t from the present u, the active sets updated on the way."""
        nonlocal u
        C, c, free = transform(act_f, act_p)
        seen = {act_f.tobytes() + act_p.tobytes()}
        last_du = np.inf
        for nit in range(80):
            fint, K, jmin = forces(u)
            if fint is None:
                raise RuntimeError(f"inverted element at load {t:.2f}")
            res = fint - t * f
            rr = C.T @ res
            rn = np.linalg.norm(rr) / fnorm
            target = C @ u[free] + c  # the constraints applied to the present free dofs
            dp = target - u
            if verbose:
                print(f"    t={t:.2f} newton {nit}: |res| {rn:.3e}, |dp| {np.abs(dp).max():.1e}, "
                      f"flat {act_f.sum()}, pair {act_p.sum()}, min J {jmin:.4f}", flush=True)
            if rn < 1e-6 and np.abs(dp).max() < 1e-13 * R:  # (an active pair's dp is a difference: round-off)
                gap_f = g0f + u[yf]
                gap_p = g0p + u[yup] - u[ylo]
                new_f = np.where(act_f, res[yf] > 0.0, gap_f < -1e-12 * R)
                new_p = np.where(act_p, res[yup] > 0.0, gap_p < -1e-12 * R)
                if (new_f == act_f).all() and (new_p == act_p).all():
                    if rn < tol or (rn < 1e-8 and last_du < 1e-10 * np.abs(u).max()):
                        break
                else:
                    counts["active_set"] += 1
                    key = new_f.tobytes() + new_p.tobytes()
                    if key in seen:
                        raise RuntimeError("active sets cycle")
                    seen.add(key)
                    act_f, act_p = new_f, new_p
                    C, c, free = transform(act_f, act_p)
                    target = C @ u[free] + c
                    dp = target - u
                    rr = C.T @ res
            # du = C dw + dp: C^T K (C dw + dp) = -C^T res
            dw = solve_spd((C.T @ K @ C).tocsr(), -rr - C.T @ (K @ dp), symmetric=law != "hypo_log")
            du = C @ dw + dp
            counts["factorisations"] += 1
            counts["newton"] += 1
            step = 1.0
            for _ in range(30):
                if forces(u + step * du, tangent=False)[2] > 0.05:
                    break
                step *= 0.5
            u = u + step * du
            last_du = float(np.abs(step * du).max())
        else:
            raise RuntimeError(f"Newton did not converge at load {t:.2f}: |res| {rn:.3e}")
        return act_f, act_p

    u = np.zeros(ndof)
    for t in np.linspace(0, 1, steps + 1)[1:]:
        act_f = lower.X[cf, 0] <= 0.9 * a_guess * math.sqrt(2.0 * t)
        act_p = upper.X[up, 0] <= 0.9 * a_guess * math.sqrt(t)
        act_f[0] = act_p[0] = True
        act_f, act_p = newton(t, act_f, act_p)
    g0p_node = g0p.copy()
    shift = np.zeros(len(up))
    for npass in range(segment_passes):
        # the lower surface's deformed height at the upper node's x (linear between its nodes)
        # against the paired node's: the node-to-node gap less the true one; lagged, to a
        # fixed point
        xu = upper.X[up, 0] + u[nl + 2 * up]
        xl = lower.X[lo, 0] + u[2 * lo]
        yl = lower.X[lo, 1] + u[ylo]
        new_shift = np.interp(xu, xl, yl) - yl
        change = float(np.abs(new_shift - shift).max())
        if verbose:
            print(f"  segment pass {npass}: gap shift change {change:.1e} mm", flush=True)
        if change < 1e-10 * R:
            break
        shift = new_shift
        g0p = g0p_node - shift
        act_f, act_p = newton(1.0, act_f, act_p)
    else:
        if segment_passes:
            raise RuntimeError("the segment gaps did not settle")

    res = forces(u, tangent=False)[0] - f
    react_f = np.where(act_f, res[yf], 0.0)
    react_p = np.where(act_p, res[yup], 0.0)
    gap_f = g0f + u[yf]
    gap_p = g0p + u[yup] - u[ylo]
    other = np.ones(ndof, bool)
    other[np.concatenate([fixed_x, yf[act_f], yup[act_p], ylo[act_p]])] = False
    # relative sliding of the paired nodes (deformed x) over the contact and just beyond it
    xu = upper.X[up, 0] + u[nl + 2 * up]
    xl = lower.X[lo, 0] + u[2 * lo]
    near = upper.X[up, 0] <= 1.5 * a_guess
    slide = float(np.abs(xu - xl)[near].max())
    # what the sliding does to the gaps: the lower surface's height at the upper node's x (linear
    # between its deformed nodes) against its height at the paired node
    yl = lower.X[lo, 1] + u[ylo]
    gap_shift = float(np.abs(np.interp(xu, xl, yl) - yl)[near].max())
    common = {"law": law, "counts": counts, "deformed": True}
    flat = {**common, "u": u[:nl], "cand": cf, "active": act_f, "react": react_f, "g0": g0f, "gap": gap_f,
            "d": np.tile([0.0, 1.0], (len(cf), 1)), "load_carried_half": float(react_f.sum()), "area": ml.area}
    pair = {**common, "u": u[nl:], "cand": up, "active": act_p, "react": react_p, "g0": g0p, "gap": gap_p,
            "d": np.tile([0.0, 1.0], (len(up), 1)), "load_carried_half": float(react_p.sum()), "area": mu.area,
            "action_reaction": float(np.abs(res[ylo[act_p]] + res[yup[act_p]]).max()),
            "residual_free": float(np.abs(res[other]).max()), "slide": slide, "gap_shift": gap_shift,
            "slide_edge_ux": float(u[nl + 2 * up][act_p].min())}
    return {"flat": flat, "pair": pair}


def run_pair(a: float, level: int, law: str = "linear", steps: int = 5, segment: bool = False,
             verbose: bool = False) -> dict:
    """Mesh, solve and measure the pair (small strain, vertical, circle gaps): the contact
    between the disks (Hertz for two identical cylinders, R* = R/2, E* = E/(2(1 - nu^2)): the
    same a for the same P as one cylinder on the flat) and the lower disk's on the flat (load 2P)."""
    t0 = time.perf_counter()
    lower, upper = pair_meshes(a, level)
    P = load_for(a)
    if law == "linear":
        sol = solve_pair(lower, upper, P, verbose=verbose)
    else:
        sol = solve_pair_finite(lower, upper, P, law, steps=steps, segment_passes=20 if segment else 0,
                                verbose=verbose)
    out = measure(upper, sol["pair"], P)
    if "slide" in sol["pair"]:  # relative sliding of the paired nodes against the surface node spacing
        out.update({"slide": sol["pair"]["slide"], "slide_over_spacing": sol["pair"]["slide"] / (0.5 * upper.h0),
                    "gap_shift": sol["pair"]["gap_shift"],
                    "edge_ux_over_a": sol["pair"]["slide_edge_ux"] / hertz(P)[0]})
    out["flat"] = {k: v for k, v in measure(lower, sol["flat"], 2 * P).items()}
    out.update({"a": a, "level": level, "model": law, "gap": "circle", "segment": segment,
                "direction": "vertical" if law == "linear" else "vertical (deformed)",
                "case": "pair", "h0": upper.h0, "nodes": len(lower.X) + len(upper.X),
                "elements": len(lower.tri) + len(upper.tri), "min_angle_deg": min(lower.min_angle, upper.min_angle),
                "counts": sol["pair"]["counts"], "residual_free": sol["pair"]["residual_free"],
                "action_reaction": sol["pair"]["action_reaction"],
                "wall_s": time.perf_counter() - t0, "solver": "cholmod" if _cholesky is not None else "splu"})
    return out


# ---------------------------------------------------------------- measures

def configuration(mesh: Mesh, sol: dict) -> np.ndarray:
    """Where the pressure lives: the reference positions for the linear model (its surface and
    tractions are the reference ones), the deformed ones for the finite-strain models."""
    deformed = sol.get("deformed", sol["law"] != "linear")
    return mesh.X + sol["u"].reshape(-1, 2) if deformed else mesh.X


def recover_pressure(mesh: Mesh, sol: dict) -> tuple[np.ndarray, np.ndarray]:
    """Nodal pressures on the surface from the nodal reactions through the consistent P2 edge
    mass matrix of the surface (M p = F over the edges that touch the contact; lengths in the
    configuration of `configuration`). Returns x (sorted) and p at those surface nodes."""
    xdef = configuration(mesh, sol)
    cand = sol["cand"]
    F = np.zeros(len(mesh.X))
    F[cand] = sol["react"]
    xa = xdef[cand[sol["active"]], 0].max()
    se = mesh.sedges[xdef[mesh.sedges[:, 0], 0] <= xa + 1e-12]
    nodes = np.unique(se)
    idx = {n: i for i, n in enumerate(nodes)}
    s = np.array([0.1127016653792583, 0.5, 0.8872983346207417])
    wq = np.array([5 / 18, 8 / 18, 5 / 18])
    N = np.stack([(1 - s) * (1 - 2 * s), 4 * s * (1 - s), s * (2 * s - 1)], 1)  # (3q, 3)
    dN = np.stack([4 * s - 3, 4 - 8 * s, 4 * s - 1], 1)
    rows, cols, vals = [], [], []
    for e in se:
        xe = xdef[e]
        jac = np.linalg.norm(dN @ xe, axis=1)
        if sol.get("axisymmetric"):  # reactions per radian: the surface's r ds
            jac = jac * (N @ xe[:, 0])
        Me = np.einsum("q,qa,qb->ab", wq * jac, N, N)
        ii = [idx[n] for n in e]
        for a in range(3):
            for b in range(3):
                rows.append(ii[a]); cols.append(ii[b]); vals.append(Me[a, b])
    M = sp.csr_matrix((vals, (rows, cols)), shape=(len(nodes), len(nodes)))
    p = spla.spsolve(M.tocsc(), F[nodes])
    order = np.argsort(xdef[nodes, 0])
    return xdef[nodes[order], 0], p[order]


def measure(mesh: Mesh, sol: dict, P: float) -> dict:
    """Half-width (edge, moment, ellipse fit), centre pressure, profile against Hertz (the
    sphere's contact radius and centre pressure when the solution is axisymmetric)."""
    sphere = bool(sol.get("axisymmetric"))
    aH, p0H = hertz(P, sphere)
    cand, act, F = sol["cand"], sol["active"], sol["react"]
    xc = configuration(mesh, sol)[cand, 0]
    gap = sol["gap"]
    last = int(np.flatnonzero(act).max())
    x1, x2 = xc[last + 1], xc[last + 2]
    g1, g2 = max(gap[last + 1], 0.0) ** (2 / 3), max(gap[last + 2], 0.0) ** (2 / 3)
    a_edge = x1 - g1 * (x2 - x1) / (g2 - g1) if g2 > g1 else x1
    a_edge = float(min(max(a_edge, xc[last]), x1))
    load = (2.0 * math.pi if sphere else 2.0) * sol["load_carried_half"]
    # Hertz's p: <x^2> = a^2 / 4 over the strip's nodal forces; <r^2> = 2 a^2 / 5 over the
    # sphere's per-radian nodal forces (p r dr)
    a_moment = math.sqrt((2.5 if sphere else 4.0) * float((xc**2 * F).sum() / F.sum()))
    x, p = recover_pressure(mesh, sol)
    fit = p > 0.1 * p.max()
    c = np.linalg.lstsq(np.stack([np.ones(fit.sum()), x[fit] ** 2], 1), p[fit] ** 2, rcond=None)[0]
    a_fit = math.sqrt(-c[0] / c[1]) if c[0] > 0 > c[1] else float("nan")
    centre = float(p[0])
    xs = np.linspace(0.0, 0.8 * aH, 81)
    pi = np.interp(xs, x, p)
    ph = p0H * np.sqrt(1 - (xs / aH) ** 2)
    grid = np.arange(0.0, 1.0001 * aH * 1.0, 0.125 * aH)
    tens = float(F[act].min())
    pen = float(np.minimum(gap, 0.0).min())
    return {"a_hertz": aH, "p0_hertz": p0H, "load_applied": P, "load_carried": load,
            "load_error": load / P - 1.0, "a_edge": a_edge, "a_edge_error": a_edge / aH - 1.0,
            "a_bracket": [float(xc[last]), float(x1)],
            "a_moment": a_moment, "a_moment_error": a_moment / aH - 1.0,
            "a_fit": a_fit, "a_fit_error": a_fit / aH - 1.0, "p0_fit_error": math.sqrt(max(c[0], 0.0)) / p0H - 1.0,
            "centre_p": centre, "centre_error": centre / p0H - 1.0,
            "p_max_over_p0": float(p.max() / p0H),
            "profile_max_error": float(np.abs(pi - ph).max() / p0H),
            "profile_x_over_a": (grid / aH).tolist(), "profile_p_over_p0": (np.interp(grid, x, p) / p0H).tolist(),
            "min_active_reaction": tens, "max_penetration": pen,
            "n_active": int(act.sum()), "surface_spacing": float(np.diff(xc[: last + 2]).max())}


def run_one(a: float, level: int, law: str = "linear", gap: str = "circle", direction: str = "normal",
            steps: int = 5, verbose: bool = False, axisymmetric: bool = False) -> dict:
    """Mesh, solve and measure one case (axisymmetric: the sphere, a its Hertz contact radius)."""
    t0 = time.perf_counter()
    mesh = Mesh(a, level)
    P = load_for(a, axisymmetric)
    sol = solve_contact(mesh, P, law=law, gap=gap, direction=direction, steps=steps, verbose=verbose,
                        axisymmetric=axisymmetric)
    out = measure(mesh, sol, P)
    if law == "linear":  # the same solution read at the deformed positions (as the FEM scenes read theirs)
        cur = measure(mesh, {**sol, "deformed": True}, P)
        out["current"] = {k: cur[k] for k in KEYS + ["profile_p_over_p0"]}
    out.update({"a": a, "level": level, "model": law, "gap": gap,
                "direction": direction if law == "linear" else "vertical (deformed)", "h0": mesh.h0, "nodes": len(mesh.X),
                "elements": len(mesh.tri), "dofs": 2 * len(mesh.X), "min_angle_deg": mesh.min_angle,
                "counts": sol["counts"], "residual_free": sol["residual_free"],
                "area_error": sol["area"] / (0.5 * math.pi * R**2) - 1.0, "axisymmetric": axisymmetric,
                "volume_error": sol["volume"] / (4.0 / 3.0 * math.pi * R**3) - 1.0 if axisymmetric else None,
                "steps": steps if law != "linear" else 0, "wall_s": time.perf_counter() - t0,
                "solver": "cholmod" if _cholesky is not None else "splu"})
    return out


def richardson(vals: list[float]) -> dict:
    """From the last three levels (ratio 2): observed order and extrapolated value."""
    f1, f2, f3 = vals[-3:]
    d1, d2 = f1 - f2, f2 - f3
    out = {"last": f3, "change_last": d2}
    if d2 != 0 and d1 / d2 > 1.0:
        q = d1 / d2
        out.update({"order": math.log2(q), "extrapolated": f3 + d2 / (q - 1)})
    else:  # not monotone: no order; the spread of the last two is the uncertainty
        out.update({"order": float("nan"), "extrapolated": 0.5 * (f2 + f3)})
    return out


def tag(a: float, law: str, gap: str, level: int, direction: str = "normal", axisymmetric: bool = False) -> str:
    vert = "_vertical" if law == "linear" and direction == "vertical" else ""
    return f"{'sphere_' if axisymmetric else ''}{law}{vert}_{gap}_a{a:g}_L{level}"


KEYS = ["a_edge_error", "a_moment_error", "a_fit_error", "centre_error", "p0_fit_error", "profile_max_error"]


def table(rows: list[dict]) -> str:
    """Markdown table of saved runs, grouped by case (the linear runs also read at the deformed
    positions), with a Richardson row where three levels or more are saved."""
    lines = ["| model, contact, gap, a (mm) | level (h0) | nodes | load carried - 1 | a_edge | a_moment | a_fit "
             r"| p(0) | p0 (fit) | max \|p - Hertz\| / p0, \|x\| < 0.8a | active sets, Newton | wall (s) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    groups: dict = {}
    for r in rows:
        if r.get("case") == "pair":  # the contact between the two cylinders
            name = f"pair: {r['model']}{', segment gaps' if r.get('segment') else ''}"
            groups.setdefault((name, r["gap"], r["a"]), []).append(r)
        elif r["model"] == "linear":
            name = f"linear, {r['direction']}"
            groups.setdefault((name, r["gap"], r["a"]), []).append(r)
            if r["direction"] == "vertical" and "current" in r:
                groups.setdefault((name + ", deformed positions", r["gap"], r["a"]), []).append({**r, **r["current"]})
        else:
            groups.setdefault((r["model"], r["gap"], r["a"]), []).append(r)
    for (name, gap, a), rs in sorted(groups.items()):
        rs.sort(key=lambda r: r["level"])
        for r in rs:
            lines.append(f"| {name}, {gap}, {a:g} | {r['level']} (a/{a / r['h0']:.0f}) | {r['nodes']} | "
                         f"{r['load_error']:.0e} | {100 * r['a_edge_error']:+.2f}% | {100 * r['a_moment_error']:+.2f}% | "
                         f"{100 * r['a_fit_error']:+.2f}% | {100 * r['centre_error']:+.2f}% | "
                         f"{100 * r['p0_fit_error']:+.2f}% | {100 * r['profile_max_error']:.2f}% | "
                         f"{r['counts']['active_set']}, {r['counts']['newton']} | {r['wall_s']:.1f} |")
        if len(rs) >= 3:
            ex = {k: richardson([r[k] for r in rs]) for k in KEYS}
            lines.append(f"| {name}, {gap}, {a:g} | Richardson (order) | | | "
                         + " | ".join(f"{100 * ex[k]['extrapolated']:+.2f}% "
                                      + (f"({ex[k]['order']:.1f})" if ex[k]["order"] == ex[k]["order"] else "(osc.)")
                                      for k in KEYS[:5]) + f" | {100 * ex[KEYS[5]]['extrapolated']:.2f}% | | |")
    return "\n".join(lines)


def profiles(rows: list[dict]) -> str:
    """p(x)/p0 at x/a = 0, 1/8, ..., 1 (Hertz's a and p0) of the finest level of each case."""
    best: dict = {}
    for r in rows:
        key = (("pair: " if r.get("case") == "pair" else "") + r["model"]
               + (", segment gaps" if r.get("segment") else ""), r.get("direction", ""), r["gap"], r["a"])
        if key not in best or r["level"] > best[key]["level"]:
            best[key] = r
    xs = best[next(iter(best))]["profile_x_over_a"] if best else []
    out = ["| case (finest level) | " + " | ".join(f"{x:.3f}" for x in xs) + " |",
           "|---|" + "---|" * len(xs),
           "| Hertz | " + " | ".join(f"{math.sqrt(max(1 - x * x, 0.0)):.3f}" for x in xs) + " |"]
    for (law, direction, gap, a), r in sorted(best.items()):
        name = f"{law}{', ' + direction if law.endswith('linear') else ''}, {gap}, a = {a:g}"
        out.append(f"| {name} | " + " | ".join(f"{p:.3f}" for p in r["profile_p_over_p0"]) + " |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    run = sub.add_parser("run", help="solve and save results/bench_hertz_reference/<tag>.json")
    run.add_argument("--levels", type=int, nargs="+", default=[0, 1, 2, 3])
    run.add_argument("--model", choices=["linear", "neo_hookean", "svk", "hencky", "hypo_log"], default="linear")
    run.add_argument("--a", type=float, default=2.0, help="Hertz half-width that sets the load (mm)")
    run.add_argument("--gap", choices=["circle", "parabola"], default="circle")
    run.add_argument("--direction", choices=["normal", "vertical"], default="normal",
                     help="linear model: the contact along the body's normal (classical Signorini) or vertical")
    run.add_argument("--steps", type=int, default=5, help="load steps (finite-strain models)")
    run.add_argument("--pair", action="store_true",
                     help="two cylinders stacked on the flat (small strain, vertical contact, circle gaps)")
    run.add_argument("--segment", action="store_true",
                     help="--pair at finite strain: the pairs' gaps corrected for their relative sliding "
                          "(the lower surface's height at the upper node's x), to a fixed point")
    run.add_argument("--axisymmetric", action="store_true",
                     help="the sphere in its r-z section (linear, hencky or hypo_log; --a its Hertz contact radius)")
    run.add_argument("--verbose", action="store_true")
    tb = sub.add_parser("table", help="the table of saved runs")
    tb.add_argument("--tags", nargs="*", help="result tags (default: all)")
    args = ap.parse_args(argv)
    RESULTS.mkdir(parents=True, exist_ok=True)
    if args.cmd == "run":
        for level in args.levels:
            if args.pair:
                if args.gap != "circle" or (args.model == "linear" and args.direction != "vertical"):
                    print("--pair: the circles' gaps, vertical contact (--gap circle --direction vertical)")
                    return 2
                out = run_pair(args.a, level, args.model, args.steps, args.segment, args.verbose)
                name = f"pair_{args.model}{'_segment' if args.segment else ''}_vertical_circle_a{args.a:g}_L{level}"
                (RESULTS / f"{name}.json").write_text(json.dumps(out, indent=1))
                fl = out["flat"]
                print(f"{name}: nodes {out['nodes']}, min angle {out['min_angle_deg']:.1f}, pair contact: load "
                      f"{out['load_error']:+.1e}, a_edge {100 * out['a_edge_error']:+.3f}%, a_moment "
                      f"{100 * out['a_moment_error']:+.3f}%, a_fit {100 * out['a_fit_error']:+.3f}%, p(0) "
                      f"{100 * out['centre_error']:+.3f}%, profile {100 * out['profile_max_error']:.2f}%; flat (2P): "
                      f"load {fl['load_error']:+.1e}, a_edge {100 * fl['a_edge_error']:+.3f}%, a_moment "
                      f"{100 * fl['a_moment_error']:+.3f}%, a_fit {100 * fl['a_fit_error']:+.3f}%, p(0) "
                      f"{100 * fl['centre_error']:+.3f}%"
                      + (f"; slide {out['slide']:.2e} mm = {out['slide_over_spacing']:.3f} of the surface spacing, "
                         f"gap shift {out['gap_shift']:.1e} mm, edge u_x "
                         f"{100 * out['edge_ux_over_a']:+.2f}% of a" if "slide" in out else "")
                      + f"; {out['wall_s']:.1f} s", flush=True)
                continue
            if args.axisymmetric and (args.model not in ("linear", "hencky", "hypo_log") or args.pair):
                print("--axisymmetric: the linear, hencky or hypo_log model, one body")
                return 2
            out = run_one(args.a, level, args.model, args.gap, args.direction, args.steps, args.verbose,
                          args.axisymmetric)
            name = tag(args.a, args.model, args.gap, level, args.direction, args.axisymmetric)
            (RESULTS / f"{name}.json").write_text(json.dumps(out, indent=1))
            print(f"{name}: nodes {out['nodes']}, load {out['load_error']:+.1e}, "
                  f"a_edge {100 * out['a_edge_error']:+.3f}%, a_moment {100 * out['a_moment_error']:+.3f}%, "
                  f"a_fit {100 * out['a_fit_error']:+.3f}%, p(0) {100 * out['centre_error']:+.3f}%, "
                  f"profile {100 * out['profile_max_error']:.2f}%, {out['wall_s']:.1f} s", flush=True)
        return 0
    files = sorted(RESULTS.glob("*.json"))
    rows = [json.loads(f.read_text()) for f in files if not args.tags or f.stem.rsplit("_L", 1)[0] in args.tags]
    print(table(rows))
    print()
    print(profiles(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
