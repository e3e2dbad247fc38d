"""The stability suite as data: each known failure reproduced, and the recommended method shown
stable on the same scene. One row = scene, method, metric, threshold and which side of it the
row must land; `test_suite.py` asserts every row, `report.py` writes the table in
docs/stability-suite.md. A new failure mode (or method) is one more `Scenario` in SCENARIOS.

Runs are cached per process (functools.cache), so rows sharing a run (the single-material
column, LR with two passes) run it once.
"""

from __future__ import annotations

import functools
import json
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from mpmsim.deck.overrides import with_overrides
from mpmsim.errors import InstabilityError
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation
from mpmsim.sweep.metrics import cube_bulk_modulus, max_rel_error

from ..conftest import ROOT, deck_from
from ..validation.helpers import example


@dataclass(frozen=True)
class Measured:
    value: float
    stopped: str = ""  # the instability message if the run stopped


@dataclass(frozen=True)
class Scenario:
    failure: str  # the known failure mode this row belongs to
    scene: str
    method: str
    metric: str
    threshold: float
    expect: str  # "above": the failure is reproduced; "below": the method stays within bounds
    measure: Callable[[], Measured]
    unit: str = "%"  # "%": value and threshold are fractions shown in percent
    must_stop: bool | None = None  # True: the run must be stopped as unstable; False: must finish

    @property
    def id(self) -> str:
        return f"{self.scene}: {self.method}".replace(" ", "_")

    def passed(self, m: Measured) -> bool:
        side = m.value > self.threshold if self.expect == "above" else m.value < self.threshold
        stop_ok = self.must_stop is None or bool(m.stopped) == self.must_stop
        return bool(side and stop_ok)


@functools.cache
def _run(name: str, overrides_json: str) -> tuple[Simulation, str]:
    """Run inputs/<name>.yaml with overrides; (simulation, instability message or '')."""
    deck = with_overrides(example(name), json.loads(overrides_json))
    sim = Simulation(build_scene(deck_from(deck, ROOT / "inputs")))
    try:
        sim.run()
    except InstabilityError as exc:
        return sim, str(exc).splitlines()[0]
    return sim, ""


def run(name: str, **overrides) -> tuple[Simulation, str]:
    return _run(name, json.dumps(overrides, sort_keys=True))


# --------------------------------------------------------------- two-block column (LR paper Fig. 5)
COLUMN_5PCT = {"time.end": 5.2}  # 5% strain: CP = 0.8 has failed by then, LR once peaks at 1.4%
CP08 = {"contact.normal": "average_gradient", "contact.separation": "cutoff", "contact.cutoff": 0.8}


def column_error(**method) -> Measured:
    """max |MM - SMM| / SMM of the mean axial stress over 0.2-5% strain (the Fig. 5 metric)."""
    smm, _ = run("column", **COLUMN_5PCT)
    mm, stopped = run("two_blocks", **COLUMN_5PCT, **method)

    def strain(sim):
        return -sim.recorder.column("u_platen_y") / 100.0

    err = max_rel_error(strain(mm), mm.recorder.column("syy"), strain(smm), smm.recorder.column("syy"), 0.002, 0.05)
    return Measured(err, stopped)


# --------------------------------------------------------------- bar stretched to 100% (shape functions)
K, G, RHO = 2450.0, 940.0, 0.001
C0 = float(np.sqrt((K + 4 * G / 3) / RHO))


def uniaxial_sxx(lam):
    """Cauchy stress of the neo-Hookean bar (Eq. 18) in uniaxial strain at stretch lam."""
    return 0.5 * K * (lam - 1 / lam) + (2 * G / 3) * lam ** (-5 / 3) * (lam**2 - 1)


def grip_stretch(sim) -> float:
    """The stretch the grip imposes on the 12 mm bar."""
    return 1.0 + float(sim.state.rigid.disp[0, 0]) / 12.0


def interior_deviation(sim) -> float:
    """max |sxx - exact| / exact over particles two cells from the wall and the grip, exact at
    their mean stretch; if that stretch is more than 0.03 off the grip's the bar tore, and the
    strain it lost, |lam - lam_grip| / (lam_grip - 1), counts too (a torn bar scores ~100%)."""
    P = sim.state.particles
    inside = (P.x0[:, 0] > 2.0) & (P.x0[:, 0] < 10.0)
    lam, grip = float(P.F[inside, 0, 0].mean()), grip_stretch(sim)
    exact = uniaxial_sxx(lam)
    dev = float(np.abs(P.stress[inside, 0] - exact).max() / exact)
    return dev if abs(lam - grip) < 0.03 else max(dev, abs(lam - grip) / (grip - 1.0))


def stretch_deviation(shape: str) -> Measured:
    sim, stopped = run("stretch", shape_function=shape)
    return Measured(interior_deviation(sim), stopped)


# --------------------------------------------------------------- time step on a stiffening material
# The stretch bar taken to stretch 3: the current wave speed rises 1.92x (uniaxial strain,
# Eq. 18), so a step fixed at CFL 0.8 of the initial wave speed ends up at CFL ~1.5.
STRETCH_3 = {"grid.domain": {"min": [0.0, 0.0], "max": [40.0, 1.0]}, "time.end": 6.235}


def wave_speed(lam: float) -> float:
    """Current dilatational wave speed of the bar at stretch lam: c^2 = lam^2 dsxx/dlam / rho0
    (docs/stability.md)."""
    d = 1e-6
    return float(np.sqrt(lam**2 * (uniaxial_sxx(lam + d) - uniaxial_sxx(lam - d)) / (2 * d) / RHO))


def fixed_step_stress() -> Measured:
    """The bar pulled to stretch 3 under a fixed step 0.8 h/c0 (effective CFL dt c(lam) / h 1.54
    by the end, with the exact wave speed): the interior stress error (a torn bar scores ~100%),
    whether or not the run was stopped. Where and whether it stops depends on the last bits of
    the arithmetic (docs/stability.md, "A fixed step on the stretched bar"); the stress it
    leaves does not: ~100% either way, 0.2% at 0.7 h/c0."""
    dt = 0.8 * 1.0 / C0  # the end a whole number of steps, so the run's steps are this dt exactly
    end = math.ceil(STRETCH_3["time.end"] / dt) * dt
    sim, stopped = run("stretch", **{**STRETCH_3, "time.end": end}, time={"end": end, "dt": dt})
    return Measured(interior_deviation(sim), stopped)


def adaptive_step_stress() -> Measured:
    sim, stopped = run("stretch", **STRETCH_3, **{"time.cfl": 0.8})
    return Measured(interior_deviation(sim), stopped)


STRETCH_METRIC = "max |sxx - exact(mean stretch)| / exact, interior particles (torn: strain lost)"


# --------------------------------------------------------------- shock bar (LR paper Fig. 7)
def shock_ring(corrected: bool) -> Measured:
    from ..validation.test_shock import fig7_deviations

    c, u, _, _ = fig7_deviations()
    return Measured(c if corrected else u)


# --------------------------------------------------------------- imperfect interfaces (2013 paper)
def two_layer_energy(**overrides) -> tuple[float, str]:
    """Static strain + interfacial energy of the two-layer specimen at 1 mm cells."""
    from ..validation.specimens import two_layer

    sim = Simulation(build_scene(deck_from(two_layer(1.0, **overrides), ROOT / "inputs")))
    try:
        sim.run()
    except InstabilityError as exc:
        return float("nan"), str(exc).splitlines()[0]
    h = sim.recorder
    tail = max(1, len(h.rows) // 5)
    return float((h.column("strain_energy") + h.column("interface_energy"))[-tail:].mean()), ""


def stiff_interface(scheme: str) -> Measured:
    """|E - E_perfect| / E_perfect with Dn = Dt = 1e8 MPa/mm (inf when the run stopped)."""
    perfect, _ = two_layer_energy(Dt="perfect")
    e, stopped = two_layer_energy(Dt=1e8, **{"contact.default.Dn": 1e8, "contact.interface_integration": scheme})
    return Measured(abs(e / perfect - 1) if not stopped else float("inf"), stopped)


def stiff_normal(opening: str) -> Measured:
    """Dt = 1, Dn = 3000 MPa/mm (phi^2 ~ 0.8 at the interface nodes, below the bonding switch):
    |E / E_perfect normal - 1| (inf when the run stopped)."""
    perfect, _ = two_layer_energy(Dt=1.0)
    e, stopped = two_layer_energy(Dt=1.0, **{"contact.default.Dn": 3000.0, "contact.interface_opening": opening})
    return Measured(abs(e / perfect - 1) if not stopped else float("inf"), stopped)


def sphere_moduli_gap(integration: str) -> Measured:
    """3D glass sphere at 100 um cells, Dn = Dt = 3e5 MPa/mm (many interface nodes just below the
    bonding switch): |K_energy / K_pressure - 1| (inf when the run stopped)."""
    deck = with_overrides(example("sphere_composite"), {
        "grid.cell_size": 0.1, "time.end": 0.01, "contact.default.Dn": 3e5, "contact.default.Dt": 3e5,
        "contact.interface_integration": integration})
    sim = Simulation(build_scene(deck_from(deck, ROOT / "inputs")))
    try:
        sim.run()
    except InstabilityError as exc:
        return Measured(float("inf"), str(exc).splitlines()[0])
    h = sim.recorder
    tail = max(1, len(h.rows) // 5)
    mean = lambda c: float(h.column(c)[-tail:].mean())  # noqa: E731
    k_energy, k_pressure = cube_bulk_modulus(mean("strain_energy") + mean("interface_energy"),
                                             (mean("sxx") + mean("syy") + mean("szz")) / 3, 1.0, 0.005)
    return Measured(abs(k_energy / k_pressure - 1))


def interface_energy_error(normal: str, Dn, bond: str = "consistent") -> Measured:
    """Interfacial energy on cell mid-planes against the specified normal on a grid line (Dt = 1)."""
    from ..validation.specimens import two_layer

    def energy(deck):
        sim = Simulation(build_scene(deck_from(deck, ROOT / "inputs")))
        sim.run()
        h = sim.recorder
        return float(h.column("interface_energy")[-max(1, len(h.rows) // 5):].mean())

    ref = energy(two_layer(1.0, 1.0, **{"contact.default.Dn": Dn}))
    mid = energy(two_layer(1.0, 1.0, mid=True, **{"contact.default.Dn": Dn, "contact.normal": normal,
                                                  "contact.interface_bond": bond}))
    return Measured(abs(mid / ref - 1))

# --------------------------------------------------------------- FEM blocks, APIC augury contact
def augury_blocks(h: float, speed: float, method: str = "augury") -> Measured:
    """Smallest gap between the 2D blocks of inputs/fem_blocks_2d.yaml over the run, in augury
    cells (h_c = 2h, the default 4-node kernel, APIC, N = 1, or field contact; impact speed
    scaled); 0 when the
    interpenetration check stopped the run."""
    from mpmsim.fem.probes import boundary_gap

    d = example("fem_blocks_2d")
    for b in d["bodies"]:
        b["element_size"] = h
        b["velocity"] = [speed * float(c) for c in b["velocity"]]
    d["contact"]["augury"].update(cell_size=2.0 * h, method=method)
    d["time"] = {"end": 0.06 / speed, "dt": 1e-4 * h}
    sim = Simulation(build_scene(deck_from(d, ROOT / "inputs")), threads=1)
    st, gap = sim.state, np.inf
    try:
        while st.t < sim.end * (1 - 1e-9):
            sim.step()
            if st.step % 20 == 0:
                gap = min(gap, boundary_gap(st.fem.x, st.fem.facets, st.fem.node_body, 0, 1))
    except InstabilityError as exc:
        return Measured(0.0, str(exc).splitlines()[0])
    return Measured(gap / (2.0 * h))


def ramp_slide_error(method: str) -> Measured:
    """|x / analytic - 1| of the block's slide at t = 0.1 s on inputs/fem_ramp_2d.yaml at
    h = 0.25 (h_c = h / 2, dt = 2.5e-5 h, mu = 0.2, the paper's 4-node kernel), APIC augury
    (N = 1) or field contact."""
    d = example("fem_ramp_2d")
    for b in d["bodies"]:
        b["element_size"] = 0.25
    d["contact"]["augury"].update(cell_size=0.125, method=method)
    d["time"] = {"end": 0.1, "dt": 6.25e-6}
    sim = Simulation(build_scene(deck_from(d, ROOT / "inputs")), threads=1)
    f = sim.state.fem
    block = f.node_body == 1
    centre = lambda: float(np.sum(f.mass[block] * f.x[block, 0]) / f.mass[block].sum())  # noqa: E731
    x0 = centre()
    while sim.state.t < sim.end * (1 - 1e-9):
        sim.step()
    th = np.radians(30.0)
    analytic = 0.5 * 100.0 * (np.sin(th) - 0.2 * np.cos(th)) * np.cos(th) * 0.1**2
    return Measured(abs((centre() - x0) / analytic - 1.0))


SCENARIOS = [
    Scenario("contact cutoff at large strain", "two-block column to 5% strain", "AVG normals, CP = 0.8 cutoff",
             "max |MM - SMM| / SMM of mean syy, 0.2-5% strain", 0.04, "above", lambda: column_error(**CP08)),
    Scenario("contact cutoff at large strain", "two-block column to 5% strain", "LR normals and separation, 2 passes",
             "max |MM - SMM| / SMM of mean syy, 0.2-5% strain", 0.01, "below", lambda: column_error()),
    Scenario("one contact pass", "two-block column to 5% strain", "LR, 1 pass (contact after the momentum update only)",
             "max |MM - SMM| / SMM of mean syy, 0.2-5% strain", 0.001, "above",
             lambda: column_error(**{"contact.passes": 1})),
    Scenario("one contact pass", "two-block column to 5% strain", "LR, 2 passes",
             "max |MM - SMM| / SMM of mean syy, 0.2-5% strain", 0.001, "below", lambda: column_error()),
    Scenario("cell crossing at large stretch", "neo-Hookean bar stretched to 100%", "uGIMP (XPIC(5))",
             STRETCH_METRIC, 0.5, "above", lambda: stretch_deviation("gimp")),
    Scenario("cell crossing at large stretch", "neo-Hookean bar stretched to 100%", "CPDI (XPIC(5))",
             STRETCH_METRIC, 0.02, "below", lambda: stretch_deviation("cpdi")),
    Scenario("cell crossing at large stretch", "neo-Hookean bar stretched to 100%", "B2CPDI (XPIC(5))",
             STRETCH_METRIC, 0.02, "below", lambda: stretch_deviation("b2cpdi")),
    Scenario("time step too large on a stiffening material", "neo-Hookean bar stretched to 200%",
             "fixed dt = 0.8 h / c0 (c rises 1.9x: CFL 1.54 at stretch 3)", STRETCH_METRIC + " (to stretch 3)",
             0.5, "above", fixed_step_stress),
    Scenario("time step too large on a stiffening material", "neo-Hookean bar stretched to 200%",
             "adaptive step, CFL 0.8 on the current wave speed",
             STRETCH_METRIC + " (to stretch 3)", 0.02, "below", adaptive_step_stress,
             must_stop=False),
    Scenario("multimaterial XPIC without its contact term", "nickel shock bar split by a perfect interface",
             "uncorrected XPIC(5)", "max |split - single| axial stress behind the interface / plateau", 0.005,
             "above", lambda: shock_ring(False)),
    Scenario("multimaterial XPIC without its contact term", "nickel shock bar split by a perfect interface",
             "XPIC(5) with the contact term on every increment",
             "max |split - single| axial stress behind the interface / plateau", 0.02, "below",
             lambda: shock_ring(True)),
    Scenario("stiff imperfect interface", "two-layer specimen, Dn = Dt = 1e8 MPa/mm",
             "first-order interface force, no limit", "|E / E_perfect - 1| (inf: stopped)", 0.01, "above",
             lambda: stiff_interface("first_order"), must_stop=True),
    Scenario("stiff imperfect interface", "two-layer specimen, Dn = Dt = 1e8 MPa/mm",
             "2013 paper's force limit", "|E / E_perfect - 1| (inf: stopped)", 0.01, "above",
             lambda: stiff_interface("force_limit"), must_stop=True),
    Scenario("stiff imperfect interface", "two-layer specimen, Dn = Dt = 1e8 MPa/mm",
             "exact oscillator, bonded when phi^2 > 1", "|E / E_perfect - 1| (inf: stopped)", 1e-6, "below",
             lambda: stiff_interface("oscillator"), must_stop=False),
    Scenario("stiff normal below the bonding switch", "two-layer specimen, grid line, Dt = 1, Dn = 3000 MPa/mm",
             "opening at the node (reference code)", "|E / E_perfect normal - 1| (inf: stopped)", 0.01, "above",
             lambda: stiff_normal("node"), must_stop=True),
    Scenario("stiff normal below the bonding switch", "two-layer specimen, grid line, Dt = 1, Dn = 3000 MPa/mm",
             "opening at the interface point", "|E / E_perfect normal - 1| (inf: stopped)", 0.01, "below",
             lambda: stiff_normal("interface"), must_stop=False),
    Scenario("stiff curved interface", "3D glass sphere, 100 um cells, Dn = Dt = 3e5 MPa/mm",
             "trapezoidal spring", "|K_energy / K_pressure - 1| (inf: stopped)", 0.02, "above",
             lambda: sphere_moduli_gap("trapezoidal"), must_stop=True),
    Scenario("stiff curved interface", "3D glass sphere, 100 um cells, Dn = Dt = 3e5 MPa/mm",
             "backward-Euler spring (default)", "|K_energy / K_pressure - 1| (inf: stopped)", 0.02, "below",
             lambda: sphere_moduli_gap("backward_euler"), must_stop=False),
    Scenario("gradient normals at edge nodes, stiff normal", "two-layer specimen, interface on mid-planes, Dt = 1",
             "AVG normals, Dn perfect, node-wise bond (reference code)",
             "|interfacial energy / specified-normal grid-line value - 1|", 0.5, "above",
             lambda: interface_energy_error("average_gradient", "perfect", "nodal")),
    Scenario("gradient normals at edge nodes, stiff normal", "two-layer specimen, interface on mid-planes, Dt = 1",
             "AVG normals, Dn perfect, consistent bond", "|interfacial energy / specified-normal grid-line value - 1|",
             0.05, "below", lambda: interface_energy_error("average_gradient", "perfect")),
    Scenario("gradient normals at edge nodes, stiff normal", "two-layer specimen, interface on mid-planes, Dt = 1",
             "AVG normals, Dn = Dt (imperfect normal)", "|interfacial energy / specified-normal grid-line value - 1|",
             0.02, "below", lambda: interface_energy_error("average_gradient", 1.0)),
    Scenario("augury contact loses its repulsion", "2D FEM blocks, four times the paper's impact speed (304 m/s)",
             "APIC augury, N = 1, h = 1/8, h_c = 1/4", "smallest gap / h_c (0: interpenetrated, stopped)", 1e-3,
             "below", lambda: augury_blocks(0.125, 4.0), unit="", must_stop=True),
    Scenario("augury contact loses its repulsion", "2D FEM blocks, four times the paper's impact speed (304 m/s)",
             "APIC augury, N = 1, h = 1/4, h_c = 1/2", "smallest gap / h_c (0: interpenetrated, stopped)", 1e-3,
             "above", lambda: augury_blocks(0.25, 4.0), unit="", must_stop=False),
    Scenario("augury contact loses its repulsion", "2D FEM blocks, four times the paper's impact speed (304 m/s)",
             "field contact, h = 1/8, h_c = 1/4", "smallest gap / h_c (0: interpenetrated, stopped)", 1e-3,
             "above", lambda: augury_blocks(0.125, 4.0, "field"), unit="", must_stop=False),
    Scenario("augury contact drags sliding bodies", "2D block on a 30 degree FEM ramp, mu = 0.2, h = 1/4",
             "APIC augury, N = 1, tau = dt (the paper's)", "|slide at 0.1 s / analytic - 1|", 0.5, "above",
             lambda: ramp_slide_error("augury")),
    Scenario("augury contact drags sliding bodies", "2D block on a 30 degree FEM ramp, mu = 0.2, h = 1/4",
             "field contact", "|slide at 0.1 s / analytic - 1|", 0.05, "below",
             lambda: ramp_slide_error("field")),
]
