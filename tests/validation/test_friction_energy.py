"""Friction's dissipation as its own term of the energy ledger (`friction_loss`,
mpmsim/tasks/ledger.py friction_work), against closed forms: the work of a moving floor that
drags a block up to its speed splits half into the block's kinetic energy and half into
friction; a block sliding to rest on a slab gives friction all of its kinetic energy; the
kernel on one node against the slip work written out. And the contact scenes of a user's first
3D run: a sphere dropped plainly (seeded in shells by default) keeps its energy, and struck
obliquely with friction keeps its energy less what friction took (docs/validation.md, "Energy
ledger")."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.contact.grid.spec import COULOMB, FRICTIONLESS
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation
from mpmsim.tasks.ledger import FRICTION, friction_work

from ..conftest import deck_from

pytestmark = pytest.mark.contact_continuum

G, MU = 10.0, 0.3  # gravity (mm/ms^2) and friction coefficient of the sliding scenes


def sliding_deck(floor: str, scheme: str, mu: float = MU) -> dict:
    """A 4 x 2 mm block (E = 100 MPa, 0.5 mm cells) under gravity on a floor: floor "rigid" is
    a rigid contact material moving at 1 m/s in x under a block at rest; "slab" a deformable
    slab ten times stiffer with a fixed bottom under a block sliding at 1 m/s."""
    rigid = floor == "rigid"
    floor_mat = ({"type": "rigid", "mode": "contact", "velocity": [1.0, 0.0]} if rigid
                 else {"type": "linear_elastic", "E": 1000.0, "nu": 0.3, "density": 0.001})
    return {"title": f"block on a {floor} floor", "units": "mm-g-ms",
            "grid": {"cell_size": 0.5, "domain": {"min": [-2.0, -1.0], "max": [8.0, 4.0]},
                     **({} if rigid else {"boundaries": {"ymin": "fixed"}})},
            "materials": {"block": {"type": "linear_elastic", "E": 100.0, "nu": 0.3, "density": 0.001},
                          "floor": floor_mat},
            "bodies": [{"name": "floor", "shape": "rectangle", "min": [-1.5 if rigid else -2.0, -1.0],
                        "max": [6.0 if rigid else 8.0, 0.0], "material": "floor"},
                       {"name": "block", "shape": "rectangle", "min": [0.0, 0.0], "max": [4.0, 2.0],
                        "material": "block", "velocity": [0.0 if rigid else 1.0, 0.0]}],
            "gravity": [0.0, -G], "update": {"scheme": scheme},
            "contact": {"default": {"law": "coulomb", "friction": mu}},
            "time": {"end": 0.5}, "output": {"energy_ledger": True}}


def run_sliding(floor: str, scheme: str, mu: float = MU):
    """(friction_loss / (1/2 m 1^2), the block's mean x velocity at the end, the ledger)."""
    sim = Simulation(build_scene(deck_from(sliding_deck(floor, scheme, mu))), threads=1)
    sim.run()
    P = sim.state.particles
    block = P.x[:, 1] > 0.0
    m = P.mass[block].sum()
    return sim.state.ledger[FRICTION] / (0.5 * m), float(P.v[block, 0].mean()), sim.state.ledger.copy()


@pytest.mark.parametrize("scheme", ["flip", "pic"])
def test_a_moving_floor_gives_friction_half_its_work(scheme):
    """A rigid floor moving at U drags a block at rest up to U (in 0.33 ms at mu g): it does
    work m U^2, half of which is the block's kinetic energy and half friction's, 1/2 m U^2,
    whatever mu. friction_loss within 2% of 1/2 m U^2 and the block at U within 2% at 0.5 ms.
    Measured 0.9916 (FLIP) and 0.9989 (PIC). Wrong forms fail: the slip taken at the block's
    velocity instead of relative to the floor's gives -1.03 and -0.97 (the floor's work on the
    block, not the dissipation); FLIP's pass-1 change counted as friction (its particles never
    take it) 1.147."""
    ratio, vx, _ = run_sliding("rigid", scheme)
    assert ratio == pytest.approx(1.0, abs=0.02)
    assert vx == pytest.approx(1.0, abs=0.02)


@pytest.mark.parametrize("scheme", ["flip", "pic"])
def test_a_block_sliding_to_rest_gives_friction_its_kinetic_energy(scheme):
    """A block sliding at v0 on a deformable slab ten times stiffer (two deformable materials,
    LR contact) stops in 0.33 ms: friction_loss within 2% of its 1/2 m v0^2, and the block at
    rest (|vx| < 0.01 v0). Measured 0.9865 (FLIP) and 1.0037 (PIC). Counting only the targets
    that slid in a step (tangential change at mu |normal change|), not the stuck ones, gives
    0.887 and 0.667: a third of the slab's contact nodes under the block are stuck in a step, and
    the change that lands each pair on one velocity dissipates there too; FLIP's pass-1 change
    counted as friction 1.237."""
    ratio, vx, _ = run_sliding("slab", scheme)
    assert ratio == pytest.approx(1.0, abs=0.02)
    assert abs(vx) < 0.01


def test_frictionless_contact_books_no_friction():
    """The same slab with mu = 0: friction_loss zero to round-off (5e-11 of 1/2 m v0^2: the
    normal change's tangential remainder), and the block still sliding (0.970 v0 at 0.5 ms,
    where with mu = 0.3 it stops)."""
    ratio, vx, _ = run_sliding("slab", "pic", mu=0.0)
    assert abs(ratio) < 1e-9
    assert vx > 0.9


def test_friction_work_of_one_node_is_the_tangential_impulse_times_the_slip():
    """friction_work on hand-set slots against the closed form, to round-off: a two-material
    node (target 0, deformable partner 1) whose change is -dp on the partner counts
    dp_t . (v0_mean - v1_mean) once; a target against a rigid partner counts dp_t . (v_mean -
    v_rigid); a frictionless target and a rigid slot nothing."""
    nn, dim = 2, 2
    slot_group = np.array([0, 1, 0, 5, 1])  # groups >= n_def (2) are rigid
    n_def = 2
    role = np.array([1, 0, 1, 0, 1])
    partner = np.array([1, -1, 3, -1, 3])
    normal = np.array([[0.0, 1.0], [0.0, 0.0], [0.6, 0.8], [0.0, 0.0], [0.0, -1.0]])
    law = np.array([COULOMB, COULOMB, COULOMB, COULOMB, FRICTIONLESS])
    mass = np.array([9.0, 9.0, 1.0, 2.0, 3.0, 4.0, 5.0])  # grid nodes 0, 1, then the five slots
    dp = np.array([[0.3, -1.0], [-0.3, 1.0], [0.2, 0.5], [0.0, 0.0], [0.7, 0.4]])
    v_start = np.array([[1.0, -2.0], [0.5, 0.0], [2.0, 1.0], [0.0, 0.0], [1.0, 1.0]])
    v_end = np.array([[0.8, -1.0], [0.4, -0.5], [1.0, 0.0], [0.25, -0.5], [2.0, 2.0]])
    v_rigid = np.array([[0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [0.25, -0.5], [0.0, 0.0]])

    def tangential(s):
        n = normal[s]
        return dp[s] - (dp[s] @ n) * n

    mean = 0.5 * (v_start + v_end)
    expected = tangential(0) @ (mean[0] - mean[1]) + tangential(2) @ (mean[2] - v_rigid[3])
    got = friction_work(nn, 5, slot_group, n_def, role, partner, normal, law, mass, dp, v_start, v_end, v_rigid)
    assert got == pytest.approx(expected, rel=1e-14, abs=1e-15)
    assert expected != 0.0


# -------------------------------------------------- a user's first 3D contact run, both ways
def sphere_drop(seeding: str, mu: float, vx: float) -> dict:
    """As a user writes it: a steel sphere (R = 10 mm, 2 mm cells: R/h = 5) 0.1 mm above a
    30 x 30 x 10 mm aluminium block with a fixed bottom, z up, falling at 1 m/s (and moving
    at vx along x), every setting but the contact law and the ledger at its default."""
    body = {"name": "sphere", "shape": "sphere", "center": [15.0, 15.0, 20.1], "radius": 10.0, "material": "steel",
            "velocity": [vx, 0.0, -1.0]}
    if seeding != "auto":
        body["seeding"] = seeding
    return {"title": "sphere drop", "units": "mm-g-ms", "analysis": "3d",
            "grid": {"cell_size": 2.0, "domain": {"min": [0.0, 0.0, 0.0], "max": [30.0, 30.0, 34.0]},
                     "boundaries": {"zmin": "fixed"}},
            "materials": {"steel": {"type": "linear_elastic", "E": 200000.0, "nu": 0.3, "density": 0.00785},
                          "alu": {"type": "linear_elastic", "E": 70000.0, "nu": 0.33, "density": 0.0027}},
            "bodies": [{"name": "block", "shape": "box", "min": [0.0, 0.0, 0.0], "max": [30.0, 30.0, 10.0],
                        "material": "alu"}, body],
            "contact": {"default": {"law": "coulomb", "friction": mu} if mu else {"law": "frictionless"}},
            "time": {"end": 0.3}, "output": {"energy_ledger": True, "history_interval": 0.005}}


def sphere_energy(seeding: str, mu: float, vx: float) -> tuple[float, float]:
    """(largest and final (kinetic + strain + friction_loss) / initial energy)."""
    sim = Simulation(build_scene(deck_from(sphere_drop(seeding, mu, vx))))
    sim.run()
    col = sim.recorder.column
    total = col("kinetic_energy") + col("strain_energy") + col("friction_loss")
    return float(total.max() / total[0]), float(total[-1] / total[0])


@pytest.mark.validation
@pytest.mark.parametrize("mu, vx, low", [(0.0, 0.0, 0.98), (0.3, 1.0, 0.96)], ids=["normal-frictionless", "oblique-mu=0.3"])
def test_a_plainly_written_sphere_drop_keeps_its_energy(mu, vx, low, measure):
    """The sphere drop as a user writes it (seeded in shells by default): kinetic + strain
    energy + what friction took never above its start by more than 0.2%, and at the end (the
    sphere gone from the block) no lower than 2% below it frictionless, as the elastic
    continuum keeps it exactly, and 4% struck obliquely (1, 0, -1) m/s with mu = 0.3.
    Measured: frictionless 1.0001 / 0.9965, where the same deck seeded on the lattice ends at
    0.9577 and fails; oblique 1.0006 / 0.9694 with friction's 9.1% counted, where without it
    the end is 0.879 and fails (seeded on the lattice: 1.0024, above the 0.2%, / 0.9817)."""
    top, end = sphere_energy("auto", mu, vx)
    measure(f"sphere drop R/h = 5, {'frictionless' if not mu else 'oblique, mu = 0.3'}: (E + friction) max, end",
            f"{top:.4f}, {end:.4f}", f"<= 1.002, >= {low}")
    assert top <= 1.002
    assert end >= low
