"""Spatial-hash candidate pairs against brute force: the same set as an all-pairs swept-box
test (so no far pairs beyond the inflated boxes), a superset of the truly near pairs, the
self-exclusion of shared vertices, 3D boxes, and the boundary-node correction's nodes."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.contact.barrier import (box_pairs, correction_nodes, point_edge_candidates, point_edge_distance,
                            point_node_candidates)

pytestmark = pytest.mark.implicit


def brute_point_edge(points, dpoints, verts, dverts, edges, dhat, point_ids):
    plo = np.minimum(points, points + dpoints)
    phi = np.maximum(points, points + dpoints)
    ends = np.stack([verts[edges[:, 0]], verts[edges[:, 1]], verts[edges[:, 0]] + dverts[edges[:, 0]],
                     verts[edges[:, 1]] + dverts[edges[:, 1]]])
    elo = ends.min(axis=0) - dhat
    ehi = ends.max(axis=0) + dhat
    ok = np.all((plo[:, None, :] <= ehi[None]) & (elo[None] <= phi[:, None, :]), axis=2)
    shared = (point_ids[:, None] >= 0) & ((point_ids[:, None] == edges[None, :, 0]) | (point_ids[:, None] == edges[None, :, 1]))
    return {(int(i), int(j)) for i, j in zip(*np.nonzero(ok & ~shared))}


def segment_distances(points, verts, edges):
    """All point-segment distances (n, m), vectorised."""
    a = verts[edges[:, 0]][None]
    e = verts[edges[:, 1]][None] - a
    r = points[:, None] - a
    t = np.clip(np.sum(r * e, axis=2) / np.sum(e * e, axis=2), 0, 1)
    return np.linalg.norm(r - t[..., None] * e, axis=2)


def polyline(rng, m, closed):
    th = np.sort(rng.uniform(0, 2 * np.pi, m))
    r = 0.3 + 0.1 * rng.uniform(size=m)
    verts = np.c_[0.5 + r * np.cos(th), 0.5 + r * np.sin(th)]
    n_e = m if closed else m - 1
    edges = np.array([[k, (k + 1) % m] for k in range(n_e)], dtype=np.int64)
    return verts, edges


@pytest.mark.parametrize("seed", range(6))
def test_point_edge_candidates_equal_brute_force(seed):
    rng = np.random.default_rng(seed)
    n, m = 400, 120
    points = rng.uniform(0, 1, (n, 2))
    verts, edges = polyline(rng, m, closed=seed % 2 == 0)
    moving = seed >= 2
    dpoints = rng.normal(0, 0.02, (n, 2)) * moving
    dverts = rng.normal(0, 0.01, (m, 2)) * moving
    dhat = [0.005, 0.02, 0.05][seed % 3]
    ids = -np.ones(n, dtype=np.int64)
    pairs = point_edge_candidates(points, dpoints, verts, dverts, edges, dhat, ids)
    got = {(int(i), int(j)) for i, j in pairs}
    assert len(got) == len(pairs)  # no duplicates
    ref = brute_point_edge(points, dpoints, verts, dverts, edges, dhat, ids)
    assert got == ref
    d_start = segment_distances(points, verts, edges)
    # superset of the truly near pairs (distance below dhat at the start or end of the step)
    for t in (0.0, 1.0):
        d = segment_distances(points + t * dpoints, verts + t * dverts, edges)
        assert {(int(i), int(j)) for i, j in zip(*np.nonzero(d < dhat))} <= got
    # spot-check the vectorised distances against the package's
    for i, j in zip(rng.integers(0, n, 50), rng.integers(0, len(edges), 50)):
        y = np.r_[points[i], verts[edges[j, 0]], verts[edges[j, 1]]]
        assert d_start[i, j] == pytest.approx(point_edge_distance(y, -1), rel=1e-12, abs=1e-15)
    # an explicit cell size gives the same set
    for cell in (0.003, 0.2, 5.0):
        assert {(int(i), int(j)) for i, j in point_edge_candidates(points, dpoints, verts, dverts, edges, dhat, ids,
                                                                    cell)} == ref


def test_shared_index_space_excludes_own_edges():
    """FEM boundary nodes as points against their own boundary edges (point_ids = vertex ids)."""
    rng = np.random.default_rng(11)
    verts, edges = polyline(rng, 200, closed=True)
    ids = np.arange(len(verts), dtype=np.int64)
    dv = rng.normal(0, 0.005, verts.shape)
    pairs = point_edge_candidates(verts, dv, verts, dv, edges, 0.03, ids)
    got = {(int(i), int(j)) for i, j in pairs}
    assert got == brute_point_edge(verts, dv, verts, dv, edges, 0.03, ids)
    assert all(i not in edges[j] for i, j in got)
    assert len(got) > 0


def test_point_node_candidates_and_correction_nodes():
    rng = np.random.default_rng(12)
    verts, edges = polyline(rng, 60, closed=False)
    nodes, weights = correction_nodes(edges, len(verts))
    assert list(nodes) == list(range(1, 59)) and np.all(weights == 1.0)  # open: ends excluded
    closed_nodes, closed_w = correction_nodes(polyline(rng, 60, closed=True)[1], 60)
    assert len(closed_nodes) == 60 and np.all(closed_w == 1.0)
    points = rng.uniform(0, 1, (500, 2))
    dp = rng.normal(0, 0.01, points.shape)
    dv = rng.normal(0, 0.01, verts.shape)
    dhat = 0.03
    pairs = point_node_candidates(points, dp, verts, dv, nodes, dhat, -np.ones(500, dtype=np.int64))
    got = {(int(i), int(v)) for i, v in pairs}
    plo, phi = np.minimum(points, points + dp), np.maximum(points, points + dp)
    vlo = np.minimum(verts, verts + dv)[nodes] - dhat
    vhi = np.maximum(verts, verts + dv)[nodes] + dhat
    ok = np.all((plo[:, None] <= vhi[None]) & (vlo[None] <= phi[:, None]), axis=2)
    assert got == {(int(i), int(nodes[k])) for i, k in zip(*np.nonzero(ok))}
    assert len(got) > 0


def test_box_pairs_in_3d_and_degenerate_inputs():
    rng = np.random.default_rng(13)
    alo = rng.uniform(0, 1, (300, 3))
    ahi = alo + rng.exponential(0.03, (300, 3))
    blo = rng.uniform(0, 1, (200, 3))
    bhi = blo + rng.exponential(0.05, (200, 3))
    b_ids = rng.integers(0, 300, (200, 3)).astype(np.int64)
    a_ids = np.where(rng.random(300) < 0.5, np.arange(300), -1).astype(np.int64)
    pairs = box_pairs(alo, ahi, blo, bhi, a_ids, b_ids)
    got = {(int(i), int(j)) for i, j in pairs}
    assert len(got) == len(pairs)
    ok = np.all((alo[:, None] <= bhi[None]) & (blo[None] <= ahi[:, None]), axis=2)
    excl = (a_ids[:, None, None] >= 0) & (a_ids[:, None, None] == b_ids[None]).astype(bool)
    ok &= ~excl.any(axis=2)
    assert got == {(int(i), int(j)) for i, j in zip(*np.nonzero(ok))}
    empty = box_pairs(alo[:0], ahi[:0], blo, bhi, a_ids[:0], b_ids)
    assert empty.shape == (0, 2)
    # all boxes degenerate to one point (zero extent): still found
    pts = np.zeros((3, 2))
    e = point_edge_candidates(pts, pts, np.zeros((2, 2)), np.zeros((2, 2)), np.array([[0, 1]], dtype=np.int64), 0.0,
                              -np.ones(3, dtype=np.int64))
    assert {(int(i), int(j)) for i, j in e} == {(0, 0), (1, 0), (2, 0)}
