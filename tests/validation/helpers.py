"""Load the shipped example decks as dicts so validation runs the same scenes users run."""

from __future__ import annotations

import yaml

from mpmsim.deck.overrides import with_overrides
from mpmsim.sweep.metrics import zero_crossings  # noqa: F401 (re-exported for the tests)

from ..conftest import ROOT, simulate


def example(name: str) -> dict:
    return yaml.safe_load((ROOT / "inputs" / f"{name}.yaml").read_text())


def run_example(name: str, **overrides):
    """Run inputs/<name>.yaml with dotted-key overrides, e.g. {"update.scheme": "pic",
    "bodies.0.max": [25, 2]} (numbers index lists)."""
    deck = with_overrides(example(name), overrides)
    return simulate(deck, ROOT / "inputs"), deck
