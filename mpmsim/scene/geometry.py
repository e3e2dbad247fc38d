"""Shape membership tests and bounding boxes, vectorised over points.

`inside(body, points)` answers for an (n, dim) array of particle centres; 2D shapes (and 2D
meshes) in a 3D deck are extruded over `z_range` along `extrude_axis` (z unless it says otherwise;
the shape's coordinates are then the other two axes in their order). Mesh files: scene/meshbody.py.
"""

from __future__ import annotations

import numpy as np
from matplotlib.path import Path as MplPath

from ..deck.schema import SHAPES_2D, Image
from .bitmap import image_bbox, image_classes
from .meshbody import mesh_region


def _extruded(body) -> bool:
    return (body.shape in SHAPES_2D or body.shape == "mesh") and body.z_range is not None


def _extrusion_order(body) -> list[int]:
    """The scene's axes in the order (shape's first, shape's second, extrusion axis)."""
    axis = "xyz".index(body.extrude_axis)
    return [a for a in range(3) if a != axis] + [axis]


def bbox(body, base_dir, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """The body's bounding box in a `dim`-dimensional deck (a mesh file is read to find it:
    fem.mesh.MeshError for a bad one)."""
    s = body.shape
    if s in ("rectangle", "box"):
        lo, hi = np.array(body.min, float), np.array(body.max, float)
    elif s in ("circle", "sphere"):
        c = np.array(body.center, float)
        lo, hi = c - body.radius, c + body.radius
    elif s == "annulus":
        c = np.array(body.center, float)
        lo, hi = c - body.outer_radius, c + body.outer_radius
    elif s == "ellipse":
        c = np.array(body.center, float)
        a, b = body.semi_axes
        t = np.radians(body.angle)
        ex = np.hypot(a * np.cos(t), b * np.sin(t))
        ey = np.hypot(a * np.sin(t), b * np.cos(t))
        lo, hi = c - [ex, ey], c + [ex, ey]
    elif s == "ellipsoid":
        c = np.array(body.center, float)
        lo, hi = c - body.semi_axes, c + np.array(body.semi_axes)
    elif s == "polygon":
        v = np.array(body.vertices, float)
        lo, hi = v.min(axis=0), v.max(axis=0)
    elif s == "image":
        lo, hi = image_bbox(body, base_dir)
    elif s == "mesh":
        region = mesh_region(body, base_dir, dim)
        lo, hi = region.lo.copy(), region.hi.copy()
    else:  # pragma: no cover - the schema admits no other shape
        raise ValueError(s)
    if _extruded(body):
        order = _extrusion_order(body)
        lo3, hi3 = np.empty(3), np.empty(3)
        lo3[order], hi3[order] = np.append(lo, body.z_range[0]), np.append(hi, body.z_range[1])
        lo, hi = lo3, hi3
    return lo, hi


def inside(body, points: np.ndarray, base_dir) -> np.ndarray:
    """Boolean mask of points inside the body (for images: inside a mapped pixel)."""
    s = body.shape
    if _extruded(body):  # the shape's two axes first, the extrusion axis last
        points = points[:, _extrusion_order(body)]
    xy = points[:, :2]
    if s in ("rectangle", "box"):
        lo, hi = np.array(body.min), np.array(body.max)
        n = len(lo)
        mask = np.all((points[:, :n] >= lo) & (points[:, :n] <= hi), axis=1)
    elif s in ("circle", "sphere"):
        c = np.array(body.center)
        n = len(c)
        mask = np.sum((points[:, :n] - c) ** 2, axis=1) <= body.radius**2
    elif s == "annulus":
        r2 = np.sum((xy - np.array(body.center)) ** 2, axis=1)
        mask = (r2 >= body.inner_radius**2) & (r2 <= body.outer_radius**2)
    elif s == "ellipse":
        d = xy - np.array(body.center)
        t = np.radians(body.angle)
        u = d[:, 0] * np.cos(t) + d[:, 1] * np.sin(t)
        w = -d[:, 0] * np.sin(t) + d[:, 1] * np.cos(t)
        a, b = body.semi_axes
        mask = (u / a) ** 2 + (w / b) ** 2 <= 1.0
    elif s == "ellipsoid":
        d = (points - np.array(body.center)) / np.array(body.semi_axes)
        mask = np.sum(d**2, axis=1) <= 1.0
    elif s == "polygon":
        mask = MplPath(np.array(body.vertices, float)).contains_points(xy)
    elif s == "image":
        mask = image_classes(body, xy, base_dir) >= 0
    elif s == "mesh":
        mask = mesh_region(body, base_dir, points.shape[1]).contains(points)
    else:  # pragma: no cover
        raise ValueError(s)
    if _extruded(body):
        z = points[:, 2]
        mask &= (z >= body.z_range[0]) & (z <= body.z_range[1])
    return mask


def body_materials(body, points: np.ndarray, base_dir) -> np.ndarray:
    """Index into the body's material list per point (images map pixels; others are 0)."""
    if isinstance(body, Image):
        if _extruded(body):
            points = points[:, _extrusion_order(body)]
        return image_classes(body, points[:, :2], base_dir)
    return np.zeros(len(points), dtype=np.int64)
