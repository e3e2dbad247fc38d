"""Shared test helpers: decks from Python dicts, runs without file output."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from mpmsim.deck import load_deck_text
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation

ROOT = Path(__file__).resolve().parents[1]


def deck_from(data: dict, directory: Path | None = None, name: str = "deck"):
    """Validate a deck given as a dict, as if read from `directory/name.yaml`."""
    directory = Path(directory) if directory is not None else ROOT
    plain = json.loads(json.dumps(data, default=float))  # numpy scalars -> plain floats
    return load_deck_text(yaml.safe_dump(plain, sort_keys=False), directory / f"{name}.yaml")


def simulate(data: dict, directory: Path | None = None, out_dir=None, threads: int | None = None):
    """Build and run a deck dict; return the finished Simulation (history in memory)."""
    sim = Simulation(build_scene(deck_from(data, directory)), out_dir=out_dir, threads=threads)
    sim.run()
    return sim


@pytest.fixture
def root() -> Path:
    return ROOT
