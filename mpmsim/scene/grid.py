"""The background grid: sized from the scene, not a fixed box.

The *domain* is where material may go; particles leaving it (or passing a constrained face
by more than half a cell) stop the run. The grid adds
`ghost` node layers outside the domain so every shape function near the edge has its
nodes. Node (i, j, k) sits at origin + (i, j, k) * h; flat index i + nx * (j + ny * k).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..views import GridView

FACES = ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")
FREE, FIXED, ROLLER = 0, 1, 2
FACE_CODES = {"free": FREE, "fixed": FIXED, "roller": ROLLER, "slip": ROLLER}


def faces_tuple(values) -> tuple:
    """Six plain ints, one per face in FACES order (faces a 2D grid lacks are 0: free)."""
    out = [int(v) for v in values]
    return tuple(out + [0] * (6 - len(out)))


@dataclass
class GridSpec:
    dim: int
    h: np.ndarray  # (dim,) cell sizes
    origin: np.ndarray  # (dim,) position of node 0
    shape: np.ndarray  # (3,) nodes per direction (nz = 1 in 2D)
    ghost: int
    domain_lo: np.ndarray  # (dim,)
    domain_hi: np.ndarray
    face_type: np.ndarray  # (6,) FREE / FIXED / ROLLER per face in FACES order
    wall_index: np.ndarray  # (6,) node index of each face's grid line along its axis

    @cached_property
    def view(self) -> GridView:
        """The grid as kernels take it (its node counts and faces as tuples of ints: views.GridView)."""
        return GridView(tuple(int(n) for n in self.shape), self.origin, self.h, faces_tuple(self.face_type),
                        faces_tuple(self.wall_index))

    @cached_property
    def has_walls(self) -> bool:
        """Some domain face holds velocities (fixed or roller): ghost values are mirrored."""
        return bool(np.any(self.face_type[: 2 * self.dim] != 0))

    @property
    def n_nodes(self) -> int:
        return int(np.prod(self.shape))

    @property
    def particle_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Where particle centres may go: the domain, plus half a cell beyond constrained faces.
        Under heavy compression a particle squeezed against a wall can have its centre cross
        the wall line by a sliver (CPDI corners see the mirrored ghost velocities); its
        support is still on the ghost nodes, so only a deeper crossing stops the run."""
        lo, hi = self.domain_lo.copy(), self.domain_hi.copy()
        for a in range(self.dim):
            if self.face_type[2 * a] != FREE:
                lo[a] -= 0.5 * self.h[a]
            if self.face_type[2 * a + 1] != FREE:
                hi[a] += 0.5 * self.h[a]
        return lo, hi

    @property
    def cells(self) -> np.ndarray:
        return np.round((self.domain_hi - self.domain_lo) / self.h).astype(int)

    def node_position(self, ijk) -> np.ndarray:
        return self.origin + np.asarray(ijk)[: self.dim] * self.h


MAX_CELLS_PER_AXIS = 1e7  # far beyond any memory; keeps node counts in 64-bit integers


def plan_grid(dim, h, lo, hi, faces, explicit: bool, ghost: int) -> tuple[GridSpec | None, str | None]:
    """Place grid lines so constrained faces lie on grid lines at the domain's edge.

    `lo`, `hi` are the requested domain bounds. Returns (grid, None) or (None, problem).
    """
    lo, hi = np.array(lo, float), np.array(hi, float)
    n = np.zeros(dim, dtype=int)
    for a in range(dim):
        fixed_lo = faces[2 * a] != FREE
        fixed_hi = faces[2 * a + 1] != FREE
        cells = (hi[a] - lo[a]) / h[a]
        if not cells < MAX_CELLS_PER_AXIS:
            return None, (f"{cells:.3g} cells along {'xyz'[a]} (extent {hi[a] - lo[a]:g}, cell size {h[a]:g}); "
                          f"at most {MAX_CELLS_PER_AXIS:.0e} are possible: use a larger cell_size")
        whole = abs(cells - round(cells)) < 1e-6 * max(1.0, cells)
        n[a] = int(round(cells)) if whole else int(np.ceil(cells))
        if fixed_lo and fixed_hi and not whole:
            return None, (f"both {'xyz'[a]} faces are constrained but the {'xyz'[a]} extent "
                          f"{hi[a] - lo[a]:g} is not a whole number of cells of size {h[a]:g}; "
                          "set grid.domain or change cell_size")
        if fixed_hi and not fixed_lo and not explicit:
            lo[a] = hi[a] - n[a] * h[a]  # keep the constrained face on the bodies' edge
        else:
            hi[a] = lo[a] + n[a] * h[a]
    origin = lo - ghost * h
    shape = np.ones(3, dtype=int)
    shape[:dim] = n + 1 + 2 * ghost
    wall = np.zeros(6, dtype=int)
    for a in range(dim):
        wall[2 * a] = ghost
        wall[2 * a + 1] = ghost + n[a]
    face_type = np.array(faces, dtype=np.int64)
    return GridSpec(dim, np.array(h, float), origin, shape, ghost, lo, hi, face_type, wall), None
