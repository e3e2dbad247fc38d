"""FEM contact that slides: the APIC augury paper's ramp (its Fig. 11) with the paper's method and
4-node kernel, and field contact (`contact.augury.method: field`, contact/augury/fields.py) on
the ramp, an MPM block on an FEM slab and two colliding blocks. Numbers measured in
docs/fem-contact.md.

- Paper's method: two grid-aligned rows of boundary nodes (spacing 2 h_c) slide over each other
  with no loss through the 4-node kernel (PIC and APIC, any offset, mass ratios 1 and 3); on the
  ramp APIC slides further than PIC at every h and mu, and the slide falls with mu (Fig. 11's
  claims). It does not reach the analytic slide (0.1 to 0.6 of it): no closeness is claimed.
- Field contact: the ramp's slide within 10% of the analytic one at h = 0.5 and 5% at h = 0.25,
  mu = 0 and 0.2, t = 0.05 and 0.1 s; the MPM block's acceleration on the FEM slab within 5% of
  g (sin 30 - mu cos 30) at both cells; two blocks: linear momentum to round-off, no boundary
  node inside the other block at any sampled time, and they rebound.
- mu = 0.7 (above tan 30): with the deck's stiffness (wave speed 100 m/s) the suddenly loaded
  elastic block rings, and while the normal force dips it slips (7% of the frictionless slide
  by 0.1 s, the paper's method alike); at 100 x the stiffness it holds within 1%. Loaded slowly
  (gravity_ramp over three periods of the block's slowest mode) its slip at the interface stays
  below 1% of the frictionless slide with either method.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
import yaml
from matplotlib.path import Path as Polygon

from mpmsim.contact.augury.transfers import KERNELS, AuguryGrid, augury_correction
from mpmsim.deck.overrides import with_overrides
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation
from tests.conftest import ROOT, deck_from

from .test_augury_contact import boundary_loop

pytestmark = pytest.mark.fem
TH = np.radians(30.0)
G = 100.0  # the ramp deck's gravity


def ramp_analytic(mu: float, t: float) -> float:
    return 0.5 * G * max(np.sin(TH) - mu * np.cos(TH), 0.0) * np.cos(TH) * t * t


@functools.lru_cache(maxsize=None)
def ramp(h: float, mu: float, method: str, transfer: str = "apic", E: float | None = None) -> dict:
    """The block's horizontal slide at t = 0.05 and 0.1 s on inputs/fem_ramp_2d.yaml at element
    size h (h_c = h / 2, dt = 2.5e-5 h: the paper's ratios)."""
    d = yaml.safe_load((ROOT / "inputs" / "fem_ramp_2d.yaml").read_text())
    for b in d["bodies"]:
        b["element_size"] = h
    d["contact"]["augury"].update(cell_size=0.5 * h, transfer=transfer, method=method)
    d["contact"]["default"] = {"law": "coulomb", "friction": mu} if mu > 0 else {"law": "frictionless"}
    if E is not None:
        d["materials"]["solid"]["E"] = E
    d["time"] = {"end": 0.1, "dt": 2.5e-5 * h}
    d["output"] = {"history_interval": 0.005}
    sim = Simulation(build_scene(deck_from(d)), out_dir=None, threads=1)
    st = sim.state
    block = st.fem.node_body == 1
    m = st.fem.mass[block]
    centre = lambda: float(np.sum(m * st.fem.x[block, 0]) / m.sum())  # noqa: E731
    x0, out = centre(), {}
    for T in (0.05, 0.1):
        while st.t < T * (1 - 1e-9):
            sim.step()
        out[T] = centre() - x0
    return out


# ------------------------------------------------------------------------------ the paper's method
@pytest.mark.parametrize("apic", [False, True])
@pytest.mark.parametrize("ratio", [1.0, 3.0])
def test_four_node_kernel_lets_grid_aligned_rows_slide_without_loss(apic, ratio):
    """Rows spaced 2 h_c: with the 4-node kernel each row deposits uniformly on the grid (its
    weights at spacing 2 h_c sum to a constant on every node), so H leaves a uniform slide alone:
    N = 1 loses nothing at any offset. The quadratic B-spline loses up to 0.19 of it."""
    h, k = 0.5, 41
    s = (np.arange(k) - k // 2) * h
    mid = slice(k // 4, k - k // 4)
    losses = []
    for kernel in ("four_node", "bspline2"):
        for offset in (0.0, 0.1, 0.2, 0.3, 0.4, 0.5):
            x = np.r_[np.c_[s + offset * h, np.zeros(k)], np.c_[s, np.zeros(k)]]
            v = np.zeros((2 * k, 2))
            v[:k, 0] = 1.0
            normal = np.zeros((2 * k, 2))
            normal[:k, 1], normal[k:, 1] = -1.0, 1.0
            acc, _ = augury_correction(x, np.r_[np.full(k, ratio), np.ones(k)], v, np.zeros((2 * k, 2, 2)), normal,
                                       np.zeros(2 * k), AuguryGrid(0.5 * h, KERNELS[kernel], apic), 1, 1.0)
            relative = (1.0 + acc[:k][mid, 0]) - acc[k:][mid, 0]
            losses.append((kernel, offset, float(np.abs(1.0 - relative).max())))
    assert max(v for kernel, _, v in losses if kernel == "four_node") <= 1e-14
    assert max(v for kernel, _, v in losses if kernel == "bspline2") > 0.1  # the test can tell


@pytest.mark.parametrize("h", [0.5, 0.33, 0.25])
def test_paper_ramp_apic_slides_further_than_pic_and_less_with_friction(h):
    """Fig. 11's claims, 4-node kernel, N = 1, tau = dt, at t = 0.1 s. Measured x / analytic
    (mu = 0, 0.2) APIC 0.12-0.17, PIC 0.02-0.05 (docs/fem-contact.md)."""
    for mu in (0.0, 0.2, 0.7):
        assert ramp(h, mu, "augury", "apic")[0.1] > ramp(h, mu, "augury", "pic")[0.1]
    for transfer in ("apic", "pic"):
        x = [ramp(h, mu, "augury", transfer)[0.1] for mu in (0.0, 0.2, 0.7)]
        assert x[0] > x[1] > x[2]


# ------------------------------------------------------------------------------ field contact
@pytest.mark.parametrize("h,tolerance", [(0.5, 0.10), (0.25, 0.05)])
@pytest.mark.parametrize("mu", [0.0, 0.2])
def test_field_contact_ramp_slides_as_coulomb(h, tolerance, mu):
    slide = ramp(h, mu, "field")
    for t in (0.05, 0.1):
        assert slide[t] == pytest.approx(ramp_analytic(mu, t), rel=tolerance)


def test_field_contact_ramp_holds_above_the_friction_angle():
    """mu = 0.7 > tan 30: the rigid block would not move. At 100 x the deck's stiffness (the
    ringing of the suddenly loaded block 10 x slower in velocity) it moves less than 1% of the
    frictionless slide; at the deck's stiffness it slips while the ringing lightens the contact
    (measured 0.07 of it)."""
    frictionless = ramp_analytic(0.0, 0.1)
    assert abs(ramp(0.5, 0.7, "field", E=1e10)[0.1]) < 0.01 * frictionless
    assert abs(ramp(0.5, 0.7, "field")[0.1]) < 0.1 * frictionless


@pytest.mark.parametrize("cell,top", [(0.05, 0.01), (0.025, 0.00375)])
def test_field_contact_mpm_block_slides_on_fem_slab_as_coulomb(cell, top):
    """inputs/implicit_mpm_slope_2d.yaml run explicit: the MPM block (neo-Hookean particles) on
    the FEM slab through field contact (augury grid 0.05), mu = 0.3, gravity tilted 30 degrees;
    the block's acceleration over 0.15-0.3 s against g (sin 30 - mu cos 30) = 2.35629."""
    base = yaml.safe_load((ROOT / "inputs" / "implicit_mpm_slope_2d.yaml").read_text())
    d = with_overrides(base, {"integrator": "explicit", "implicit": None, "time.dt": None,
                              "contact.augury": {"cell_size": 0.05, "method": "field"},
                              "materials.block": {"type": "neo_hookean", "K": 8.3333e6, "G": 3.8462e6,
                                                  "density": 1000.0},
                              "bodies.1.material": "block", "grid.cell_size": cell, "bodies.0.max": [2.0, top]})
    sim = Simulation(build_scene(deck_from(d)), out_dir=None, threads=1)
    st = sim.state
    P = st.particles
    t, v = [], []
    while st.t < 0.3 * (1 - 1e-9):
        sim.step()
        if st.t >= 0.15 * (1 - 1e-9):
            t.append(st.t)
            v.append(np.sum(P.mass * P.v[:, 0]) / P.mass.sum())
    a = np.polyfit(t, v, 1)[0]
    assert a == pytest.approx(2.35629, rel=0.05)


def test_field_contact_blocks_keep_momentum_stay_apart_and_rebound():
    """inputs/fem_blocks_2d.yaml (h = 0.25, h_c = 2h), frictionless, to 0.1 s."""
    d = yaml.safe_load((ROOT / "inputs" / "fem_blocks_2d.yaml").read_text())
    for b in d["bodies"]:
        b["element_size"] = 0.25
    d["contact"]["augury"].update(cell_size=0.5, method="field")
    d["time"] = {"end": 0.1, "dt": 2.5e-5}
    d["output"] = {"history_interval": 0.002}
    sim = Simulation(build_scene(deck_from(d)), out_dir=None, threads=1)
    st, f = sim.state, sim.state.fem
    loops = [boundary_loop(f.facets, f.node_body, b) for b in (0, 1)]
    inside = 0
    sim.recorder.record(st)
    while st.t < 0.1 * (1 - 1e-9):
        sim.step()
        if st.step % 40 == 0:
            sim.recorder.record(st)
            for a, b in ((0, 1), (1, 0)):
                inside += int(Polygon(f.x[loops[b]]).contains_points(f.x[loops[a]], radius=-1e-9).sum())
    rows = np.array(sim.recorder.rows, dtype=float)
    col = {n: rows[:, i] for i, n in enumerate(sim.recorder.names)}
    p0 = np.hypot(col["px"][0], col["py"][0])
    assert max(np.abs(col["px"] - col["px"][0]).max(), np.abs(col["py"] - col["py"][0]).max()) < 1e-12 * p0
    assert inside == 0
    v_rel = col["py_upper"] - col["py_lower"]
    assert v_rel[0] < 0.0 < v_rel[-1]  # the upper block came down on the lower one, and went back up


def interface_slip(st) -> float:
    """The block's slip down the ramp at the interface: the mean displacement along the ramp of
    the block's bottom nodes less the ramp's top-face displacement under them (interpolated
    between its nodes in the reference frame). Unlike the centre's travel it leaves out the two
    bodies' elastic deformation (a bonded block's centre moves 2.5% of the frictionless slide
    by 0.1 s under the deck's sudden gravity)."""
    t, n = np.array([np.cos(TH), -np.sin(TH)]), np.array([np.sin(TH), np.cos(TH)])
    f = st.fem
    u = f.x - f.X
    block, ramp_ = np.where(f.node_body == 1)[0], np.where(f.node_body == 0)[0]
    hb, hr = f.X[block] @ n, f.X[ramp_] @ n
    bottom, top = block[hb < hb.min() + 1e-9], ramp_[hr > hr.max() - 1e-9]
    s = f.X[top] @ t
    order = np.argsort(s)
    under = np.interp(f.X[bottom] @ t, s[order], (u[top] @ t)[order])
    return float(np.mean(u[bottom] @ t - under))


@functools.lru_cache(maxsize=None)
def slow_ramp_slip(method: str, gravity_ramp: float, end: float) -> float:
    d = yaml.safe_load((ROOT / "inputs" / "fem_ramp_2d.yaml").read_text())
    for b in d["bodies"]:
        b["element_size"] = 0.5
    d["contact"]["augury"].update(cell_size=0.25, transfer="apic", method=method)
    d["contact"]["default"] = {"law": "coulomb", "friction": 0.7}
    if gravity_ramp > 0.0:
        d["gravity_ramp"] = gravity_ramp
    d["time"] = {"end": end, "dt": 2.5e-5 * 0.5}
    d["output"] = {"history_interval": end / 10}
    sim = Simulation(build_scene(deck_from(d)), out_dir=None, threads=1)
    sim.run()
    return interface_slip(sim.state)


@functools.lru_cache(maxsize=None)
def implicit_ramp_slip(gravity_ramp: float, end: float, mu: float) -> float:
    """The ramp deck at h = 0.5 through the implicit step's barrier (backward Euler, dt = 1 ms,
    dhat = 0.1 mm, the block 2 dhat above the ramp, adaptive kappa): the interface slip."""
    d = yaml.safe_load((ROOT / "inputs" / "fem_ramp_2d.yaml").read_text())
    dhat = 1e-4
    for b in d["bodies"]:
        b["element_size"] = 0.5
    d["bodies"][1].update(min=[0.5, 2 * dhat], max=[1.5, 1.0 + 2 * dhat])
    d["contact"] = {"default": {"law": "coulomb", "friction": mu}}
    d["integrator"] = "implicit"
    d["implicit"] = {"scheme": "backward_euler", "dhat": dhat}
    if gravity_ramp > 0.0:
        d["gravity_ramp"] = gravity_ramp
    d["time"] = {"end": end, "dt": 1e-3}
    d["output"] = {"history_interval": end}
    sim = Simulation(build_scene(deck_from(d)), out_dir=None, threads=1)
    sim.run()
    return interface_slip(sim.state)


@pytest.mark.implicit
def test_the_implicit_barrier_ramp_rings_under_sudden_gravity_and_holds_when_loaded_slowly():
    """The same ramp, mu = 0.7, through the implicit barrier. Gravity all at once: the block
    slips 14.4% of the frictionless slide by 0.1 s (16.6% at the deck's h = 0.25). It rings: at
    h = 0.25 the normal contact force swings between 0.70 and 1.70 of its static value over the
    first 0.1 s (a period of about 70 ms), friction acts at mu times it while slipping, and the
    block slips while it dips; the centre's travel is the same whatever kappa (1e7 to 1e11),
    friction lags (1, 5) or eps_v (1e-5, 1e-3). Gravity ramped over 0.2 s and held to 0.4 s:
    1.22% (1.81% at h = 0.25), where a block held by mu = 100 reads 0.49% (0.70%), the measure's
    own floor (the two bodies' elastic strains along the interface)."""
    frictionless = ramp_analytic(0.0, 0.1)
    slow, stuck = implicit_ramp_slip(0.2, 0.4, 0.7), implicit_ramp_slip(0.2, 0.4, 100.0)
    assert abs(slow) < 0.02 * frictionless and abs(stuck) < 0.01 * frictionless
    assert implicit_ramp_slip(0.0, 0.1, 0.7) > 0.1 * frictionless


@pytest.mark.parametrize("method", ["field", "augury"])
def test_ramp_loaded_slowly_holds_above_the_friction_angle(method):
    """mu = 0.7, h = 0.5, the deck's stiffness. Gravity all at once (the deck): the ringing block
    slips at the interface by 0.1 s 4.7% (field) and 2.5% (augury) of the frictionless slide.
    Gravity ramped over 0.2 s (three periods of the block's slowest, shearing mode, 4 H / c_s =
    0.065 s) and held to 0.4 s: 0.05% (field) and 0.56% (augury), below the 1% the issue asks;
    at h = 0.25, 0.59% and 0.84% (docs/fem-contact.md). A ramp over 0.05 s (less than a period)
    leaves 1.7% at h = 0.25: the loading must be slow against the block's own period."""
    frictionless = ramp_analytic(0.0, 0.1)
    assert abs(slow_ramp_slip(method, 0.2, 0.4)) < 0.01 * frictionless
    assert slow_ramp_slip(method, 0.0, 0.1) > 0.015 * frictionless
