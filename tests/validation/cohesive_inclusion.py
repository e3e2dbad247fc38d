"""A debonding spherical inclusion (issue 78, Must show 6): one stiff elastic sphere bonded to an
elastic matrix by a cohesive law, the matrix pulled in uniaxial tension, axisymmetric (x = r,
y = z), and the theory it is held to.

The specimen: a sphere of radius R = 1 mm (E_i = 20000 MPa, nu_i = 0.25) at the centre of a
matrix cylinder of radius and half-height 5 R (E_m = 2000 MPa, nu_m = 0.35), the quarter r, z >= 0
(the equator a roller plane, the axis a symmetry line); volume fraction 2/375 = 0.53%. The
sphere and a matrix shell out to 2 R are seeded in rings that follow the sphere; the rest of the
matrix (a polygon outside that shell) on the lattice: a lattice staircase at the interface puts
its corners' openings near 45 degrees and starts the debond there. The top face carries a
traction ramped linearly to `s_max` over `ramp`, quasi-static under grid damping. The cohesive
law (bilinear, Dn = Dt = D, peak traction sigma_c in both modes) with its normal radial from
the centre: from the sphere (the first material) to the matrix.

Goodier (1933, J. Appl. Mech. 1, 39-44) for a bonded sphere, in Eshelby's (1957,
doi:10.1098/rspa.1957.0133) form: with alpha =
(1 + nu_m) / (3 (1 - nu_m)), beta = 2 (4 - 5 nu_m) / (15 (1 - nu_m)), the stress inside the
sphere is uniform, its bulk part B_K s / 3 and its deviatoric part B_G times the applied one,
B_K = K_i / (K_m + alpha (K_i - K_m)), B_G = G_i / (G_m + beta (G_i - G_m)). On the interface
at polar angle theta (from the loading axis) the normal traction is s (sigma_zz cos^2 theta +
sigma_rr sin^2 theta), sigma_zz = (B_K + 2 B_G) / 3, sigma_rr = (B_K - B_G) / 3, and the shear
traction s B_G sin(2 theta) / 2. For these materials the pole's traction is 1.7519 s, the
largest anywhere under the quadratic onset criterion with equal peaks, so the debond starts at
the pole at s = sigma_c / 1.7519.

Hashin and Shtrikman's bounds (1963, doi:10.1016/0022-5096(63)90060-7) on the moduli of the
composite at the sphere's volume fraction bound the specimen's stiffness before the debond (to
first order in the dilute fraction, the lower bound is the dilute Eshelby solution)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mpmsim.deck.loader import as_loaded_deck
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation


def bulk(E: float, nu: float) -> float:
    return E / (3.0 * (1.0 - 2.0 * nu))


def shear(E: float, nu: float) -> float:
    return E / (2.0 * (1.0 + nu))


@dataclass
class Inclusion:
    R: float = 1.0
    E_i: float = 20000.0
    nu_i: float = 0.25
    rho_i: float = 0.0025
    E_m: float = 2000.0
    nu_m: float = 0.35
    rho_m: float = 0.0012
    size: float = 5.0  # the matrix cylinder's radius and half-height
    shell: float = 2.0  # the matrix seeded in rings out to this radius
    cell: float = 0.1
    D: float = 3.0e5  # intact stiffness (MPa/mm)
    peak: float = 10.0  # sigma_c = tau_c (MPa)
    G_c: float = 0.05  # N/mm, both modes
    s_max: float = 9.0  # MPa, the applied stress at the end of the ramp
    ramp: float = 0.1  # ms
    damping: float = 800.0  # grid damping (1/ms)
    bonded: bool = True  # False: the sphere is matrix (the matrix alone, seeded the same)
    extra: dict = field(default_factory=dict)

    def goodier(self) -> tuple[float, float, float]:
        """(sigma_zz, sigma_rr, B_G) per unit applied stress: the sphere's uniform stress and
        its deviatoric concentration."""
        Km, Gm, Ki, Gi = bulk(self.E_m, self.nu_m), shear(self.E_m, self.nu_m), bulk(self.E_i, self.nu_i), shear(
            self.E_i, self.nu_i)
        alpha = (1.0 + self.nu_m) / (3.0 * (1.0 - self.nu_m))
        beta = 2.0 * (4.0 - 5.0 * self.nu_m) / (15.0 * (1.0 - self.nu_m))
        BK = Ki / (Km + alpha * (Ki - Km))
        BG = Gi / (Gm + beta * (Gi - Gm))
        return (BK + 2.0 * BG) / 3.0, (BK - BG) / 3.0, BG

    def tractions(self, theta):
        """Goodier's normal and shear interface tractions per unit applied stress at polar angle
        theta (radians from the loading axis)."""
        szz, srr, BG = self.goodier()
        return szz * np.cos(theta) ** 2 + srr * np.sin(theta) ** 2, 0.5 * BG * np.sin(2.0 * theta)

    @property
    def onset_stress(self) -> float:
        """The applied stress at which the pole's traction reaches the peak."""
        return self.peak / self.goodier()[0]

    @property
    def fraction(self) -> float:
        return (2.0 / 3.0 * self.R ** 3) / (self.size ** 2 * self.size)

    def hashin_shtrikman(self) -> tuple[float, float]:
        """Lower and upper Hashin-Shtrikman bounds on Young's modulus at the volume fraction."""
        c = self.fraction
        Km, Gm, Ki, Gi = bulk(self.E_m, self.nu_m), shear(self.E_m, self.nu_m), bulk(self.E_i, self.nu_i), shear(
            self.E_i, self.nu_i)

        def bound(K1, G1, K2, G2, c2):  # phase 1 the reference (the bound's matrix), phase 2 at fraction c2
            K = K1 + c2 / (1.0 / (K2 - K1) + 3.0 * (1.0 - c2) / (3.0 * K1 + 4.0 * G1))
            G = G1 + c2 / (1.0 / (G2 - G1) + 6.0 * (1.0 - c2) * (K1 + 2.0 * G1) / (5.0 * G1 * (3.0 * K1 + 4.0 * G1)))
            return 9.0 * K * G / (3.0 * K + G)

        return bound(Km, Gm, Ki, Gi, c), bound(Ki, Gi, Km, Gm, 1.0 - c)

    def deck(self) -> dict:
        s, R = self.size, self.R
        arc = [[self.shell * math.sin(a), self.shell * math.cos(a)] for a in np.linspace(0.0, 0.5 * math.pi, 91)]
        inner = "incl" if self.bonded else "matrix"
        law = {"law": "cohesive", "Dn": self.D, "Dt": self.D,
               "cohesive": {"peak_traction": self.peak, "G_Ic": self.G_c}}
        data = {
            "title": "A stiff sphere debonding from a matrix in uniaxial tension (Goodier)",
            "units": "mm-g-ms", "analysis": "axisymmetric",
            "grid": {"cell_size": self.cell, "domain": {"min": [0.0, 0.0], "max": [s + 0.5, s + 0.5]},
                     "boundaries": {"ymin": "roller"}},
            "materials": {"incl": {"type": "linear_elastic", "E": self.E_i, "nu": self.nu_i, "density": self.rho_i},
                          "matrix": {"type": "linear_elastic", "E": self.E_m, "nu": self.nu_m, "density": self.rho_m}},
            "bodies": [
                {"name": "sphere", "shape": "circle", "center": [0.0, 0.0], "radius": R, "material": inner,
                 "seeding": "rings_half_step", "clip": {"min": [0.0, 0.0], "max": [R, R]}},
                {"name": "shell", "shape": "annulus", "center": [0.0, 0.0], "inner_radius": R,
                 "outer_radius": self.shell, "material": "matrix", "seeding": "rings_half_step",
                 "clip": {"min": [0.0, 0.0], "max": [self.shell, self.shell]}},
                {"name": "matrix", "shape": "polygon", "vertices": arc + [[s, 0.0], [s, s], [0.0, s]],
                 "material": "matrix"}],
            "loads": [{"region": {"min": [0.0, s - self.cell], "max": [s, s]}, "face": "ymax",
                       "traction": [0.0, self.s_max], "ramp": self.ramp}],
            "contact": {"normal": "specified", "normal_center": [0.0, 0.0], "default": law},
            "damping": {"grid": self.damping},
            "time": {"end": self.ramp, "cfl": 0.5},
            "output": {"history_interval": self.ramp / 100.0},
        }
        if not self.bonded:  # one material: no contact
            del data["contact"], data["materials"]["incl"]
        data.update(self.extra)
        return data


@dataclass
class InclusionRun:
    onset: float | None  # the far-field stress when a pole particle (within 10 degrees) first damages
    onset_angle: float | None  # its polar angle (degrees)
    early: float  # the most damage on any particle (with a share of the interface) before that
    stress: np.ndarray  # the far-field stress at the recorded rows
    stretch: np.ndarray  # the top face's mean axial displacement over the half-height
    theta: np.ndarray  # the bonded sphere particles' polar angles (degrees)
    damage: np.ndarray  # (rows, particles) their damage at the recorded rows


def run_inclusion(spec: Inclusion, every: int = 25, threads: int | None = 1) -> InclusionRun:
    sim = Simulation(build_scene(as_loaded_deck(spec.deck(), "inclusion", Path("."))), out_dir=None, threads=threads)
    P = sim.state.particles
    top = P.x0[:, 1] > spec.size - 0.5 * spec.cell
    far = P.x0[:, 1] > 0.6 * spec.size  # the matrix from 3 R up: the sphere's disturbance there ~ (R / z)^3
    sphere = np.hypot(P.x0[:, 0], P.x0[:, 1]) < spec.R
    theta0 = np.degrees(np.arctan2(P.x0[:, 0], P.x0[:, 1]))
    state = {"onset": None, "angle": None, "early": 0.0}
    rows, damage = [], []
    pick: list[np.ndarray] = []

    def record(st) -> None:
        s = far_stress(st.particles)
        d = st.particles.interface_damage
        if d is not None and state["onset"] is None:
            share = st.particles.interface_area
            real = share > 0.2 * np.median(share[share > 0.0]) if (share > 0.0).any() else share > 0.0
            pole = real & (theta0 < 10.0) & (d > 0.0)
            state["early"] = max(state["early"], float(d[real].max(initial=0.0)))
            if pole.any():
                state["onset"], state["angle"] = s, float(theta0[pole][np.argmax(d[pole])])
        if st.step % every == 0:
            rows.append((s, (st.particles.x[top, 1] - P.x0[top, 1]).mean() / spec.size))
            if d is not None:
                if not pick:
                    pick.append(sphere & st.particles.interface_bonded)
                damage.append(d[pick[0]].copy())

    def far_stress(Q) -> float:
        """The mean axial stress of the matrix far from the sphere (volume-weighted): what the
        ramp has loaded the specimen to (the applied traction runs ahead of it by what grid
        damping holds back, some 8% at the onset)."""
        return float(np.sum(Q.stress[far, 1] * Q.vol[far]) / np.sum(Q.vol[far]))

    sim.run(progress=record)
    rows = np.array(rows)
    n = len(damage)
    return InclusionRun(state["onset"], state["angle"], state["early"], rows[-n:, 0], rows[-n:, 1],
                        theta0[pick[0]] if pick else np.zeros(0), np.array(damage))
