"""Central finite differences for the derivative tests.

Central differences have truncation error O(h^2 f''') and rounding error O(eps f / h); with
coordinates of order one a step h = 1e-6 leaves both near 1e-10 relative to the derivative,
so the tests' 1e-6 relative tolerances separate a correct formula from a wrong one by four
orders of magnitude. Hessians are differenced from the analytic gradient (one order less)."""

from __future__ import annotations

import numpy as np


def fd_gradient(f, y, h):
    y = np.array(y, dtype=float)
    g = np.empty_like(y)
    for i in range(len(y)):
        yp = y.copy()
        ym = y.copy()
        yp[i] += h
        ym[i] -= h
        g[i] = (f(yp) - f(ym)) / (2 * h)
    return g


def fd_jacobian(grad, y, h):
    """Columns d grad / d y_i by central differences of the analytic gradient."""
    y = np.array(y, dtype=float)
    n = len(y)
    J = np.empty((len(grad(y)), n))
    for i in range(n):
        yp = y.copy()
        ym = y.copy()
        yp[i] += h
        ym[i] -= h
        J[:, i] = (grad(yp) - grad(ym)) / (2 * h)
    return J


def rel_err(a, b, floor=0.0):
    """||a - b|| / max(||b||, floor) (Frobenius for matrices)."""
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    return float(np.linalg.norm(a - b) / max(np.linalg.norm(b), floor, 1e-300))
