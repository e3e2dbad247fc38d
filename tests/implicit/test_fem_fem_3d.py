"""3D FEM-FEM barrier contact in the implicit step (mpmsim/contact/barrier/surface.py;
docs/bfemp.md, "3D contact"): two free FEM cubes colliding corner patch on corner patch (their
rims cross: edge-edge terms carry the contact there), and two FEM cubes and an MPM cube meeting
in one scene. Checked at every step with tests of this file's own: no FEM node strictly inside a
tetrahedron of another body, no boundary edge of one FEM body crossing a boundary triangle of
another, no particle inside a tetrahedron; linear momentum kept to 1e-10 of the incoming one."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.contact.barrier.surface import min_edge_distance
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation
from tests.conftest import deck_from
from tests.implicit.test_implicit_3d import impact_deck, inside_tets

pytestmark = pytest.mark.implicit


def fem_box(name, lo, hi, velocity=(0.0, 0.0, 0.0)):
    return {"name": name, "shape": "box", "min": list(lo), "max": list(hi), "material": "m",
            "discretization": "fem", "element_size": 0.05, "velocity": list(velocity)}


def deck(bodies, dt, end, friction=0.0, cell=0.025):
    return impact_deck("3D FEM-FEM impact", bodies, ([-0.2, -0.2, -0.2], [0.25, 0.3, 0.2]), cell, dt, end, friction)


def segments_cross_triangles(p0, p1, tri):
    """(k,) which segments p0-p1 (k, 3) cross the triangle tri (k, 3, 3) of the same row:
    the segment's ends strictly on opposite sides of the triangle's plane and the crossing point
    strictly inside the triangle (signed volumes, no solve)."""
    def vol(a, b, c, d):
        return np.einsum("...i,...i->...", np.cross(b - a, c - a), d - a)

    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    s0, s1 = vol(a, b, c, p0), vol(a, b, c, p1)
    # the segment passes inside iff the three tetrahedra (p0, p1, edge) have one sign
    t0, t1, t2 = vol(p0, p1, a, b), vol(p0, p1, b, c), vol(p0, p1, c, a)
    same = ((t0 > 0) & (t1 > 0) & (t2 > 0)) | ((t0 < 0) & (t1 < 0) & (t2 < 0))
    return (s0 * s1 < 0) & same


class Watch:
    """Per-step checks on the FEM bodies of a simulation."""

    def __init__(self, sim):
        """After the first step (the integrator builds its terms there)."""
        self.sim = sim
        f = sim.state.fem
        self.f = f
        self.body = f.node_body
        self.cell_body = self.body[f.cells[:, 0]]
        bar = sim.integrator.barrier_term
        self.edges = bar.surface.edges
        self.edge_body = bar.edge_body
        self.tris = bar.surface.triangles
        self.tri_body = self.body[self.tris[:, 0]]
        self.closest_ee = np.inf

    def check(self):
        f, t = self.f, self.sim.state.t
        bodies = np.unique(self.body)
        for b in bodies:
            own = self.body == b
            others = self.cell_body != b
            assert not inside_tets(f.x[own], f.x, f.cells[others]).any(), f"an FEM node inside another body at t = {t}"
            E = self.edges[self.edge_body == b]
            T = self.tris[self.tri_body != b]
            i, j = np.meshgrid(np.arange(len(E)), np.arange(len(T)), indexing="ij")
            i, j = i.ravel(), j.ravel()
            hit = segments_cross_triangles(f.x[E[i, 0]], f.x[E[i, 1]], f.x[T[j]])
            assert not hit.any(), f"an edge crosses another body's face at t = {t}"
        P = self.sim.state.particles
        if P is not None and P.n:
            assert not inside_tets(P.x, f.x, f.cells).any(), f"a particle inside an FEM body at t = {t}"
        ee = self.sim.integrator.barrier_term.edge_current.pairs
        if len(ee):
            self.closest_ee = min(self.closest_ee, min_edge_distance(f.x, self.edges, ee))


def momentum(st):
    p = st.fem.mass @ st.fem.v
    if st.particles is not None and st.particles.n:
        p = p + st.particles.mass @ st.particles.v
    return p


def run(d):
    sim = Simulation(build_scene(deck_from(d)), threads=1)
    st = sim.state
    p0 = momentum(st)
    drift, watch = 0.0, None
    while st.t < sim.end * (1 - 1e-12):
        sim.step()
        watch = watch or Watch(sim)
        watch.check()
        drift = max(drift, float(np.abs(momentum(st) - p0).max()))
    return sim, watch, p0, drift


def test_two_free_fem_cubes_collide_corner_patch_on_corner_patch():
    """Cube B (0.1 m, 48 tetrahedra) at 3 m/s down onto cube A offset by half a side in x and z:
    the faces meet over a quarter of their area and the rims cross there. dt = 1 ms over 20 ms
    (lands at ~0.7 ms, in contact for ~8 ms, leaves): no node inside, no edge through a face,
    edge pairs came within dhat, momentum to 1e-10, A pushed down (the cubes' masses are equal:
    both end near 1.5 m/s, backward Euler's damping at this dt)."""
    A = fem_box("A", (-0.05, -0.1, -0.05), (0.05, 0.0, 0.05))
    B = fem_box("B", (0.0, 0.002, 0.0), (0.1, 0.102, 0.1), (0.0, -3.0, 0.0))
    sim, watch, p0, drift = run(deck([A, B], 1e-3, 0.02))
    st = sim.state
    assert drift < 1e-10 * np.abs(p0).max(), drift
    assert watch.closest_ee < 1e-3  # the edge-edge terms were in play
    va = st.fem.v[st.fem.node_body == 0].mean(axis=0)
    vb = st.fem.v[st.fem.node_body == 1].mean(axis=0)
    assert va[1] < -1.0 and vb[1] > -2.0  # A pushed down, B slowed
    print("closest edge pair", watch.closest_ee, "va", va, "vb", vb, "drift", drift / np.abs(p0).max())


def test_two_fem_cubes_and_an_mpm_cube_meet():
    """FEM cubes A (free, at rest) and B (at 1 m/s towards A, 4 mm apart) side by side, an MPM
    cube (0.1 m, 64 particles on a 5 cm grid) at 2 m/s down onto both, with friction mu = 0.3:
    all three meet within 15 ms (dt = 1 ms). No particle inside a tetrahedron, no FEM node inside the other
    FEM body, no edge through the other's faces, momentum to 1e-10."""
    A = fem_box("A", (-0.1, -0.1, -0.05), (0.0, 0.0, 0.05))
    B = fem_box("B", (0.004, -0.1, -0.05), (0.104, 0.0, 0.05), (-1.0, 0.0, 0.0))
    mpm = {"name": "cube", "shape": "box", "min": [-0.05, 0.004, -0.05], "max": [0.05, 0.104, 0.05],
           "material": "m", "velocity": [0.0, -2.0, 0.0]}
    sim, watch, p0, drift = run(deck([A, B, mpm], 1e-3, 0.015, friction=0.3, cell=0.05))
    st = sim.state
    P, f = st.particles, st.fem
    assert drift < 1e-10 * np.abs(p0).max(), drift
    va = f.v[f.node_body == 0].mean(axis=0)
    vb = f.v[f.node_body == 1].mean(axis=0)
    assert va[0] < -0.1 and va[1] < -0.1 and vb[1] < -0.1  # B pushed A; the MPM cube pushed both down
    print("va", va, "vb", vb, "particles", P.v.mean(axis=0), "drift", drift / np.abs(p0).max())


def ridge_decks(dt=1e-3):
    """Cube A turned 45 degrees about x (a ridge along x on top), cube B turned 45 degrees about
    z (a ridge along z below) 2 mm above it, off the ridges' middle nodes (12, 13 mm), at 3 m/s
    down: the ridges cross where no node is near the other's faces."""
    r2 = 0.05 * np.sqrt(2.0)
    A = fem_box("A", (-0.05, -0.05, -0.05), (0.05, 0.05, 0.05))
    A["transform"] = [{"rotate": 45.0, "axis": "x"}, {"translate": [0.0, -r2, 0.0]}]
    B = fem_box("B", (-0.05, -0.05, -0.05), (0.05, 0.05, 0.05), (0.0, -3.0, 0.0))
    B["transform"] = [{"rotate": 45.0, "axis": "z"}, {"translate": [0.012, r2 + 0.002, 0.013]}]
    return deck([A, B], dt, 0.02)


@pytest.mark.parametrize("dt", [1e-3, 2e-4])
def test_two_free_fem_cubes_collide_ridge_across_ridge(dt):
    """The whole impact (20 ms): no node inside, no edge through a face, the edge pair came
    within dhat (measured 0.20 mm at dt = 1 ms), momentum to 1e-10 (measured 1.4e-15 relative),
    and the cubes part (at dt = 1 ms A leaves at 2.3 m/s, B at 0.7 m/s)."""
    sim, watch, p0, drift = run(ridge_decks(dt))
    f = sim.state.fem
    assert drift < 1e-10 * np.abs(p0).max(), drift
    assert watch.closest_ee < 1e-3
    va = f.v[f.node_body == 0].mean(axis=0)
    vb = f.v[f.node_body == 1].mean(axis=0)
    assert va[1] < vb[1] < 0.0  # A pushed ahead of B: parted
    print("closest edge pair", watch.closest_ee, "va", va, "vb", vb, "drift", drift / np.abs(p0).max())


def test_without_the_edge_edge_terms_the_ridges_pass_through_each_other(monkeypatch):
    """The checks have teeth: with node-triangle terms only, the first step (1 ms) puts B's ridge
    through A's faces."""
    from mpmsim.contact.barrier import surface

    monkeypatch.setattr(surface.SurfaceBarrier, "edge_pairs", lambda self, y, p: surface.NO_EDGE_GROUPS)
    with pytest.raises(AssertionError, match="an edge crosses another body's face at t = 0.001"):
        run(ridge_decks())


def test_fem_bodies_closer_than_dhat_in_3d_are_a_deck_error():
    from mpmsim.errors import DeckError

    A = fem_box("A", (-0.05, -0.1, -0.05), (0.05, 0.0, 0.05))
    B = fem_box("B", (0.0, 0.0005, 0.0), (0.1, 0.1005, 0.1))
    with pytest.raises(DeckError) as err:
        Simulation(build_scene(deck_from(deck([A, B], 1e-3, 0.01))), threads=1)
    assert "bodies 'A' and 'B' start 0.0005 apart, not farther than dhat = 0.001" in str(err.value)


def crossed_ridge_deck(mu: float, dt: float = 1e-3, end: float = 0.06) -> dict:
    """Bar B (0.05 x 0.05 x 0.2 m, turned 45 degrees about z: a ridge along z below) resting
    across the ridges of two held bars A1, A2 (turned 45 degrees about x: ridges along x on top,
    at z = -/+ 62.5 mm), 12 mm off their middle nodes; gravity tilted 30 degrees towards +z, so B
    slides along its ridge, across A's, on edge-edge contact alone (every node of one body more
    than dhat from the other's faces). Starts 1.5 mm above (dhat 1 mm)."""
    r2 = 0.025 * np.sqrt(2.0)
    bars = []
    for name, zc in (("A1", -0.0625), ("A2", 0.0625)):
        a = fem_box(name, (-0.1, -0.025, -0.025), (0.1, 0.025, 0.025))
        a["transform"] = [{"rotate": 45.0, "axis": "x"}, {"translate": [0.0, -r2, zc]}]
        a["constraints"] = [{"region": {"min": [-1.0, -1.0, -1.0], "max": [1.0, 1.0, 1.0]}}]
        bars.append(a)
    B = fem_box("B", (-0.025, -0.025, -0.1), (0.025, 0.025, 0.1))
    B["transform"] = [{"rotate": 45.0, "axis": "z"}, {"translate": [0.012, r2 + 0.0015, 0.0]}]
    d = impact_deck("bar sliding across two ridges", bars + [B], ([-0.2, -0.2, -0.3], [0.2, 0.2, 0.3]), 0.05,
                    dt, end, mu)
    g, theta = 9.81, np.radians(30.0)
    d["gravity"] = [0.0, -g * np.cos(theta), g * np.sin(theta)]
    return d


@pytest.mark.parametrize("mu", [0.3, 0.8])
def test_friction_acts_on_edge_edge_contact(mu):
    """crossed_ridge_deck over 0.12 s: B's centre-of-mass acceleration along the ridge (z) and across it
    (y) between 40 and 120 ms give the tangential and normal contact forces per mass,
    g sin 30 - a_z and g cos 30 + a_y; while sliding (mu = 0.3 < tan 30) their ratio is mu
    within 1%. With mu = 0.8 it sticks: at the end B moves along z slower than eps_v =
    1e-3 m/s (smoothed static friction creeps at 0.47 eps_v here). Without edge-edge friction
    B slides at g sin 30 = 4.9 m/s^2 whatever mu."""
    sim = Simulation(build_scene(deck_from(crossed_ridge_deck(mu, end=0.12))), out_dir=None, threads=1)
    st = sim.state
    B = st.fem.node_body == 2
    v = {}
    while st.t < sim.end * (1 - 1e-12):
        sim.step()
        v[round(st.t * 1000)] = st.fem.mass[B] @ st.fem.v[B] / st.fem.mass[B].sum()  # B's centre of mass
    g, theta = 9.81, np.radians(30.0)
    a = (v[120] - v[40]) / 0.08
    tangential, normal = g * np.sin(theta) - a[2], g * np.cos(theta) + a[1]
    print("mu", mu, "a", a, "ratio", tangential / normal, "v40", v[40], "v120", v[120])
    if mu < np.tan(theta):
        assert abs(tangential / normal / mu - 1.0) < 0.01, (a, tangential, normal)
    else:
        assert 0.0 <= v[120][2] < 1e-3, (v[40], v[120])
