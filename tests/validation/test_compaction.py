"""High-rate compaction of a block filling a box (the ellipse box of inputs/ellipse_box.yaml
filled with one material): compressed 75% by a rigid piston at 100 m/s, the volume-averaged
sigma_yy follows the confined plane-strain neo-Hookean curve and the particle volumes J V0 keep
adding up to the box area, for CPDI and uGIMP with every particle update at CFL 0.5, when the
particles move with the updated grid velocity (`update.position: updated`); the midpoint
position updates let FLIP blow up (docs/stability.md, "High-rate compaction"). The ellipse box
itself: the particle volumes never exceed the box (docs/contact.md, "Ellipses in a box")."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from mpmsim.deck.overrides import with_overrides
from mpmsim.errors import InstabilityError
from mpmsim.overlap import overlap_fraction
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation
from mpmsim.stability import compaction_warnings

from ..conftest import ROOT, deck_from
from .helpers import example, run_example

CP08 = {"contact.normal": "average_gradient", "contact.separation": "cutoff", "contact.cutoff": 0.8}

K, G, SPEED, HEIGHT, WIDTH = 78090.0, 27600.0, 100.0, 2.0, 1.0


def confined_syy(lam):
    """sigma_yy of the neo-Hookean block at stretch lam in y, x and z held."""
    return G * lam ** (-5 / 3) * (lam**2 - (lam**2 + 2) / 3) + 0.5 * K * (lam - 1 / lam)


def filled_box(shape: str, scheme: str, position: str = "updated", contact: dict | None = None) -> dict:
    """1/20 mm cells, 2 x 2 particles per cell; roller walls and floor; the piston a rigid
    velocity condition on y (frictionless), or with `contact` a rigid contact material and
    these contact settings (frictionless)."""
    update = {"scheme": scheme, "stress": "usavg", "position": position}
    if scheme == "xpic":
        update["order"] = 5
    deck = {"title": "block compressed 75% in a box", "units": "mm-g-ms", "analysis": "plane_strain",
            "grid": {"cell_size": 0.05, "boundaries": {"xmin": "roller", "xmax": "roller", "ymin": "roller"}},
            "shape_function": shape, "particles_per_direction": 2,
            "materials": {"block": {"type": "neo_hookean", "K": K, "G": G, "density": 0.00278},
                          "piston": {"type": "rigid", "velocity": [0.0, -SPEED], "constrain": ["y"]}},
            "bodies": [{"shape": "rectangle", "min": [0.0, 0.0], "max": [WIDTH, HEIGHT], "material": "block"},
                       {"shape": "rectangle", "min": [0.0, HEIGHT], "max": [WIDTH, HEIGHT + 0.1], "material": "piston"}],
            "time": {"end": 0.75 * HEIGHT / SPEED, "cfl": 0.5}, "update": update}
    if contact is not None:
        deck["materials"]["piston"] = {"type": "rigid", "mode": "contact", "velocity": [0.0, -SPEED]}
        deck["contact"] = {"default": {"law": "frictionless"}, **contact}
    return deck


def compress(deck: dict, directory=None):
    """Step the deck (files it names relative to `directory`); at every 1% of compression (lam,
    volume-averaged sigma_yy, sum J V0 over the box area)."""
    return compress_with_ledger(deck, directory)[0]


def compress_with_ledger(deck: dict, directory=None):
    """compress() with output.energy_ledger: (its rows, the history recorded at the same times)."""
    return compress_run(deck, directory)[:2]


def compress_run(deck: dict, directory=None):
    """compress_with_ledger(), and the finished simulation."""
    deck = {**deck, "output": {**deck.get("output", {}), "energy_ledger": True}}
    sim = Simulation(build_scene(deck_from(deck, directory)))
    st, P = sim.state, sim.state.particles
    rows, nxt = [], 0.01
    while st.t < sim.end * (1 - 1e-9):
        sim.step()
        lam = 1.0 - SPEED * st.t / HEIGHT
        if 1.0 - lam >= nxt - 1e-9:
            rows.append((lam, np.sum(P.stress[:, 1] * P.vol) / P.vol.sum(), P.vol.sum() / (WIDTH * HEIGHT * lam)))
            sim.recorder.record(st)  # a history row at every 1%
            nxt += 0.01
    return np.array(rows).T, sim.history, sim


def assert_follows_confined_compression(lam, syy, ratio):
    """To 75% compression: mean sigma_yy within 2% of the curve at every 5%, sum J V0 within
    0.5% of the box area at every 1%."""
    assert 1 - lam[-1] == pytest.approx(0.75, abs=1e-3)
    every5 = np.isclose((1 - lam) * 20, np.round((1 - lam) * 20), atol=0.02)
    assert every5.sum() == 15
    rel = np.abs(syy[every5] / confined_syy(lam[every5]) - 1)
    assert rel.max() < 0.02, f"sigma_yy off the curve by {rel.max():.4f}"
    assert np.abs(ratio - 1).max() < 0.005, f"sum J V0 off the box area by {np.abs(ratio - 1).max():.4f}"


def assert_energy_balances(history, limit=0.02):
    """The energy ledger closes: wherever the work put in exceeds 1% of its final value, the
    residual external_work + E0 - (kinetic + strain energy + the losses) is within `limit`
    of the work."""
    W = history["external_work"].to_numpy()
    later = W > 0.01 * W[-1]
    assert later.sum() > 10
    rel = np.abs(history["energy_residual"].to_numpy()[later]) / W[later]
    assert rel.max() < limit, f"energy ledger residual {rel.max():.4f} of the work"
    return history.iloc[-1] / W[-1]


GIMP_PIC = pytest.mark.xfail(strict=True, reason="uGIMP with PIC: sum J V0 reaches 1.0088 x the box area "
                             "(sigma_yy within 1.2%); docs/stability.md")


@pytest.mark.compaction
@pytest.mark.parametrize("scheme", ["pic", "flip", "xpic", "apic"])
@pytest.mark.parametrize("shape", ["cpdi", "gimp"])
def test_filled_box_follows_confined_compression(shape, scheme, request):
    if (shape, scheme) == ("gimp", "pic"):
        request.applymarker(GIMP_PIC)
    assert confined_syy(0.25) == pytest.approx(-320.3e3, rel=1e-4)
    rows, history = compress_with_ledger(filled_box(shape, scheme))
    assert_follows_confined_compression(*rows)  # measured 0.26-0.58%, 0.11-0.28%
    assert_energy_balances(history)  # largest residual measured 0.03% (CPDI, PIC) to 1.4% (uGIMP, APIC)


@pytest.mark.compaction
@pytest.mark.contact_default
@pytest.mark.parametrize("scheme, contact", [
    # the computed normal at the piston's corners: on the roller walls it has no component across
    # them (mirror planes); with the walls' tilted normals a particle was pushed through at 60%
    ("flip", {}),
    # pass 1 with XPIC's contact term: 1.8% and 0.98% (docs/stability.md). Shape-function cloud
    # weights: with the paper's uniform ones (test below) sum J V0 ends 0.60% off
    ("xpic", {"passes": 1, "cloud_weights": "shape_function"}),
])
def test_filled_box_against_a_rigid_contact_piston(scheme, contact):
    """Measured: FLIP 0.33% and 0.12%, XPIC(5) 0.16% and 0.04%; energy residual 0.17%, 0.15%."""
    rows, history = compress_with_ledger(filled_box("cpdi", scheme, contact=contact))
    assert_follows_confined_compression(*rows)
    assert_energy_balances(history)


@pytest.mark.compaction
@pytest.mark.contact_default
def test_filled_box_with_uniform_cloud_weights_keeps_the_xpic_piston_out():
    """XPIC(5), one contact pass, the default (uniform) cloud weights: no block particle is pushed
    through the rigid piston to 75% compression (with normals tilted across the roller walls one
    was at 64%, 58% with `pass_3: keep`). sigma_yy within 2% of the curve (measured 0.87%); sum J V0
    ends 0.60% off the box area, outside the 0.5% the other boxes hold (shape-function weights:
    0.04%), so it is held at 1%."""
    rows, history = compress_with_ledger(filled_box("cpdi", "xpic", contact={"passes": 1}))
    lam, syy, ratio = rows
    assert 1 - lam[-1] == pytest.approx(0.75, abs=1e-3)
    every5 = np.isclose((1 - lam) * 20, np.round((1 - lam) * 20), atol=0.02)
    assert np.abs(syy[every5] / confined_syy(lam[every5]) - 1).max() < 0.02
    assert np.abs(ratio - 1).max() < 0.01
    assert_energy_balances(history)


@pytest.mark.compaction
def test_midpoint_positions_let_flip_blow_up():
    """The second-order FLIP position update on the same box: the kinetic energy grows until
    the energy check stops the run, between 20% and 40% compression (measured ~28%)."""
    with pytest.raises(InstabilityError) as stop:
        compress(filled_box("cpdi", "flip", position="midpoint"))
    compression = SPEED * stop.value.time / HEIGHT
    assert 0.2 < compression < 0.4, compression


@pytest.mark.compaction
def test_check_warns_on_midpoint_positions_under_strong_compression():
    def warning(shape, scheme, position):
        scene = build_scene(deck_from(filled_box(shape, scheme, position)))
        return " ".join(compaction_warnings(scene, scene.deformable.x))
    assert "travels 76%" in warning("cpdi", "flip", "midpoint")  # 1.5 mm of the centres' 1.975 mm
    assert "position midpoint" in warning("cpdi", "xpic", "midpoint")
    assert warning("cpdi", "flip", "updated") == ""
    assert warning("cpdi", "pic", "midpoint") == ""  # PIC's midpoint form measured stable


ELLIPSE_H = 0.05  # 1/20 mm cells, 3.5x coarser than the paper


def ellipse_box_overrides(h: float = ELLIPSE_H) -> dict:
    """inputs/ellipse_box.yaml at cell size h, the piston two cells above the box."""
    return {"grid.cell_size": h, "bodies.1.max": [1.0, 2.0 + 2 * h]}


@cache
def ellipse_box_lr():
    """The ellipse box with its LR contact (compress_run, rows at every 1%), run once for the
    energy ledger's test and the LR-against-CP test."""
    return compress_run(with_overrides(example("ellipse_box"), ellipse_box_overrides()), ROOT / "inputs")


@pytest.mark.validation
@pytest.mark.compaction
def test_ellipse_box_volumes_stay_within_the_box_and_energy_balances(measure):
    """inputs/ellipse_box.yaml at 1/20 mm cells (LR, PIC, the piston a velocity condition): at
    every 1% of the stroke sum J V0 <= the box area (+0.5%), and at the end the voids have
    closed to within 5% of the box (measured 0.9983; with XPIC(5) 1.12 when the energy check
    stops it at 71% of the stroke, with the piston a rigid contact material 1.09: docs/contact.md).
    Energy: piston work = kinetic + strain energy + transfer, contact, condition and force-gap
    losses within 2% at every history time (measured: residual at most 0.20% of the work;
    without the losses 4.4% is missing at the end, more than twice the 2%: with `pass_3: keep`
    7.9%). Contact removes 22% of the work; the
    internal forces drive grid velocity that the re-extrapolated stress update does not see
    (force gap -158%), which the transfers take out again (+144%): docs/validation.md,
    "Energy ledger"."""
    (_, _, ratios), history, _ = ellipse_box_lr()
    measure("ellipse box: largest sum J V0 / box, final", f"{max(ratios):.4f}, {ratios[-1]:.4f}", "< 1.005, > 0.95")
    assert len(ratios) == 75
    assert max(ratios) < 1.005, max(ratios)
    assert ratios[-1] > 0.95, ratios[-1]
    end = assert_energy_balances(history)
    unbalanced = end["external_work"] - end["kinetic_energy"] - end["strain_energy"]
    assert unbalanced > 0.04, unbalanced  # the losses are needed: without them 4.4% is missing
    assert 0.1 < end["contact_loss"] < 0.4, end["contact_loss"]
    assert end["transfer_loss"] > 1.0 and end["force_gap_loss"] < -1.0, end
    assert abs(end["condition_loss"]) < 0.02, end["condition_loss"]


@pytest.mark.validation
def test_lr_keeps_ellipses_apart_and_cp_does_not(measure):
    """Fig. 6: twenty ellipses compressed 75% at 1/20 mm cells (3.5x coarser than the paper):
    the area claimed by two materials is 2.0% with LR and 35% with CP = 0.8, whose ellipses
    pass into each other, so that their particle volumes add up to more than the box (1.34x;
    LR 0.998x). The final stresses (137 and 85 GPa here) are compared at full size in
    docs/contact.md. (The LR run is the energy ledger's above.)"""
    lr = ellipse_box_lr()[2]
    cp, _ = run_example("ellipse_box", **ellipse_box_overrides(), **CP08)
    overlap = {}
    for name, sim in (("lr", lr), ("cp", cp)):
        assert sim.recorder.column("u_piston_y")[-1] == pytest.approx(-1.5, rel=1e-6)  # 75% of 2 mm
        P = sim.state.particles
        overlap[name] = overlap_fraction(P.x, P.F, P.mat, sim.scene.semi_size, ELLIPSE_H / 8)
    measure("Fig. 6: area claimed by two materials, LR and CP = 0.8", f"{overlap['lr']:.3f}, {overlap['cp']:.3f}",
            "LR < 0.06, CP > 4 x LR")
    assert overlap["lr"] < 0.06
    assert overlap["cp"] > 4 * overlap["lr"]
    assert lr.state.contact.n_cn > 0
    box = 1.0 * 0.5
    assert lr.state.particles.vol.sum() / box < 1.005
    assert cp.state.particles.vol.sum() / box > 1.1


@pytest.mark.compaction
def test_check_warns_on_methods_that_lose_volume_in_compaction():
    """`mpmsim check`'s warnings: uGIMP with PIC (domains of fixed size), a scheme other than PIC
    where many materials meet, and a rigid contact piston over several deformable materials in
    contact (it takes the nodes it reaches)."""
    def warnings(deck):
        scene = build_scene(deck_from(deck, ROOT / "inputs"))
        return compaction_warnings(scene, scene.deformable.x)
    assert any("uGIMP" in w for w in warnings(filled_box("gimp", "pic")))
    assert warnings(filled_box("cpdi", "pic")) == []
    ellipses = example("ellipse_box")
    assert warnings(ellipses) == []
    xpic = {**ellipses, "update": {"scheme": "xpic", "order": 5, "stress": "usavg"}}
    assert any("xpic and 20 deformable materials in contact" in w for w in warnings(xpic))
    ellipses["materials"]["piston"] = {"type": "rigid", "mode": "contact", "velocity": [0.0, -SPEED]}
    assert any("rigid contact material 'piston' with 20 deformable materials" in w for w in warnings(ellipses))
    ellipses["contact"]["default"] = {"law": "none"}
    assert warnings(ellipses) == []
