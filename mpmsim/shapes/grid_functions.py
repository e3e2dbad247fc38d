"""One-dimensional weights along an axis, shared by every shape function.

`weights_1d(kind, xi, l, inv_h, w, dw)` fills the weights w and their x-derivatives dw of
`NODES[kind]` consecutive nodes starting at the returned `base`, for a point at xi (cell
units from the grid origin). `l` is the particle semi-length in cell units (uGIMP only).

- LINEAR: hat function, nodes floor(xi), floor(xi) + 1.
- GIMP (uGIMP, notes §7.1): the hat averaged over a particle of semi-length l <= 1/2:
      S = 1 - (r^2 + l^2)/(2l)   r < l;   1 - r   l <= r <= 1 - l;   (1 + l - r)^2/(4l)   r < 1 + l.
- BSPLINE2 (notes §7.2): N = 3/4 - r^2 for r <= 1/2; (3/2 - r)^2/2 for r <= 3/2.
- BSPLINE3: N = r^3/2 - r^2 + 2/3 for r < 1; (2 - r)^3/6 for r < 2.
(r = |xi - node|.) All four reproduce constants and linear functions exactly.
"""

from __future__ import annotations

import numpy as np
from numba import njit

LINEAR = 0
GIMP = 1
BSPLINE2 = 2
BSPLINE3 = 3
NODES = {LINEAR: 2, GIMP: 3, BSPLINE2: 3, BSPLINE3: 4}


@njit(cache=True, inline="always")
def _gimp(r, l):
    """uGIMP weight and d/dr for signed distance r (cell units) from node to point."""
    a = abs(r)
    sgn = 1.0 if r >= 0.0 else -1.0
    if a < l:
        return 1.0 - (a * a + l * l) / (2.0 * l), -sgn * a / l
    if a <= 1.0 - l:
        return 1.0 - a, -sgn
    if a < 1.0 + l:
        t = 1.0 + l - a
        return t * t / (4.0 * l), -sgn * t / (2.0 * l)
    return 0.0, 0.0


@njit(cache=True, inline="always")
def _bspline2(r):
    a = abs(r)
    if a <= 0.5:
        return 0.75 - a * a, -2.0 * r
    if a < 1.5:
        t = 1.5 - a
        return 0.5 * t * t, (-t if r > 0.0 else t)
    return 0.0, 0.0


@njit(cache=True, inline="always")
def _bspline3(r):
    a = abs(r)
    if a < 1.0:
        return 0.5 * a * a * a - a * a + 2.0 / 3.0, 1.5 * r * a - 2.0 * r
    if a < 2.0:
        t = 2.0 - a
        return t * t * t / 6.0, (-0.5 * t * t if r > 0.0 else 0.5 * t * t)
    return 0.0, 0.0


@njit(cache=True, inline="always")
def weights_1d(kind, xi, l, inv_h, w, dw):
    if kind == LINEAR:
        base = int(np.floor(xi))
        t = xi - base
        w[0] = 1.0 - t
        w[1] = t
        dw[0] = -inv_h
        dw[1] = inv_h
        return base
    if kind == BSPLINE3:
        base = int(np.floor(xi)) - 1
        for a in range(4):
            s, ds = _bspline3(xi - (base + a))
            w[a] = s
            dw[a] = ds * inv_h
        return base
    # GIMP and BSPLINE2: the nearest node and its two neighbours cover the support
    base = int(np.floor(xi + 0.5)) - 1
    for a in range(3):
        if kind == GIMP:
            s, ds = _gimp(xi - (base + a), l)
        else:
            s, ds = _bspline2(xi - (base + a))
        w[a] = s
        dw[a] = ds * inv_h
    return base
