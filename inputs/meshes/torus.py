"""Writes torus.stl (binary STL, read through meshio): a closed triangulated torus about the z
axis, centre-line radius 1, tube radius 0.4 (the deck scales it), for inputs/mesh_torus.yaml.
48 sectors around the axis x 24 around the tube, each quad split along a diagonal, facets
outward. Its enclosed volume is 1.4% below the smooth torus's 2 pi^2 R r^2.
tests/unit/test_mesh_bodies.py uses `torus` for finer tori.

    python inputs/meshes/torus.py
"""

from pathlib import Path

import meshio
import numpy as np


def torus(R: float, r: float, nu: int, nv: int) -> tuple[np.ndarray, np.ndarray]:
    """(points (nu nv, 3), outward triangles (2 nu nv, 3)) of a torus about z: nu sectors around
    the axis, nv around the tube."""
    u = 2.0 * np.pi * np.arange(nu) / nu
    v = 2.0 * np.pi * np.arange(nv) / nv
    U, V = np.meshgrid(u, v, indexing="ij")
    points = np.stack([(R + r * np.cos(V)) * np.cos(U), (R + r * np.cos(V)) * np.sin(U), r * np.sin(V)], -1)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a, b = i * nv + j, (i + 1) % nu * nv + j
    c, d = (i + 1) % nu * nv + (j + 1) % nv, i * nv + (j + 1) % nv
    cells = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return points.reshape(-1, 3), cells


def main() -> None:
    points, cells = torus(1.0, 0.4, 48, 24)
    meshio.write(Path(__file__).with_name("torus.stl"), meshio.Mesh(points, [("triangle", cells)]), binary=True)


if __name__ == "__main__":
    main()
