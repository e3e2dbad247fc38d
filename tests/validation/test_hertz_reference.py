"""The finite-element reference of the Hertz cylinder (bench/hertz_reference.py, docs/contact-methods.md
"A converged reference"): the same half-disk and gravity load as the MPM scene, exact frictionless
(Signorini) contact on the rigid flat by an active-set iteration.

1. At a small load (Hertz half-width a = 0.5 mm, a/R = 0.05) on the coarsest mesh (elements a/20
   at the contact) the small-strain solution with the contact's consistent linearisation
   (vertical gap and reaction) gives Hertz: measured half-width -0.04% (edge), -0.10% (force
   moment), centre pressure +0.04%, p(x) within 0.42% of p0 over |x| < 0.8a; the load carried
   equals the applied one to 1e-13; no node below the flat, no tensile reaction. A wrong E*
   (plane stress: a +5%), load or gap would fail the 0.5% bands.
2. The same at a/R = 0.05 with the contact along the body's normal (the Kikuchi-Oden form)
   departs from Hertz by O(a/R): half-width -0.74% at a = 0.5 mm, -0.35% at 0.25 mm (ratio 2.1:
   first order in a/R), which is why the two forms are reported apart.
3. Neo-Hookean at finite strain, a/R = 0.05, coarsest mesh: equilibrium, no penetration, no
   tension, half-width -0.97% and centre +1.00% (converged -0.96%, +1.05%).
4. Two identical cylinders stacked on the flat (the lower graded to both its contacts, the
   upper's bottom surface nodes at the x of the lower's top ones), small strain with the contact
   linearised about the undeformed bodies (vertical gaps of the two circles, node to node), at
   a/R = 0.05 on the coarsest mesh: their contact gives Hertz for two cylinders (R* = R/2,
   E* = E/(2(1 - nu^2)): the half-width of one cylinder on the flat under the same load) within
   0.2% (measured -0.04% edge, -0.07% moment, -0.16% fit, centre +0.01%), the flat's (load 2P)
   within 0.4%; each contact carries what is above it to 1e-12, action equals reaction, no node
   pair interpenetrates, none pulls. A single circle's gap (the rigid flat's: R* = R) or one
   body's compliance only (a rigid partner: E* = E/(1 - nu^2)) would put the half-width +41% or
   -29% off.
5. The finite-strain laws' tangent stiffness is the derivative of their internal forces
   (directional finite differences, 1e-6 relative), so that Newton converges to their
   equilibrium; the logarithmic laws tend to linear elasticity at small strain.
"""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from ..conftest import ROOT

_spec = importlib.util.spec_from_file_location("hertz_reference", ROOT / "bench" / "hertz_reference.py")
ref = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(ref)

pytestmark = pytest.mark.hertz


def solve(a: float, direction: str, law: str = "linear", level: int = 0):
    mesh = ref.Mesh(a, level)
    P = ref.load_for(a)
    sol = ref.solve_contact(mesh, P, law=law, direction=direction)
    return mesh, sol, ref.measure(mesh, sol, P)


def test_small_load_gives_hertz():
    mesh, sol, m = solve(0.5, "vertical")
    assert abs(m["load_error"]) < 1e-8
    assert m["max_penetration"] > -1e-12 * ref.R
    assert m["min_active_reaction"] > 0.0
    assert abs(m["a_edge_error"]) < 0.005, m["a_edge_error"]
    assert abs(m["a_moment_error"]) < 0.005, m["a_moment_error"]
    assert abs(m["centre_error"]) < 0.005, m["centre_error"]
    assert m["profile_max_error"] < 0.01, m["profile_max_error"]
    # the contact spans many nodes (P2: surface nodes h0/2 apart) and ends between two of them
    lo, hi = m["a_bracket"]
    assert m["n_active"] > 30 and lo <= m["a_edge"] <= hi


def test_normal_contact_departs_at_first_order():
    errs = [solve(a, "normal")[2]["a_moment_error"] for a in (0.25, 0.5)]
    assert -0.012 < errs[1] < -0.004, errs
    assert 1.6 < errs[1] / errs[0] < 2.6, errs  # first order in a/R


def test_finite_strain_contact():
    """Neo-Hookean at a/R = 0.05, coarsest mesh: equilibrium with the flat (load to 1e-10), no
    node below it, none pulled, and the half-width and centre within bands around what the
    converged levels measure (-0.96% and +1.05%: first order in a/R, docs/contact.md)."""
    mesh, sol, m = solve(0.5, "vertical", law="neo_hookean")
    assert abs(m["load_error"]) < 1e-10
    assert m["max_penetration"] > -1e-12 * ref.R
    assert m["min_active_reaction"] > 0.0
    assert -0.013 < m["a_moment_error"] < -0.007, m["a_moment_error"]
    assert 0.007 < m["centre_error"] < 0.013, m["centre_error"]


@pytest.mark.parametrize("law", ["neo_hookean", "svk", "hencky", "hypo_log"])
def test_tangent_is_the_derivative_of_the_forces(law):
    mesh = ref.Mesh(2.0, 0, n0=4, hmax0=4.0)
    model = ref.Model(mesh, ref.load_for(2.0))
    rng = np.random.default_rng(1)
    X, Y = mesh.X[:, 0], mesh.X[:, 1]
    u = np.stack([0.5 * np.sin(0.3 * Y + 0.1 * X), -0.4 * np.cos(0.25 * X - 0.1 * Y)], 1).ravel()
    u += 1e-3 * rng.standard_normal(model.ndof)  # strains of about 10% with a local roughness
    v = rng.standard_normal(model.ndof)
    f, K, jmin = model.forces(u, law)
    assert jmin > 0.5
    h = 1e-6
    fd = (model.forces(u + h * v, law, tangent=False)[0] - model.forces(u - h * v, law, tangent=False)[0]) / (2 * h)
    assert np.abs(K @ v - fd).max() < 1e-6 * np.abs(fd).max()


@pytest.mark.parametrize("law", ["neo_hookean", "svk", "hencky", "hypo_log"])
def test_small_strain_limit_is_linear(law):
    mesh = ref.Mesh(2.0, 0, n0=4, hmax0=4.0)
    model = ref.Model(mesh, ref.load_for(2.0))
    u = 1e-7 * np.random.default_rng(2).standard_normal(model.ndof)
    f_lin = model.forces(u, "linear", tangent=False)[0]
    f = model.forces(u, law, tangent=False)[0]
    assert np.abs(f - f_lin).max() < 1e-5 * np.abs(f_lin).max()


def test_two_cylinders_small_load_give_hertz():
    lower, upper = ref.pair_meshes(0.5, 0)
    P = ref.load_for(0.5)
    sol = ref.solve_pair(lower, upper, P)
    m = ref.measure(upper, sol["pair"], P)
    fl = ref.measure(lower, sol["flat"], 2 * P)
    for x in (m, fl):
        assert abs(x["load_error"]) < 1e-8, x["load_error"]
        assert x["max_penetration"] > -1e-12 * ref.R
        assert x["min_active_reaction"] > 0.0
    assert sol["pair"]["action_reaction"] < 1e-10 * P
    assert sol["pair"]["residual_free"] < 1e-10 * P
    for k in ("a_edge_error", "a_moment_error", "a_fit_error", "centre_error"):
        assert abs(m[k]) < 0.002, (k, m[k])
        assert abs(fl[k]) < 0.004, (k, fl[k])
    assert m["profile_max_error"] < 0.006, m["profile_max_error"]
    lo, hi = m["a_bracket"]
    assert m["n_active"] > 30 and lo <= m["a_edge"] <= hi


@pytest.mark.axisymmetric
def test_sphere_in_its_r_z_section_gives_hertz():
    """The same half-disk as the sphere's r-z section (AxisymmetricModel: integrals per radian,
    the hoop strain u_r / r, the whole sphere's weight P), contact radius a = R/10, coarsest mesh,
    vertical contact: Hertz's sphere within 0.5% (measured radius +0.05% moment, -0.07% fit,
    centre -0.36%; converged over four levels +0.04%, +0.01%, -0.22%: docs/axisymmetric.md), the
    load carried (x 2 pi) equal to P to 1e-8, the discrete sphere's volume 4/3 pi R^3 to 1e-6
    (3e-7: the curved P2 edges). Without the hoop strain (measured) the fitted radius is off by
    95% and the centre pressure by 15x."""
    mesh = ref.Mesh(1.0, 0)
    P = ref.load_for(1.0, sphere=True)
    sol = ref.solve_contact(mesh, P, direction="vertical", axisymmetric=True)
    m = ref.measure(mesh, sol, P)
    assert m["a_hertz"] == pytest.approx(1.0, rel=1e-12)
    assert abs(m["load_error"]) < 1e-8
    assert abs(sol["volume"] / (4.0 / 3.0 * np.pi * ref.R**3) - 1.0) < 1e-6
    assert m["max_penetration"] > -1e-12 * ref.R
    assert m["min_active_reaction"] > 0.0
    for key in ("a_moment_error", "a_fit_error", "centre_error", "p0_fit_error"):
        assert abs(m[key]) < 0.005, (key, m[key])
    assert m["profile_max_error"] < 0.01, m["profile_max_error"]
    # along the body's normal instead: the same at first order in a/R (measured radius -0.30%, centre +0.29%)
    normal = ref.measure(mesh, ref.solve_contact(mesh, P, direction="normal", axisymmetric=True), P)
    assert abs(normal["a_moment_error"]) < 0.005 and abs(normal["centre_error"]) < 0.005, normal


@pytest.mark.axisymmetric
@pytest.mark.parametrize("law", ["hencky", "hypo_log"])
def test_sphere_finite_strain_model(law):
    """The r-z section at finite strain (total Lagrangian per radian, in-plane F and hoop stretch
    1 + u_r/R): its tangent is the derivative of its internal forces (1e-6 relative; measured
    4e-9), it tends to the linear model at small strain (1e-6; measured 6e-8), and on the
    coarsest mesh the sphere at a/R = 0.1 (hypo_log: the MPM's linear_elastic law) carries its
    load (1e-10) with no node below the flat and no tensile reaction, within 1% of Hertz's radius
    and 1.5% of its centre pressure (measured -0.45% moment, -0.53% fit, centre +0.82%)."""
    mesh = ref.Mesh(1.0, 0)
    P = ref.load_for(1.0, sphere=True)
    model = ref.AxisymmetricModel(mesh, P)
    X = mesh.X

    def field(scale, c1, c2):
        u = np.zeros((len(X), 2))
        u[:, 0] = c1 * X[:, 0] * (1 + 0.5 * np.sin(X[:, 1]))  # zero on the axis
        u[:, 1] = c2 * X[:, 1] + 0.4 * c1 * np.cos(X[:, 0])
        return scale * u.ravel()

    u, v = field(1.0, 0.03, -0.05), field(0.1, 0.3, 0.7)
    _, K, _ = model.forces(u, law)
    e = 1e-6
    fd = (model.forces(u + e * v, law, False)[0] - model.forces(u - e * v, law, False)[0]) / (2 * e)
    assert np.abs(K @ v - fd).max() < 1e-6 * np.abs(fd).max()
    small = field(1e-8, 1.0, -2.0)
    lin = model.forces(small, "linear")[0]
    assert np.abs(model.forces(small, law, False)[0] - lin).max() < 1e-6 * np.abs(lin).max()
    if law == "hypo_log":
        sol = ref.solve_contact(mesh, P, law=law, axisymmetric=True)
        m = ref.measure(mesh, sol, P)
        assert abs(m["load_error"]) < 1e-10
        assert m["max_penetration"] > -1e-9 * ref.R and m["min_active_reaction"] > 0.0
        assert abs(m["a_moment_error"]) < 0.01 and abs(m["a_fit_error"]) < 0.01, m
        assert abs(m["centre_error"]) < 0.015, m["centre_error"]
