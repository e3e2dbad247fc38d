"""Cohesive interfaces in MPM runs (mpmsim/contact/cohesive_history.py): the damage carried by
the particles, the fracture energy, failure handed to the contact law, deck errors (issue 78).

Two 4 x 2 mm blocks bonded on the grid line y = 2 (0.5 mm cells, plane strain, unit thickness),
flung apart at +-10 m/s (the impact stress rho c v = 15.5 MPa is three times the 5 MPa peak):
the interface fails everywhere, so the energy it dissipates is G_c times its area, 4 mm^2."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from mpmsim.deck.loader import as_loaded_deck
from mpmsim.errors import DeckError
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation

pytestmark = pytest.mark.cohesive

G_I, G_II, AREA = 0.05, 0.1, 4.0


def deck(mode: str, shape: str = "bilinear", after: str = "frictionless") -> dict:
    v = (0.0, 10.0) if mode == "I" else (10.0, 0.0)
    law = {"law": "cohesive", "Dn": 2000.0, "Dt": 2000.0,
           "cohesive": {"shape": shape, "peak_traction": 5.0, "G_Ic": G_I, "G_IIc": G_II, "after": after}}
    return {"title": "bonded blocks flung apart", "units": "mm-g-ms", "analysis": "plane_strain", "thickness": 1.0,
            "grid": {"cell_size": 0.5, "domain": {"min": [-4.0, -4.0], "max": [8.0, 8.0]}},
            "materials": {"a": {"type": "linear_elastic", "E": 2000.0, "nu": 0.3, "density": 0.0012},
                          "b": {"type": "linear_elastic", "E": 2000.0, "nu": 0.3, "density": 0.0012}},
            "bodies": [{"shape": "rectangle", "min": [0.0, 0.0], "max": [4.0, 2.0], "material": "a",
                        "velocity": [-v[0], -v[1]]},
                       {"shape": "rectangle", "min": [0.0, 2.0], "max": [4.0, 4.0], "material": "b",
                        "velocity": list(v)}],
            "contact": {"normal": "specified", "normal_vector": [0.0, 1.0], "default": law},
            "time": {"end": 0.3, "cfl": 0.5}, "output": {"history_interval": 0.0015}}


def run(data: dict) -> Simulation:
    sim = Simulation(build_scene(as_loaded_deck(data, "cohesive", Path("."))), out_dir=None, threads=1)
    sim.run()
    return sim


@pytest.fixture(scope="module")
def runs():
    return {(m, s): run(deck(m, s)) for m, s in (("I", "bilinear"), ("II", "bilinear"), ("I", "exponential"))}


@pytest.mark.parametrize("mode,shape,G", [("I", "bilinear", G_I), ("II", "bilinear", G_II),
                                          ("I", "exponential", G_I)])
def test_a_failed_interface_dissipated_its_toughness_times_its_area(runs, mode, shape, G):
    """fracture_energy = G_c A: each particle books its damage growth on its share of the
    interface when bonded (the shares sum to the area), which neither opening nor sliding
    shrinks. Mode I within 0.5% (measured 1.0000, bilinear and exponential); mode II within 3%
    (measured 0.985: the blocks slide while the interface fails, and their ends slide off the
    other block before failing). Booked on the current share, mode I gave 0.975 and mode II
    0.963 G A (1.030 G times the area booked as failed)."""
    sim = runs[(mode, shape)]
    col = sim.recorder.column
    energy, failed = col("fracture_energy")[-1], col("debonded_area")[-1]
    print(f"mode {mode} {shape}: fracture energy / (G_c A) = {energy / (G * AREA):.4f}, debonded {failed:.4f}")
    assert np.all(np.diff(col("fracture_energy")) >= 0.0)
    assert energy == pytest.approx(G * AREA, rel=0.005 if mode == "I" else 0.03)
    assert energy <= G * failed * (1.0 + 1e-12)
    if shape == "bilinear":  # (the exponential law's last particles fail after the blocks part)
        assert failed == pytest.approx(AREA, rel=0.07)


@pytest.mark.parametrize("mode,shape", [("I", "bilinear"), ("II", "bilinear")])
def test_the_damage_is_on_the_interface_particles_and_stays_with_them(runs, mode, shape):
    """The interface's two particle rows on each side end failed (d = 1) and no other
    particle is damaged; in mode II the blocks have slid over 3 cells past each other (2.1 mm)
    with the damage on the same particles."""
    sim = runs[(mode, shape)]
    P = sim.state.particles
    y0 = P.x0[:, 1]
    near = np.abs(y0 - 2.0) < 0.5
    assert np.all(P.interface_damage[near] == 1.0)
    assert np.all(P.interface_damage[~near] == 0.0)
    # the opening each interface particle last saw is past the law's failure opening 2 G / peak
    G = G_I if mode == "I" else G_II
    assert np.all(P.interface_opening[near] > 2 * G / 5.0) and np.all(P.interface_opening[~near] == 0.0)
    if mode == "II":
        slid = (P.x[:, 0] - P.x0[:, 0])[P.mat == 1].mean() - (P.x[:, 0] - P.x0[:, 0])[P.mat == 0].mean()
        assert slid > 3 * 0.5


def test_after_failure_the_frictionless_interface_carries_no_shear_and_never_rebonds(runs):
    """Mode II: once the interface has failed (debonded area reached), the blocks slide past
    each other on the frictionless law: each block's x momentum stays constant to 1e-9 of its
    value (a re-bonded node would pull them back)."""
    col = runs[("II", "bilinear")].recorder.column
    failed = np.nonzero(col("debonded_area") >= 0.999 * col("debonded_area")[-1])[0][0] + 2
    px_b = col("px_mat_b")
    e = col("fracture_energy")
    assert e[-1] == e[failed]
    print(f"px of b after failure: {px_b[failed]:.6g} .. spread {np.ptp(px_b[failed:]):.3g}")
    assert np.ptp(px_b[failed:]) <= 1e-9 * abs(px_b[failed])


def test_an_intact_interface_that_never_reaches_its_peak_is_the_elastic_interface():
    """Slow enough (2 m/s: rho c v = 3.1 MPa < 5) the cohesive law never damages: its run is
    the elastic interface's (law interface, the same Dn, Dt) within 0.5% of each energy's
    largest value (measured 0.10-0.14%: the elastic law bonds the nodes where D A dt^2 / m_red >
    1, the cohesive law never bonds), and dissipates nothing but a trace (below 1e-6 of G_c A:
    the free corners' nodes open most)."""
    slow = deck("I")
    for body, s in zip(slow["bodies"], (-1, 1)):
        body["velocity"] = [0.0, 2.0 * s]
    slow["time"]["end"] = 0.05
    elastic = copy.deepcopy(slow)
    elastic["contact"]["default"] = {"law": "interface", "Dn": 2000.0, "Dt": 2000.0}
    a, b = run(slow), run(elastic)
    assert a.recorder.column("fracture_energy")[-1] < 1e-6 * G_I * AREA
    for name in ("kinetic_energy", "strain_energy", "interface_energy"):
        x, y = a.recorder.column(name), b.recorder.column(name)
        assert np.abs(x - y).max() < 0.005 * np.abs(y).max()


@pytest.mark.parametrize("change,key,words", [
    (lambda law: law.pop("cohesive"), "contact.default.cohesive", "needs a cohesive block"),
    (lambda law: law.update(law="interface"), "contact.default.cohesive", "needs law: cohesive"),
    (lambda law: law.update(Dn="perfect"), "contact.default.Dn", "finite intact stiffness"),
    (lambda law: law.update(Dt=10.0), "contact.default.Dt", "too soft"),
    (lambda law: law["cohesive"].update(G_Ic=-1.0), "contact.default.cohesive.G_Ic", "greater than 0"),
    (lambda law: law["cohesive"].update(peak_traction=0.0), "contact.default.cohesive.peak_traction", "greater than 0"),
    (lambda law: law["cohesive"].update(friction=0.3), "contact.default.cohesive.friction", "after: coulomb"),
    (lambda law: law["cohesive"].update(precrack=[{"min": [2.0, 1.5], "max": [1.0, 2.5]}]),
     "contact.default.cohesive.precrack.0", "each below its max"),
])
def test_bad_cohesive_input_is_one_line_naming_the_key(change, key, words):
    data = deck("I")
    change(data["contact"]["default"])
    with pytest.raises(DeckError) as err:
        build_scene(as_loaded_deck(data, "cohesive", Path(".")))
    text = str(err.value)
    assert key in text and words in text and "\n" not in text.strip()


@pytest.mark.parametrize("analysis", ["3d", "axisymmetric"])
def test_the_same_blocks_in_3d_and_axisymmetric(analysis):
    """The mode I blocks as a 3D pair of 4 x 2 x 2 mm boxes (interface area 8 mm^2) and as
    axisymmetric discs of radius 4 mm (8 mm^2 per radian): fracture energy G_Ic A within 0.5%
    (measured 1.0000 and 1.0000), the interface particles failed, no other one damaged."""
    data = deck("I")
    data.pop("thickness")
    data["analysis"] = analysis
    data["time"]["end"] = 0.1
    if analysis == "3d":
        data["grid"]["domain"] = {"min": [-4.0, -4.0, -1.0], "max": [8.0, 8.0, 3.0]}
        for body, y, v in zip(data["bodies"], (0.0, 2.0), (-10.0, 10.0)):
            body.update(shape="box", min=[0.0, y, 0.0], max=[4.0, y + 2.0, 2.0], velocity=[0.0, v, 0.0])
        data["contact"]["normal_vector"] = [0.0, 1.0, 0.0]
    else:
        data["grid"]["domain"] = {"min": [0.0, -4.0], "max": [6.0, 8.0]}
    sim = run(data)
    P = sim.state.particles
    near = np.abs(P.x0[:, 1] - 2.0) < 0.5
    assert sim.recorder.column("fracture_energy")[-1] == pytest.approx(G_I * 8.0, rel=0.005)
    assert np.all(P.interface_damage[near] == 1.0) and np.all(P.interface_damage[~near] == 0.0)


def test_the_ledger_books_the_fracture_energy_as_its_own_loss(tmp_path):
    """With output.energy_ledger the fracture energy is the ledger's fracture_loss, row by row,
    taken out of contact_loss (the ledger's residual unchanged); the VTU carries
    interface_damage from the first file on."""
    data = deck("I")
    data["time"]["end"] = 0.05
    data["output"].update(energy_ledger=True, vtu_interval=0.025)
    sim = Simulation(build_scene(as_loaded_deck(data, "cohesive", tmp_path)), out_dir=tmp_path, threads=1)
    sim.run()
    col = sim.recorder.column
    assert np.array_equal(col("fracture_loss"), col("fracture_energy"))
    assert col("fracture_loss")[-1] == pytest.approx(G_I * AREA, rel=0.03)
    import meshio
    files = sorted(tmp_path.rglob("*.vtu"))
    assert len(files) >= 2
    for f in files:
        pts = meshio.read(f).point_data
        if "interface_damage" in pts or "material" in pts:
            assert "interface_damage" in pts and "interface_opening" in pts


def test_a_cohesive_law_in_the_implicit_step_is_refused_naming_the_key():
    """Cohesive interfaces are the explicit step's (the implicit barrier and FEM bodies have
    none): one line naming contact.default.law."""
    data = deck("I")
    data["integrator"] = "implicit"
    data["time"] = {"end": 0.01, "dt": 1e-4}
    data["update"] = {"scheme": "flip"}
    with pytest.raises(DeckError) as err:
        build_scene(as_loaded_deck(data, "cohesive", Path(".")))
    assert "contact.default.law" in str(err.value) and "explicit step" in str(err.value)


def tilted(deg: float, shift: float = 0.0) -> dict:
    """The mode I blocks rotated by deg about the origin (polygons, velocities and the
    specified normal rotated), the interface moved by shift along its normal."""
    import math
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    rot = lambda x, y: [c * x - s * y, s * x + c * y]  # noqa: E731
    data = deck("I")
    y = 2.0 + shift
    data["bodies"][0] = {"shape": "polygon", "vertices": [rot(0, 0), rot(4, 0), rot(4, y), rot(0, y)],
                         "material": "a", "velocity": rot(0, -10.0)}
    data["bodies"][1] = {"shape": "polygon", "vertices": [rot(0, y), rot(4, y), rot(4, 4), rot(0, 4)],
                         "material": "b", "velocity": rot(0, 10.0)}
    data["contact"]["normal_vector"] = rot(0, 1.0)
    data["grid"]["domain"] = {"min": [-6.0, -4.0], "max": [8.0, 8.0]}
    data["time"]["end"] = 0.1
    return data


def test_the_fracture_energy_does_not_depend_on_where_the_interface_lies():
    """The mode I blocks with the interface on a grid line, mid-cell (moved by a particle
    spacing, 0.25 mm: the seeding moves in particle spacings), and tilted 1 and 10 degrees to
    the grid: fracture energy within 1% of the grid-line value (measured +1e-11, +6e-9,
    +0.63%). At 30 degrees it is +7.1% (the failed areas sum to 4.28 mm, not 4: open)."""
    ref = run(tilted(0.0)).recorder.column("fracture_energy")[-1]
    for deg, shift in ((0.0, 0.25), (1.0, 0.0), (10.0, 0.0)):
        e = run(tilted(deg, shift)).recorder.column("fracture_energy")[-1]
        assert e == pytest.approx(ref, rel=0.01), (deg, shift, e / ref)


def test_a_cohesive_pair_that_never_touches_is_refused_naming_the_key():
    """Blocks 3 mm apart (six cells) bonded by a cohesive pair: refused before the run, one
    line naming contact.pairs.0.between; as a default law, contact.default.law."""
    apart = deck("I")
    for end in ("min", "max"):
        apart["bodies"][1][end][1] += 3.0
    law = apart["contact"]["default"]
    as_pair = copy.deepcopy(apart)
    as_pair["contact"].update(default={"law": "frictionless"}, pairs=[dict(law, between=["a", "b"])])
    for data, key in ((as_pair, "contact.pairs.0.between"), (apart, "contact.default.law")):
        with pytest.raises(DeckError) as err:
            Simulation(build_scene(as_loaded_deck(data, "cohesive", Path("."))), out_dir=None)
        text = str(err.value).strip()
        assert key in text and "within two cells" in text and len(text.splitlines()) == 1


def test_a_precrack_starts_debonded_and_dissipates_nothing():
    """The mode I blocks with `precrack` over their left half (x < 2 mm): only the right half's
    particles are bonded, and the fracture energy is G_Ic times that half, 2 mm^2 (within 3%,
    as the whole interface's), not the whole 4 mm^2."""
    data = deck("I")
    data["contact"]["default"]["cohesive"]["precrack"] = [{"min": [-1.0, 1.5], "max": [2.0, 2.5]}]
    sim = run(data)
    P = sim.state.particles
    near = np.abs(P.x0[:, 1] - 2.0) < 0.5
    assert np.array_equal(P.interface_bonded, near & (P.x0[:, 0] > 2.0))
    assert sim.recorder.column("fracture_energy")[-1] == pytest.approx(G_I * 2.0, rel=0.03)


def test_a_sliver_of_mass_at_an_interface_node_books_no_energy():
    """The end-notched flexure deck's first 40 steps (tests/validation/cohesive_beams.py ENF,
    time.end 12 ms, which sets the step): at step 20 a lower-arm particle reaches the row of
    nodes above the interface with a sliver of its shape function (mass 1e-62 of the node's),
    and its round-off velocity made the cohesive spring report 6.7e-4 mJ there, 2e6 times the
    step's true 3e-10; the energy check stopped the run. With the sliver held bonded
    (mpmsim/contact/grid/spec.py SLIVER), the interface energy grows smoothly."""
    from tests.validation.cohesive_beams import ENF

    spec = ENF(end=12.0, extra={"update": {"scheme": "xpic", "order": 2}, "stability": {"energy_tolerance": 1e9}})
    sim = Simulation(build_scene(as_loaded_deck(spec.deck(), "enf", Path("."))), out_dir=None, threads=1)
    energy = []
    for _ in range(40):
        sim.step()
        energy.append(sim.state.interface_energy)
    energy = np.array(energy)
    assert energy.max() < 1e-8  # (a spike books 6.7e-4)
    assert np.all(np.diff(energy[10:]) > 0.0)  # the load grows: so does the stored energy


def test_an_interface_crossing_the_axis_opens_there_as_elsewhere():
    """Axisymmetric discs (r < 2 mm, 1 mm thick each) bonded on z = 1 (cohesive law far below
    its peak, D = 1000 MPa/mm) and pulled apart by 2 MPa on the top face, nearly static under
    grid damping: the opening is T / D across the interface, on the axis as at mid-radius
    (within 2%; measured 1.004). A contact area per radian is the r-z area times the mean
    radius of the node's material (mpmsim/contact/grid/plan.py mean_radius); the interface
    paper's node radius gave the node on the axis no area, so the bond carried nothing there
    and the particles by the axis opened 13% more than those at mid-radius."""
    D, T = 1000.0, 2.0
    data = {"title": "discs pulled apart", "units": "mm-g-ms", "analysis": "axisymmetric",
            "grid": {"cell_size": 0.25, "domain": {"min": [0.0, 0.0], "max": [3.0, 3.0]},
                     "boundaries": {"ymin": "roller"}},
            "materials": {"a": {"type": "linear_elastic", "E": 2000.0, "nu": 0.3, "density": 0.0012},
                          "b": {"type": "linear_elastic", "E": 2000.0, "nu": 0.3, "density": 0.0012}},
            "bodies": [{"shape": "rectangle", "min": [0.0, 0.0], "max": [2.0, 1.0], "material": "a"},
                       {"shape": "rectangle", "min": [0.0, 1.0], "max": [2.0, 2.0], "material": "b"}],
            "loads": [{"region": {"min": [0.0, 1.75], "max": [2.0, 2.0]}, "face": "ymax", "traction": [0.0, T],
                       "ramp": 0.02}],
            "contact": {"normal": "specified", "normal_vector": [0.0, 1.0],
                        "default": {"law": "cohesive", "Dn": D, "Dt": D,
                                    "cohesive": {"peak_traction": 100.0, "G_Ic": 10.0}}},
            "damping": {"grid": 500.0},
            "time": {"end": 0.1, "cfl": 0.5}, "output": {"history_interval": 0.01}}
    P = run(data).state.particles
    r, near = P.x0[:, 0], np.abs(P.x0[:, 1] - 1.0) < 0.25
    axis = P.interface_opening[near & (r < 0.25)].mean()
    middle = P.interface_opening[near & (r > 0.5) & (r < 1.0)].mean()
    assert middle == pytest.approx(T / D, rel=0.05)
    assert axis == pytest.approx(middle, rel=0.02)


@pytest.mark.parametrize("normal, warned", [({"normal_vector": [0.0, 1.0]}, False),
                                            ({"normal_vector": [0.0, -1.0]}, True),
                                            ({"normal_center": [2.0, -10.0]}, False),
                                            ({"normal_center": [2.0, 14.0]}, True)])
def test_a_specified_normal_pointing_the_wrong_way_is_a_notice(normal, warned):
    """The specified normal points from the material listed first ('a', below) to the other
    ('b', above). Pointing the other way (down, or radially from a centre above the blocks) a
    cohesive law reads every opening as compression and never softens (the debonding sphere
    listed matrix first never debonded at its pole): `check` and `run` say so, naming the key."""
    data = deck("I")
    data["contact"].pop("normal_vector")
    data["contact"].update(normal)
    notices = build_scene(as_loaded_deck(data, "cohesive", Path("."))).notices
    said = [n for n in notices if "the specified normal points from 'a' to 'b'" in n]
    assert bool(said) == warned
    if warned:
        assert said[0].startswith(f"contact.{next(iter(normal))}:")
