"""Writes shell_cap.msh (Gmsh 2.2 ASCII, read through meshio): a spherical shell cap opening
upwards (a bowl), for inputs/implicit_twist_3d.yaml. Sphere centre (0, 0, 0.185), inner radius
0.07, outer radius 0.085: the outer surface's lowest point (the pole) is at z = 0.1; the cap
reaches 50 degrees from the pole (its rim at z = 0.13-0.14).

Structured tetrahedra without a pole singularity: an N x N square grid is mapped onto the unit
disk (elliptical map x = u sqrt(1 - v^2/2), y = v sqrt(1 - u^2/2)), the disk radius rho onto
the polar angle rho x 50 degrees and the azimuth kept, and NR layers span the radii; each
hexahedron is cut into 6 tetrahedra along its main diagonal (Kuhn: conforming across faces),
each oriented positively.

    python inputs/meshes/shell_cap.py
"""

from itertools import permutations
from pathlib import Path

import meshio
import numpy as np

CENTER_Z, R_IN, R_OUT, CAP_DEG = 0.185, 0.07, 0.085, 50.0
N, NR = 12, 2  # cells per side of the square, cells through the thickness


def main() -> None:
    s = np.linspace(-1.0, 1.0, N + 1)
    u, v = np.meshgrid(s, s, indexing="ij")
    dx, dy = u * np.sqrt(1.0 - v ** 2 / 2.0), v * np.sqrt(1.0 - u ** 2 / 2.0)
    theta = np.radians(CAP_DEG) * np.hypot(dx, dy)
    phi = np.arctan2(dy, dx)
    direction = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), -np.cos(theta)], axis=-1)
    radii = np.linspace(R_IN, R_OUT, NR + 1)
    points = np.array([[0.0, 0.0, CENTER_Z] + r * direction[i, j]
                       for i in range(N + 1) for j in range(N + 1) for r in radii])
    index = lambda i, j, k: (i * (N + 1) + j) * (NR + 1) + k  # noqa: E731
    cells = []
    for i in range(N):
        for j in range(N):
            for k in range(NR):
                for order in permutations(range(3)):  # Kuhn: the 6 monotone paths from corner 0 to 1
                    corner = [0, 0, 0]
                    tet = [index(i, j, k)]
                    for axis in order:
                        corner[axis] += 1
                        tet.append(index(i + corner[0], j + corner[1], k + corner[2]))
                    a, b, c, d = points[tet]
                    if np.dot(np.cross(b - a, c - a), d - a) < 0.0:
                        tet[2], tet[3] = tet[3], tet[2]
                    cells.append(tet)
    meshio.write(Path(__file__).with_name("shell_cap.msh"),
                 meshio.Mesh(points, [("tetra", np.array(cells))]), file_format="gmsh22", binary=False)


if __name__ == "__main__":
    main()
