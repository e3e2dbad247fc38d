"""Imperfect interfaces (2013 paper): the two-layer and double-lap-shear specimens and the 3D
composite sphere, at coarse resolution. Full-resolution sweeps: bench/interfaces.py and
docs/interfaces.md."""

from __future__ import annotations

import json
from functools import cache

import numpy as np
import pytest

from mpmsim.deck.overrides import with_overrides
from mpmsim.sweep.metrics import csa_bulk_modulus, cube_bulk_modulus

from ..conftest import ROOT, simulate
from .specimens import dls_tilted, shipped, two_layer, two_layer_3d


def settled(deck, *columns) -> dict:
    """Run to the end; each column's mean over the last fifth of the history (the static state
    under grid damping; residual ringing is below 0.5% there)."""
    means = settled_means(json.dumps(deck, default=float))  # (key order kept: materials are numbered by it)
    return {c: means[c] for c in columns}


@cache
def settled_means(deck_json: str) -> dict:
    """settled() of every history column, run once per deck in this module (the double lap
    shear at 0.5 mm cells serves the stiffness curve and the tilted specimens' reference)."""
    sim = simulate(json.loads(deck_json), ROOT / "inputs")
    h = sim.recorder
    tail = max(1, len(h.rows) // 5)
    return {c: float(h.column(c)[-tail:].mean()) for c in h.names}


def interface_energy(deck) -> float:
    return settled(deck, "interface_energy")["interface_energy"]


def total_energy(deck) -> float:
    cols = ("strain_energy", "interface_energy") if deck["contact"].get("default", {}).get("law") == "interface" \
        else ("strain_energy",)
    return sum(settled(deck, *cols).values())


# --------------------------------------------------------------------------- two-layer specimen
@pytest.mark.parametrize("Dt", [0.2, 1.0, 5.0])
def test_interfacial_energy_does_not_depend_on_where_the_interface_lies(Dt):
    """Paper Fig. 8 with Dn = Dt, 1 mm cells: interface on a grid line vs on cell mid-planes.
    With the area correction (Eq. 20) the energies agree (measured +0.08%, +0.10%, +0.06%);
    without it the mid-plane interface acts as if Dt were doubled: its energy equals the
    grid-line energy at 2 Dt (measured +0.29%, +0.23%, +0.23%), 1.93x / 1.68x / 1.11x the
    energy at Dt. The last ratio is small because the energy curve peaks near Dt = 5-10, so
    the check of the shift is that the uncorrected result sits ten times closer to the 2 Dt
    result than to its own Dt's. With the paper's perfect normal: the next two tests."""
    o = {"contact.default.Dn": Dt}
    grid = interface_energy(two_layer(1.0, Dt, **o))
    mid = interface_energy(two_layer(1.0, Dt, mid=True, **o))
    assert mid == pytest.approx(grid, rel=0.02)
    uncorrected = interface_energy(two_layer(1.0, Dt, mid=True, **o, **{"contact.area_correction": False}))
    doubled = interface_energy(two_layer(1.0, 2 * Dt, **o))
    assert uncorrected == pytest.approx(doubled, rel=0.03)
    assert abs(uncorrected / grid - 1) > 10 * abs(uncorrected / doubled - 1)  # the shift, resolved


@pytest.mark.parametrize("Dt", [0.2, 1.0, 5.0])
def test_perfect_normal_interface_position_does_not_matter(Dt):
    """Paper Fig. 8 as the paper runs it (Dn perfect), 1 mm cells, plane strain: with the
    consistent normal bond (contact.bond) the mid-plane energy agrees with the grid-line one
    within 2% (measured +0.05%, +0.10%, +0.09%); without the area correction the mid-plane
    interface acts as if Dt were doubled (measured +0.06%, +0.13%, +0.08% against the grid
    line at 2 Dt; 1.93x / 1.68x / 1.10x the energy at Dt). On a grid line the consistent bond
    is the node-wise one (measured +0.018% at Dt = 1)."""
    grid = interface_energy(two_layer(1.0, Dt))
    mid = interface_energy(two_layer(1.0, Dt, mid=True))
    assert mid == pytest.approx(grid, rel=0.02)
    uncorrected = interface_energy(two_layer(1.0, Dt, mid=True, **{"contact.area_correction": False}))
    doubled = interface_energy(two_layer(1.0, 2 * Dt))
    assert uncorrected == pytest.approx(doubled, rel=0.03)
    assert abs(uncorrected / grid - 1) > 10 * abs(uncorrected / doubled - 1)
    if Dt == 1.0:
        nodal = interface_energy(two_layer(1.0, Dt, **{"contact.interface_bond": "nodal"}))
        assert grid == pytest.approx(nodal, rel=1e-3)
        # with XPIC(3) the bond is re-imposed on the filter increments (measured +0.62%)
        xpic = {"update.scheme": "xpic", "update.order": 3}
        mid_x = interface_energy(two_layer(1.0, Dt, mid=True, **xpic))
        assert mid_x == pytest.approx(interface_energy(two_layer(1.0, Dt, **xpic)), rel=0.02)


def poisson(nu: float, E: float = 2400.0) -> dict:
    return {f"materials.{m}.{k}": v for m in ("left", "right") for k, v in (("nu", nu), ("E", E))}


def test_two_layer_in_3d_matches_2d():
    """Must-show 2's 2D/3D check at 1 mm cells, Dt = 1: the 4 x 4 x 20 mm layers in 3D with
    rollers on the z faces are the plane-strain problem of the 2D runs; interfacial energy
    within 5% (measured -0.001%). This runs the 3D path of the interface (3 x 3 displacement
    gradients for the opening, single tangent, 3D areas)."""
    two_d = interface_energy(two_layer(1.0, 1.0))
    three_d = interface_energy(two_layer_3d(1.0, 1.0, z_rollers=True))
    assert three_d == pytest.approx(two_d, rel=0.05)


def test_nodal_normal_bond_clamps_the_poisson_mismatch():
    """The reference code's node-wise bond (interface_bond: nodal) on mid-planes makes the
    normal velocity single-valued at both nodes of the crossed cell, so the two edge particle
    columns share one normal strain although the layers' Poisson contractions differ: the
    mid-plane energy is 19.2% low at 1 mm cells and 10.9% at 0.5 mm (Dt = 1; first order in the
    cells). Without a Poisson mismatch (nu = 0) it agrees (measured +0.04%), and the gap grows
    with the Poisson coupling: plane stress (plane strain with E(1+2nu)/(1+nu)^2, nu/(1+nu))
    -7.7%, plane strain -19.2%."""
    nodal = {"contact.interface_bond": "nodal"}
    gap = {}
    for name, cell, o in (("strain", 1.0, {}), ("strain_half", 0.5, {}), ("nu0", 1.0, poisson(0.0)),
                          ("stress", 1.0, poisson(0.33 / 1.33, 2400.0 * 1.66 / 1.33**2))):
        grid = interface_energy(two_layer(cell, 1.0, **nodal, **o))
        gap[name] = interface_energy(two_layer(cell, 1.0, mid=True, **nodal, **o)) / grid - 1
    assert -0.2 < gap["strain"] < -0.12  # measured -0.192 (node opening: -0.161)
    assert 0.7 * gap["strain"] < gap["strain_half"] < 0  # measured -0.109: shrinks with the cells
    assert abs(gap["nu0"]) < 0.02
    assert -0.1 < gap["stress"] < -0.03  # measured -0.077


def test_interface_limits():
    """Dt -> perfect gives the single body (law none) within 1% (measured: identical for
    'perfect' and 1e6, +0.29% at Dt = 1e3); Dt = 0 lets the loaded layer slide freely: its
    energy is that of the loaded layer alone within 2% (measured -0.31%)."""
    single = total_energy(two_layer(1.0, 1.0, **{"contact.default.law": "none"}))
    for Dt in ("perfect", 1.0e6, 1.0e3):
        assert total_energy(two_layer(1.0, Dt)) == pytest.approx(single, rel=0.01)
    alone = two_layer(1.0, 1.0)
    del alone["bodies"][0]
    alone["contact"] = {}
    assert total_energy(two_layer(1.0, 0.0)) == pytest.approx(total_energy(alone), rel=0.02)


def test_traction_load_on_a_free_standing_layer():
    """The loaded layer alone on a roller base, 0.5 MPa on top (1 mm cells, damped to rest):
    Clapeyron's theorem, final load x final displacement of the loaded particles = 2 x strain
    energy (measured +0.36%), and the energy matches uniaxial stress in plane strain,
    sigma^2 (1 - nu^2) / (2E) V (measured -2.0%: the residual settling and the roller base)."""
    deck = two_layer(1.0, 1.0)
    del deck["bodies"][0]
    deck["contact"] = {}
    deck["grid"]["boundaries"] = {"ymin": "roller"}
    sim = simulate(deck, ROOT / "inputs")
    h = sim.recorder
    strain = float(h.column("strain_energy")[-max(1, len(h.rows) // 5):].mean())
    loads, P = sim.state.loads, sim.state.particles
    load_times_displacement = float((loads.force * (P.x - P.x0)[loads.particle]).sum())
    assert load_times_displacement == pytest.approx(2.0 * strain, rel=0.01)
    E, nu, sigma, volume = 2400.0, 0.33, 0.5, 4.0 * 20.0 * 4.0
    assert strain == pytest.approx(0.5 * sigma**2 * (1 - nu**2) / E * volume, rel=0.03)


# --------------------------------------------------------------------------- double lap shear
def dls_stiffness(deck) -> tuple[float, float]:
    """k = P^2 / (2 U), U = strain + interfacial energy; and the interface's share of U."""
    e = settled(deck, "strain_energy", "interface_energy")
    U = e["strain_energy"] + e["interface_energy"]
    P = 2.0 * deck["thickness"]  # 2 MPa on the 1 mm central strand
    return P**2 / (2.0 * U), e["interface_energy"] / U


@pytest.mark.validation
def test_dls_stiffness_falls_as_the_interface_softens(measure):
    """Paper Fig. 7 at 0.5 mm cells: k against 1/Dt = 0, 0.2, 0.5, 1 mm/MPa falls
    monotonically, by more than 3x (measured 553.4, 168.0, 83.5, 45.5 N/mm: 12x), and the
    interface holds 91% of the energy at Dt = 1 MPa/mm (paper: 91%; measured 90.8%)."""
    k, share = zip(*(dls_stiffness(with_overrides(shipped("dls"), {"grid.cell_size": 0.5,
                                                                    "contact.default.Dt": Dt}))
                     for Dt in ("perfect", 5.0, 2.0, 1.0)))
    measure("DLS k at 1/Dt = 0, 0.2, 0.5, 1 mm/MPa", ", ".join(f"{v:.1f}" for v in k) + " N/mm",
            "falling, first/last > 3")
    measure("DLS interface share of the energy at Dt = 1", f"{share[-1]:.3f}", "0.91 +- 0.02 (paper)")
    assert all(a > b for a, b in zip(k, k[1:]))
    assert k[0] / k[-1] > 3.0
    assert share[-1] == pytest.approx(0.91, abs=0.02)


def test_h_perp_corrects_a_tilted_interface_on_uneven_cells():
    """Paper Fig. 9 on coarse cells: the DLS specimen tilted 30 degrees on 0.25 x 0.5 mm cells
    against the untilted one on 0.5 mm square cells, all three run to 0.15 ms (half the deck's
    time: the load's ramp ends at 0.04 ms, its damped state is reached by 0.09 ms; the next
    test): flat 166.6 N/mm, with h_perp (Eq. 22) 161.9 N/mm (-2.8%), with h_perp = dx 194.9
    (+17.0%): the correction must at least halve the error, and the uncorrected one is visibly
    off. At the paper's resolution: the next test."""
    half = {"time.end": 0.15}
    flat, _ = dls_stiffness(with_overrides(shipped("dls"), {"grid.cell_size": 0.5, **half}))
    tilted, _ = dls_stiffness(dls_tilted(30.0, [0.25, 0.5], 5.0, **half))
    uncorrected, _ = dls_stiffness(dls_tilted(30.0, [0.25, 0.5], 5.0, **{"contact.h_perp": False, **half}))
    assert abs(tilted / flat - 1) < 0.06
    assert abs(uncorrected / flat - 1) > 0.08
    assert abs(tilted / flat - 1) < 0.5 * abs(uncorrected / flat - 1)


@pytest.mark.validation
def test_h_perp_corrects_a_tilted_interface_on_the_papers_cells(measure):
    """Paper Fig. 9: the tilted DLS specimen on 0.125 x 0.25 mm cells with h_perp: 167.9 N/mm,
    within 3% of the untilted one at 0.5 mm (168.0; 167.4 at 0.25 mm, 167.0 at 0.125 mm;
    measured -0.05%); without the correction 199.3 (+18.5%, docs/interfaces.md).
    The run ends at 0.15 ms instead of the deck's 0.3 (21,500 steps to 0.3 ms): the load's ramp
    ends at 0.04 ms, its damped state is reached by 0.09 ms, and any later window of the last
    fifth's length reads within the +-0.5% of the damped ringing (k 168.23 N/mm over 0.12-0.15 ms,
    167.96 over 0.24-0.3 ms, the flat 167.98)."""
    flat, _ = dls_stiffness(with_overrides(shipped("dls"), {"grid.cell_size": 0.5}))
    fine, _ = dls_stiffness(dls_tilted(30.0, [0.125, 0.25], 5.0, **{"time.end": 0.15}))
    measure("k, DLS tilted 30 deg, 0.125 x 0.25 mm cells", f"{fine:.2f} N/mm ({fine / flat - 1:+.2%})",
            f"within 3% of the flat {flat:.2f} N/mm")
    assert fine == pytest.approx(flat, rel=0.03)


# --------------------------------------------------------------------------- stiff interfaces, 3D
def test_stiff_interfaces_stay_stable_only_with_the_bonding_switch():
    """Dn = Dt = 1e8 MPa/mm on the two-layer specimen: the default integrator (trapezoidal; the
    oscillator alike) switches the direction
    to bonded and gives the perfect-interface energy to round-off; the first-order force
    without a limit blows up within a few steps (the failure the 2013 paper's limit is for);
    the paper's force limit also lets the energy grow here (stops after ~0.2 ms)."""
    from mpmsim.errors import InstabilityError

    stiff = {"contact.default.Dn": 1e8}
    perfect = total_energy(two_layer(1.0, "perfect", **{"contact.default.Dn": "perfect"}))
    assert total_energy(two_layer(1.0, 1e8, **stiff)) == pytest.approx(perfect, rel=1e-9)
    for scheme in ("first_order", "force_limit"):
        with pytest.raises(InstabilityError):
            simulate(two_layer(1.0, 1e8, **stiff, **{"contact.interface_integration": scheme}), ROOT / "inputs")


def test_stiff_normal_near_the_bonding_switch_is_stable_and_monotone():
    """Dt = 1, Dn = 1e3, 3e3, 5e3 MPa/mm on a grid line (phi^2 = Dn A dt^2 / m_red ~ 0.3, 0.8,
    1.4 at the interface nodes; the bonding switch is at 1): every run finishes and the
    interfacial energy falls monotonically to the perfect normal's (measured 1.5594, 1.5274,
    1.4880 against 1.4880e-4 mJ: Dn = 5000 bonds). With the opening measured at the node
    (`interface_opening: node`, the reference code's) Dn = 3000 stops as unstable (stability
    suite)."""
    energies = [interface_energy(two_layer(1.0, 1.0, **{"contact.default.Dn": Dn}))
                for Dn in (1e3, 3e3, 5e3, "perfect")]
    assert energies[0] > energies[1] > energies[-1]
    assert all(a >= b * (1 - 1e-9) for a, b in zip(energies, energies[1:]))
    assert energies[2] == pytest.approx(energies[-1], rel=0.002)
    assert energies[0] < 1.06 * energies[-1]


SPHERE_STRAIN, SPHERE_CUBE = 0.005, 1.0
CSA = csa_bulk_modulus(2400.0, 0.33, 70000.0, 0.25, np.pi * 0.7**3 / 6)  # 3062 MPa (17.96% glass)


def sphere_moduli(deck) -> tuple[float, float]:
    """(K from energy, K from pressure) of the settled cube (Eqs. 34-36 at finite strain)."""
    e = settled(deck, "strain_energy", "interface_energy", "sxx", "syy", "szz")
    return cube_bulk_modulus(e["strain_energy"] + e["interface_energy"], (e["sxx"] + e["syy"] + e["szz"]) / 3,
                             SPHERE_CUBE, SPHERE_STRAIN)


def sphere_deck(cell: float, D) -> dict:
    return with_overrides(shipped("sphere_composite"), {"grid.cell_size": cell, "time.end": 0.01,
                                                        "contact.default.Dn": D, "contact.default.Dt": D})


def test_bulk_modulus_measures_read_the_matrix_modulus_of_a_uniform_cube():
    """The sphere deck without the sphere (polymer alone, K = 2353 MPa), 100 um cells: both
    measures give K within 0.5% (measured +0.13% from energy, +0.06% from pressure). With the
    paper's small-strain forms (V = l^3, dV/V0 = 3 e0) at this 0.5% strain, K from energy reads
    +1.13% (and from pressure -0.19%): 1.3 points of the 1.6% gap those forms left between the
    two measures on the composite (3208 against 3157 MPa at 100 um)."""
    deck = shipped("sphere_composite")
    deck["bodies"] = [b for b in deck["bodies"] if b["material"] != "glass"]
    del deck["materials"]["glass"]
    deck = with_overrides(deck, {"grid.cell_size": 0.1, "time.end": 0.01})
    e = settled(deck, "strain_energy", "sxx", "syy", "szz")
    K_matrix = 2400.0 / (3 * (1 - 2 * 0.33))
    K_energy, K_pressure = cube_bulk_modulus(e["strain_energy"], (e["sxx"] + e["syy"] + e["szz"]) / 3,
                                             SPHERE_CUBE, SPHERE_STRAIN)
    assert K_energy == pytest.approx(K_matrix, rel=0.005)
    assert K_pressure == pytest.approx(K_matrix, rel=0.005)
    small_strain_energy = 2 * e["strain_energy"] / (9 * SPHERE_CUBE**3 * SPHERE_STRAIN**2)
    assert small_strain_energy / K_matrix - 1 > 0.008


@pytest.mark.validation
def test_composite_sphere_bulk_modulus_in_the_stiff_limit(measure):
    """3D, 100 um cells, D = Dn = Dt = 1e12 (stable, acts as perfect): K from energy and from
    pressure agree within 2% (measured 3176.6 and 3165.3 MPa, +0.36%) and lie within 4% of the
    CSA value 3062 MPa (+3.7%, +3.4%; at 50 um within 3%, docs/interfaces.md)."""
    K_energy, K_pressure = sphere_moduli(sphere_deck(0.1, 1e12))
    measure("composite sphere K (energy, pressure), D = 1e12", f"{K_energy:.1f}, {K_pressure:.1f} MPa",
            f"agree within 2%, within 4% of CSA {CSA:.1f}")
    assert K_energy == pytest.approx(K_pressure, rel=0.02)
    for K in (K_energy, K_pressure):
        assert K == pytest.approx(CSA, rel=0.04)


@pytest.mark.validation
@pytest.mark.parametrize("D, csa", [(1e4, 2328.7), (1e5, 2939.0)])
def test_composite_sphere_follows_the_imperfect_interface_csa(D, csa, measure):
    """3D, 100 um cells, D = Dn = Dt below the bonding switch: K from energy and from pressure
    lie within 2% of the composite spheres assemblage with an interface spring Dn (Hashin 1991,
    the paper's Fig. 13 lines); measured K_energy, K_pressure: D = 1e4 2354.8, 2345.5 MPa
    (+1.1%, +0.7%); D = 1e5 2952.5, 2957.9 MPa (+0.5%, +0.6%). A cubic array is not the
    assemblage, so the gap is not all numerical (at 50 um see docs/interfaces.md)."""
    analytic = csa_bulk_modulus(2400.0, 0.33, 70000.0, 0.25, np.pi * 0.7**3 / 6, D, 0.7)
    assert analytic == pytest.approx(csa, rel=1e-4)  # limits checked in tests/unit/test_interfaces.py
    moduli = sphere_moduli(sphere_deck(0.1, D))
    measure(f"composite sphere K (energy, pressure), D = {D:g}", ", ".join(f"{K:.1f}" for K in moduli) + " MPa",
            f"within 2% of CSA {analytic:.1f}")
    for K in moduli:
        assert K == pytest.approx(analytic, rel=0.02)


@pytest.mark.validation
def test_composite_sphere_moduli_agree_where_interface_nodes_bond(measure):
    """3D, 100 um cells, D = Dn = Dt = 1e7: every interface node bonds (phi^2 > 1), so K from
    energy and from pressure agree within 2% (measured 3176.6 and 3165.3 MPa, +0.36%, the
    perfect values).
    The run's last step is cut short to land on time.end; judged at that step the switch
    un-bonded every node for one step and reported their kept openings as 0.15 mJ of
    interfacial energy (K from energy +4.7%); the switch now uses the CFL step."""
    K_energy, K_pressure = sphere_moduli(sphere_deck(0.1, 1e7))
    measure("composite sphere K (energy, pressure), D = 1e7", f"{K_energy:.1f}, {K_pressure:.1f} MPa",
            "agree within 2%")
    assert K_energy == pytest.approx(K_pressure, rel=0.02)
