"""Every shipped deck through `mpmsim check`, in this process (the function the command calls):
no warning but those the deck declares, and every declared warning given.

A deck declares a warning it exists to show, or one it knowingly accepts, with a comment line
    # check: expects warning "<a fragment of its text>"
(issue 76: the first `check` a newcomer runs must not look wrong)."""

from __future__ import annotations

import re

import pytest

from mpmsim import cli
from mpmsim.deck import load_deck
from mpmsim.scene import build_scene

from ..conftest import ROOT

pytestmark = pytest.mark.newcomer

DECLARED = re.compile(r'^#\s*check:\s*expects warning\s+"([^"]+)"\s*$', re.MULTILINE)
DECKS = sorted((ROOT / "inputs").glob("*.yaml")) + sorted((ROOT / "inputs" / "faults").glob("*.yaml"))


def declared(path) -> list[str]:
    return DECLARED.findall(path.read_text())


def check_warnings(path) -> list[str]:
    """The warnings `mpmsim check --no-probe DECK` prints (the probe runs the first steps of a
    FEM or implicit scene: minutes of compiling, left out here)."""
    return cli._check(build_scene(load_deck(path)), want_probe=False)


def unexpected(warnings: list[str], expected: list[str]) -> tuple[list[str], list[str]]:
    """(warnings no declaration matches, declarations no warning matches)."""
    stray = [w for w in warnings if not any(e in w for e in expected)]
    missing = [e for e in expected if not any(e in w for w in warnings)]
    return stray, missing


def test_there_are_decks():
    assert len(DECKS) > 40


@pytest.mark.parametrize("path", DECKS, ids=lambda p: str(p.relative_to(ROOT / "inputs")))
def test_check_warns_only_as_the_deck_declares(path, capsys):
    stray, missing = unexpected(check_warnings(path), declared(path))
    assert not stray, f"{path.name}: warnings it does not declare: {stray}"
    assert not missing, f"{path.name}: declared warnings that did not appear: {missing}"


def test_declarations_are_read_and_matched():
    """The matching itself: a declared fragment covers its warning, an undeclared one is stray,
    an unmet declaration is missing."""
    text = '# A deck\n# check: expects warning "position midpoint"\ntitle: t\n'
    assert DECLARED.findall(text) == ["position midpoint"]
    w = ["rigid 'top' travels 21% ... update.position midpoint: ...", "something else"]
    assert unexpected(w, ["position midpoint"]) == (["something else"], [])
    assert unexpected([], ["position midpoint"]) == ([], ["position midpoint"])


def test_stretch_is_not_told_it_compresses():
    """inputs/stretch.yaml pulls its bar to 100% strain: no compaction warning; the same grip
    driven the other way compresses, and the check says so (it can fail both ways)."""
    scene = build_scene(load_deck(ROOT / "inputs" / "stretch.yaml"))
    from mpmsim.stability import compaction_warnings, rigid_travel

    compression, _, stretch, who = rigid_travel(scene, scene.deformable.x)
    assert compression == 0.0 and stretch == pytest.approx(1.0, abs=0.05) and who == "grip"
    assert compaction_warnings(scene, scene.deformable.x) == []
    from mpmsim.materials import RigidMotion

    motion = scene.materials.motions[0]
    scene.materials.motions[0] = RigidMotion(motion.times, -motion.values)  # the grip pushed in, not pulled
    compression, _, stretch, _ = rigid_travel(scene, scene.deformable.x)
    assert compression == pytest.approx(1.0, abs=0.05) and stretch == 0.0
    assert any("towards it" in w and "position midpoint" in w for w in compaction_warnings(scene, scene.deformable.x))
