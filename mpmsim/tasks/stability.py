"""Task: stop the run, with when/where/which material, when the state goes bad.

Kernels flag the first bad particle they meet (NaN/Inf, J <= 0, left the grid); this task
also watches kinetic energy against the energy put into the system.
"""

from __future__ import annotations

import numpy as np

from ..deck.units import unit_system
from ..errors import InstabilityError
from ..globals import INTERNAL, KINETIC, STRAIN, particle_sums
from ..shapes import SHAPE_BAD_MESSAGES
from .stress import BAD_MESSAGES

MESSAGES = {**BAD_MESSAGES, **SHAPE_BAD_MESSAGES}

REMEDY = ("try a smaller time.cfl, update.scheme: pic, or update.stress: usavg; raise "
          "stability.energy_tolerance to accept the drift")


def describe_particle(state, p: int) -> str:
    P = state.particles
    name = state.materials.deformable[int(P.mat[p])]
    length = unit_system(state.scene.deck.units).length
    pos = ", ".join(f"{c:.6g}" for c in P.x[p])
    return f"particle {p} (material '{name}', body {int(P.body[p])}) at ({pos}) {length}"


def where(state) -> str:
    """The failing step: its number (1-based) and its end time."""
    tu = unit_system(state.scene.deck.units).time
    return f"step {state.step + 1}, t = {state.t + state.dt:.6g} {tu}"


def excess_text(excess: float, supplied: float) -> str:
    return f"{100 * excess / supplied:.1f}%" if supplied > 0.0 else f"{excess:.4g}"


def check_stability(state) -> None:
    fl = state.flags
    if fl.bad_particle >= 0:
        what = MESSAGES[fl.bad_code].format(value=fl.bad_value)
        raise InstabilityError(f"unstable at {where(state)}: {describe_particle(state, fl.bad_particle)}: {what}",
                               state.t, state.step)
    stab = state.scene.deck.stability
    if (state.step + 1) % stab.check_every == 0:
        sums = particle_sums(state)
        total = sums[KINETIC] + sums[STRAIN] + sums[INTERNAL] + state.interface_energy  # interfaces store energy
        supplied = state.energy0 + state.work_in
        excess = total - supplied
        if excess > stab.energy_tolerance * (state.energy0 + abs(state.work_in)) + state.energy_floor:
            P = state.particles
            p = int(np.argmax(np.sum(P.v**2, axis=1)))
            stored = f" + {state.interface_energy:.4g} (interfaces)" if state.interface_energy else ""
            raise InstabilityError(
                f"unstable at {where(state)}: energy grew without a source: kinetic + strain + internal = "
                f"{sums[KINETIC]:.4g} + {sums[STRAIN]:.4g} + {sums[INTERNAL]:.4g}{stored} exceeds the energy supplied "
                f"({supplied:.4g}) by "
                f"{excess_text(excess, supplied)}; fastest is {describe_particle(state, p)}; {REMEDY}",
                state.t, state.step)
    if state.rigid.n:
        R, g = state.rigid, state.grid
        out = np.any((R.x < g.domain_lo) | (R.x > g.domain_hi), axis=1)
        if fl.bad_rigid >= 0:
            out[fl.bad_rigid] = True
        if out.any():
            name = state.materials.rigid[int(R.mat[np.argmax(out)])]
            raise InstabilityError(f"stopped at {where(state)}: rigid material '{name}' left the grid domain; "
                                   "enlarge grid.domain", state.t, state.step)
