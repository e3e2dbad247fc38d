"""The radial factor of the axisymmetric shape functions (x = r, y = z; Nairn and Guilkey,
IJNME 101 (2015) 127-147, doi:10.1002/nme.4792).

In r-z every particle integral carries the weight r: with V_p = int_p r dA (volume per
radian) the particle-node functions are

    S_ip = (1/V_p) int_p N_i r dA,  G_ip = (1/V_p) int_p grad N_i r dA,  T_ip = (1/V_p) int_p N_i dA,

S and G for mass, momentum and the in-plane forces and velocity gradient, T (the hoop
function) for the hoop strain rate L_tt = sum_i v_r,i T_ip and the hoop stress's radial force
-V_p sigma_tt T_ip. The z factor is the planar one; only the r factor changes, and this
module computes it:

- linear (point values): S, G planar at r_p; T = N_i(r_p) / r_p.
- gimp (uGIMP, undeformed half-width l): the integrals over the particle's radial extent
  [lo, hi] = [max(r_p - l, 0), r_p + l], exactly, as differences of the hat's antiderivatives
  int N dr and int N r dr (piecewise polynomials in u = (r - r_i)/h), with
  int N' r dr = [N r] - int N dr. A domain that crosses the axis is cut there, as the reference
  code does; the nodes at r < 0 get no weight.

Both reproduce what the r-z step needs: sum_i S_ip = 1, sum_i G_ip = 0 and sum_i r_i T_ip = 1,
so a homogeneous expansion v_r = c r gives L_rr = L_tt = c exactly, next to the axis too.
A particle at r_p <= 0 has no hoop function: it is flagged (BAD_AXIS).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .grid_functions import GIMP, LINEAR, weights_1d

BAD_AXIS = 9  # a particle of an axisymmetric scene reached the axis r = 0


@njit(cache=True, inline="always")
def _hat_antiderivatives(u):
    """For the unit hat n(u) = max(0, 1 - |u|): (n(u), int_-1^u n dt, int_-1^u n t dt)."""
    if u <= -1.0:
        return 0.0, 0.0, 0.0
    if u <= 0.0:
        return 1.0 + u, 0.5 * (1.0 + u) ** 2, u * u * (0.5 + u / 3.0) - 1.0 / 6.0
    if u < 1.0:
        return 1.0 - u, 1.0 - 0.5 * (1.0 - u) ** 2, u * u * (0.5 - u / 3.0) - 1.0 / 6.0
    return 0.0, 1.0, 0.0


@njit(cache=True, inline="always")
def radial_weights(kind, rp, o, h, semi, per_axis, n, w, dw, wt):
    """The r factors of a particle at radius rp (grid origin o, spacing h, n nodes along r;
    semi: its half-width for uGIMP): S into w, dS/dr into dw, T into wt (each that axis's row,
    per_axis entries). Returns (lowest node, whether its support lies on the grid and rp > 0)."""
    xi = (rp - o) / h
    ok = rp > 0.0 and xi < 1e9
    if not ok:
        xi = 0.0
    b = weights_1d(kind, xi, semi / h, 1.0 / h, w, dw)
    if b < 0 or b + per_axis > n:
        ok = False
    if not ok:
        return b, False
    if kind == LINEAR:
        for a in range(per_axis):
            wt[a] = w[a] / rp
        return b, True
    # GIMP: the r-weighted averages over [lo, hi]; with r = c + h u about the node c,
    # int N dr = h [A0], int N r dr = c h [A0] + h^2 [A1], int N' r dr = [N r] - int N dr
    lo = max(rp - semi, 0.0)
    hi = rp + semi
    den = 0.5 * (hi * hi - lo * lo)
    for a in range(per_axis):
        c = o + (b + a) * h
        n_lo, a0_lo, a1_lo = _hat_antiderivatives((lo - c) / h)
        n_hi, a0_hi, a1_hi = _hat_antiderivatives((hi - c) / h)
        s0 = h * (a0_hi - a0_lo)  # int N
        w[a] = (c * s0 + h * h * (a1_hi - a1_lo)) / den
        dw[a] = (n_hi * hi - n_lo * lo - s0) / den
        wt[a] = s0 / den
    return b, True


AXISYMMETRIC_KINDS = (LINEAR, GIMP)  # the grid functions with an axisymmetric form here
