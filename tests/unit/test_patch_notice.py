"""A round body struck into frictional contact with too few cells across it is a notice
(mpmsim/scene/contact.py patch_resolution_notices; docs/contact.md, "Resolve the contact patch":
the oblique cylinder with friction 0.3 is 16% off the continuum in vx at 10 cells across its
radius, 5% at 20 and within 2% from 40)."""

from __future__ import annotations

import pytest

from mpmsim.scene import build_scene

from ..conftest import deck_from

pytestmark = pytest.mark.contact_continuum


def deck(radius_cells: float, law: dict, velocity=(1.0, -1.0), pairs=None) -> dict:
    h = 10.0 / radius_cells
    contact = {"default": law}
    if pairs:
        contact["pairs"] = pairs
    return {"title": "patch", "units": "mm-g-ms", "analysis": "plane_strain",
            "grid": {"cell_size": h, "domain": {"min": [-12.0, 0.0], "max": [12.0, 27.0]}},
            "materials": {"steel": {"type": "linear_elastic", "E": 200000.0, "nu": 0.3, "density": 0.00785},
                          "alu": {"type": "linear_elastic", "E": 70000.0, "nu": 0.33, "density": 0.0027}},
            "bodies": [{"name": "block", "shape": "rectangle", "min": [-11.0, 0.0], "max": [11.0, 4.0],
                        "material": "alu"},
                       {"name": "cylinder", "shape": "circle", "center": [0.0, 14.0], "radius": 10.0,
                        "material": "steel", "velocity": list(velocity)}],
            "contact": contact, "time": {"end": 0.01}}


def said(data: dict) -> list[str]:
    return [n for n in build_scene(deck_from(data)).notices if "frictional contact" in n]


COULOMB = {"law": "coulomb", "friction": 0.3}


@pytest.mark.parametrize("cells", [10.0, 20.0])
def test_a_coarse_round_body_struck_with_friction_is_told(cells):
    notices = said(deck(cells, COULOMB))
    assert len(notices) == 1
    assert notices[0].startswith(f"bodies.1: 'cylinder' is a circle of radius {cells:g} cells")
    assert "use 40 or more cells" in notices[0]


def test_a_listed_coulomb_pair_counts_as_the_default_does():
    pairs = [{"between": ["steel", "alu"], "law": "coulomb", "friction": 0.3}]
    assert len(said(deck(10.0, {"law": "frictionless"}, pairs=pairs))) == 1


@pytest.mark.parametrize("case", ["frictionless", "at rest", "resolved"])
def test_no_notice_without_friction_motion_or_with_the_cells(case):
    data = {"frictionless": deck(10.0, {"law": "frictionless"}),
            "at rest": deck(10.0, COULOMB, velocity=(0.0, 0.0)),
            "resolved": deck(40.0, COULOMB)}[case]
    assert said(data) == []
