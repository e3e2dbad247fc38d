"""Adaptive barrier stiffness kappa: the IPC rule (Li et al. 2020, doi:10.1145/3386569.3392425,
supplement; the IPC toolkit's initial_barrier_stiffness / update_barrier_stiffness) in the
distance form of potential.py, with the implicit step's scaling. docs/bfemp.md.

The incremental potential is E = 1/2 |y - y~|_M^2 + c (Psi + sum_p w_p b(d; kappa)), c = 2 zeta beta
dt^2, b = kappa btilde, btilde''(d) ~ dhat / d^2 for d << dhat.

- Bounds. IPC asks the barrier's stiffness at a tiny distance d_eps = 1e-8 x (the scene's
  bounding-box diagonal L) to be 1e11 times the average mass: c w kappa_min btilde''(d_eps) =
  1e11 m, so kappa_min = 1e11 m d_eps^2 / (c w dhat) = 1e-5 m L^2 / (c w dhat) (m the mean lumped
  mass of the unknowns, w the mean contact weight), and kappa_max = 100 kappa_min. c kappa_min
  does not depend on the time step: the barrier keeps one stiffness relative to the inertia.
- Initial value, at the first step that starts with pairs within dhat: the kappa whose barrier
  gradient best balances the rest of the potential's gradient (inertia, strain, gravity) in the
  least-squares sense, kappa = -g_B . g_E / |g_B|^2 (g_B the barrier's gradient at kappa = 1),
  clamped to [kappa_min, kappa_max]. Before any contact, kappa_min.
- Raise: after each Newton iteration, if the smallest pair distance was and still is below
  1e-9 L and shrinks, kappa doubles (up to kappa_max). Added here: a Newton solve that has taken
  STALL iterations with pairs within dhat doubles kappa too (and again every STALL iterations).
  A soft barrier lets fast impacts press points deep, where projected Newton crawls with many
  line-search halvings; a stiffer one holds them farther out and converges (docs/bfemp.md).
An explicit `implicit.kappa` in the deck switches all of this off.
"""

from __future__ import annotations

import numpy as np

from ...linalg import dot

MASS_SCALE = 1e11  # IPC's min_barrier_stiffness_scale
TINY = 1e-8  # d_eps / L for the bounds
CLOSE = 1e-9  # distance / L under which a shrinking distance raises kappa
SPAN = 100.0  # kappa_max / kappa_min
STALL = 20  # Newton iterations of one solve in contact after which kappa doubles


def stiffness_bounds(mean_mass: float, diagonal: float, c: float, mean_weight: float, dhat: float):
    """(kappa_min, kappa_max) of the module docstring."""
    kmin = MASS_SCALE * mean_mass * (TINY * diagonal) ** 2 / (c * mean_weight * dhat)
    return kmin, SPAN * kmin


def initial_stiffness(g_barrier: np.ndarray, g_rest: np.ndarray, kmin: float, kmax: float) -> float:
    """The least-squares balance -g_B . g_E / |g_B|^2 clamped to [kmin, kmax] (kmin without pairs)."""
    gb, gr = np.ascontiguousarray(g_barrier, dtype=np.float64), np.ascontiguousarray(g_rest, dtype=np.float64)
    gg = float(dot(gb, gb))
    kappa = -float(dot(gb, gr)) / gg if gg > 0.0 else kmin
    return float(np.clip(kappa, kmin, kmax))


def raised_stiffness(d_before: float, d_now: float, kappa: float, kmax: float, diagonal: float) -> float:
    """kappa doubled (up to kmax) when the smallest distance was and is below 1e-9 L and shrinks."""
    close = CLOSE * diagonal
    if d_before < close and d_now < close and d_now < d_before:
        return min(kmax, 2.0 * kappa)
    return kappa
