"""Writes semi_ring.msh (Gmsh 2.2 ASCII, read through meshio): the upper half of an annulus
about the origin, inner radius 0.41, outer 0.5, for inputs/implicit_buckling_2d.yaml.
Structured triangles: 7 layers x 112 sectors of quads, each split along a diagonal mirrored
about x = 0 (the mesh is symmetric, so a buckle picks its side from the physics).

    python inputs/meshes/semi_ring.py
"""

from pathlib import Path

import meshio
import numpy as np

R_IN, R_OUT = 0.41, 0.5
NR, NT = 7, 112


def main() -> None:
    r = np.linspace(R_IN, R_OUT, NR + 1)
    theta = np.linspace(0.0, np.pi, NT + 1)
    points = [[ri * np.cos(t), ri * np.sin(t), 0.0] for t in theta for ri in r]
    points = np.array(points)
    points[np.abs(points[:, 1]) < 1e-12, 1] = 0.0  # the feet exactly on y = 0
    cells = []
    for j in range(NT):
        for i in range(NR):
            a = j * (NR + 1) + i  # (r_i, theta_j)
            b, c, d = a + 1, a + NR + 2, a + NR + 1  # (r_i+1, theta_j), (r_i+1, theta_j+1), (r_i, theta_j+1)
            cells += [[a, b, c], [a, c, d]] if j < NT // 2 else [[a, b, d], [b, c, d]]  # counter-clockwise
    meshio.write(Path(__file__).with_name("semi_ring.msh"),
                 meshio.Mesh(points, [("triangle", np.array(cells))]), file_format="gmsh22", binary=False)


if __name__ == "__main__":
    main()
