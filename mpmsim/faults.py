"""What kernels can find wrong with a particle, as codes they flag, and the words for each.

Kernels flag the first bad particle they meet with one of these codes (and a value); the run
loop turns the flag into the stop message. Shape-function codes (a support leaving the grid,
a CPDI domain spanning or inverting) live with the shape functions and are merged here.
"""

from __future__ import annotations

from .shapes import SHAPE_BAD_MESSAGES

BAD_NONE = 0
BAD_NAN = 1
BAD_INVERTED = 2
BAD_LEFT_GRID = 3
BAD_ENERGY = 4
BAD_EOS = 8

MESSAGES = {
    BAD_EOS: "Mie–Grüneisen compression reached eta = 1 - J = 1/S1 (1 - S1 eta = {value:.4g}), where the "
             "pressure of Eq. (51) has no finite value: the load is beyond the EOS (check S1 and the "
             "drive), or the run is unstable (try a smaller time.cfl or artificial viscosity)",
    BAD_NAN: "stress or velocity is not finite (NaN/Inf)",
    BAD_INVERTED: "J = {value:.4g} <= 0: the particle inverted",
    BAD_LEFT_GRID: "the particle left the grid domain",
    **SHAPE_BAD_MESSAGES,
}
