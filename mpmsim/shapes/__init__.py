"""Shape functions: fill each particle's node list, S_ip and G_ip once per step.

Every later task (extrapolation, forces, stress, particle update) reads these arrays, so a
new shape function only has to fill them. Tensor-product functions (linear, uGIMP) share
one kernel; `span` is the largest node-index spread of one particle along an axis, used
to size the parallel scatter slabs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .tensor import GIMP, LINEAR, tensor_shape_functions

KINDS = {"linear": LINEAR, "gimp": GIMP}
NODES_PER_AXIS = {"linear": 2, "gimp": 3}


@dataclass
class ShapeFunction:
    name: str
    kind: int
    per_axis: int

    def nodes_per_particle(self, dim: int) -> int:
        return self.per_axis**dim

    @property
    def span(self) -> int:
        return self.per_axis - 1

    def compute(self, x, semi, grid, nchunk, sd: "ShapeData") -> tuple[np.ndarray, np.ndarray]:
        """Fill `sd`; return the (lo, hi) node box the particles touch."""
        lo = np.empty((nchunk, 3), dtype=np.int64)
        hi = np.empty((nchunk, 3), dtype=np.int64)
        tensor_shape_functions(x, grid.origin, grid.h, semi, self.kind, self.per_axis, grid.shape, nchunk,
                               sd.nodes, sd.S, sd.G, sd.lowest, lo, hi)
        return lo.min(axis=0), hi.max(axis=0)


def shape_function(name: str) -> ShapeFunction:
    return ShapeFunction(name, KINDS[name], NODES_PER_AXIS[name])


@dataclass
class ShapeData:
    """Per-particle node lists and weights for one particle set, refreshed every step."""

    nodes: np.ndarray  # (n, K) flat node index
    S: np.ndarray  # (n, K)
    G: np.ndarray  # (n, K, dim)
    lowest: np.ndarray  # (n, 3) lowest node (i, j, k) the particle touches

    @classmethod
    def empty(cls, n: int, K: int, dim: int) -> "ShapeData":
        return cls(np.zeros((n, K), dtype=np.int64), np.zeros((n, K)), np.zeros((n, K, dim)),
                   np.zeros((n, 3), dtype=np.int64))
