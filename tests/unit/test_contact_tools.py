"""Tools around contact: the overlap measure, the ellipse-pack image, per-material stress
histories and rigid contact materials' reactions and work."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from mpmsim.overlap import overlap_fraction
from mpmsim.scene.ellipse_pack import BACKGROUND, ellipse_box, grey_level

from mpmsim.deck.overrides import with_overrides

from ..conftest import ROOT, simulate
from .test_output import DECK as OUTPUT_DECK
from ..validation.helpers import run_example


def tiles(x0, x1, y0, y1, spacing):
    """Particle centres tiling [x0, x1] x [y0, y1] with square domains of side `spacing`."""
    xs = np.arange(x0 + spacing / 2, x1, spacing)
    ys = np.arange(y0 + spacing / 2, y1, spacing)
    return np.array([(x, y) for y in ys for x in xs])


def test_overlap_fraction_of_known_squares():
    a = tiles(0.0, 2.0, 0.0, 1.0, 0.25)
    b = tiles(1.5, 3.5, 0.0, 1.0, 0.25)
    x = np.vstack([a, b])
    mat = np.r_[np.zeros(len(a), int), np.ones(len(b), int)]
    F = np.tile(np.eye(3), (len(x), 1, 1))
    semi = np.array([0.125, 0.125])
    # [1.5, 2] x [0, 1] claimed twice, out of [0, 3.5] x [0, 1]
    assert overlap_fraction(x, F, mat, semi, 0.01) == pytest.approx(0.5 / 3.5, rel=0.02)
    # one material overlapping itself does not count; apart, nothing overlaps
    assert overlap_fraction(x, F, np.zeros_like(mat), semi, 0.01) == 0.0
    x[len(a):, 0] += 0.6
    assert overlap_fraction(x, F, mat, semi, 0.01) == 0.0


def test_overlap_fraction_follows_deformed_domains():
    """A stretch F = diag(2, 1) doubles each domain's width: two columns of particles 0.5
    apart whose undeformed domains just touch now overlap by half."""
    x = np.array([[0.0, 0.0], [0.5, 0.0]])
    F = np.tile(np.diag([2.0, 1.0, 1.0]), (2, 1, 1))
    frac = overlap_fraction(x, F, np.array([0, 1]), np.array([0.25, 0.25]), 0.005)
    assert frac == pytest.approx(0.5 / 1.5, rel=0.02)  # [0, 0.5] doubly claimed of [-0.5, 1]


def test_ellipse_pack_is_deterministic_and_separated():
    img = ellipse_box(width=70, height=140, count=5, gap=3, seed=3)
    assert np.array_equal(img, ellipse_box(width=70, height=140, count=5, gap=3, seed=3))
    levels = sorted(set(np.unique(img)) - {BACKGROUND})
    assert levels == [grey_level(k) for k in range(5)]
    # no two ellipses (nor an ellipse and the wall) come closer than the gap
    for k in levels:
        rows, cols = np.nonzero(img == k)
        others = np.argwhere((img != k) & (img != BACKGROUND))
        d = np.abs(rows[:, None] - others[None, :, 0]).clip(min=0)
        d = np.maximum(d, np.abs(cols[:, None] - others[None, :, 1]))
        assert d.min() > 3
        assert rows.min() >= 3 and cols.min() >= 3 and rows.max() < 137 and cols.max() < 67


def test_committed_ellipse_image_is_the_generator_output():
    """inputs/ellipse_box.png is exactly what `python -m mpmsim.scene.ellipse_pack` writes."""
    img = np.array(Image.open(ROOT / "inputs" / "ellipse_box.png"))
    assert img.shape == (560, 280)
    assert np.array_equal(img, ellipse_box())
    assert len(set(np.unique(img)) - {BACKGROUND}) == 20
    assert 0.6 < np.mean(img != BACKGROUND) < 0.8  # packed: 69.5% of the box


def test_material_stress_columns_average_to_the_global_stress():
    deck = with_overrides(OUTPUT_DECK, {"time.end": 0.05, "output": {"history_interval": 0.05,
                                                                      "material_stress": ["soft", "hard"]}})
    sim = simulate(deck)
    h, P = sim.recorder, sim.state.particles
    v_soft, v_hard = P.vol[P.mat == 0].sum(), P.vol[P.mat == 1].sum()
    for s in ("sxx", "syy", "sxy"):
        mixed = (v_soft * h.column(f"{s}_mat_soft")[-1] + v_hard * h.column(f"{s}_mat_hard")[-1]) / (v_soft + v_hard)
        assert mixed == pytest.approx(h.column(s)[-1], rel=1e-10)
    assert h.column("syy_mat_soft")[-1] < 0 and h.column("syy_mat_hard")[-1] < 0


@pytest.fixture(scope="module")
def platen_runs():
    """The column compressed 2% by a rigid platen that holds y on the nodes it touches
    (mode: bc, constrain: [y]) and by the same platen acting through frictionless contact."""
    common = {"materials.platen.velocity": [0.0, -8 * 0.9622], "time.end": 2.0 / 8 / 0.9622, "time.cfl": 0.5}
    bc, _ = run_example("column", **common, **{"materials.platen.constrain": ["y"]})
    contact, _ = run_example("column", **common, **{"materials.platen.mode": "contact"})
    return bc, contact


def test_rigid_contact_platen_matches_a_roller_platen(platen_runs):
    """Measured: syy -57.91 (bc) and -57.81 MPa (contact); platen force -2736 and -2679 N."""
    bc, contact = (r.recorder for r in platen_runs)
    assert contact.column("u_platen_y")[-1] == pytest.approx(-2.0, rel=1e-9)
    assert contact.column("syy")[-1] == pytest.approx(bc.column("syy")[-1], rel=0.005)
    assert contact.column("F_platen_y")[-1] == pytest.approx(bc.column("F_platen_y")[-1], rel=0.04)
    assert contact.column("F_platen_y")[-1] < 0  # the platen pushes down on the column


def test_rigid_contact_work_balances_the_energy(platen_runs):
    """The contact platen's work (pass 2 impulses times its velocity) is the energy put in:
    measured 2449.7 against kinetic + strain 2442.1."""
    h = platen_runs[1].recorder
    stored = h.column("kinetic_energy")[-1] + h.column("strain_energy")[-1]
    assert h.column("external_work")[-1] == pytest.approx(stored, rel=0.01)
    assert h.column("external_work")[-1] > 2000.0


def test_h_perp_is_the_cell_size_across_the_contact_plane():
    """[Imperfect interfaces] Eq. (22), method 1: sqrt(nx^2 dx^2 + ny^2 dy^2) in 2D; in 3D
    dx dy dz / (h1 h2), h1, h2 the distances to the cell ellipsoid along two tangents."""
    from mpmsim.contact.grid.geometry import h_perp

    h2 = np.array([1.0, 2.0, 0.0])
    for angle in np.linspace(0.0, np.pi, 7):
        n = np.array([np.cos(angle), np.sin(angle), 0.0])
        assert h_perp(n, h2, 2) == pytest.approx(np.hypot(n[0] * 1.0, n[1] * 2.0), rel=1e-12)
    h3 = np.array([1.0, 2.0, 3.0])
    for axis in range(3):
        n = np.zeros(3)
        n[axis] = 1.0
        assert h_perp(n, h3, 3) == pytest.approx(h3[axis], rel=1e-12)
    rng = np.random.default_rng(7)
    for _ in range(5):  # regular cells: always the cell size
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        assert h_perp(n, np.full(3, 2.5), 3) == pytest.approx(2.5, rel=1e-12)
        assert h_perp(n, np.full(3, 2.5), 2) == pytest.approx(2.5 * np.hypot(n[0], n[1]), rel=1e-12)


@pytest.mark.parametrize("y", [50.0, 52.5], ids=["grid line", "mid-cell"])
@pytest.mark.parametrize("normal", ["logistic_regression", "average_gradient"])
def test_contact_areas_add_up_to_the_interface(y, normal):
    """The node areas of a flat 40 mm interface add up to 40 mm x thickness wherever it sits
    in the cell (one row of nodes on a grid line, two rows mid-cell), for LR's edge-distance
    weighting and for the gradient methods' sqrt(2 V min(Va, Vb)) / h."""
    from mpmsim.deck.overrides import with_overrides
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation

    from ..conftest import deck_from
    from ..validation.helpers import example

    data = with_overrides(example("two_blocks"), {"bodies.0.max": [40.0, y], "bodies.1.min": [0.0, y],
                                                  "contact.normal": normal})
    sim = Simulation(build_scene(deck_from(data, ROOT / "inputs")))
    for _ in range(3):
        sim.step()
    cs = sim.state.contact
    targets = cs.role[: cs.n_slots] != 0
    assert targets.sum() == (9 if y == 50.0 else 18)
    assert cs.area[: cs.n_slots][targets].sum() == pytest.approx(40.0, rel=1e-9)


def law_impulse(law, dp, dotn_sign=-1, mu=0.0, mu_static=-1.0, in_contact=True):
    """Impulse applied for a stick impulse dp with normal (0, 1)."""
    from mpmsim.contact.grid.laws import apply_law

    n = np.array([0.0, 1.0, 0.0])
    dp = np.array([dp[0], dp[1], 0.0])
    out = np.zeros(3)
    applied = apply_law(law, mu, mu_static, 0, dp, n, float(dp @ n), in_contact, 2, out)
    return applied, out[:2]


def test_contact_laws_impulses_in_impulses_out():
    from mpmsim.contact.grid.spec import COULOMB, FRICTIONLESS, STICK

    dp = (3.0, -2.0)  # approaching (dp . n < 0) with a tangential stick impulse of 3
    assert law_impulse(STICK, dp, in_contact=False)[1].tolist() == [3.0, -2.0]  # bonded: always
    assert law_impulse(FRICTIONLESS, dp)[1].tolist() == [0.0, -2.0]
    applied, out = law_impulse(FRICTIONLESS, dp, in_contact=False)
    assert not applied and out.tolist() == [0.0, 0.0]
    # Coulomb: tangential capped at mu N = 0.5 * 2 = 1; below the cap it sticks
    assert law_impulse(COULOMB, dp, mu=0.5)[1] == pytest.approx([1.0, -2.0])
    assert law_impulse(COULOMB, dp, mu=2.0)[1] == pytest.approx([3.0, -2.0])
    # static coefficient: sticks while S <= mu_s N (3 <= 1.6 * 2), else slides at mu_k
    assert law_impulse(COULOMB, dp, mu=0.5, mu_static=1.6)[1] == pytest.approx([3.0, -2.0])
    assert law_impulse(COULOMB, dp, mu=0.5, mu_static=1.4)[1] == pytest.approx([1.0, -2.0])
    assert law_impulse(COULOMB, dp, mu=0.0, mu_static=1.4)[1] == pytest.approx([0.0, -2.0])
    # a contact already decided (pass 3) removes the normal relative velocity of either sign
    assert law_impulse(COULOMB, (3.0, 2.0), mu=0.5)[1] == pytest.approx([1.0, 2.0])
