"""Contact normals on mirror planes (contact/grid/plan.py, mirror_normal; __init__.mirror_planes):
a node on a roller face or the axisymmetric axis sees a one-sided cloud, so its fitted normal
tilts across the plane; by symmetry it has no component across it."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from mpmsim.contact.grid import mirror_planes
from mpmsim.contact.grid.plan import mirror_normal
from mpmsim.scene.grid import FIXED, FREE, ROLLER

NONE = np.array([[-np.inf] * 3, [np.inf] * 3])


def grid(faces, dim=3):
    """Two cells of 0.5 beyond the domain on each side; the domain [0, 4]^dim."""
    return SimpleNamespace(dim=dim, face_type=np.array(faces), origin=np.full(dim, -1.0), h=np.full(dim, 0.5),
                           wall_index=np.array([2, 10] * dim + [0] * (6 - 2 * dim)))


def test_roller_faces_are_mirror_planes_fixed_and_free_faces_are_not():
    m = mirror_planes(grid([ROLLER, FREE, FIXED, ROLLER, FREE, ROLLER]), False)
    assert m[0, 0] == 0.0 and m[1, 1] == 4.0 and m[1, 2] == 4.0
    assert m[1, 0] == np.inf and m[0, 1] == -np.inf and m[0, 2] == -np.inf
    assert np.array_equal(mirror_planes(grid([FREE] * 4 + [0, 0], dim=2), False), NONE)
    assert mirror_planes(grid([FREE] * 4 + [0, 0], dim=2), True)[0, 0] == 0.0  # the axis r = 0


def test_the_component_across_a_mirror_plane_is_dropped():
    m = mirror_planes(grid([ROLLER, FREE, FREE, FREE, ROLLER, FREE]), False)  # x = 0 and z = 0
    n = np.array([0.6, -0.8, 0.0])
    assert mirror_normal(np.array([0.0, 2.0, 1.0]), m, 3, n)
    assert n.tolist() == [0.0, -1.0, 0.0]  # exactly: one component left
    n = np.array([0.48, -0.6, 0.64])
    assert mirror_normal(np.array([0.0, 2.0, 0.0]), m, 3, n)  # on both planes
    assert n.tolist() == [0.0, -1.0, 0.0]
    n = np.array([0.36, -0.48, 0.8])
    assert mirror_normal(np.array([-0.5, 2.0, 1.0]), m, 3, n)  # beyond the plane (a ghost node) too
    assert n == pytest.approx([0.0, -0.48 / np.hypot(0.48, 0.8), 0.8 / np.hypot(0.48, 0.8)], abs=1e-15)
    assert np.linalg.norm(n) == pytest.approx(1.0, abs=1e-15)
    n = np.array([0.36, -0.48, 0.8])
    assert mirror_normal(np.array([0.5, 2.0, 1.0]), m, 3, n)  # off the planes: untouched
    assert n.tolist() == [0.36, -0.48, 0.8]


def test_a_normal_across_the_plane_alone_is_dropped_and_tiny_ones_survive():
    m = mirror_planes(grid([ROLLER, FREE, FREE, FREE, 0, 0], dim=2), False)
    n = np.array([1.0, 0.0, 0.0])
    assert not mirror_normal(np.array([0.0, 1.0]), m, 2, n)  # nothing left: the target is dropped
    n = np.array([1.0, -1e-200, 0.0])
    assert mirror_normal(np.array([0.0, 1.0]), m, 2, n)
    assert n[:2].tolist() == [0.0, -1.0]  # (squared, 1e-200 would underflow to a zero normal)
