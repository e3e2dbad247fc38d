"""Writes sine_wall.msh (Gmsh 2.2 ASCII, read through meshio): a wall 0.1 wide and 0.4 high whose
left face is a sine wave x = 0.15 + 0.03 sin(2 pi y / 0.1), for inputs/implicit_sine_wall_2d.yaml.
Structured triangles: 5 columns x 40 rows of quads, each split along a diagonal.

    python inputs/meshes/sine_wall.py
"""

from pathlib import Path

import meshio
import numpy as np

NX, NY = 5, 40
Y0, H = 0.01, 0.4
LEFT = lambda y: 0.15 + 0.03 * np.sin(2.0 * np.pi * (y - Y0) / 0.1)  # noqa: E731
RIGHT = 0.25


def main() -> None:
    ys = Y0 + H * np.arange(NY + 1) / NY
    points = []
    for y in ys:
        xl = LEFT(y)
        for i in range(NX + 1):
            points.append([xl + (RIGHT - xl) * i / NX, y, 0.0])
    cells = []
    for j in range(NY):
        for i in range(NX):
            a = j * (NX + 1) + i
            b, c, d = a + 1, a + NX + 2, a + NX + 1
            cells += [[a, b, c], [a, c, d]]  # counter-clockwise
    meshio.write(Path(__file__).with_name("sine_wall.msh"),
                 meshio.Mesh(np.array(points), [("triangle", np.array(cells))]), file_format="gmsh22", binary=False)


if __name__ == "__main__":
    main()
