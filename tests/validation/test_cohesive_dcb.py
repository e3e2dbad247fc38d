"""The double cantilever beam against the converged solution of the same specimen and law
(bench/cohesive_fem.py, stored in data/dcb_fem_reference.json) and corrected beam theory, which
that solution is within 0.1% on the propagation branch (issue 78, Must show 2):
tests/validation/cohesive_beams.py builds it and states the theory. make validate (one run of
5 ms, ~2 minutes on one thread).

The specimen: arms 2 mm thick, a 12 mm pre-crack (a0 = 6h), 26 mm long, E = 3000 MPa, nu = 0.3,
plane strain; bilinear cohesive law, peak 8 MPa, G_Ic = 0.3 N/mm, intact stiffness 2000 MPa/mm,
on a grid line; 0.5 mm cells (four across an arm), XPIC(2); the grips open at 0.8 mm/ms after a
0.5 ms ramp, some seven periods of the arms' first mode to the peak. The crack grows about
7 mm."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from .cohesive_beams import DCB, run_dcb

pytestmark = [pytest.mark.cohesive, pytest.mark.validation]

SPEC = dict(cell=0.5, a0=12.0, length=26.0, peak=8.0, D=2000.0, V=0.4, ramp=0.5, end=5.0,
            extra={"update": {"scheme": "xpic", "order": 2}})
WINDOW = 0.3  # mm of opening the load is averaged over (the crack front crosses a node at a time)
LAST = 3.7  # mm: the opening at which beam theory's crack reaches 3h from the far end
REFERENCE = Path(__file__).parent / "data" / "dcb_fem_reference.json"


@pytest.fixture(scope="module")
def dcb():
    spec = DCB(**SPEC)
    return spec, run_dcb(spec)


def propagating(spec, c):
    """The rows from 1.2 times the peak's opening to LAST."""
    return (c.opening > 1.2 * spec.peak_load * spec.compliance(spec.a0)) & (c.opening < LAST)


@pytest.mark.xfail(strict=True, reason="peak 4.2% above the converged solution of the same law (issue 78)")
def test_the_peak_load_is_the_converged_solution_of_the_same_law(dcb, measure):
    """Peak load within 3% of the converged finite-element solution of the same specimen and
    law (bench/cohesive_fem.py dcb --h-elem 0.0625, stored in data/dcb_fem_reference.json:
    1.7524 N/mm, 0.945 of beam theory's M / (a0 + chi h): the 3 mm cohesive zone rounds
    LEFM's corner). Measured 0.985 of beam theory, 1.042 of the converged peak: this fails
    (xfail, strict). On 0.25 mm cells the peak is 0.991 of the converged one, but the
    propagation load is then 6% low (docs/interfaces.md)."""
    spec, c = dcb
    peak = c.load.max()
    converged = json.loads(REFERENCE.read_text())["summary"]["p_peak"]
    measure("DCB peak load / M (a0 + chi h)", f"{peak / spec.peak_load:.4f}", "none (beam theory's corner)")
    measure("DCB peak load / converged FE peak", f"{peak / converged:.4f}", "within 3%")
    assert abs(peak / (spec.M / spec.a0) - 1.0) > 0.03  # (the beam without the root rotation)
    assert peak == pytest.approx(converged, rel=0.03)


def test_the_load_follows_the_propagation_branch(dcb, measure):
    """While the crack grows (to 3h from the far end), the load averaged over 0.3 mm of
    opening is within 3% of sqrt(8 M^3 / (E' h^3 delta)) (measured -0.9% .. +0.6%)."""
    spec, c = dcb
    k = propagating(spec, c)
    lo, hi = c.opening[k].min(), c.opening[k].max()
    ratio = []
    for d in np.arange(lo + WINDOW / 2, hi - WINDOW / 2, 0.05):
        w = np.abs(c.opening - d) < WINDOW / 2
        ratio.append(c.load[w].mean() / spec.propagation_load(c.opening[w]).mean())
    ratio = np.array(ratio)
    measure("DCB propagation load / beam theory", f"{ratio.min():.4f} .. {ratio.max():.4f}", "within 3%")
    assert c.debonded[k].max() - c.debonded[k].min() > 6.0  # mm of new crack
    assert np.all(np.abs(ratio - 1.0) < 0.03)


def test_the_energy_lost_is_the_toughness_times_the_new_crack(dcb, measure):
    """While the crack grows, per unit of debonded area: the fracture energy booked grows by
    G_Ic, and so does what the run lost (the grips' work less kinetic and strain energy), both
    least-squares slopes within 2% (measured 1.001 and 0.981). Booked on each particle's
    current share of the contact area instead of its share when bonded, the first slope is 0.92
    (the crack's nodes leave contact before the particles around them fail)."""
    spec, c = dcb
    k = propagating(spec, c)
    booked = np.polyfit(c.debonded[k], c.fracture_energy[k], 1)[0] / spec.G_c
    lost = np.polyfit(c.debonded[k], c.lost[k], 1)[0] / spec.G_c
    measure("DCB d(fracture energy) / d(debonded area) / G_Ic", f"{booked:.4f}", "within 2%")
    measure("DCB d(work - kinetic - strain) / d(debonded area) / G_Ic", f"{lost:.4f}", "within 2%")
    assert booked == pytest.approx(1.0, abs=0.02)
    assert lost == pytest.approx(1.0, abs=0.02)
