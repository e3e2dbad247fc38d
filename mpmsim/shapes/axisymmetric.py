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
  [max(r_p - l, 0), r_p + l], taken exactly piece by piece between the hat's kinks (N_i r is
  quadratic on each piece: Simpson's rule is exact). A domain that crosses the axis is cut
  there, as the reference code does; the nodes at r < 0 get no weight.

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
def _hat_piece(u, v, node, h):
    """(int N, int N r, int N' r) over [u, v] where the hat of the node at r = node (spacing
    h) is linear (no kink inside)."""
    m = 0.5 * (u + v)
    nu = max(0.0, 1.0 - abs(u - node) / h)
    nv = max(0.0, 1.0 - abs(v - node) / h)
    nm = max(0.0, 1.0 - abs(m - node) / h)
    slope = (nv - nu) / (v - u) if v > u else 0.0
    return (0.5 * (nu + nv) * (v - u), (v - u) / 6.0 * (nu * u + 4.0 * nm * m + nv * v),
            0.5 * slope * (v * v - u * u))


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
    # GIMP: the r-weighted averages over [lo, hi]
    lo = max(rp - semi, 0.0)
    hi = rp + semi
    den = 0.5 * (hi * hi - lo * lo)
    for a in range(per_axis):
        node = o + (b + a) * h
        s0 = 0.0  # int N
        s1 = 0.0  # int N r
        g1 = 0.0  # int N' r
        u = lo
        for kink in (node - h, node, node + h, hi):
            if kink <= u:
                continue
            v = min(kink, hi)
            a0, a1, a2 = _hat_piece(u, v, node, h)
            s0 += a0
            s1 += a1
            g1 += a2
            u = v
            if u >= hi:
                break
        w[a] = s1 / den
        dw[a] = g1 / den
        wt[a] = s0 / den
    return b, True


AXISYMMETRIC_KINDS = (LINEAR, GIMP)  # the grid functions with an axisymmetric form here
