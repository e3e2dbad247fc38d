"""Shock measurements on particle data (docs/shock.md): the linear Us-up Hugoniot of the
Mie–Grüneisen EOS, front position and plateau pressure of a 1D-like bar, profiles for the
LR paper's Fig. 7. Used by tests/validation/test_shock.py and bench/shock.py.

Profiles are per particle *column* (particles with the same initial x, averaged over the
bar's height), in the initial (Lagrangian) coordinate x0 and the current x.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def hugoniot(K: float, rho0: float, S1: float, up: float) -> tuple[float, float, float]:
    """(Us, P, eta) behind a steady shock driven at particle speed up: Us = C0 + S1 up,
    P = rho0 Us up, eta = up / Us, C0 = sqrt(K / rho0)."""
    Us = np.sqrt(K / rho0) + S1 * up
    return Us, rho0 * Us * up, up / Us


@dataclass
class Profile:
    x0: np.ndarray  # column initial positions, increasing
    x: np.ndarray  # column mean current positions
    p: np.ndarray  # column mean pressure


def columns(x0: np.ndarray, x: np.ndarray, p: np.ndarray, spacing: float) -> Profile:
    """Average particles over columns of equal initial x (`spacing` = particle spacing)."""
    col = np.floor(x0[:, 0] / spacing).astype(np.int64)
    col -= col.min()
    cnt = np.bincount(col)
    keep = cnt > 0
    mean = lambda a: (np.bincount(col, weights=a) / np.maximum(cnt, 1))[keep]  # noqa: E731
    return Profile(mean(x0[:, 0]), mean(x[:, 0]), mean(p))


def crossing(coord: np.ndarray, p: np.ndarray, level: float) -> float:
    """Coordinate where the pressure first reaches `level` coming from the low-x (unshocked)
    side, linearly interpolated between columns."""
    hit = np.nonzero(p >= level)[0]
    if len(hit) == 0 or hit[0] == 0:
        raise ValueError(f"no crossing of {level:g} from the unshocked side")
    i = hit[0]
    return float(coord[i - 1] + (level - p[i - 1]) / (p[i] - p[i - 1]) * (coord[i] - coord[i - 1]))


@dataclass
class Front:
    x: float  # current position of the half-plateau crossing
    x0: float  # the same in initial coordinates
    width: float  # x0 distance from the 10% to the 90% crossing
    plateau: float  # mean pressure over the plateau window
    window: tuple[float, float]  # x0 range of that window


def measure_front(prof: Profile, piston_x0: float, piston_margin: float) -> Front:
    """Front and plateau of a shock moving towards -x into material at rest.

    1. A first plateau guess: the median pressure of the columns above half the peak.
    2. The front width w: x0 distance between the 10% and 90% crossings of that guess.
    3. The plateau: the mean column pressure over x0 from 3 w behind the half crossing to
       `piston_margin` before the piston (the post-shock ringing averages out there).
    4. The front: the current x where the pressure crosses half that plateau."""
    p = prof.p
    guess = float(np.median(p[p > 0.5 * p.max()]))
    half0 = crossing(prof.x0, p, 0.5 * guess)
    width = crossing(prof.x0, p, 0.9 * guess) - crossing(prof.x0, p, 0.1 * guess)
    lo, hi = half0 + 3.0 * width, piston_x0 - piston_margin
    win = (prof.x0 > lo) & (prof.x0 < hi)
    if win.sum() < 4:
        raise ValueError(f"plateau window x0 in ({lo:.3g}, {hi:.3g}) holds {win.sum()} columns: run longer")
    plateau = float(p[win].mean())
    return Front(crossing(prof.x, p, 0.5 * plateau), crossing(prof.x0, p, 0.5 * plateau), width, plateau, (lo, hi))


def shock_speed(times, profiles: list[Profile], plateau: float) -> tuple[float, list[float]]:
    """(Us, front positions): the current x where each profile crosses half the (steady)
    plateau, and minus the slope of a least-squares line through them."""
    xs = [crossing(prof.x, prof.p, 0.5 * plateau) for prof in profiles]
    return float(-np.polyfit(np.asarray(times), xs, 1)[0]), xs


def run_with_profiles(sim, times, spacing: float) -> list[tuple[float, Profile]]:
    """Run a Simulation to its end, keeping the pressure profile by reference position at the
    first step at or past each of `times`."""
    snaps: list[tuple[float, Profile]] = []

    def grab(st):
        if len(snaps) < len(times) and st.t >= times[len(snaps)] * (1 - 1e-9):
            P = st.particles
            snaps.append((st.t, columns(P.x0, P.x, P.pressure, spacing)))

    sim.run(progress=grab)
    return snaps
