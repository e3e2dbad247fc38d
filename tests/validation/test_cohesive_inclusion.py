"""A stiff sphere debonding from its matrix in uniaxial tension, against Goodier's bonded sphere
and Hashin and Shtrikman's bounds (issue 78, Must show 6): tests/validation/cohesive_inclusion.py
builds the specimen (axisymmetric, R/h = 10, volume fraction 0.53%) and states the theory.
make validate (two runs, ~1.5 minutes on one thread). The figure of the debonded cap:
`python bench/interfaces.py inclusion`."""

from __future__ import annotations

import numpy as np
import pytest

from .cohesive_inclusion import Inclusion, run_inclusion

pytestmark = [pytest.mark.cohesive, pytest.mark.validation]


@pytest.fixture(scope="module")
def runs():
    spec = Inclusion()
    return spec, run_inclusion(spec), run_inclusion(Inclusion(bonded=False))


def test_the_debond_starts_at_the_pole_at_goodiers_stress(runs, measure):
    """The far-field stress (the matrix's mean axial stress above z = 3 R; the applied traction
    runs some 8% ahead of it under grid damping) at which the pole's interface (particles within
    10 degrees of the axis) first damages is within 5% of sigma_c / 1.7519, Goodier's bonded
    sphere (measured 0.979 at R/h = 10, D R / E_m = 150; on 0.05 mm cells, R/h = 20, 1.045). Before it, no particle of either side anywhere on the interface carries more
    than 0.1 of damage (measured 0.067: the nodes at the edge of the contact band, a sliver
    of the sphere in their support, measure a spurious opening; their damage reaches a particle
    by its share of their area, which is small). With each particle reading its nodes' damage
    by shape function alone, that spurious damage reaches 0.70 at 37 degrees before the pole
    starts; with the interface paper's contact area per radian (the node's radius: none on the
    axis) the pole's bond carries nothing on the axis and starts at 0.74 of Goodier's stress."""
    spec, run, _ = runs
    measure("inclusion: debond onset (far-field stress) / Goodier's sigma_c / 1.7519", f"{run.onset / spec.onset_stress:.4f}",
            "within 5%")
    measure("inclusion: most damage anywhere before the pole's onset", f"{run.early:.3f}", "below 0.1")
    assert run.onset == pytest.approx(spec.onset_stress, rel=0.05)
    assert run.early < 0.1


def test_the_stiffness_before_the_debond_is_within_hashins_bounds(runs, measure):
    """Young's modulus of the specimen (the slope of the far-field stress against the top face's
    stretch between 1.5 and 4.5 MPa), over that of the same specimen with the sphere made of
    matrix (1980.5 MPa: E_m within 2%, measured -1.0%), lies within the Hashin-Shtrikman bounds
    at the sphere's volume fraction: 1.0092 .. 1.0277 (measured 1.0148)."""
    spec, run, alone = runs

    def modulus(r):
        k = (r.stress > 1.5) & (r.stress < 4.5)
        return np.polyfit(r.stretch[k], r.stress[k], 1)[0]

    lower, upper = (b / spec.E_m for b in spec.hashin_shtrikman())
    ratio = modulus(run) / modulus(alone)
    measure("inclusion: modulus / the matrix's (same seeding)", f"{ratio:.4f}", f"{lower:.4f} .. {upper:.4f}")
    assert modulus(alone) == pytest.approx(spec.E_m, rel=0.02)
    assert lower <= ratio <= upper


def test_the_debonded_cap_grows_from_the_pole(runs, measure):
    """Past the onset the sphere's interface particles are damaged in a cap about the pole that
    widens as the load grows: its edge (the largest angle where damage exceeds 0.5) moves out
    with the far-field stress (measured 22, 33, 39, 45 and 54 degrees at 6.5, 7, 7.5, 8 and 8.5
    MPa), and at each load the damage falls with the angle from the pole (10-degree bins'
    means, within 0.05)."""
    spec, run, _ = runs
    edges = []
    for s in (6.5, 7.0, 7.5, 8.0, 8.5):
        row = run.damage[np.argmin(np.abs(run.stress - s))]
        edges.append(run.theta[row > 0.5].max(initial=0.0))
        bins = np.array([row[(run.theta >= lo) & (run.theta < lo + 10.0)].mean() for lo in range(0, 90, 10)])
        assert np.all(np.diff(bins) < 0.05)
    measure("inclusion: cap edge (degrees) at 6.5, 7, 7.5, 8, 8.5 MPa", " ".join(f"{e:.0f}" for e in edges),
            "growing")
    assert edges[0] > 0.0 and np.all(np.diff(edges) > 0.0)
    assert edges[-1] < 90.0
