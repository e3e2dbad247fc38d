"""Additive CCD: exact safety on 10^4 random point-edge trajectories (generic, head-on,
grazing, parallel, exactly collinear, rotating edge, near-touching), and tightness.

Safety is certified with rational arithmetic (ccd_cases.contacts): no instant in [0, toi] puts
the point on the segment. Tightness: the CCD stops where the distance would drop below
eta d0 (10% of the start distance), so it is compared with t_eta, the first time d(t) = eta d0
(<= the true time of impact): t_eta / toi <= 10 on every trajectory that reaches it, and
toi_true / toi <= 10 on every impact whose distance does not fall below eta d0 before half the
time of impact (where it does, e.g. a point sliding along the edge before being pinched, any
method honouring the 10% rule must stop much earlier than the impact)."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from mpmsim.contact.barrier import point_edge_ccd, point_edge_ccd_pairs, point_edge_distance, point_point_ccd

from .ccd_cases import Trajectory, contacts, first_time_below, make_cases

pytestmark = pytest.mark.implicit

ETA = 0.1
N_CASES = 10_000


def run_cases(n, seed):
    ys, dys, labels = make_cases(n, seed)
    tois = np.array([point_edge_ccd(ys[k], dys[k], ETA, 1.0, 1_000_000) for k in range(len(ys))])
    return ys, dys, labels, tois


def test_ccd_never_lets_the_point_touch_and_is_not_too_conservative():
    ys, dys, labels, tois = run_cases(N_CASES, seed=2024)
    assert len(ys) >= N_CASES
    unsafe, thin, loose_eta, loose_toi, ambiguous = [], [], [], [], []
    n_impacts = n_direct = 0
    for k in range(len(ys)):
        y, dy, toi = ys[k], dys[k], tois[k]
        assert 0.0 <= toi <= 1.0
        events = contacts(Trajectory(y, dy))
        T = Fraction(float(toi))
        for lo, hi, status in events:
            ambiguous += [k] if status == "ambiguous" else []
            if lo <= T:
                unsafe.append((k, labels[k], float(lo), toi))
        d0 = point_edge_distance(y, -1)  # (all arguments given: numba's fast dispatch path)
        scale = np.abs(y).max() + np.abs(dy).max()
        if point_edge_distance(y + toi * dy, -1) < ETA * d0 - 1e-13 * scale:
            thin.append((k, labels[k]))
        # t_eta <= 1, so it is only needed when toi < 0.1 or to classify an impact
        t_eta = first_time_below(y, dy, ETA * d0) if (toi < 0.1 or events) else None
        if t_eta is not None and t_eta > 10 * toi:
            loose_eta.append((k, labels[k], t_eta, toi))
        if events:
            n_impacts += 1
            t_hit = float(events[0][0])
            if t_eta is not None and t_eta >= 0.5 * t_hit:
                n_direct += 1
                if t_hit > 10 * toi:
                    loose_toi.append((k, labels[k], t_hit, toi))
    assert not unsafe, unsafe[:5]
    assert not ambiguous, ambiguous[:5]
    assert not thin, thin[:5]
    assert not loose_eta, loose_eta[:5]
    assert not loose_toi, loose_toi[:5]
    assert n_impacts > 2000 and n_direct > 1500, (n_impacts, n_direct)


def test_head_on_and_sliding_closed_forms():
    # head-on at unit speed toward a static edge from distance 0.5: time of impact 0.5; the CCD
    # stops at (1 - eta) of it
    y = np.array([0.5, 0.5, 0.0, 0.0, 1.0, 0.0])
    dy = np.array([0.0, -1.0, 0, 0, 0, 0])
    assert point_edge_ccd(y, dy, ETA) == pytest.approx(0.45, rel=1e-12)
    # sliding parallel at a tiny height over a static edge: no contact, full step
    y = np.array([0.2, 1e-9, 0.0, 0.0, 1.0, 0.0])
    dy = np.array([0.5, 0.0, 0, 0, 0, 0])
    assert point_edge_ccd(y, dy, ETA) == 1.0
    # the same while the edge approaches slowly: impact at t = 0.5, stop near 0.45
    dy = np.array([0.5, 0.0, 0.0, 2e-9, 0.0, 2e-9])
    assert point_edge_ccd(y, dy, ETA) == pytest.approx(0.45, rel=1e-2)
    # approaching the end e0 along the edge's line at a tiny offset: the distance falls to 1e-9
    # near x = 0, so the CCD stops where it reaches eta d0 = 0.05 (x = -0.05, t = 0.225)
    y = np.array([-0.5, 1e-9, 0.0, 0.0, 1.0, 0.0])
    dy = np.array([2.0, 0.0, 0, 0, 0, 0])
    assert 0.2 < point_edge_ccd(y, dy, ETA) <= 0.225
    # touching start, no motion, moving away
    assert point_edge_ccd(np.array([0.5, 0.0, 0, 0, 1, 0.0]), dy, ETA) == 0.0
    assert point_edge_ccd(y, np.zeros(6), ETA) == 1.0
    assert point_edge_ccd(y, np.array([0.0, 1.0, 0, 0, 0, 0]), ETA) == 1.0
    # t_max caps the answer
    assert point_edge_ccd(y, np.array([0.0, 1.0, 0, 0, 0, 0]), ETA, 0.3) == 0.3


def test_point_point_ccd():
    y = np.array([0.0, 0.0, 1.0, 0.0])
    assert point_point_ccd(y, np.array([2.0, 0.0, 0.0, 0.0]), ETA) == pytest.approx(0.45, rel=1e-12)
    assert point_point_ccd(y, np.array([0.0, 1.0, 0.0, 0.0]), ETA) == 1.0  # passes at distance 0.707
    rng = np.random.default_rng(0)
    for _ in range(500):
        y = rng.uniform(-1, 1, 4)
        dy = rng.normal(0, 1, 4)
        t = point_point_ccd(y, dy, ETA)
        r0 = y[:2] - y[2:]
        dr = dy[:2] - dy[2:]
        # exact closest approach of the linear relative motion over [0, t]
        s = np.clip(-(r0 @ dr) / (dr @ dr), 0, t) if dr @ dr > 0 else 0.0
        assert np.linalg.norm(r0 + s * dr) > 0
        assert np.linalg.norm(r0 + t * dr) >= ETA * np.linalg.norm(r0) * (1 - 1e-12)


def test_batched_ccd_is_the_minimum_over_pairs():
    ys, dys, _, tois = run_cases(200, seed=5)
    pts = ys[:, 0:2].copy()
    dpts = dys[:, 0:2].copy()
    verts = np.concatenate([ys[:, 2:4], ys[:, 4:6]])
    dverts = np.concatenate([dys[:, 2:4], dys[:, 4:6]])
    n = len(ys)
    edges = np.array([[k, n + k] for k in range(n)], dtype=np.int64)
    pairs = np.array([[k, k] for k in range(n)], dtype=np.int64)
    assert point_edge_ccd_pairs(pts, dpts, verts, dverts, edges, pairs, ETA) == pytest.approx(tois.min(), rel=1e-12)


def test_a_capped_first_advance_is_never_forfeited():
    """A pair capped at exactly its own CCD time (another pair, e.g. the coincident corner of a
    neighbouring particle, set the running minimum): at that time round-off puts the distance a
    hair below eta d0, but the first advance is safe by the bounds and must be returned whole,
    as the uncapped call does, not as 0 (which stalled Newton on an MPM column's corners)."""
    y = np.array([0.05000000000000368, -0.0013500000004642394, 0.10000000000003421, -0.003000000000489901,
                  0.05000000000001589, -0.0030000000004653726])
    dy = np.array([-2.4553563986396292e-11, -9.998650000084448, 2.536058665942328e-10, -3.628407413070593e-09,
                   1.1781148872020606e-10, -3.4467401455006574e-09])
    t = point_edge_ccd(y, dy, ETA)
    assert t == pytest.approx((1 - ETA) * 0.00165 / 9.99865, rel=1e-9)
    assert point_edge_ccd(y, dy, ETA, t) == t
    pts, dpts = np.stack([y[:2], y[:2]]), np.stack([dy[:2], dy[:2]])
    verts, dverts = np.stack([y[2:4], y[4:6]]), np.stack([dy[2:4], dy[4:6]])
    edges = np.array([[0, 1]], dtype=np.int64)
    pairs = np.array([[0, 0], [1, 0]], dtype=np.int64)
    assert point_edge_ccd_pairs(pts, dpts, verts, dverts, edges, pairs, ETA) == t
