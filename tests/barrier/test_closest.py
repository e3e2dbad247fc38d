"""3D contact primitives (mpmsim/contact/barrier/closest.py, ccd.py, potential.py) against the IPC
toolkit (ipctk, the oracle) and finite differences: point-triangle and edge-edge distance types,
squared distances, gradients and Hessians on 10,000 random pairs each and on degenerate ones
(coplanar points, points over region boundaries, parallel and nearly parallel edges); the
unsigned distance and the barrier by finite differences; the additive CCD on 10,000 random
trajectories against ipctk's tight-inclusion CCD (its time of impact unscaled)."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.contact.barrier import (barrier, edge_edge_barrier, edge_edge_ccd, edge_edge_distance2,
                                    edge_edge_distance2_hessian, edge_edge_distance_hessian, edge_edge_distance_type,
                                    point_triangle_barrier, point_triangle_ccd, point_triangle_distance2,
                                    point_triangle_distance2_hessian, point_triangle_distance_hessian,
                                    point_triangle_distance_type)

from .fd import fd_gradient, fd_jacobian, rel_err

pytestmark = pytest.mark.implicit
N = 10_000


def split(y):
    return [y[3 * i: 3 * i + 3] for i in range(4)]


def degenerate_pt(rng, n):
    """Point-triangle pairs on the edges of the type regions: the point in the triangle's plane
    (inside and outside), over an edge (on the face/edge region boundary), over a vertex's
    corner (on an edge/vertex boundary)."""
    out = []
    for k in range(n):
        t = rng.normal(size=(3, 3))
        u, v = t[1] - t[0], t[2] - t[0]
        nrm = np.cross(u, v)
        nrm /= np.linalg.norm(nrm)
        kind = k % 4
        if kind == 0:  # coplanar, inside
            a, b = rng.uniform(0.05, 0.45, 2)
            p = t[0] + a * u + b * v
        elif kind == 1:  # coplanar, outside
            p = t[0] + rng.uniform(-1.5, 2.5) * u + rng.uniform(-1.5, -0.1) * v
        elif kind == 2:  # above a point of edge t0-t1: projection on the edge
            p = t[0] + rng.uniform(0.1, 0.9) * u + rng.uniform(0.1, 1.0) * nrm
        else:  # above the vertex t0
            p = t[0] + rng.uniform(0.1, 1.0) * nrm
        out.append(np.r_[p, t.ravel()])
    return out


def degenerate_ee(rng, n, kinds=(0, 1, 2)):
    """Edge pairs that are parallel (kind 0), nearly parallel (1e-6 rad, kind 1) or whose line
    passes over a vertex's foot (kind 2)."""
    out = []
    for k in range(n):
        a0, d = rng.normal(size=3), rng.normal(size=3)
        off = np.cross(d, rng.normal(size=3))
        kind = kinds[k % len(kinds)]
        if kind == 0:  # parallel, overlapping
            b0, b1 = a0 + off + 0.3 * d, a0 + off + 1.7 * d
        elif kind == 1:  # nearly parallel
            turn = np.cross(d, off)
            turn *= 1e-6 * np.linalg.norm(d) / np.linalg.norm(turn)
            b0, b1 = a0 + off + 0.3 * d, a0 + off + 1.7 * d + turn
        else:  # b's line passes over a0's foot exactly
            b0, b1 = a0 + off - 0.5 * np.cross(off, d), a0 + off + 0.5 * np.cross(off, d)
        out.append(np.r_[a0, a0 + d, b0, b1])
    return out


def compare(pairs, ours_type, ours_hess, ref_type, ref_value, ref_grad, ref_hess, floor=1e-300):
    """Worst relative error of the value, and where the types agree of the gradient and Hessian;
    count of type disagreements (ties on a region boundary, where the distance is a minimum of
    equal branches and its derivatives depend on the branch). floor: the scale below which
    errors count as absolute (coordinates are of order one: a coplanar point has d^2 = 0 to
    rounding, its relative error means nothing)."""
    worst, differ = 0.0, 0
    g, H = np.zeros(12), np.zeros((12, 12))
    for y in pairs:
        v = split(y)
        ref_t = int(ref_type(*v).value)
        mine = ours_type(y)
        s = ours_hess(y, g, H, mine, True)
        worst = max(worst, abs(s - ref_value(*v)) / max(ref_value(*v), floor))
        if mine == ref_t:
            gref, Href = np.asarray(ref_grad(*v)).ravel(), np.asarray(ref_hess(*v))
            worst = max(worst, np.abs(g - gref).max() / max(np.abs(gref).max(), floor),
                        np.abs(H - Href).max() / max(np.abs(Href).max(), floor))
        else:
            differ += 1
    return worst, differ


@pytest.mark.parametrize("kind", ["pt", "ee"])
def test_distances_match_ipctk_on_random_and_degenerate_pairs(kind):
    ipctk = pytest.importorskip("ipctk")
    rng = np.random.default_rng(11 if kind == "pt" else 12)
    if kind == "pt":
        funcs = (point_triangle_distance_type, point_triangle_distance2_hessian, ipctk.point_triangle_distance_type,
                 ipctk.point_triangle_distance, ipctk.point_triangle_distance_gradient,
                 ipctk.point_triangle_distance_hessian)
        special = degenerate_pt(rng, 400)
    else:
        funcs = (edge_edge_distance_type, edge_edge_distance2_hessian, ipctk.edge_edge_distance_type,
                 ipctk.edge_edge_distance, ipctk.edge_edge_distance_gradient, ipctk.edge_edge_distance_hessian)
        special = degenerate_ee(rng, 300, kinds=(0, 2))
    worst, differ = compare([rng.normal(size=12) for _ in range(N)], *funcs)
    assert differ == 0 and worst < 1e-10, (differ, worst)
    # on region boundaries a type is a tie: values agree whatever the tie-break, and most ties
    # are broken the same way (exactly parallel overlapping edges have no unique gradient)
    worst, differ = compare(special, *funcs, floor=1.0)
    assert worst < 1e-10, worst
    assert differ < len(special) // 4, differ


@pytest.mark.parametrize("dist,bar", [(point_triangle_distance_hessian, point_triangle_barrier),
                                      (edge_edge_distance_hessian, edge_edge_barrier)])
def test_unsigned_distance_and_barrier_match_finite_differences(dist, bar):
    """d = sqrt(d^2) and b(d) with b the 2D barrier (tested against ipctk in test_potential.py):
    gradient and Hessian by central differences; far pairs (d >= dhat) have none."""
    rng = np.random.default_rng(5)
    worst = 0.0
    for _ in range(200):
        y = rng.normal(size=12)

        def value(z):
            return dist(z, np.zeros(12), np.zeros((12, 12)))

        def grad(z):
            g = np.zeros(12)
            dist(z, g, np.zeros((12, 12)))
            return g

        g, H = np.zeros(12), np.zeros((12, 12))
        d = dist(y, g, H)
        worst = max(worst, rel_err(g, fd_gradient(value, y, 1e-6)), rel_err(H, fd_jacobian(grad, y, 1e-6)))
        dhat, kappa = 2.0 * d, 3.0
        gb, Hb = np.zeros(12), np.zeros((12, 12))
        assert bar(y, dhat, kappa, gb, Hb) == pytest.approx(barrier(d, dhat, kappa), rel=1e-14)
        worst = max(worst, rel_err(gb, fd_gradient(lambda z: bar(z, dhat, kappa, np.zeros(12), np.zeros((12, 12))),
                                                  y, 1e-6)))
        assert bar(y, 0.5 * d, kappa, gb, Hb) == 0.0 and not gb.any()
    assert worst < 1e-6, worst


@pytest.mark.parametrize("kind", ["pt", "ee"])
def test_ccd_never_passes_the_first_contact_and_keeps_a_tenth_of_the_distance(kind):
    """10,000 random linear trajectories per kind (half of them fast enough to tunnel through
    the other primitive within the step): the CCD's step never passes the time of impact that
    ipctk's tight-inclusion CCD finds (conservative rescaling 1: its bound on the first
    contact), never returns the whole step when there is a contact (no tunnelling), and leaves
    at least eta = 0.1 of the starting distance."""
    ipctk = pytest.importorskip("ipctk")
    ref = ipctk.TightInclusionCCD(conservative_rescaling=1.0)
    ccd, dist2, ref_ccd = ((point_triangle_ccd, point_triangle_distance2, ref.point_triangle_ccd) if kind == "pt"
                           else (edge_edge_ccd, edge_edge_distance2, ref.edge_edge_ccd))
    rng = np.random.default_rng(21 if kind == "pt" else 22)
    hits, ratio = 0, np.inf
    for k in range(N):
        y = rng.normal(size=12)
        dy = rng.normal(size=12) * (4.0 if k % 2 else 1.0)
        t = ccd(y, dy)
        hit, toi = ref_ccd(*split(y), *split(y + dy))
        if hit:
            hits += 1
            assert t <= toi and t < 1.0, (k, t, toi)
        ratio = min(ratio, np.sqrt(dist2(y + t * dy) / dist2(y)))
    assert hits > N // 40  # the test has teeth: hundreds of trajectories collide (550 point-triangle)
    assert ratio >= 0.1 * (1 - 1e-12), ratio


def test_nearly_parallel_edges_agree_with_ipctk_as_far_as_their_conditioning_allows():
    """Edges 1e-6 rad from parallel: the distance agrees with ipctk to 1e-10; its derivatives
    only to about 1e-16 / sin^2 (angle) = 1e-4, because the closest points slide freely along
    nearly parallel lines (the Hessian is 1e13 here) and two exact formulas round differently.
    IPC multiplies such pairs by a mollifier that vanishes as the edges become parallel, so
    their barrier never uses these derivatives at full weight."""
    ipctk = pytest.importorskip("ipctk")
    rng = np.random.default_rng(13)
    pairs = degenerate_ee(rng, 300, kinds=(1,))
    value, grad = 0.0, 0.0
    g, H = np.zeros(12), np.zeros((12, 12))
    for y in pairs:
        v = split(y)
        ref = ipctk.edge_edge_distance(*v)
        value = max(value, abs(edge_edge_distance2(y) - ref) / ref)
        t = int(ipctk.edge_edge_distance_type(*v).value)
        edge_edge_distance2_hessian(y, g, H, t, True)
        gref = np.asarray(ipctk.edge_edge_distance_gradient(*v, ipctk.EdgeEdgeDistanceType(t))).ravel()
        grad = max(grad, np.abs(g - gref).max() / np.abs(gref).max())
    assert value < 1e-10, value
    assert grad < 1e-3, grad
