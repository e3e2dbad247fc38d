"""Compiled dispatch over the material models a scene uses: a kernel that needs a per-particle
model function (the strain energy of each particle, whatever its material) takes a dispatcher
built here for the scene's models, bound as a constant (parallel.specialize), so registered
models plug in without an edit of the kernel and a scene compiles only its models."""

from __future__ import annotations

from functools import cache

import numpy as np
from numba import njit

from ..parallel import specialize
from .model import model_of


@njit(cache=True, inline="always")
def _none(code, pr, F3, s, J):
    return np.nan


CODE, ENERGY, REST = -1, None, _none


def energy_link(code, pr, F3, s, J):
    """Strain energy per current volume of a particle of model `code`: this link's model, or
    the rest of the chain (NaN past its end: a model the scene does not use)."""
    if code == CODE:
        return ENERGY(pr, F3, s, J)
    return REST(code, pr, F3, s, J)


@cache
def energy_dispatch(codes: tuple):
    """(tag, compiled dispatcher) for the models with these type codes: a chain of links, one
    per model."""
    tag, rest = "none", _none
    for code in reversed(codes):
        m = model_of(code)
        tag = f"{m.tag}_{tag}" if tag != "none" else m.tag
        rest = njit(cache=True, inline="always")(specialize(energy_link, tag, CODE=m.code, ENERGY=m.energy,
                                                            REST=rest))
    return tag, rest
