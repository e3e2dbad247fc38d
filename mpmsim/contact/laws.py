"""Contact laws: impulses in, impulses out (notes §3.3–3.4).

Input: the stick impulse dp (what moves material a to the centre-of-mass, or rigid,
velocity), the unit normal n (a -> b), dotn = dp . n (negative when approaching), and whether
the materials are in contact (the passes decide: touching and approaching, or pass 2's
decision kept). Output: the impulse actually applied to a. In contact the normal part dotn n
is always applied, whatever its sign (pass 3 enforces pass 2's decision that way). Contact area cancels for
Coulomb friction, so it is not an input here; the interface laws of the next issue add it.

- stick: always dp (bonded; never separates, like NairnMPM's stick).
- frictionless: dotn n when in contact.
- coulomb: when in contact, the tangential stick impulse S = |dp - dotn n| is capped at
  mu_k N (N = |dotn|); with a static coefficient, S <= mu_s N sticks.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .spec import COULOMB, FRICTIONLESS, STICK


@njit(cache=True, inline="always")
def apply_law(law, mu, mu_static, dp, n, dotn, in_contact, dim, out):
    """Write the applied impulse into out; return True if anything is applied."""
    if law == STICK:
        for d in range(dim):
            out[d] = dp[d]
        return True
    if not in_contact:
        for d in range(dim):
            out[d] = 0.0
        return False
    if law == FRICTIONLESS:
        for d in range(dim):
            out[d] = dotn * n[d]
        return True
    # Coulomb: tangential part of the stick impulse, capped by friction
    s_stick = 0.0
    for d in range(dim):
        t = dp[d] - dotn * n[d]
        s_stick += t * t
    s_stick = np.sqrt(s_stick)
    normal = abs(dotn)
    if mu_static >= 0.0 and s_stick <= mu_static * normal:
        for d in range(dim):
            out[d] = dp[d]
        return True
    s_slide = mu * normal
    if s_stick > s_slide:
        scale = s_slide / s_stick  # 0 for mu = 0: frictionless sliding
        for d in range(dim):
            out[d] = dotn * n[d] + scale * (dp[d] - dotn * n[d])
    else:
        for d in range(dim):
            out[d] = dp[d]
    return True


__all__ = ["apply_law", "STICK", "FRICTIONLESS", "COULOMB"]
