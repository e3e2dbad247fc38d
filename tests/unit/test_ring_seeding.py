"""`seeding: rings` on circles and annuli (mpmsim/scene/rings.py): particles in rings that follow
the surface, each with its ring sector's exact area; the default lattice seeding is unchanged;
half and quarter bodies clipped on lines through the centre keep whole sectors; what the rings
cannot take part in (overlaps, other clips, 3D, unequal cell sizes) is refused with one line
naming the key."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mpmsim.errors import DeckError
from mpmsim.scene import build_scene
from tests.conftest import deck_from

pytestmark = pytest.mark.hertz

H = 0.5  # cell size; 2 particles per direction: spacing 0.25
R = 5.0


def deck(*bodies, cell=H, thickness=None) -> dict:
    d = {"title": "rings", "units": "mm-g-ms", "analysis": "plane_strain",
         "grid": {"cell_size": cell, "domain": {"min": [-10, -10], "max": [10, 12]}},
         "materials": {"a": {"type": "linear_elastic", "E": 1000.0, "nu": 0.3, "density": 0.001}},
         "bodies": list(bodies), "time": {"end": 0.1}}
    if thickness is not None:
        d["thickness"] = thickness
    return d


def circle(seeding="rings", **kw) -> dict:
    return {"name": "disk", "shape": "circle", "center": [0.0, 1.0], "radius": R, "material": "a",
            "seeding": seeding, **kw}


def test_rings_fill_the_circle_exactly_symmetric_at_the_particle_spacing():
    scene = build_scene(deck_from(deck(circle())))
    P = scene.deformable
    c = np.array([0.0, 1.0])
    r = np.linalg.norm(P.x - c, axis=1)
    assert P.vol.sum() == pytest.approx(math.pi * R**2 * scene.thickness, rel=1e-13)  # the circle's area
    assert r.max() < R and r.max() == pytest.approx(R - 0.125, rel=1e-12)  # the outer ring half a spacing in
    # mirror-symmetric about the vertical through the centre: each particle's mirror image is a particle
    mirror = np.stack([2 * c[0] - P.x[:, 0], P.x[:, 1]], axis=1)
    d = np.linalg.norm(mirror[:, None, :] - P.x[None, :, :], axis=2).min(axis=1)
    assert d.max() < 1e-12
    # one particle at the bottom of every ring: the lowest point of the body is on the vertical axis
    low = np.argmin(P.x[:, 1])
    assert abs(P.x[low, 0]) < 1e-12 and P.x[low, 1] == pytest.approx(1.0 - R + 0.125)
    # spacing: rings 0.25 apart; each particle's nearest neighbour between 0.2 and 0.3 of the spacing's 0.25
    nn = np.sort(np.linalg.norm(P.x[:, None, :] - P.x[None, :, :], axis=2), axis=1)[:, 1]
    assert nn.min() > 0.8 * 0.25 and nn.max() < 1.2 * 0.25
    # each particle's area is the lattice spacing's square to within the rounding of its ring's count
    assert np.all(np.abs(P.vol / (0.25**2 * scene.thickness) - 1.0) < 0.06)
    assert len(np.unique(np.round(r, 12))) == 20  # R / spacing rings
    assert np.allclose(scene.semi_size, 0.125)  # domains: squares of the lattice spacing


def test_annulus_rings_between_the_radii():
    body = {"name": "ring", "shape": "annulus", "center": [1.0, 0.0], "inner_radius": 2.0, "outer_radius": 4.5,
            "material": "a", "seeding": "rings"}
    scene = build_scene(deck_from(deck(body, thickness=2.0)))
    P = scene.deformable
    r = np.linalg.norm(P.x - [1.0, 0.0], axis=1)
    assert P.vol.sum() == pytest.approx(math.pi * (4.5**2 - 2.0**2) * 2.0, rel=1e-13)
    assert r.min() == pytest.approx(2.125) and r.max() == pytest.approx(4.375)


def test_lattice_seeding_is_the_default_and_unchanged():
    a = build_scene(deck_from(deck(circle(seeding="lattice")))).deformable
    d = circle()
    del d["seeding"]
    b = build_scene(deck_from(deck(d))).deformable
    assert np.array_equal(a.x, b.x) and np.array_equal(a.vol, b.vol)
    assert len(np.unique(a.vol)) == 1


def test_rings_beside_lattice_bodies_keep_both():
    block = {"name": "block", "shape": "rectangle", "min": [-8, -8], "max": [8, -4], "material": "a"}
    scene = build_scene(deck_from(deck(circle(), block)))
    P = scene.deformable
    assert P.vol[P.body == 1].sum() == pytest.approx(16 * 4 * scene.thickness)
    assert P.vol[P.body == 0].sum() == pytest.approx(math.pi * R**2 * scene.thickness)
    assert scene.notices == ()


@pytest.mark.parametrize("extra, bodies, message", [
    ({}, [{"name": "block", "shape": "rectangle", "min": [-8, -8], "max": [8, -3], "material": "a"}],
     r"bodies\.0\.seeding.*seeded in rings and overlaps body 'block'"),
    ({"clip": {"min": [-10, -10], "max": [10, 0]}}, [], r"bodies\.0\.seeding.*clipped only by lines through its "
     r"centre or lines that miss it \(clip y range \[-10, 0\], centre 1, radius 5\)"),
    ({"clip": {"min": [0, -10], "max": [10, 10]}}, [], r"bodies\.0\.seeding.*rings put particles on the axes "
     r"through the centre.*rings_half_step"),
])
def test_what_rings_cannot_do_is_refused_in_one_line(extra, bodies, message):
    with pytest.raises(DeckError, match=message) as err:
        build_scene(deck_from(deck(circle(**extra), *bodies)))
    assert "\n" not in str(err.value).strip()


def test_rings_need_square_cells():
    with pytest.raises(DeckError, match=r"bodies\.0\.seeding.*same along x and y"):
        build_scene(deck_from(deck(circle(), cell=[0.5, 0.25])))


def test_half_step_rings_are_the_rings_turned_by_half_their_spacing():
    """`seeding: rings_half_step`: each ring's particles turned by half their angular step, so none
    sits on the vertical below the centre (the two lowest half a spacing either side of it);
    the same radii, areas and symmetry as `rings`."""
    plain = build_scene(deck_from(deck(circle()))).deformable
    half = build_scene(deck_from(deck(circle("rings_half_step")))).deformable
    c = np.array([0.0, 1.0])
    assert half.x.shape == plain.x.shape
    assert half.vol.sum() == pytest.approx(math.pi * R**2, rel=1e-13)
    r_plain, r_half = np.linalg.norm(plain.x - c, axis=1), np.linalg.norm(half.x - c, axis=1)
    assert np.allclose(np.sort(r_half), np.sort(r_plain), rtol=0, atol=1e-12)
    for radius in np.unique(np.round(r_plain, 9)):  # ring by ring: the angles shifted by half the step
        a = np.sort(np.arctan2(*(plain.x[np.isclose(r_plain, radius)] - c).T[::-1]))
        b = np.sort(np.arctan2(*(half.x[np.isclose(r_half, radius)] - c).T[::-1]))
        turned = np.exp(1j * (a + math.pi / a.size))  # each angle plus half the step 2 pi / m
        assert b.size == a.size and np.abs(np.exp(1j * b)[:, None] - turned[None, :]).min(axis=1).max() < 1e-12
    below = half.x[:, 1] < c[1]
    assert np.abs(half.x[below, 0] - c[0]).min() > 0.05  # nothing on the vertical axis below the centre
    low = np.argsort(half.x[:, 1])[:2]
    assert half.x[low[0], 1] == pytest.approx(half.x[low[1], 1], abs=1e-12)
    assert half.x[low[0], 0] == pytest.approx(-half.x[low[1], 0], abs=1e-12)
    mirror = np.stack([2 * c[0] - half.x[:, 0], half.x[:, 1]], axis=1)
    assert np.linalg.norm(mirror[:, None, :] - half.x[None, :, :], axis=2).min(axis=1).max() < 1e-12


@pytest.mark.parametrize("clip, share", [
    ({"min": [0.0, -10.0], "max": [10.0, 10.0]}, 0.5),  # the right half: a symmetry line x = centre
    ({"min": [-10.0, -10.0], "max": [10.0, 1.0]}, 0.5),  # the lower half
    ({"min": [0.0, -10.0], "max": [10.0, 1.0]}, 0.25),  # the lower right quarter
    ({"min": [-10.0, -10.0], "max": [10.0, 10.0]}, 1.0),  # lines that miss it: the whole disk
])
def test_half_step_rings_clipped_through_the_centre_keep_whole_sectors(clip, share):
    """rings_half_step clipped on lines through the centre (a symmetry model): each ring's count
    a multiple of 4, so the sectors' edges include both axes and no particle lies on them; the
    clipped body's area is exactly its share of the circle's, no particle is outside the clip
    or on its lines, and the clipped set is the full body's (seeded the same way) inside the
    clip. The full body's mirror images about both axes are particles."""
    full = build_scene(deck_from(deck(circle("rings_half_step", clip={"min": [-10, -10], "max": [10, 10]})))).deformable
    part = build_scene(deck_from(deck(circle("rings_half_step", clip=clip)))).deformable
    c = np.array([0.0, 1.0])
    assert part.vol.sum() == pytest.approx(share * math.pi * R**2, rel=1e-13)
    lo, hi = np.array(clip["min"]), np.array(clip["max"])
    assert np.all((part.x > lo) & (part.x < hi))
    assert np.abs(part.x - c).min() > 0.01  # none on the lines through the centre
    inside = np.all((full.x >= lo) & (full.x <= hi), axis=1)
    assert np.array_equal(np.sort(part.x, axis=0), np.sort(full.x[inside], axis=0))
    for axis in (0, 1):
        mirror = full.x.copy()
        mirror[:, axis] = 2 * c[axis] - mirror[:, axis]
        assert np.linalg.norm(mirror[:, None, :] - full.x[None, :, :], axis=2).min(axis=1).max() < 1e-12
    r = np.linalg.norm(full.x - c, axis=1)
    for radius in np.unique(np.round(r, 9)):
        assert np.isclose(r, radius).sum() % 4 == 0


def contact_deck(*bodies) -> dict:
    """deck(...) with a rigid contact material `wall` for a flat under the disk."""
    d = deck(*bodies)
    d["materials"]["wall"] = {"type": "rigid", "mode": "contact", "velocity": [0.0, 0.0]}
    return d


FLAT = {"name": "flat", "shape": "rectangle", "min": [-8, -5], "max": [8, -4], "material": "wall"}


@pytest.mark.contact_default
def test_round_bodies_in_grid_contact_follow_their_surface_by_default():
    """`seeding: auto` (the default): a circle in contact is seeded as rings_half_step writes it
    (the same particles), a half cylinder clipped at its symmetry line too; alone (no contact),
    laid over another body, or clipped off its centre, on the lattice; each says why."""
    def seeded(*bodies, make=contact_deck):
        scene = build_scene(deck_from(make(*bodies)))
        return scene, scene.seedings[0]

    auto = {k: v for k, v in circle().items() if k != "seeding"}  # written plainly: no seeding key
    scene, how = seeded(auto, FLAT)
    assert (how.how, how.auto, how.why) == ("rings_half_step", True, "auto: grid contact acts on it")
    explicit = build_scene(deck_from(contact_deck(circle("rings_half_step"), FLAT)))
    assert np.array_equal(scene.deformable.x, explicit.deformable.x)
    assert np.array_equal(scene.deformable.vol, explicit.deformable.vol)
    half = dict(auto, clip={"min": [0.0, -10.0], "max": [10.0, 12.0]})  # clipped on x = centre
    scene, how = seeded(half, FLAT)
    assert how.how == "rings_half_step"
    assert scene.deformable.vol.sum() == pytest.approx(math.pi * R**2 / 2 * scene.thickness, rel=1e-13)
    assert seeded(auto, make=deck)[1].why == "auto: no grid contact in the scene"
    off = dict(auto, clip={"min": [1.0, -10.0], "max": [10.0, 12.0]})  # a clip line off the centre
    assert seeded(off, FLAT)[1].how == "lattice"
    block = {"name": "block", "shape": "rectangle", "min": [-8, -8], "max": [8, -3], "material": "b"}
    d = contact_deck(auto, block)
    d["materials"]["b"] = d["materials"]["a"]
    d["bodies"][0]["center"] = [0.0, 1.5]  # the disk's bottom inside the block: it overlaps
    how = build_scene(deck_from(d)).seedings[0]
    assert (how.how, how.why) == ("lattice", "auto: it overlaps body 'block'")


def test_check_says_how_round_bodies_are_seeded(tmp_path):
    """`mpmsim check` names the seeding of each round body and why; a lattice-seeded one in a
    scene with contact gets the staircase's cost (one line each); nothing for a lone circle."""
    import yaml
    from typer.testing import CliRunner

    from mpmsim.cli import app

    for seeding, want in (
            ("lattice", "body 'disk' (circle): seeded on the lattice, its surface a staircase"),
            ("auto", "body 'disk' (circle): seeded in rings_half_step that follow its surface (auto: grid contact"),
            ("rings_half_step", "body 'disk' (circle): seeded in rings_half_step that follow its surface")):
        path = tmp_path / f"{seeding}.yaml"
        path.write_text(yaml.safe_dump(contact_deck(circle(seeding), FLAT)))
        result = CliRunner().invoke(app, ["check", str(path), "--no-probe"])
        assert result.exit_code == 0, result.output
        lines = [line for line in result.output.splitlines() if "(circle)" in line]
        assert len(lines) == 1 and lines[0].startswith(want), result.output
    alone = tmp_path / "alone.yaml"  # no contact: nothing to say of a lattice circle
    alone.write_text(yaml.safe_dump(deck(circle("lattice"))))
    result = CliRunner().invoke(app, ["check", str(alone), "--no-probe"])
    assert result.exit_code == 0 and "(circle)" not in result.output, result.output
