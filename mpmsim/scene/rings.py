"""Round bodies seeded in rings that follow their surface (`seeding: rings`).

A circle (or annulus) filled on the grid lattice has a staircase surface: the lowest row is a
flat facet that touches a flat all at once, and the contact pressure and width under it are far
from Hertz's (docs/contact.md, docs/bfemp.md). Seeded in rings, the surface is round to within
the particle spacing: n = round((R_out - R_in) / s) rings of width dr = (R_out - R_in) / n (s the
lattice spacing h / particles_per_direction), ring k at radius r_k = R_in + (k + 1/2) dr holding
m_k = round(2 pi r_k / dr) particles (at least 3) at angles -pi/2 + 2 pi j / m_k: one particle at
the bottom of every ring, the set mirror-symmetric about the vertical through the centre. Each
particle carries its ring sector's exact area 2 pi r_k dr / m_k, so the areas sum to
pi (R_out^2 - R_in^2) exactly (times the thickness in 2D).
"""

from __future__ import annotations

import math

import numpy as np


def ring_seed(center, r_in: float, r_out: float, spacing: float, thickness: float = 1.0
              ) -> tuple[np.ndarray, np.ndarray]:
    """(x (n, 2), volume (n,)) of the particles of the ring-seeded disk or annulus."""
    n = max(1, int(round((r_out - r_in) / spacing)))
    dr = (r_out - r_in) / n
    c = np.asarray(center, float)[:2]
    xs, vols = [], []
    for k in range(n):
        r = r_in + (k + 0.5) * dr
        m = max(3, int(round(2.0 * math.pi * r / dr)))
        th = -0.5 * math.pi + 2.0 * math.pi * np.arange(m) / m
        xs.append(c + np.stack([r * np.cos(th), r * np.sin(th)], axis=1))
        vols.append(np.full(m, 2.0 * math.pi * r * dr / m * thickness))
    return np.concatenate(xs), np.concatenate(vols)
