"""Interpenetration of materials, measured on the particles' deformed domains.

Each particle occupies the parallelogram x_p + F_p (s * a, t * b), |s|, |t| <= 1, with a, b
its undeformed half-sizes (CPDI's domain). The domains are rasterised on pixels of size
`pixel` (a fraction of a cell); a pixel whose centre lies in the domains of two or more
materials is *overlapped*. The measure is the overlapped area over the material area (all
pixels claimed by any particle). Particles of one material overlap each other slightly in
any MPM run; those pixels do not count. Used to compare contact methods (LR paper Fig. 6:
interfaces that stay clean have little overlap; methods that let ellipses pass into each
other have much more).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _rasterise(x, F, mat, semi, lo, pixel, nx, ny, owner, multi):
    for p in range(x.shape[0]):
        f00, f01, f10, f11 = F[p, 0, 0], F[p, 0, 1], F[p, 1, 0], F[p, 1, 1]
        det = f00 * f11 - f01 * f10
        if det <= 0.0:
            continue
        ex = abs(f00) * semi[0] + abs(f01) * semi[1]  # half-extents of the parallelogram
        ey = abs(f10) * semi[0] + abs(f11) * semi[1]
        i0 = max(0, int((x[p, 0] - ex - lo[0]) / pixel))
        i1 = min(nx - 1, int((x[p, 0] + ex - lo[0]) / pixel))
        j0 = max(0, int((x[p, 1] - ey - lo[1]) / pixel))
        j1 = min(ny - 1, int((x[p, 1] + ey - lo[1]) / pixel))
        m = mat[p]
        for j in range(j0, j1 + 1):
            dy = lo[1] + (j + 0.5) * pixel - x[p, 1]
            for i in range(i0, i1 + 1):
                dx = lo[0] + (i + 0.5) * pixel - x[p, 0]
                s = (f11 * dx - f01 * dy) / det  # F^-1 (pixel - x_p)
                t = (-f10 * dx + f00 * dy) / det
                if abs(s) <= semi[0] and abs(t) <= semi[1]:
                    o = owner[j, i]
                    if o < 0:
                        owner[j, i] = m
                    elif o != m:
                        multi[j, i] = True


def overlap_fraction(x: np.ndarray, F: np.ndarray, mat: np.ndarray, semi: np.ndarray, pixel: float) -> float:
    """Area claimed by two or more materials over the area claimed by any (2D)."""
    if x.shape[1] != 2:
        raise ValueError("overlap_fraction is implemented for 2D scenes")
    reach = float(np.abs(F).max()) * float(np.max(semi)) * 2.0
    lo = x.min(axis=0) - reach
    hi = x.max(axis=0) + reach
    nx, ny = (np.ceil((hi - lo) / pixel).astype(int) + 1)
    owner = np.full((ny, nx), -1, dtype=np.int64)
    multi = np.zeros((ny, nx), dtype=np.bool_)
    _rasterise(x, F[:, :2, :2], mat.astype(np.int64), np.asarray(semi, float)[:2], lo, float(pixel), nx, ny, owner,
               multi)
    claimed = int((owner >= 0).sum())
    return float(multi.sum()) / claimed if claimed else 0.0
