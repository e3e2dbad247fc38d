"""`seeding: shells` on spheres (mpmsim/scene/rings.py shell_seed): particles in concentric shells
that follow the surface, each with its band sector's exact volume; a quarter sphere clipped by
the symmetry planes through the centre keeps an exact quarter; what the shells cannot take part in
(2D, unequal cell sizes, clips that cut the shells elsewhere, overlaps) is refused with one line
naming the key."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from mpmsim.errors import DeckError
from mpmsim.scene import build_scene
from mpmsim.scene.rings import shell_seed
from tests.conftest import deck_from

pytestmark = pytest.mark.hertz

H = 0.5  # cell size; 2 particles per direction: spacing 0.25
R = 2.5
C = [0.0, 3.0, 0.0]


def deck(*bodies, cell=H) -> dict:
    return {"title": "shells", "units": "mm-g-ms", "analysis": "3d",
            "grid": {"cell_size": cell, "domain": {"min": [-4, -1, -4], "max": [4, 7, 4]}},
            "materials": {"a": {"type": "linear_elastic", "E": 1000.0, "nu": 0.3, "density": 0.001}},
            "bodies": list(bodies), "time": {"end": 0.1}}


def sphere(seeding="shells", **kw) -> dict:
    return {"name": "ball", "shape": "sphere", "center": C, "radius": R, "material": "a", "seeding": seeding, **kw}


def test_shells_fill_the_sphere_exactly_in_shells_half_a_spacing_apart():
    scene = build_scene(deck_from(deck(sphere())))
    P = scene.deformable
    r = np.linalg.norm(P.x - C, axis=1)
    assert P.vol.sum() == pytest.approx(4.0 / 3.0 * math.pi * R**3, rel=1e-13)  # the sphere's volume
    radii = np.unique(np.round(r, 12))
    assert np.allclose(radii, (np.arange(10) + 0.5) * 0.25, rtol=0, atol=1e-12)  # R / spacing shells at (k + 1/2) s
    # each shell's particles carry the shell's exact volume
    for rk in radii:
        on = np.abs(r - rk) < 1e-9
        assert P.vol[on].sum() == pytest.approx(4.0 / 3.0 * math.pi * ((rk + 0.125) ** 3 - (rk - 0.125) ** 3),
                                                rel=1e-13)
    # mirror-symmetric about x = c_x and z = c_z, no particle on either plane
    for axis in (0, 2):
        mirror = P.x.copy()
        mirror[:, axis] = 2 * C[axis] - mirror[:, axis]
        assert cKDTree(P.x).query(mirror)[0].max() < 1e-12
        assert np.abs(P.x[:, axis] - C[axis]).min() > 0.01
    # the surface is round: the outer shell's particles all at R - s/2, the lowest within dr^2 / (8 r) of its bottom
    assert r.max() == pytest.approx(R - 0.125, rel=1e-12)
    assert P.x[:, 1].min() - (C[1] - (R - 0.125)) < 0.25**2 / (8 * (R - 0.125)) * 1.01
    # about one spacing apart outside the two innermost shells: nearest neighbour 0.69 to 1.07 spacings (the polar
    # caps' four particles sit ~0.7 apart), volumes 0.75 to 1.22 of the lattice's (0.52 in the innermost shell)
    outer = r > 0.5
    nn = cKDTree(P.x).query(P.x[outer], 2)[0][:, 1]
    assert nn.min() > 0.65 * 0.25 and nn.max() < 1.1 * 0.25
    assert np.all(np.abs(P.vol[outer] / 0.25**3 - 1.0) < 0.25)
    assert np.allclose(scene.semi_size, 0.125)


def test_quarter_sphere_clipped_on_the_symmetry_planes_is_an_exact_quarter():
    clip = {"min": [0.0, -1.0, 0.0], "max": [4.0, 7.0, 4.0]}
    P = build_scene(deck_from(deck(sphere(clip=clip)))).deformable
    assert P.vol.sum() == pytest.approx(math.pi * R**3 / 3.0, rel=1e-13)
    assert P.x[:, 0].min() > 0 and P.x[:, 2].min() > 0
    x, v = shell_seed(C, R, 0.25)
    assert len(P.x) * 4 == len(x)


def test_lattice_stays_the_default():
    d = sphere()
    del d["seeding"]
    P = build_scene(deck_from(deck(d))).deformable
    assert len(np.unique(P.vol)) == 1


@pytest.mark.parametrize("extra, bodies, message", [
    ({"clip": {"min": [-4, 3.0, -4], "max": [4, 7, 4]}}, [], r"bodies\.0\.seeding.*clipped only by planes through"),
    ({"clip": {"min": [0.5, -1, -4], "max": [4, 7, 4]}}, [], r"bodies\.0\.seeding.*clipped only by planes through"),
    ({}, [{"name": "block", "shape": "box", "min": [-3, -1, -3], "max": [3, 1.0, 3], "material": "a"}],
     r"bodies\.0\.seeding.*seeded in shells and overlaps body 'block'"),
])
def test_what_shells_cannot_do_is_refused_in_one_line(extra, bodies, message):
    with pytest.raises(DeckError, match=message) as err:
        build_scene(deck_from(deck(sphere(**extra), *bodies)))
    assert "\n" not in str(err.value).strip()


def test_shells_need_cubic_cells():
    with pytest.raises(DeckError, match=r"bodies\.0\.seeding.*same along x, y and z"):
        build_scene(deck_from(deck(sphere(), cell=[0.5, 0.5, 0.25])))


@pytest.mark.contact_default
def test_a_sphere_in_grid_contact_is_seeded_in_shells_by_default():
    """`seeding: auto` (no seeding key) on a sphere over a rigid contact flat: shells, the same
    particles as `seeding: shells`; a quarter sphere clipped on its symmetry planes too; alone,
    on the lattice."""
    def contact_deck(ball):
        d = deck(ball, {"name": "flat", "shape": "box", "min": [-4, -1, -4], "max": [4, 0.0, 4], "material": "wall"})
        d["materials"]["wall"] = {"type": "rigid", "mode": "contact", "velocity": [0.0, 0.0, 0.0]}
        return d

    plain = {k: v for k, v in sphere().items() if k != "seeding"}
    auto = build_scene(deck_from(contact_deck(plain)))
    assert (auto.seedings[0].how, auto.seedings[0].auto) == ("shells", True)
    shells = build_scene(deck_from(contact_deck(sphere())))
    assert np.array_equal(auto.deformable.x, shells.deformable.x)
    quarter = dict(plain, clip={"min": [0.0, -1.0, 0.0], "max": [4.0, 7.0, 4.0]})  # the planes x = 0, z = 0
    scene = build_scene(deck_from(contact_deck(quarter)))
    assert scene.seedings[0].how == "shells"
    assert scene.deformable.vol.sum() == pytest.approx(math.pi * R**3 / 3.0, rel=1e-12)
    assert build_scene(deck_from(deck(plain))).seedings[0].how == "lattice"
