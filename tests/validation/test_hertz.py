"""Contact tractions (output.contact_traction) and the Hertz cylinder (bench/hertz.py).

1. The traction output reads back with meshio, and its integral over the contact (traction x
   contact area, summed over the contact nodes; each node's traction is its normal line's)
   equals the history's pair contact force (`contact_f*`) to 1e-10 relative, for FLIP (pass
   2's force) and APIC (pass 1's change counts too), with Coulomb friction so that the tangential tractions are not zero; against
   a rigid contact flat it equals the flat's reaction (`F_flat_*`). Without the deck key no
   contact series and no traction fields are written.
2. The Hertz cylinder at R/h = 20, seeded in rings that follow its surface: the load the
   contact carries balances the applied load (the issue's 1%), p(x) and the peaks are within
   the issue's 10% and 1.3 p0 (columns, nodes and particles), and the half-width and centre
   pressure stay within bands around what this resolution measures (docs/contact.md, "Hertz
   contact": R/h = 40 and 80 run in bench/hertz.py; there the half-width at R/h = 80 is 3.2%
   below Hertz's and within 0.2% of the converged reference of the same law,
   bench/hertz_reference.py; the node tractions peak at 1.05 p0 at R/h = 40).
"""

from __future__ import annotations

import re
import sys

import meshio
import numpy as np
import pytest

from mpmsim.output.paraview import find_series
from mpmsim.solver import Simulation

from ..conftest import ROOT
from ..tiers import tiered

sys.path.insert(0, str(ROOT / "bench"))
import hertz  # noqa: E402

pytestmark = pytest.mark.hertz


def pair_deck(scheme: str, traction: bool = True) -> dict:
    """A coarse disk pushed obliquely (gravity at 30 degrees) into a deformable block, Coulomb 0.3."""
    return {
        "title": "disk on a block, oblique load",
        "units": "mm-g-ms",
        "grid": {"cell_size": 1.0, "boundaries": {"ymin": "fixed"}},
        "materials": {"disk": {"type": "linear_elastic", "E": 1000.0, "nu": 0.3, "density": 0.001},
                      "block": {"type": "linear_elastic", "E": 2000.0, "nu": 0.3, "density": 0.001}},
        "bodies": [{"shape": "rectangle", "min": [-10.0, 0.0], "max": [10.0, 6.0], "material": "block"},
                   # on the lattice: the Coulomb bound of a node line's traction below is measured for it
                   {"shape": "circle", "center": [0.0, 11.0], "radius": 5.0, "material": "disk", "seeding": "lattice"}],
        "gravity": [400.0, -700.0],
        "contact": {"default": {"law": "coulomb", "friction": 0.3}},
        "time": {"end": 0.03, "cfl": 0.5},
        "update": {"scheme": scheme},
        "output": {"vtu_interval": 0.005, "history_interval": 0.005, "contact_traction": traction,
                   "checkpoint_interval": "off"},
    }


def frames(out, stem: str, part: str) -> list[tuple[float, meshio.Mesh]]:
    text = (out / f"{stem}_{part}.pvd").read_text()
    return [(float(t), meshio.read(out / f)) for t, f in re.findall(r'timestep="([^"]+)"[^>]*file="([^"]+)"', text)]


def integral(mesh: meshio.Mesh) -> np.ndarray:
    """The contact's force on the targets' side (2D): traction x area summed over the contact
    nodes. Each node's traction is its normal line's (the targets of one pair along the grid
    axis nearest the normal: their forces summed over their areas summed), so the sum holds
    every force, that of nodes whose own LR area is zero (the nearer material edge a cell
    or more away) included, as long as their line has some area."""
    pd = mesh.point_data
    area = np.asarray(pd["contact_area"])
    traction = np.asarray(pd["traction"])[:, :2]
    assert np.all(area >= 0.0)
    return (traction * area[:, None]).sum(axis=0)


@pytest.mark.parametrize("scheme", ["flip", "apic"])
def test_traction_integral_is_the_pair_contact_force(tmp_path, scheme):
    sim = Simulation.from_deck(pair_deck(scheme), out_dir=tmp_path, name="pair")
    sim.run()
    hist = sim.history
    names = sim.state.contact.spec.group_names
    found = frames(tmp_path, "pair", "contact")
    assert len(found) >= 4
    for t, mesh in found:
        row = hist.iloc[int(np.argmin(np.abs(hist["time"] - t)))]
        assert abs(row["time"] - t) < 1e-9 * t
        pd = mesh.point_data
        # every target here is the disk's (group 0) against the block (group 1): one pair per node
        assert set(np.asarray(pd["group"])) == {names.index("block")} or set(np.asarray(pd["group"])) == {
            names.index("disk")}
        g = int(pd["group"][0])
        a, b = names[g], names[1 - g]
        hist_f = np.array([row[f"contact_fx_{a}_{b}"], row[f"contact_fy_{a}_{b}"]])
        assert np.abs(hist_f).max() > 1.0  # a loaded contact
        assert np.allclose(integral(mesh), hist_f, rtol=1e-10, atol=1e-10 * np.abs(hist_f).max())
        # normal and tangential parts: traction = -p n + t_t, and friction within Coulomb
        n = np.asarray(pd["normal"])[:, :2]
        t = np.asarray(pd["traction"])[:, :2]
        tt = np.asarray(pd["tangential_traction"])[:, :2]
        p = np.asarray(pd["contact_pressure"])
        assert np.allclose(t, -p[:, None] * n + tt, atol=1e-9 * np.abs(t).max())
        # Coulomb: the law bounds each node's force about its own normal; a node's traction is its line's,
        # whose nodes' normals differ by a few degrees, so the bound holds there to within that (measured
        # 0.7% over at most)
        f = np.asarray(pd["contact_force"])[:, :2]
        fn = np.sum(f * n, axis=1)
        ft = f - fn[:, None] * n
        assert np.all(np.linalg.norm(ft, axis=1) <= 0.3 * np.abs(fn) * (1 + 1e-9) + 1e-9 * np.abs(f).max())
        assert np.all(np.linalg.norm(tt, axis=1) <= 0.3 * np.abs(p) * 1.02 + 1e-9 * np.abs(t).max())
    particles = meshio.read(sorted(tmp_path.glob("pair_0*.vtu"))[-1])
    pp = np.asarray(particles.point_data["contact_pressure"])
    y = particles.points[:, 1]
    assert pp.max() > 0.0 and np.all(pp[(y > 8.0) & (y < 14.0)] == 0.0)  # only near the contact


def test_normal_lines_follow_the_grid_axis_nearest_the_normal():
    """Targets of one pair on consecutive nodes along the axis nearest their normals share a
    line; another pair, a gap, or a node whose normal is nearer the other axis starts a new one."""
    from mpmsim.contact.grid.traction import normal_lines

    shape = np.array([6, 6, 1])
    ij = np.array([[1, 1], [1, 2], [1, 3], [1, 4], [1, 5], [3, 2], [4, 2], [3, 3], [5, 0]])
    normal = np.array([[0.1, 1.0], [-0.2, 1.0], [0.0, -1.0], [0.0, 1.0], [0.0, 1.0], [1.0, 0.3], [1.0, -0.9],
                       [0.0, 1.0], [0.6, 0.7]])
    key = np.array([7, 7, 7, 8, 7, 7, 7, 7, 7])
    line = normal_lines(ij[:, 0] + shape[0] * ij[:, 1], shape, normal, key)
    # (1,1)-(1,3) one line along y; (1,4) another pair; (1,5) cut off by it; (3,2)-(4,2) along x;
    # (3,3) along y, not joined to (3,2) (which is on an x line); (5,0) alone
    groups = [set(np.flatnonzero(line == v)) for v in np.unique(line)]
    assert sorted(map(sorted, groups)) == [[0, 1, 2], [3], [4], [5, 6], [7], [8]]


def test_no_traction_output_unless_asked(tmp_path):
    data = pair_deck("flip", traction=False)
    data["time"]["end"] = 0.01
    Simulation.from_deck(data, out_dir=tmp_path, name="pair").run()
    assert not list(tmp_path.glob("pair_contact*"))
    mesh = meshio.read(sorted(tmp_path.glob("pair_0*.vtu"))[-1])
    assert "contact_pressure" not in mesh.point_data


def test_traction_integral_is_the_rigid_reaction(tmp_path):
    """The Hertz scene, coarse and short: the flat's targets sum to its reaction F_flat."""
    data = hertz.deck(10.0, end=0.03)
    data["output"]["vtu_interval"] = data["output"]["history_interval"] = 0.01
    sim = Simulation.from_deck(data, out_dir=tmp_path, name="hz")
    sim.run()
    hist = sim.history
    for t, mesh in frames(tmp_path, "hz", "contact"):
        row = hist.iloc[int(np.argmin(np.abs(hist["time"] - t)))]
        ref = np.array([row["F_flat_x"], row["F_flat_y"]])
        assert ref[1] > 1.0
        assert np.allclose(integral(mesh), ref, rtol=1e-10, atol=1e-10 * abs(ref[1]))
    assert find_series(tmp_path).name == "hz.pvd"  # `mpmsim paraview` takes the particles' series


def test_hertz_cylinder_at_r_over_h_20(tmp_path):
    """The recommended setup for a curved body (docs/contact.md): the cylinder seeded in rings
    that follow its surface, GIMP, LR frictionless, FLIP, USAVG+. Measured at R/h = 20: load
    +0.004%, half-width +1.8% (moment) / +2.0% (ellipse fit), centre -5.3%, column peak 1.01 p0,
    p(x) within 5.3% of p0 over |x| < 0.8a (columns; particles 5.5%). The grid-seeded (staircase) cylinder gives +5.2%,
    -29%, 1.21 and 54%: the bands below catch a return to it."""
    r = hertz.run_case(20.0, out=tmp_path, seeding="rings")["result"]
    assert abs(r["load_error"]) < 0.01  # the 1%
    assert abs(r["a_moment_error"]) < 0.03 and abs(r["a_fit_error"]) < 0.03
    assert abs(r["centre_error"]) < 0.07
    assert r["profile_max_error"] < 0.10  # the 10% over |x| < 0.8a
    assert r["p_max_over_p0"] < 1.3
    # every contact node's traction (its normal line's): 1.01 p0 (f / A_c per node gave 78 p0)
    assert r["node_p_max_over_p0"] < 1.3
    # the particles' traction (a ratio of weighted sums): peak 0.99 p0, within 5.5% of Hertz
    assert r["particle_p_max_over_p0"] < 1.3 and r["particle_profile_max_error"] < 0.10


@pytest.mark.contact_default
@pytest.mark.parametrize("rh", tiered([20.0, 40.0], lambda rh: rh > 20.0, lambda rh: f"R/h={rh:g}"))
def test_plainly_written_half_cylinder_reads_hertz(tmp_path, rh, measure):
    """A half cylinder clipped at its symmetry line, written with no seeding key, on a rigid
    flat (bench/hertz.py --half --seeding auto): the default seeds it to its surface
    (rings_half_step). Measured, R/h = 20 / 40: contact traction half-width +1.06% / -3.0% (fit),
    +0.63% / -1.9% (moment), centre -5.1% / -1.2%; the bottom row's -sigma_yy half-width -0.47% /
    -2.4%, centre +0.25% / -2.1%. On the lattice the centre reads -30% (traction) and -28% (row)
    at R/h = 20, and no ellipse fits."""
    r = hertz.run_case(rh, out=tmp_path, seeding="auto", half=True, threads=1)["result"]
    measure(f"half cylinder R/h = {rh:g}: half-width (fit), centre pressure against Hertz",
            f"{r['a_fit_error']:+.2%}, {r['centre_error']:+.2%}", "within 5%, 10%")
    assert abs(r["load_error"]) < 0.01
    assert abs(r["a_fit_error"]) < 0.05 and abs(r["a_moment_error"]) < 0.05  # the 5%
    assert abs(r["centre_error"]) < 0.10  # the 10%
    assert abs(r["row_a_fit_error"]) < 0.05 and abs(r["row_centre_error"]) < 0.10


def test_traction_output_without_contact_names_the_key():
    from mpmsim.errors import DeckError

    data = pair_deck("flip")
    data["bodies"] = data["bodies"][:1]  # one material: no contact
    with pytest.raises(DeckError, match=r"output\.contact_traction: .*two or more materials"):
        Simulation.from_deck(data)


def test_hertz_fem_cylinder_through_augury_contact_at_r_over_h_20(tmp_path):
    """An FEM cylinder (the disk mesher's rings, h = R/20) on an FEM block ten times stiffer,
    augury contact (h_c = 2h, APIC, one iteration), damped to rest (bench/hertz.py run_augury);
    pressure per top node of the block = its augury force / tributary length, against Hertz with
    1/E* = (1 - nu^2)(1/E + 1/E_flat). Measured: load -1.4% (the cylinder still settling: its
    contact force -1.8%), half-width -4.0% (moment), centre -8.4%, p(x) within 9.6% over
    |x| < 0.8a, peak 1.06 p0, the top nodes beyond 1.5a 0.6% of the load (docs/contact.md)."""
    r = hertz.run_augury(20.0, out=tmp_path)["result"]
    assert abs(r["load_error"]) < 0.03
    assert abs(r["a_moment_error"]) < 0.07
    assert abs(r["centre_error"]) < 0.12
    assert r["profile_max_error"] < 0.13
    assert r["p_max_over_p0"] < 1.3
    assert r["far_force"] < 0.01


def test_hertz_mpm_cylinder_on_fem_flat_through_barrier_contact_at_r_over_h_20(tmp_path):
    """The ring-seeded MPM cylinder on the same FEM block through the implicit barrier contact
    (backward Euler, 12 steps of 6 R/c: at rest), pressure per top node from the barrier's
    point-edge forces (bench/hertz.py run_barrier). Measured: load +4e-5, half-width -1.7%
    (moment) / -2.1% (fit), centre +5.6%, p(x) within 11.5%, peak 1.06 p0 (docs/contact.md)."""
    r = hertz.run_barrier(20.0, out=tmp_path)["result"]
    assert abs(r["load_error"]) < 1e-3
    assert abs(r["a_moment_error"]) < 0.04 and abs(r["a_fit_error"]) < 0.04
    assert abs(r["centre_error"]) < 0.09
    assert r["profile_max_error"] < 0.14
    assert r["p_max_over_p0"] < 1.3


@pytest.mark.axisymmetric
def test_hertz_sphere_axisymmetric_at_r_over_h_20(tmp_path):
    """The sphere (R = 10 mm) on the rigid flat, axisymmetric, seeded in rings, loaded for
    a/R = 0.1 (a = 2 cells at R/h = 20; bench/hertz.py --sphere --rz), read over the frames of the
    last third: the contact radius from the force's second moment within 2% of Hertz's (measured
    -0.42%), the pressure of the node column at r = a/2 within 5% of Hertz's p0 sqrt(3)/2, the
    contact carrying the applied load within 3% (measured -1.7%: the load still creeps at 40 R / c,
    as in 3D); in the final step the flat's reaction is the applied load within 0.5% (measured
    -0.07%; -24% when only the last step was cut short to land on time.end, docs/timestep.md).
    Contact forces and areas are per radian, a node column's pressure their ratio (measured at
    r = a/2: +3.6%). (R/h = 80: radius +0.3%, centre pressure -0.3% in the final frame; R/h = 40
    is off the trend, 3% wide and 5.5% low in the centre: docs/axisymmetric.md.)"""
    run = hertz.run_sphere(20.0, out=tmp_path / "rz", threads=1, seeding="rings_half_step", rz=True, a_target=1.0)
    r, prof = run["result"], run["profile"]
    assert abs(r["a_moment_error"]) < 0.02
    half = np.argmin(np.abs(prof["r"] - 0.5 * r["a_hertz"]))
    assert abs(prof["r"][half] - 0.5 * r["a_hertz"]) < 1e-3
    assert prof["p"][half] / (r["p0_hertz"] * np.sqrt(0.75)) == pytest.approx(1.0, abs=0.05)
    assert abs(r["load_error"]) < 0.03
    assert abs(r["reaction_y"] / r["load_applied"] - 1.0) < 0.005  # the flat's reaction in the final step
