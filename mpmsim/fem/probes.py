"""Geometric measures between FEM bodies (2D), for studies and tests: how close two bodies'
boundaries come. Plain numpy: called at output times, not in the step."""

from __future__ import annotations

import numpy as np


def _points_to_edges(p: np.ndarray, e0: np.ndarray, e1: np.ndarray) -> float:
    """Smallest distance from the points p (k, 2) to the segments e0-e1 (s, 2)."""
    d = e1 - e0
    t = (np.einsum("pk,sk->ps", p, d) - np.einsum("sk,sk->s", e0, d)[None]) / np.einsum("sk,sk->s", d, d)[None]
    t = np.clip(t, 0.0, 1.0)
    closest = e0[None] + t[..., None] * d[None]
    return float(np.sqrt(((p[:, None] - closest) ** 2).sum(-1)).min())


def boundary_gap(x: np.ndarray, facets: np.ndarray, node_body: np.ndarray, a: int, b: int) -> float:
    """The gap between bodies a and b (rows of node_body): the smallest distance from a boundary
    node of one to a boundary edge of the other, both ways round. 2D meshes (edge facets)."""
    if x.shape[1] != 2:
        raise ValueError("boundary_gap measures 2D bodies (boundary edges)")
    fb = node_body[facets[:, 0]]
    out = np.inf
    for one, other in ((a, b), (b, a)):
        nodes = np.unique(facets[fb == one])
        edges = facets[fb == other]
        out = min(out, _points_to_edges(x[nodes], x[edges[:, 0]], x[edges[:, 1]]))
    return out
