"""Named consistent unit systems.

mpmsim never converts units: every number in a deck is in the deck's unit system and
every output is in the same system. The two systems are consistent (force = mass ×
length / time², stress = force / length², energy = force × length), so the solver is
unit-agnostic. The table below is what the docs and the history's units sidecar print.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class UnitSystem:
    name: str
    length: str
    mass: str
    time: str
    velocity: str
    acceleration: str
    force: str
    stress: str
    energy: str
    density: str
    momentum: str
    max_density: float  # densest plausible solid, to catch g/cm³ typed into g/mm³
    min_density: float  # lighter than any solid or foam (0.1 kg/m³, a tenth of air's)
    note: str


UNIT_SYSTEMS: dict[str, UnitSystem] = {
    "SI": UnitSystem(
        name="SI", length="m", mass="kg", time="s", velocity="m/s", acceleration="m/s^2",
        force="N", stress="Pa", energy="J", density="kg/m^3", momentum="kg m/s",
        max_density=5.0e4, min_density=0.1,
        note="Steel: E = 200e9 Pa, density = 7850 kg/m^3; g = 9.81 m/s^2.",
    ),
    "mm-g-ms": UnitSystem(
        name="mm-g-ms", length="mm", mass="g", time="ms", velocity="m/s (= mm/ms)",
        acceleration="mm/ms^2 (= 1000 m/s^2)", force="N", stress="MPa", energy="mJ (= N mm)",
        density="g/mm^3 (1 g/cm^3 = 0.001 g/mm^3)", momentum="g m/s (= N ms)",
        max_density=0.05, min_density=1e-10,
        note=("The consistent system NairnMPM users work in: N and MPa. Density is in g/mm^3, "
              "so aluminium is 0.00278, not 2.78; g = 9.81e-3 mm/ms^2."),
    ),
}


# the fastest elastic wave of any solid (diamond: 18 km/s): a faster one is a unit mistake
# (c = sqrt(M / rho) is in m/s in both systems: MPa / (g/mm^3) = (m/s)^2)
MAX_WAVE_SPEED = 2.0e4  # m/s


def unit_system(name: str) -> UnitSystem:
    return UNIT_SYSTEMS[name]
