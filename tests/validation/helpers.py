"""Load the shipped example decks as dicts so validation runs the same scenes users run."""

from __future__ import annotations

import numpy as np
import yaml

from mpmsim.deck.overrides import with_overrides

from ..conftest import ROOT, simulate


def example(name: str) -> dict:
    return yaml.safe_load((ROOT / "inputs" / f"{name}.yaml").read_text())


def run_example(name: str, **overrides):
    """Run inputs/<name>.yaml with dotted-key overrides, e.g. {"update.scheme": "pic",
    "bodies.0.max": [25, 2]} (numbers index lists)."""
    deck = with_overrides(example(name), overrides)
    return simulate(deck, ROOT / "inputs"), deck


def zero_crossings(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Times where y changes sign, by linear interpolation."""
    i = np.nonzero(np.sign(y[:-1]) * np.sign(y[1:]) < 0)[0]
    return t[i] - y[i] * (t[i + 1] - t[i]) / (y[i + 1] - y[i])
