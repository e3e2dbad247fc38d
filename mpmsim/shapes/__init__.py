"""Shape functions: fill each particle's node list, S_ip and G_ip once per step.

Every later task (extrapolation, forces, stress, particle update, XPIC) reads these arrays,
so a shape function only has to fill them. Two kernels serve all seven functions:

| name | kernel | grid function | nodes/particle 2D, 3D | ghost layers |
|---|---|---|---|---|
| linear | tensor | linear | 4, 8 | 1 |
| gimp | tensor | uGIMP (undeformed particle size) | 9, 27 | 1 |
| bspline2 | tensor | quadratic B-spline | 9, 27 | 2 |
| bspline3 | tensor | cubic B-spline | 16, 64 | 2 |
| cpdi | cpdi | linear at the 2^dim corners of the deformed domain | 16, 64 | 3 |
| cpdi_q | cpdi | linear at 9 points (2D only) | 16, - | 3 |
| b2cpdi | cpdi | quadratic B-spline at the corners | 25, 125 | 3 |

`span` (the largest node-index spread of one particle along an axis) sizes the parallel
scatter slabs. Linear and gimp have axisymmetric forms (`ShapeFunction.for_axisymmetric`: the
r-weighted radial factor and the hoop function T, shapes/axisymmetric.py).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from .axisymmetric import AXISYMMETRIC_KINDS, BAD_AXIS
from .cpdi import BAD_DOMAIN, BAD_SPAN, CORNERS, NINE_POINT, cpdi_shape_functions
from .grid_functions import BSPLINE2, BSPLINE3, GIMP, LINEAR, NODES
from .tensor import BAD_SUPPORT, tensor_kernel

SHAPE_BAD_MESSAGES = {
    BAD_SUPPORT: "its shape-function support (a CPDI corner or spline node) left the grid",
    BAD_SPAN: "its deformed CPDI domain spans more than two cells along an axis; refine the grid "
              "or use more particles per cell",
    BAD_DOMAIN: "its CPDI domain inverted (det F <= 0)",
    BAD_AXIS: "it reached the axis r = 0 of the axisymmetric analysis (or its support left the grid)",
}


class ShapeKind(NamedTuple):
    """A shape function as its kernels take it."""

    grid_kind: int  # grid function (grid_functions kinds)
    per_axis: int  # nodes per axis of a sample point (tensor) or of the CPDI node box
    npc: int  # nodes per axis of the grid function alone
    cpdi_scheme: int  # -1 for tensor-product functions, else CORNERS / NINE_POINT
    axisymmetric: bool  # x is r: the r-weighted radial factor and the hoop function (shapes/axisymmetric.py)


class ChunkBoxes(NamedTuple):
    """Per particle chunk: the node box touched (lo, hi) and the first flagged particle and why."""

    lo: np.ndarray  # (nchunk, 3) int64
    hi: np.ndarray  # (nchunk, 3) int64
    bad: np.ndarray  # (nchunk,) int64
    code: np.ndarray  # (nchunk,) int64


@dataclass(frozen=True)
class ShapeFunction:
    name: str
    grid_kind: int  # grid function (grid_functions kinds)
    cpdi_scheme: int  # -1 for tensor-product functions, else CORNERS / NINE_POINT
    ghost: int  # ghost node layers needed outside the domain
    dims: tuple = (2, 3)
    axisymmetric: bool = False  # the r-z form (x = r): see `for_axisymmetric`

    @property
    def per_axis(self) -> int:
        """Nodes per axis of one sample point (tensor) or of the CPDI node box."""
        return NODES[self.grid_kind] + (2 if self.cpdi_scheme >= 0 else 0)

    def nodes_per_particle(self, dim: int) -> int:
        return self.per_axis**dim

    @property
    def span(self) -> int:
        return self.per_axis - 1

    @property
    def reaches_ghosts(self) -> bool:
        """B-spline grid functions: particles well inside the domain weigh ghost nodes beyond a
        wall. (Linear and uGIMP ghosts get weight only from a CPDI corner pushed past the wall.)"""
        return self.grid_kind in (BSPLINE2, BSPLINE3)

    @property
    def uses_deformation(self) -> bool:
        return self.cpdi_scheme >= 0

    @property
    def kind(self) -> ShapeKind:
        return ShapeKind(self.grid_kind, self.per_axis, NODES[self.grid_kind], self.cpdi_scheme, self.axisymmetric)

    def for_axisymmetric(self) -> "ShapeFunction":
        """The r-z form of this function (linear and uGIMP: shapes/axisymmetric.py)."""
        if self.cpdi_scheme >= 0 or self.grid_kind not in AXISYMMETRIC_KINDS:
            raise ValueError(f"shape function {self.name} has no axisymmetric form here (linear, gimp)")
        return replace(self, axisymmetric=True)

    def compute(self, x, F, semi, grid, nchunk, sd: "ShapeData"):
        """Fill `sd` for particles at x (F: deformation gradients, or None for rigid particles).
        Returns ((lo, hi) node box, (first bad particle or -1, code))."""
        boxes = ChunkBoxes(np.empty((nchunk, 3), dtype=np.int64), np.empty((nchunk, 3), dtype=np.int64),
                           np.full(nchunk, -1, dtype=np.int64),
                           np.full(nchunk, BAD_SUPPORT if self.cpdi_scheme < 0 else 0, dtype=np.int64))
        if self.cpdi_scheme < 0:
            tensor_kernel(self.grid_kind, x.shape[1], self.axisymmetric)(x, grid.view, semi, nchunk, sd, boxes)
        else:
            if F is None:
                F = np.broadcast_to(np.eye(x.shape[1]), (len(x), x.shape[1], x.shape[1]))
            cpdi_shape_functions(x, F, grid.view, semi, self.kind, nchunk, sd, boxes)
        bad, code = boxes.bad, boxes.code
        hits = np.nonzero(bad >= 0)[0]
        first = (int(bad[hits[0]]), int(code[hits[0]])) if len(hits) else (-1, 0)
        return (boxes.lo.min(axis=0), boxes.hi.max(axis=0)), first


SHAPE_FUNCTIONS = {
    "linear": ShapeFunction("linear", LINEAR, -1, 1),
    "gimp": ShapeFunction("gimp", GIMP, -1, 1),
    "bspline2": ShapeFunction("bspline2", BSPLINE2, -1, 2),
    "bspline3": ShapeFunction("bspline3", BSPLINE3, -1, 2),
    "cpdi": ShapeFunction("cpdi", LINEAR, CORNERS, 3),
    "cpdi_q": ShapeFunction("cpdi_q", LINEAR, NINE_POINT, 3, dims=(2,)),
    "b2cpdi": ShapeFunction("b2cpdi", BSPLINE2, CORNERS, 3),
}


def shape_function(name: str) -> ShapeFunction:
    return SHAPE_FUNCTIONS[name]


class ShapeData(NamedTuple):
    """Per-particle node lists and weights for one particle set, refreshed every step (a
    bundle kernels take as is)."""

    nodes: np.ndarray  # (n, K) flat node index
    S: np.ndarray  # (n, K)
    G: np.ndarray  # (n, K, dim)
    lowest: np.ndarray  # (n, 3) lowest node (i, j, k) the particle touches
    T: np.ndarray  # (n, K) hoop function T_ip of an axisymmetric scene; (0, K) otherwise

    @classmethod
    def empty(cls, n: int, K: int, dim: int, axisymmetric: bool = False) -> "ShapeData":
        return cls(np.zeros((n, K), dtype=np.int64), np.zeros((n, K)), np.zeros((n, K, dim)),
                   np.zeros((n, 3), dtype=np.int64), np.zeros((n if axisymmetric else 0, K)))
