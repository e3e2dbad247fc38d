"""Cohesive beam specimens (issue 78) and their beam theories: the double cantilever beam (DCB)
opened by prescribed end displacements (mode I), and the end-notched flexure (ENF, mode II;
class ENF).

The DCB: two arms of one elastic material (E, nu; plane strain, unit thickness), each h thick and
L long, bonded by a bilinear cohesive law on y = 0 except over a pre-crack of length a0 from the
load line (`cohesive.precrack`). Each arm is pulled at its end through a soft tab (E / 20, one
cell wide, 2h tall) whose far end a rigid grip moves at +-V (velocity ramped over `ramp`): the
tab passes the force and leaves the arm's end free to rotate (its bending stiffness is under 0.4%
of the arm's). The opening is the load line's arm particles' mean displacement, top less bottom.

Beam theory (plane strain: E' = E / (1 - nu^2)), with the root rotation correction of the arm
a -> a + chi h, chi = sqrt(E'/(11 G)) (3 - 2 (g / (1 + g))^2), g = 1.18 E'/G (Williams 1989,
doi:10.1016/0266-3538(89)90058-4; G the shear modulus; isotropic: chi = 0.92):
compliance delta / P = 8 (a + chi h)^3 / (E' B h^3); energy release rate
G_I = 12 P^2 (a + chi h)^2 / (E' B^2 h^3). Propagation (G_I = G_Ic): P (a + chi h) = M,
M = sqrt(G_Ic E' B^2 h^3 / 12), so P = sqrt(8 M^3 / (E' B h^3 delta)) on the propagation branch,
and the peak (initiation) load is M / (a0 + chi h)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import math

import numpy as np

from mpmsim.deck.loader import as_loaded_deck
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation


@dataclass
class DCB:
    E: float = 3000.0  # MPa
    nu: float = 0.3
    density: float = 0.0012  # g/mm^3
    h: float = 2.0  # arm thickness (mm)
    length: float = 40.0
    a0: float = 20.0  # pre-crack from the load line
    cell: float = 0.5
    peak: float = 22.0  # MPa
    G_c: float = 0.3  # N/mm
    D: float = 5000.0  # intact stiffness (MPa/mm)
    V: float = 0.5  # grip speed (mm/ms), each arm
    ramp: float = 1.5  # ms
    end: float = 8.2  # ms
    offset: float = 0.0  # the interface's height above a grid line (cells)
    tab: float | None = None  # the tabs' (and grips') width; default one cell
    extra: dict = field(default_factory=dict)  # deck entries replaced

    @property
    def E_prime(self) -> float:
        return self.E / (1.0 - self.nu ** 2)

    @property
    def chi(self) -> float:
        shear = self.E / (2.0 * (1.0 + self.nu))
        g = 1.18 * self.E_prime / shear
        return float(np.sqrt(self.E_prime / (11.0 * shear)) * (3.0 - 2.0 * (g / (1.0 + g)) ** 2))

    @property
    def M(self) -> float:
        return float(np.sqrt(self.G_c * self.E_prime * self.h ** 3 / 12.0))

    def compliance(self, a: float) -> float:
        return 8.0 * (a + self.chi * self.h) ** 3 / (self.E_prime * self.h ** 3)

    @property
    def peak_load(self) -> float:
        return self.M / (self.a0 + self.chi * self.h)

    def propagation_load(self, delta):
        return np.sqrt(8.0 * self.M ** 3 / (self.E_prime * self.h ** 3 * np.asarray(delta)))

    @property
    def tab_width(self) -> float:
        return self.cell if self.tab is None else self.tab

    @property
    def load_line(self) -> float:
        return 0.5 * self.tab_width

    def deck(self) -> dict:
        c, h, y0, w = self.cell, self.h, self.offset * self.cell, self.tab_width
        tab = 2.0 * h
        elastic = {"type": "linear_elastic", "E": self.E, "nu": self.nu, "density": self.density}
        soft = dict(elastic, E=self.E / 20.0)
        table = lambda s: {"times": [0.0, self.ramp], "values": [[0.0, 0.0], [0.0, s * self.V]]}  # noqa: E731
        tip = self.load_line + self.a0
        top = c * math.ceil((h + tab + 3.0 * c + self.V * self.end + 1.0) / c)  # the grips' travel; grid lines on y = 0
        law = {"between": ["upper", "lower"], "law": "cohesive", "Dn": self.D, "Dt": self.D,
               "cohesive": {"peak_traction": self.peak, "G_Ic": self.G_c,
                            "precrack": [{"min": [-1.0, y0 - 0.5 * h], "max": [tip, y0 + 0.5 * h]}]}}
        data = {
            "title": "double cantilever beam", "units": "mm-g-ms", "analysis": "plane_strain", "thickness": 1.0,
            "grid": {"cell_size": c, "domain": {"min": [-2.0 * c, -top], "max": [self.length + 2.0 * c, top]}},
            "materials": {"upper": elastic, "lower": elastic, "tab_u": soft, "tab_l": soft,
                          "grip_u": {"type": "rigid", "constrain": ["y"], "velocity": table(1.0)},
                          "grip_l": {"type": "rigid", "constrain": ["y"], "velocity": table(-1.0)}},
            "bodies": [{"shape": "rectangle", "min": [0.0, y0], "max": [self.length, y0 + h], "material": "upper"},
                       {"shape": "rectangle", "min": [0.0, y0 - h], "max": [self.length, y0], "material": "lower"},
                       {"shape": "rectangle", "min": [0.0, y0 + h], "max": [w, y0 + h + tab], "material": "tab_u"},
                       {"shape": "rectangle", "min": [0.0, y0 - h - tab], "max": [w, y0 - h], "material": "tab_l"},
                       {"shape": "rectangle", "min": [0.0, y0 + h + tab], "max": [w, y0 + h + tab + c],
                        "material": "grip_u"},
                       {"shape": "rectangle", "min": [0.0, y0 - h - tab - c], "max": [w, y0 - h - tab],
                        "material": "grip_l"}],
            "contact": {"normal": "specified", "normal_vector": [0.0, -1.0], "default": {"law": "frictionless"},
                        "pairs": [law, {"between": ["upper", "tab_u"], "law": "none"},
                                  {"between": ["lower", "tab_l"], "law": "none"}]},
            "time": {"end": self.end, "cfl": 0.5},
            "output": {"history_interval": self.end / 400.0},
        }
        data.update(self.extra)
        return data


@dataclass
class Curve:
    t: np.ndarray
    load: np.ndarray  # the loading body's force on the specimen (per unit thickness)
    opening: np.ndarray  # DCB: the load-line opening; ENF: the mid-span deflection
    fracture_energy: np.ndarray
    debonded: np.ndarray  # debonded area (per unit thickness: crack length)
    lost: np.ndarray  # the grips' work less kinetic and strain energy
    sim: Simulation


def run_dcb(spec: DCB, every: int = 20, threads: int | None = 1) -> Curve:
    sim = Simulation(build_scene(as_loaded_deck(spec.deck(), "dcb", Path("."))), out_dir=None, threads=threads)
    P = sim.state.particles
    near = np.abs(P.x0[:, 0] - spec.load_line) < 0.5 * spec.tab_width
    y0 = spec.offset * spec.cell
    top = near & (P.x0[:, 1] > y0) & (P.x0[:, 1] < y0 + spec.h)
    bottom = near & (P.x0[:, 1] < y0) & (P.x0[:, 1] > y0 - spec.h)
    rows = []

    def record(st) -> None:
        if st.step % every == 0:
            x = st.particles.x
            u = (x[top, 1] - P.x0[top, 1]).mean() - (x[bottom, 1] - P.x0[bottom, 1]).mean()
            rows.append((st.t, u))

    sim.run(progress=record)
    return curve(sim, np.array(rows), "F_grip_u_y")


def curve(sim: Simulation, rows: np.ndarray, force: str) -> Curve:
    """The run's Curve at the recorded (time, opening) rows, the load from history column `force`."""
    col = sim.recorder.column
    t_h = col(sim.recorder.names[0])
    on = lambda values: np.interp(rows[:, 0], t_h, values)  # noqa: E731
    lost = on(col("external_work") - col("kinetic_energy") - col("strain_energy"))
    return Curve(rows[:, 0], on(np.abs(col(force))), rows[:, 1], on(col("fracture_energy")),
                 on(col("debonded_area")), lost, sim)


@dataclass
class ENF:
    """The end-notched flexure specimen (mode II): a beam of two bonded arms (each h thick, one
    elastic material, plane strain, unit thickness) on two rigid rollers (circles of radius
    `roller`, frictionless contact) 2L apart, pressed at mid-span by a rigid nose one cell wide
    that imposes a downward velocity V (ramped over `ramp`) on the nodes it touches; the
    pre-crack runs from the beam's left end (an `overhang` beyond the left roller) to a0 past
    that roller, its faces sliding frictionless. The deflection is the mid-span column's mean
    displacement less the rollers' columns'.

    Beam theory (plane strain E'), with the crack-tip correction of Wang and Williams (1992,
    doi:10.1016/0266-3538(92)90097-M), a -> a + 0.42 chi h (chi of the DCB), and the Timoshenko
    shear deflection of the beam (shear correction 5/6):
    compliance delta / P = (3 (a + 0.42 chi h)^3 + 2 L^3) / (8 E' B h^3) + 0.3 L / (G B h);
    G_II = 9 P^2 (a + 0.42 chi h)^2 / (16 E' B^2 h^3). Propagation (G_II = G_IIc):
    P (a + 0.42 chi h) = N, N = sqrt(16 E' B^2 h^3 G_IIc / 9); the peak (initiation) load is
    N / (a0 + 0.42 chi h). Growth is stable for a0 above ~0.7 L."""

    E: float = 3000.0
    nu: float = 0.3
    density: float = 0.0012
    h: float = 2.0
    L: float = 25.0  # half span
    a0: float = 19.0
    overhang: float = 2.0
    roller: float = 1.5  # radius of the rollers
    cell: float = 0.5
    peak: float = 8.0  # mode I peak traction
    shear_peak: float = 15.0
    G_Ic: float = 0.3
    G_IIc: float = 0.6
    D: float = 2000.0
    V: float = 0.25
    ramp: float = 0.5
    end: float = 12.0
    extra: dict = field(default_factory=dict)

    @property
    def E_prime(self) -> float:
        return self.E / (1.0 - self.nu ** 2)

    @property
    def shear_modulus(self) -> float:
        return self.E / (2.0 * (1.0 + self.nu))

    @property
    def delta_a(self) -> float:
        return 0.42 * DCB(E=self.E, nu=self.nu).chi * self.h

    @property
    def N(self) -> float:
        return float(np.sqrt(16.0 * self.E_prime * self.h ** 3 * self.G_IIc / 9.0))

    def compliance(self, a):
        a = np.asarray(a) + self.delta_a
        return ((3.0 * a ** 3 + 2.0 * self.L ** 3) / (8.0 * self.E_prime * self.h ** 3)
                + 0.3 * self.L / (self.shear_modulus * self.h))

    @property
    def peak_load(self) -> float:
        return self.N / (self.a0 + self.delta_a)

    def propagation_deflection(self, load):
        """The deflection on the propagation branch at a load: the crack a = N / P - 0.42 chi h."""
        load = np.asarray(load)
        return load * self.compliance(self.N / load - self.delta_a)

    @property
    def support(self) -> float:
        return self.overhang

    @property
    def nose(self) -> float:
        return self.overhang + self.L

    def deck(self) -> dict:
        c, h = self.cell, self.h
        elastic = {"type": "linear_elastic", "E": self.E, "nu": self.nu, "density": self.density}
        span = self.overhang + 2.0 * self.L
        length = span + self.overhang
        down = {"times": [0.0, self.ramp], "values": [[0.0, 0.0], [0.0, -self.V]]}
        law = {"between": ["upper", "lower"], "law": "cohesive", "Dn": self.D, "Dt": self.D,
               "cohesive": {"peak_traction": self.peak, "shear_peak_traction": self.shear_peak,
                            "G_Ic": self.G_Ic, "G_IIc": self.G_IIc,
                            "precrack": [{"min": [-1.0, -0.5 * h], "max": [self.support + self.a0, 0.5 * h]}]}}
        R = self.roller
        rest = lambda x, y: {"shape": "circle", "center": [x, y], "radius": R}  # noqa: E731
        margin = c * math.ceil((h + 2.0 * R + 2.0 * c) / c)
        data = {
            "title": "end-notched flexure", "units": "mm-g-ms", "analysis": "plane_strain", "thickness": 1.0,
            "grid": {"cell_size": c, "domain": {"min": [-2.0 * c, -margin], "max": [length + 2.0 * c, margin]}},
            "materials": {"nose": {"type": "rigid", "constrain": ["y"], "velocity": down},
                          "upper": elastic, "lower": elastic,
                          "support": {"type": "rigid", "mode": "contact"}},
            "bodies": [{"shape": "rectangle", "min": [0.0, 0.0], "max": [length, h], "material": "upper"},
                       {"shape": "rectangle", "min": [0.0, -h], "max": [length, 0.0], "material": "lower"},
                       {"shape": "rectangle", "min": [self.nose - 0.5 * c, h], "max": [self.nose + 0.5 * c, h + c],
                        "material": "nose"},
                       dict(rest(self.support, -h - R), material="support"),
                       dict(rest(span, -h - R), material="support")],
            # separation from positions: the rollers touch the beam at a point (with the displacement
            # separation every node the two share acts as touching, and the beam bears on the
            # rollers' inner edges, 1.3 mm inside the span)
            "contact": {"normal": "specified", "normal_vector": [0.0, -1.0], "separation": "cutoff",
                        "default": {"law": "frictionless"}, "pairs": [law]},
            "time": {"end": self.end, "cfl": 0.5},
            "output": {"history_interval": self.end / 400.0},
        }
        data.update(self.extra)
        return data


def run_enf(spec: ENF, every: int = 20, threads: int | None = 1) -> Curve:
    sim = Simulation(build_scene(as_loaded_deck(spec.deck(), "enf", Path("."))), out_dir=None, threads=threads)
    P = sim.state.particles
    beam = np.abs(P.x0[:, 1]) < spec.h
    column = lambda x: beam & (np.abs(P.x0[:, 0] - x) < 0.5 * spec.cell)  # noqa: E731
    mid = column(spec.nose)
    ends = column(spec.support) | column(spec.support + 2.0 * spec.L)
    rows = []

    def record(st) -> None:
        if st.step % every == 0:
            uy = st.particles.x[:, 1] - P.x0[:, 1]
            rows.append((st.t, uy[ends].mean() - uy[mid].mean()))

    sim.run(progress=record)
    return curve(sim, np.array(rows), "F_nose_y")
