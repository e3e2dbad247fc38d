"""Docs stay true: the deck reference matches the schema and every shipped deck validates."""

from __future__ import annotations

import pytest

from mpmsim.deck import load_deck
from mpmsim.deck.reference import render
from mpmsim.scene import build_scene

from ..conftest import ROOT


def test_deck_reference_is_generated_from_the_current_schema():
    assert (ROOT / "docs" / "deck-reference.md").read_text() == render(), \
        "docs/deck-reference.md is stale: run `make docs`"


@pytest.mark.parametrize("deck", sorted((ROOT / "inputs").glob("*.yaml")) + sorted((ROOT / "bench").glob("*.yaml")),
                         ids=lambda p: p.name)
def test_shipped_decks_validate_and_build(deck):
    scene = build_scene(load_deck(deck))
    assert len(scene.deformable.x) > 0 or (scene.fem is not None and len(scene.fem.cells) > 0)


def test_readme_names_the_two_commands():
    text = (ROOT / "README.md").read_text()
    assert "make run" in text and "make test" in text
    assert "make test" in (ROOT / ".ci" / "run").read_text()


def test_relative_links_in_docs_resolve():
    import re

    for page in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        for target in re.findall(r"\]\(([^)#\s]+)", page.read_text()):
            if "://" in target:
                continue
            assert (page.parent / target).exists(), f"{page.name} links to missing {target}"


@pytest.mark.parametrize("sweep", sorted((ROOT / "inputs" / "sweeps").glob("*.yaml")), ids=lambda p: p.name)
def test_shipped_sweeps_validate(sweep):
    """Every combination of a shipped sweep is a valid deck, and its runs have distinct ids."""
    from mpmsim.sweep import load_sweep
    from mpmsim.sweep.matrix import expand
    from mpmsim.sweep.runner import validate

    runs, refs = expand(load_sweep(sweep))
    validate(runs + refs, str(sweep))
    assert len({r.id for r in runs + refs}) == len(runs) + len(refs)
