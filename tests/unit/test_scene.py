"""Scene building: particles from shapes and bitmaps, overwrite order, grid sizing."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from mpmsim.scene import build_scene

from ..conftest import deck_from


def _deck(bodies, materials=None, **extra):
    d = {
        "title": "scene test", "units": "mm-g-ms",
        "grid": {"cell_size": 1.0},
        "particles_per_direction": 2,
        "materials": materials or {
            "a": {"type": "linear_elastic", "E": 100.0, "nu": 0.3, "density": 0.001},
            "b": {"type": "linear_elastic", "E": 100.0, "nu": 0.3, "density": 0.002},
            "c": {"type": "neo_hookean", "K": 100.0, "G": 10.0, "density": 0.001},
        },
        "bodies": bodies, "time": {"end": 1.0},
    }
    d.update(extra)
    return d


def test_bitmap_maps_grey_and_colour_to_expected_particle_counts(tmp_path):
    # 20 x 10 pixels: black block, grey block, red block, white (unmapped) background
    img = np.full((10, 20, 3), 255, dtype=np.uint8)
    img[:, 0:8] = 0  # black: 80 px
    img[2:7, 9:13] = 128  # grey: 20 px
    img[0:3, 15:19] = (255, 0, 0)  # red, top rows: 12 px
    Image.fromarray(img).save(tmp_path / "scene.png")
    body = {"shape": "image", "file": "scene.png", "pixel_size": 0.5, "origin": [0.0, 0.0],
            "map": [{"grey": [0, 20], "material": "a"}, {"grey": [100, 150], "material": "b"},
                    {"color": [255, 0, 0], "material": "c"}]}
    scene = build_scene(deck_from(_deck([body]), tmp_path))
    P = scene.deformable
    names = scene.materials.deformable
    counts = {names[i]: int(np.sum(P.mat == i)) for i in range(len(names))}
    # particle spacing (0.5) equals the pixel size: one particle per mapped pixel
    assert counts == {"a": 80, "b": 20, "c": 12}
    # red pixels are the image's top rows, so their particles sit at the top of the model
    red = P.x[P.mat == names.index("c")]
    assert red[:, 1].min() > 3.5 and red[:, 0].min() > 7.5
    # masses follow each material's density and the particle volume (0.5 x 0.5 x thickness 1)
    assert np.allclose(P.vol, 0.25)


def test_later_bodies_overwrite_earlier_ones():
    bodies = [{"shape": "rectangle", "min": [0, 0], "max": [10, 10], "material": "a"},
              {"shape": "circle", "center": [5, 5], "radius": 3, "material": "b", "velocity": [1.0, 0.0]}]
    scene = build_scene(deck_from(_deck(bodies)))
    P = scene.deformable
    assert len(P.x) == 400  # the circle replaced, not added to, the rectangle's particles
    inside = np.sum((P.x - 5) ** 2, axis=1) <= 9
    assert np.all(P.mat[inside] == 1) and np.all(P.mat[~inside] == 0)
    assert np.all(P.v[inside, 0] == 1.0) and np.all(P.v[~inside] == 0.0)
    assert np.sum(inside) * 0.25 == pytest.approx(np.pi * 9, rel=0.03)


@pytest.mark.parametrize("body,area", [
    ({"shape": "ellipse", "center": [10, 10], "semi_axes": [6, 3], "angle": 30}, np.pi * 18),
    ({"shape": "annulus", "center": [10, 10], "inner_radius": 3, "outer_radius": 6}, np.pi * 27),
    ({"shape": "polygon", "vertices": [[2, 2], [14, 2], [8, 12]]}, 60.0),
])
def test_shape_areas(body, area):
    body = dict(body, material="a")
    scene = build_scene(deck_from(_deck([body], grid={"cell_size": 0.5})))
    assert len(scene.deformable.x) * 0.25 ** 2 == pytest.approx(area, rel=0.02)


def test_3d_extruded_and_solid_shapes():
    bodies = [{"shape": "circle", "center": [5, 5], "radius": 4, "z_range": [0, 2], "material": "a"},
              {"shape": "sphere", "center": [5, 5, 8], "radius": 3, "material": "b"}]
    scene = build_scene(deck_from(_deck(bodies, analysis="3d", grid={"cell_size": 0.5})))
    P = scene.deformable
    vol = 0.25 ** 3
    assert np.sum(P.mat == 0) * vol == pytest.approx(np.pi * 16 * 2, rel=0.03)
    assert np.sum(P.mat == 1) * vol == pytest.approx(4 / 3 * np.pi * 27, rel=0.03)


@pytest.mark.parametrize("axis,order", [("x", [1, 2, 0]), ("y", [0, 2, 1]), ("z", [0, 1, 2])])
def test_extrude_axis_lays_the_shape_across_the_other_two_axes(axis, order):
    """A rectangle [2, 6] x [1, 4] extruded over [3, 8] along `axis` fills exactly the box whose
    extent along the other two axes (in their order) is the rectangle's and along `axis` the range:
    its particles' bounds are the box's, half a spacing in, and their count its volume."""
    body = {"shape": "rectangle", "min": [2, 1], "max": [6, 4], "z_range": [3, 8], "extrude_axis": axis,
            "material": "a"}
    x = build_scene(deck_from(_deck([body], analysis="3d", grid={"cell_size": 0.5}))).deformable.x
    lo, hi = np.empty(3), np.empty(3)
    lo[order], hi[order] = [2, 1, 3], [6, 4, 8]
    assert np.allclose(x.min(axis=0), lo + 0.125) and np.allclose(x.max(axis=0), hi - 0.125)
    assert len(x) * 0.25**3 == pytest.approx(4 * 3 * 5, rel=1e-12)


def test_a_disc_extruded_along_y_is_round_in_x_z():
    """A circle of radius 4 about (x, z) = (5, 6), extruded along y over [0, 2]: every particle within
    the radius in x-z, y inside the range, the volume pi r^2 t to the lattice's staircase."""
    body = {"shape": "circle", "center": [5, 6], "radius": 4, "z_range": [0, 2], "extrude_axis": "y",
            "material": "a"}
    x = build_scene(deck_from(_deck([body], analysis="3d", grid={"cell_size": 0.5}))).deformable.x
    assert np.all(np.hypot(x[:, 0] - 5, x[:, 2] - 6) <= 4) and np.all((x[:, 1] > 0) & (x[:, 1] < 2))
    assert len(x) * 0.25**3 == pytest.approx(np.pi * 16 * 2, rel=0.03)


def test_grid_is_sized_from_the_scene():
    bodies = [{"shape": "rectangle", "min": [0, 0], "max": [10, 20], "material": "a"},
              {"shape": "rectangle", "min": [0, 20], "max": [10, 21], "material": "p"}]
    mats = {"a": {"type": "linear_elastic", "E": 1.0, "nu": 0.3, "density": 0.001},
            "p": {"type": "rigid", "velocity": {"times": [0, 1], "values": [[0, 0], [0, -4]]}}}
    deck = _deck(bodies, materials=mats, grid={"cell_size": 1.0, "margin": 2,
                                               "boundaries": {"ymin": "fixed", "xmin": "roller"}})
    g = build_scene(deck_from(deck)).grid
    # constrained faces sit on the bodies' edges; free faces get the margin
    assert g.domain_lo[0] == 0.0 and g.domain_lo[1] == 0.0
    assert g.domain_hi[0] == 12.0
    # top: body edge 21 plus margin; the platen's path (down 2 mm by t = 1) stays inside
    assert g.domain_hi[1] == 23.0
    assert list(g.shape[:2]) == [12 + 1 + 2, 23 + 1 + 2]  # one ghost layer each side
