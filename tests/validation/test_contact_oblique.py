"""Oblique impact: contact that pushes only along its normal and never beyond Coulomb.

A steel cylinder (R = 10 mm) strikes an aluminium block at 45 degrees, v = (1, -1) m/s
(inputs/oblique_impact.yaml, contact defaults: `contact.pass_3: persist`), at R/h = 10 and 20,
frictionless and with Coulomb friction mu = 0.1, 0.3, 0.6. The cylinder's velocities after the
impact are compared with the reference code's (NairnMPM v19 on the same scene:
tests/validation/data/oblique_reference.json says how they were made; the input files are
beside it), and once with the reference code's own passes (`pass_3: recheck`). What contact must never do is
checked on every run: a tangential impulse without friction, a tangential change above mu
times the normal change at any contact node in passes 1 and 2, a rebound faster than the
impact. No contact scene may gain energy: a steel sphere dropped on a block in 3D (half,
quarter and full models, normally and obliquely, frictionless and with friction, R/h = 5 and
10) and the cylinder dropped in plane strain under PIC, FLIP, USF and USAVG+ (with the default
`pass_3: persist`, whose pass 1 holds pass 2's pairs; `recheck` gains 1.4% at R/h = 5
obliquely, docs/contact.md, choice 11). A touching start with friction is checked against the
continuum's rebound: the same scene as finite elements without particles (bench/oblique_fem.py,
tests/validation/data/oblique_fem_reference.json). Numbers in docs/contact.md, "Oblique impact".
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mpmsim.contact.grid.laws import apply_law
from mpmsim.contact.grid.spec import COULOMB
from mpmsim.deck.overrides import with_overrides
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation

from ..conftest import ROOT, deck_from
from ..tiers import tiered
from .helpers import example

pytestmark = pytest.mark.contact_oblique

DATA = Path(__file__).with_name("data")
REFERENCE = json.loads((DATA / "oblique_reference.json").read_text())


def law_of(mu: float) -> dict:
    return {"law": "frictionless"} if mu == 0.0 else {"law": "coulomb", "friction": mu}


class NodeBound:
    """Checks every contact node right after pass 2 (while the geometry is still the one
    passes 1 and 2 used; `recheck` recomputes it in pass 3): the worst excess of a node's
    tangential change over mu times its normal change, in pass 1 (dp1) and pass 2
    (applied2), relative to the node's change; and the cumulative tangential and normal
    impulses of pass 2 in each node's own frame."""

    def __init__(self, sim):
        self.worst = 0.0
        self.checked = 0
        self.tangential = 0.0
        self.normal = 0.0
        tasks = sim.integrator.tasks
        i = [t.name for t in tasks].index("contact pass 2")
        pass_2 = tasks[i].run

        def run(state):
            pass_2(state)
            self.check(state)

        tasks[i] = dataclasses.replace(tasks[i], run=run)

    def check(self, state) -> None:
        cs = state.contact
        dim = state.dim
        a = np.nonzero(cs.role[: cs.n_slots] != 0)[0]
        n = cs.normal[a, :dim]
        mu = cs.mu[a]
        for k, change in enumerate((cs.dp1[a, :dim], cs.applied2[a, :dim])):
            pn = np.einsum("ij,ij->i", change, n)
            pt = np.linalg.norm(change - pn[:, None] * n, axis=1)
            size = np.linalg.norm(change, axis=1)
            live = size > 0.0
            self.checked += int(live.sum())
            if live.any():
                excess = (pt[live] - mu[live] * np.abs(pn[live])) / size[live]
                self.worst = max(self.worst, float(excess.max()))
            if k == 1:
                self.tangential += float(pt.sum())
                self.normal += float(np.abs(pn).sum())


@cache
def cylinder(h: float, mu: float, cfl: float | None = None, pass_3: str | None = None) -> dict:
    """Run the oblique cylinder at cell size h and friction mu (and time.cfl, contact.pass_3 if
    given): final velocities, the cylinder's cumulative impulse over time, the per-node Coulomb check."""
    over = {"grid.cell_size": h, "contact.default": law_of(mu)}
    if cfl is not None:
        over["time.cfl"] = cfl
    if pass_3 is not None:
        over["contact.pass_3"] = pass_3
    data = with_overrides(example("oblique_impact"), over)
    sim = Simulation(build_scene(deck_from(data, ROOT / "inputs")))
    bound = NodeBound(sim)
    sim.run()
    col = sim.recorder.column
    px, py = col("px_cylinder"), col("py_cylinder")
    mass = px[0]  # initial velocity (1, -1)
    return {"v": (px[-1] / mass, py[-1] / mass), "Ix": px - px[0], "Iy": py - py[0], "bound": bound}


CASES = [(1.0, 0.0), (1.0, 0.1), (1.0, 0.3), (1.0, 0.6), (0.5, 0.0), (0.5, 0.3)]


def case_id(case) -> str:
    h, mu = case
    return f"R/h={10.0 / h:g}-mu={mu:g}"


def fine(case) -> bool:
    """R/h = 20 (two runs of 17,000 particles for 11,200 steps): `make validate`; R/h = 10 rows
    fail the same wrong methods in `make test`."""
    return case[0] < 1.0


@pytest.mark.contact_default
@pytest.mark.parametrize("case", tiered([c for c in CASES if c != (1.0, 0.1)], fine, case_id))
def test_cylinder_velocities_match_the_reference_code(case, measure):
    """vx and vy after the impact, with the contact defaults, within 2% of the reference code's
    (measured: within 1.8%, mu = 0.6 vx -1.7%; R/h = 10, mu = 0.1 below: its vy is chaotic in both codes). The
    former default `pass_3: keep` misses by up to 9.3% (0.5 mm, frictionless, vy)."""
    h, mu = case
    ref = REFERENCE["runs"][f"h={h:g} mu={mu:g}"]
    vx, vy = cylinder(h, mu)["v"]
    measure(f"vx, R/h = {10 / h:g}, mu = {mu:g}", f"{vx:.4f} ({vx / ref['vx'] - 1:+.2%})", f"within 2% of {ref['vx']:.4f}")
    measure(f"vy, R/h = {10 / h:g}, mu = {mu:g}", f"{vy:.4f} ({vy / ref['vy'] - 1:+.2%})", f"within 2% of {ref['vy']:.4f}")
    assert vx == pytest.approx(ref["vx"], rel=0.02)
    assert vy == pytest.approx(ref["vy"], rel=0.02)


def test_the_reference_codes_passes_give_its_velocities():
    """`pass_3: recheck` (the reference code's passes) on the 1 mm, mu = 0.6 row: within 2% of
    its vx and vy (measured +0.39%, +0.92%; over a CFL scan within 0.6% and 1.0%, docs/contact.md)."""
    ref = REFERENCE["runs"]["h=1 mu=0.6"]
    vx, vy = cylinder(1.0, 0.6, pass_3="recheck")["v"]
    assert vx == pytest.approx(ref["vx"], rel=0.02)
    assert vy == pytest.approx(ref["vy"], rel=0.02)


@pytest.mark.validation
@pytest.mark.contact_default
def test_cylinder_velocities_over_a_cfl_scan_match_the_reference_codes_scan(measure):
    """R/h = 10, mu = 0.1, contact defaults: the rebound's vy depends on the time step in both
    codes. The reference code run at CFL 0.49 ... 0.51 (seven values,
    tests/validation/data/oblique_reference.json "cfl_scan") gives vy from 0.757 to 0.827 (mean
    0.795, SD 0.025) and vx from 0.844 to 0.852; mpmsim at the same seven, vy 0.747 to 0.805
    (mean 0.779; the reference code's passes, `recheck`: 0.744 to 0.815, mean 0.771) and vx
    0.842 to 0.851. So one run's vy against the reference code's one run is a draw, not a
    check. Checked: vx at every CFL within 2% of the reference code's at the same CFL (vx tells
    the friction: 0.98 without it, 0.58 at mu = 0.3); vy's mean over the scan within 4% of the
    reference code's mean (measured -2.1%; the two means' standard errors are 1.2% each); every
    vy inside the reference code's range widened by 4%."""
    scan = REFERENCE["cfl_scan"]["rows"]
    ours = [cylinder(1.0, 0.1, None if row["cfl"] == 0.5 else row["cfl"])["v"] for row in scan]  # (the deck's is 0.5)
    for (vx, vy), row in zip(ours, scan):
        assert vx == pytest.approx(row["vx"], rel=0.02)
    vy_ref = np.array([row["vy"] for row in scan])
    vy = np.array([v[1] for v in ours])
    measure("mean vy over the CFL scan, R/h = 10, mu = 0.1", f"{vy.mean():.4f} ({vy.mean() / vy_ref.mean() - 1:+.2%})",
            f"within 4% of {vy_ref.mean():.4f}")
    assert vy.mean() == pytest.approx(vy_ref.mean(), rel=0.04)
    assert np.all(vy > 0.96 * vy_ref.min()) and np.all(vy < 1.04 * vy_ref.max())


@pytest.mark.contact_default
@pytest.mark.parametrize("h", tiered([1.0, 0.5], lambda h: h < 1.0, lambda h: f"R/h={10 / h:g}"))
def test_frictionless_contact_pushes_along_the_normal_only(h):
    """Without friction the tangential impulse on the cylinder is at most 1% of the normal
    impulse (the flat block's normal is y) at R/h = 20 (measured with the defaults 0.10%;
    recheck 0.28%). At R/h = 10 it is 1.12% (recheck 1.16%, the reference code 1.15%): the two
    nodes flanking the first contact see the wedge between the curved and the flat surface and
    tilt their normals by 1-2.5 degrees (docs/contact.md); the bound there is 1.5%."""
    run = cylinder(h, 0.0)
    assert run["Iy"][-1] > 4.0  # the cylinder rebounded (N ms per mm: m (1 + vy) with m = 2.48 g)
    assert abs(run["Ix"][-1]) <= (0.01 if h <= 0.5 else 0.015) * run["Iy"][-1]
    assert run["bound"].worst <= 1e-12  # every node: the change is along its normal


@pytest.mark.parametrize("case", tiered([c for c in CASES if c[1] > 0.0], fine, case_id))
def test_coulomb_bound_holds_cumulatively_and_at_every_node(case):
    """Must-show 3: at every contact node the tangential change of passes 1 and 2 stays below
    mu times the normal change (each node's own normal), so the cumulative pass-2 impulses in
    the nodes' frames do too; on the cylinder the tangential (x) impulse stays below mu times
    the normal (y) impulse (+1%) from 10% of the final normal impulse on. Before that the first
    contact acts at nodes whose normals tilt 1-2.5 degrees from y, which adds up to 0.04 to
    the x/y ratio: 0.307 at 6% of the impulse for mu = 0.3 at R/h = 20, and 0.307 in the
    reference code too (docs/contact.md)."""
    h, mu = case
    run = cylinder(h, mu)
    bound = run["bound"]
    assert bound.checked > 100
    assert bound.worst <= 1e-12
    assert bound.tangential <= mu * bound.normal * (1 + 1e-12)
    assert bound.tangential > 0.5 * mu * bound.normal  # friction acted (slip at many node-steps)
    Ix, Iy = run["Ix"], run["Iy"]
    loaded = Iy > 0.1 * Iy[-1]
    assert loaded.sum() > 3
    assert np.all(np.abs(Ix[loaded]) <= 1.01 * mu * Iy[loaded])


@pytest.mark.parametrize("case", tiered(CASES, fine, case_id))
def test_no_rebound_faster_than_the_impact(case):
    """Must-show 4: vy after the impact is at most the impact speed."""
    vx, vy = cylinder(*case)["v"]
    assert 0.0 < vy <= 1.0


# ---------------------------------------------- friction from a touching start
FEM = json.loads((DATA / "oblique_fem_reference.json").read_text())
_fem_spec = importlib.util.spec_from_file_location("oblique_fem", ROOT / "bench" / "oblique_fem.py")
oblique_fem = importlib.util.module_from_spec(_fem_spec)
_fem_spec.loader.exec_module(oblique_fem)


def continuum(mu: float) -> dict:
    """The finest level of the finite-element reference (bench/oblique_fem.py) for friction mu."""
    rows = [r for r in FEM["runs"] if r["mu"] == mu]
    return max(rows, key=lambda r: r["level"])


@cache
def touching_cylinder(h: float, mu: float, seeding: str | None) -> tuple[float, float]:
    """The oblique cylinder started with its particle domains touching the block (no flight),
    run to 0.1 ms: vx, vy after. seeding None: the default (a circle in contact follows its
    surface: rings_half_step, outer domains on the circle, so the centre is R above the block);
    lattice: the deck's (its lowest row's domains touch with the centre at y = 25.05)."""
    data = with_overrides(example("oblique_impact"), {"grid.cell_size": h, "contact.default": law_of(mu),
                                                      "time.end": 0.1})
    cylinder_body = data["bodies"][1]
    cylinder_body.pop("seeding")
    if seeding is None:
        cylinder_body["center"] = [-8.0, 25.0]
    else:
        cylinder_body.update(seeding=seeding, center=[-8.0, 25.05])
    sim = Simulation(build_scene(deck_from(data, ROOT / "inputs")))
    sim.run()
    px, py = sim.recorder.column("px_cylinder"), sim.recorder.column("py_cylinder")
    return px[-1] / px[0], py[-1] / px[0]


@pytest.mark.contact_default
def test_friction_does_not_raise_the_continuums_rebound():
    """The open question of a touching start (both codes rebound at 1.08 m/s with mu = 0.3),
    decided by a converged solution of the same scene that has no particles: both bodies as
    finite elements, stepped implicitly (midpoint Newmark), barrier contact with IPC's smoothed
    Coulomb friction (bench/oblique_fem.py; tests/validation/data/oblique_fem_reference.json
    holds up to four levels, element size 0.2 to 0.025 mm at the contact, time step 0.5 to
    0.0625 us, for mu = 0, 0.1, 0.3, 0.6). Its vy with friction is not above its frictionless vy
    (+0.3% allowed; measured -0.00%, -0.05%, -0.27%) nor above 1: friction slows the cylinder's
    slide and spins it up; it does not send it off faster than it came. Run here: the coarsest
    level with mu = 0.3, whose vy is within 0.3% of the finest level's (measured -0.07%)."""
    run = oblique_fem.run(0, 0.3)
    fine, frictionless = continuum(0.3), continuum(0.0)
    assert run["vy"] == pytest.approx(fine["vy"], rel=0.003)
    assert run["vx"] == pytest.approx(fine["vx"], rel=0.04)  # (level 0 +2.3%, converging: the table in docs)
    for mu in (0.1, 0.3, 0.6):
        assert continuum(mu)["vy"] <= min(1.0, frictionless["vy"] * 1.003)
    assert 0.4 < fine["vx"] < 0.6  # it stuck and slipped back: rolling alone would leave vx = 2/3


@pytest.mark.contact_default
def test_a_touching_start_rebounds_as_the_continuum_with_the_default_seeding():
    """Why both codes say 1.08: the lattice seeds the cylinder with a flat bottom (eight
    particles in its lowest row at 1 mm cells, 4 mm wide), and a start that puts that row's
    domains on the block puts six nodes in contact from the first steps: a flat punch, stiffer than
    the cylinder whose contact is about 0.4 mm wide; it rebounds at vy 1.080 (the continuum
    0.997: +8%). Approached in flight the same lattice comes in one node at a time (0.775, -22%:
    the contact lets go early; docs/contact.md). Seeded to its surface (the default for a circle
    in contact) the touching start rebounds within 2% of the continuum at R/h = 10 (measured
    0.985, -1.3%)."""
    vy_continuum = continuum(0.3)["vy"]
    _, vy = touching_cylinder(1.0, 0.3, None)
    _, vy_lattice = touching_cylinder(1.0, 0.3, "lattice")
    assert vy == pytest.approx(vy_continuum, rel=0.02)
    assert vy_lattice > 1.05 * vy_continuum  # (the staircase's flat punch; 1.080 measured)


SCENE2 = json.loads((DATA / "oblique_fem_scene2.json").read_text())


@pytest.mark.contact_continuum
def test_a_second_scene_gets_its_continuum_from_the_bench_arguments():
    """Any oblique scene gets its continuum with one command (bench/oblique_fem.py's scene
    arguments): a second one, an aluminium cylinder (R = 6 mm) at (0.5, -1) m/s onto a copper
    block, stored with five levels (tests/validation/data/oblique_fem_scene2.json, six with
    mu = 0.3). Its finest two levels agree within 0.5% in vx and vy, frictionless and with
    mu = 0.3 (measured 0.06% / 0.02% and 0.14% / 0.02%); level 0 with mu = 0.3, rerun here from
    the stored scene, gives the stored rebound (to 1e-5: the scene's arguments reach the meshes,
    materials and velocity; the default scene's level 0 is 0.4974, 0.9963)."""
    scene = oblique_fem.Scene(**{k: tuple(v) if isinstance(v, list) else v for k, v in SCENE2["scene"].items()})
    assert scene != oblique_fem.Scene()
    for mu in (0.0, 0.3):
        runs = sorted((r for r in SCENE2["runs"] if r["mu"] == mu), key=lambda r: r["level"])
        assert len(runs) >= 5
        for v in ("vx", "vy"):
            assert runs[-1][v] == pytest.approx(runs[-2][v], rel=0.005), (mu, v)
    stored = next(r for r in SCENE2["runs"] if r["mu"] == 0.3 and r["level"] == 0)
    run = oblique_fem.run(0, 0.3, scene=scene)
    assert run["vx"] == pytest.approx(stored["vx"], rel=1e-5)
    assert run["vy"] == pytest.approx(stored["vy"], rel=1e-5)


def scene_continuum(stored: dict, mu: float) -> dict:
    rows = [r for r in stored["runs"] if r["mu"] == mu and r.get("material", "linear_elastic") == "linear_elastic"]
    return max(rows, key=lambda r: r["level"])


@pytest.mark.validation
@pytest.mark.contact_continuum
@pytest.mark.parametrize("which", ["default", "second"])
def test_the_plain_deck_converges_to_the_continuum_with_friction(which, measure):
    """The scene written plainly (bench/oblique_fem.py plain_deck: every default, the cylinder
    seeded to its surface and touching), mu = 0.3, at R/h = 20 and 40 against the stored
    continuum. At R/h = 40 vx and vy within 2% (measured default scene -0.3% / -0.1%, second
    scene +0.3% / -0.8%; at R/h = 20 -5.0% / +1.3% and -8.9% / -9.6%), and the cylinder's
    angular momentum about the touch point within 1% of the continuum's (which keeps it to 0.2%:
    the contact force acts through the patch). At R/h = 20 the patch (2a about 0.4 mm at the
    peak) is under a cell wide, the force sits on the nodes either side of it, ahead of the
    touch point, and that moment (a rolling resistance the continuum has not got) is what
    keeps the cylinder sliding too long: its angular momentum there is 3-5% short, and the
    test asks that the shortfall at R/h = 40 be under half of it. Energy: kinetic + strain
    never above the start by 0.2% at any row (with the ledger's friction_loss added it ends
    1-7% above: at sliding targets the ledger books friction work that the transfers and the
    force gap return, docs/contact-methods.md; the split is open). Issue 77 asked for 2% at
    R/h = 20 and 4% at R/h = 10; docs/contact-methods.md has the evidence why nodal contact
    cannot give that and these bounds replace it."""
    stored = FEM if which == "default" else SCENE2
    scene = (oblique_fem.Scene() if which == "default" else
             oblique_fem.Scene(**{k: tuple(v) if isinstance(v, list) else v for k, v in SCENE2["scene"].items()}))
    ref = scene_continuum(stored, 0.3)
    L_ref = oblique_fem.continuum_touch_momentum(ref, scene)
    coarse, fine = (oblique_fem.run_mpm(scene, rh, 0.3) for rh in (20.0, 40.0))
    err = {k: fine[k] / ref[k] - 1 for k in ("vx", "vy")}
    measure(f"{which} scene, mu = 0.3, R/h = 40: vx, vy against the continuum; L about P (continuum {L_ref:.4f}); "
            "largest E / E0 (with friction_loss)",
            f"{100 * err['vx']:+.1f}%, {100 * err['vy']:+.1f}%; {fine['touch_L']:.4f} (R/h = 20: {coarse['touch_L']:.4f}); "
            f"{fine['energy_max']:.4f} ({fine['booked_max']:.4f})",
            "2%; within 1%, shortfall under half R/h = 20's; <= 1.002")
    assert abs(err["vx"]) < 0.02 and abs(err["vy"]) < 0.02, err
    assert fine["touch_L"] == pytest.approx(L_ref, abs=0.01)
    assert L_ref - fine["touch_L"] < 0.5 * (L_ref - coarse["touch_L"])
    for run in (coarse, fine):
        assert run["energy_max"] <= 1.002


# --------------------------------------------------------------- the law itself
vectors = st.lists(st.floats(-10.0, 10.0), min_size=3, max_size=3)


@settings(max_examples=400, deadline=None)
@given(dp=vectors, n=vectors, mu=st.floats(0.0, 2.0), mu_static=st.one_of(st.just(-1.0), st.floats(0.0, 3.0)),
       dim=st.sampled_from([2, 3]), decided=st.booleans())
def test_coulomb_law_never_exceeds_its_bound(dp, n, mu, mu_static, dim, decided):
    """For any stick impulse and normal, in contact: the applied tangential change is at most
    max(mu, mu_static if it sticks) times the applied normal change, and the normal change is
    the stick impulse's normal part. `decided` (pass 3, XPIC increments: a contact kept from
    pass 2) also admits a separating normal part."""
    n = np.array(n[:dim] + [0.0] * (3 - dim))
    if np.linalg.norm(n) < 1e-3:
        return
    n /= np.linalg.norm(n)
    dp = np.array(dp[:dim] + [0.0] * (3 - dim))
    dotn = float(dp @ n)
    if not decided and dotn >= 0.0:
        dotn = -abs(dotn) - 1e-3  # the passes call the law in contact only when approaching
        dp = dp - (float(dp @ n) - dotn) * n
    out = np.zeros(3)
    assert apply_law(COULOMB, mu, mu_static, 0, dp, n, dotn, True, dim, out)
    applied_n = float(out @ n)
    tangential = np.linalg.norm(out - applied_n * n)
    assert applied_n == pytest.approx(dotn, abs=1e-12 * (1 + abs(dotn)))
    stuck = np.allclose(out, dp, atol=1e-12 * (1 + np.abs(dp).max()))
    cap = max(mu, mu_static) if stuck else mu
    assert tangential <= cap * abs(applied_n) * (1 + 1e-12) + 1e-12


# --------------------------------------------------------------- no energy gained
def sphere_deck(h: float, oblique: bool, model: str = "half") -> dict:
    """A steel sphere (R = 10 mm) on an aluminium block, seeded on the lattice, its lowest
    particle domains on the block's top (they touch at t = 0), striking at (1, -1, 0) or
    (0, -1, 0) m/s. model: "half" (z >= 0, roller at z = 0), "quarter" (x >= 0 as well, a
    second roller; normal drops only) or "full" (no symmetry plane)."""
    data = example("oblique_impact")
    space = h / 2  # particle spacing (2 per cell direction)
    top = 6.0  # block top, on a grid line
    yc = top + 10.0 + 0.25 * space  # lowest lattice row half a spacing above the top
    x0 = -4.0 if oblique else 0.0
    lo_x = 0.0 if model == "quarter" else -16.0
    lo_z = -14.0 if model == "full" else 0.0
    boundaries = {"ymin": "fixed"}
    if model != "full":
        boundaries["zmin"] = "roller"
    if model == "quarter":
        boundaries["xmin"] = "roller"
    data.update({
        "title": f"Steel sphere on an aluminium block, {model} model",
        "analysis": "3d",
        "grid": {"cell_size": h, "domain": {"min": [lo_x, 0.0, lo_z], "max": [16.0, yc + 12.0, 14.0]},
                 "boundaries": boundaries},
        "bodies": [
            {"name": "block", "shape": "box", "min": [max(lo_x, -14.0), 0.0, max(lo_z, -12.0)], "max": [14.0, top, 12.0],
             "material": "alu"},
            {"name": "sphere", "shape": "sphere", "center": [x0, yc, 0.0], "radius": 10.0, "material": "steel",
             "seeding": "lattice",  # (the touching start above is the lattice's)
             "velocity": [1.0 if oblique else 0.0, -1.0, 0.0],
             "clip": {"min": [lo_x, 0.0, max(lo_z, -20.0)], "max": [20.0, 40.0, 20.0]}},
        ],
        "contact": {"normal": "logistic_regression", "default": {"law": "frictionless"}},
        "time": {"end": 0.08, "cfl": 0.5},
        "output": {"history_interval": 0.001},
    })
    return data


def energy_gain(data: dict, body: str) -> tuple[float, float]:
    """Run the deck: the largest relative gain of kinetic + strain energy over its initial value
    at any history row (no external work in these scenes), and the body's vy after / its vy at
    t = 0 (its rebound as a fraction of the impact speed)."""
    sim = Simulation(build_scene(deck_from(data, ROOT / "inputs")))
    sim.run()
    col = sim.recorder.column
    energy = col("kinetic_energy") + col("strain_energy")
    py = col(f"py_{body}")
    return float(energy.max() / energy[0] - 1.0), float(-py[-1] / py[0])


SPHERES = [(h, model, oblique, mu) for h in (2.0, 1.0) for model, oblique, mu in
           [("half", False, 0.0), ("half", True, 0.0), ("quarter", False, 0.0), ("full", False, 0.0),
            ("full", False, 0.3)]]


@pytest.mark.contact_default
@pytest.mark.parametrize("h, model, oblique, mu", tiered(  # R/h = 10 (up to 80 s a run): make validate
    SPHERES, lambda s: s[0] < 2.0, lambda s: f"R/h={10 / s[0]:g}-{s[1]}{'-oblique' if s[2] else ''}"
                                             f"{f'-mu={s[3]:g}' if s[3] else ''}", unpack=True))
def test_sphere_impact_never_gains_energy(h, model, oblique, mu):
    """Total energy (kinetic + strain) never above its initial value by more than 0.2% at any
    history row, and the sphere rebounds no faster than it came: half models dropped normally
    and obliquely, the quarter model (two symmetry planes through the contact) and the full model
    (frictionless and mu = 0.3) at R/h = 5 and 10. Measured: 0.000% in every case, where without
    pass 1 holding last step's contacts (docs/contact.md, choice 11) the half oblique model
    gained +0.33% (R/h = 5), the quarter +0.997% and the full model +0.786% (R/h = 10)."""
    data = sphere_deck(h, oblique, model)
    if mu:
        data["contact"]["default"] = law_of(mu)
    gain, vy = energy_gain(data, "sphere")
    assert gain <= 0.002
    assert 0.85 < vy <= 1.0  # it bounced (0.90-0.995 measured)


def dropped_cylinder(scheme: str, stress: str, law: dict | None = None) -> dict:
    """The oblique deck's cylinder dropped normally from a touching start (plane strain, h = 1 mm,
    linear shape functions), with the given update and stress scheme (and contact law)."""
    data = example("oblique_impact")
    data["bodies"][1].update(center=[0.0, 15.0 + 10.0 + 0.125], velocity=[0.0, -1.0])
    data.update({"shape_function": "linear", "update": {"scheme": scheme, "stress": stress},
                 "time": {"end": 0.12, "cfl": 0.5}, "output": {"history_interval": 0.001},
                 "stability": {"energy_tolerance": 1.0}})
    if law is not None:
        data["contact"]["default"] = law
    return data


@pytest.mark.contact_default
@pytest.mark.parametrize("scheme, stress", [("pic", "usf"), ("pic", "usavg"), ("flip", "usavg")])
def test_impact_gains_no_energy_whatever_the_update(scheme, stress):
    """The dropped cylinder: kinetic + strain energy never above its initial value by more than
    0.2%, and no rebound faster than the impact. Where pass 2 stopped slots whose start-of-step
    velocities separate, its impulse did work at the step's mean velocity that the stress update
    never took back: with PIC and USF +11.9% and vy 1.047 after (docs/contact-methods.md, "Where the
    3D gain came from"); pass 1 now holds such pairs (choice 11). Measured 0.000% in all three."""
    gain, vy = energy_gain(dropped_cylinder(scheme, stress), "cylinder")
    assert gain <= 0.002 and 0.85 < vy <= 1.0


@pytest.mark.contact_default
def test_flip_usf_impact_gains_no_more_than_one_velocity_field():
    """FLIP with USF gains energy without contact too: the same cylinder bonded to the block (law
    `none`, one velocity field) gains +0.446%. Contact must add nothing to it: measured +0.385%
    with the default frictionless contact."""
    one_field, _ = energy_gain(dropped_cylinder("flip", "usf", {"law": "none"}), "cylinder")
    gain, vy = energy_gain(dropped_cylinder("flip", "usf"), "cylinder")
    assert one_field > 0.002  # (the scheme's own gain, which the bound below allows)
    assert gain <= one_field and 0.85 < vy <= 1.0
