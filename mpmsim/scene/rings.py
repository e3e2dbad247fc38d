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


def ring_seed(center, r_in: float, r_out: float, spacing: float, thickness: float = 1.0,
              half_step: bool = False, quarters: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(x (n, 2), volume (n,)) of the particles of the ring-seeded disk or annulus: ring k's m
    particles at angles -pi/2 + 2 pi j / m (one at the bottom), or with half_step (`seeding:
    rings_half_step`) at -pi/2 + 2 pi (j + 1/2) / m (the two lowest at +-half a spacing from the
    vertical through the centre, none below the centre on it). quarters: each m rounded to a
    multiple of 4 (at least 4), so that with half_step the sectors' edges include the two axes
    through the centre and no particle lies on them: a half or quarter clipped by those axes
    keeps whole sectors, the exact half or quarter of the area."""
    n = max(1, int(round((r_out - r_in) / spacing)))
    dr = (r_out - r_in) / n
    c = np.asarray(center, float)[:2]
    xs, vols = [], []
    for k in range(n):
        r = r_in + (k + 0.5) * dr
        if quarters:
            m = 4 * max(1, int(round(2.0 * math.pi * r / (4.0 * dr))))
        else:
            m = max(3, int(round(2.0 * math.pi * r / dr)))
        th = -0.5 * math.pi + 2.0 * math.pi * (np.arange(m) + (0.5 if half_step else 0.0)) / m
        xs.append(c + np.stack([r * np.cos(th), r * np.sin(th)], axis=1))
        vols.append(np.full(m, 2.0 * math.pi * r * dr / m * thickness))
    return np.concatenate(xs), np.concatenate(vols)


def shell_seed(center, radius: float, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """(x (n, 3), volume (n,)) of the particles of a sphere seeded in concentric shells (`seeding:
    shells`), the 3D analogue of ring_seed: n = round(R / s) shells of width dr = R / n, shell k
    at radius r_k = (k + 1/2) dr. Each shell is cut into n_t = max(2, round(pi r_k / dr)) bands
    of polar angle t (from the bottom pole, -y) of equal width dt = pi / n_t; band j at
    t_j = (j + 1/2) dt holds m_j = 4 max(1, round(2 pi r_k sin t_j / (4 dr))) particles at
    azimuths (i + 1/2) 2 pi / m_j in the x-z plane. So the points are spaced about dr along
    both directions of the shell, the lowest ones (band 0) sit r_k (1 - cos(dt/2)) ~ dr^2 / (8 r_k)
    above the shell's bottom, and the set is mirror-symmetric about the planes x = c_x and
    z = c_z with no point on them (m_j a multiple of 4, azimuths offset by half a step): a quarter
    or half sphere clipped by those planes keeps an exact quarter or half. Each particle carries
    its band sector's exact volume (2 pi / 3) (r_out^3 - r_in^3) (cos t_lo - cos t_hi) / m_j,
    so the volumes sum to 4/3 pi R^3 exactly."""
    n = max(1, int(round(radius / spacing)))
    dr = radius / n
    c = np.asarray(center, float)[:3]
    xs, vols = [], []
    for k in range(n):
        r = (k + 0.5) * dr
        shell = 2.0 * math.pi / 3.0 * ((r + 0.5 * dr) ** 3 - (r - 0.5 * dr) ** 3)
        n_t = max(2, int(round(math.pi * r / dr)))
        dt = math.pi / n_t
        for j in range(n_t):
            t = (j + 0.5) * dt
            m = 4 * max(1, int(round(2.0 * math.pi * r * math.sin(t) / (4.0 * dr))))
            phi = 2.0 * math.pi * (np.arange(m) + 0.5) / m
            rho = r * math.sin(t)
            xs.append(c + np.stack([rho * np.cos(phi), np.full(m, -r * math.cos(t)), rho * np.sin(phi)], axis=1))
            vols.append(np.full(m, shell * (math.cos(j * dt) - math.cos((j + 1) * dt)) / m))
    return np.concatenate(xs), np.concatenate(vols)
