"""Expand a sweep into runs: one per combination of axis values, plus the reference runs.

A run is a deck path and its overrides; its id hashes both and the deck's text, so the same
run in a re-started (or edited) sweep gets the same id, and an edited base deck gets new ids.
"""

from __future__ import annotations

import hashlib
import itertools
import json
from dataclasses import dataclass, field
from pathlib import Path

from .spec import LoadedSweep


@dataclass(frozen=True)
class Run:
    id: str
    deck: Path
    overrides: dict
    values: dict = field(default_factory=dict)  # axis -> value label
    method: str = ""
    reference: str | None = None  # id of the run this one is measured against (None: analytic)
    role: str = "run"  # or "reference"


def run_id(deck: Path, overrides: dict) -> str:
    text = Path(deck).read_bytes()
    key = json.dumps({"deck": hashlib.sha1(text).hexdigest(), "overrides": overrides}, sort_keys=True, default=str)
    return hashlib.sha1(key.encode()).hexdigest()[:12]


def axis_choices(name: str, values) -> list[tuple[str, dict]]:
    """(label, overrides) for each value of an axis: a deck key with values, or named variants."""
    if isinstance(values, dict):
        return [(str(label), dict(over)) for label, over in values.items()]
    return [(_short(v), {name: v}) for v in values]


def _short(v) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def method_label(name: str, label: str, values) -> str:
    # named variants carry their own label; a plain key shows as `passes=2`
    return label if isinstance(values, dict) else f"{name.split('.')[-1]}={label}"


def expand(loaded: LoadedSweep) -> tuple[list[Run], list[Run]]:
    """(runs, reference runs); references shared by several runs appear once."""
    sw, base = loaded.sweep, loaded.base
    names = list(sw.axes)
    choices = [axis_choices(n, sw.axes[n]) for n in names]
    combos = []
    for picked in itertools.product(*choices):
        values = {n: lab for n, (lab, _) in zip(names, picked)}
        per_axis = {n: over for n, (_, over) in zip(names, picked)}
        overrides = {k: v for over in per_axis.values() for k, v in over.items()}
        method = ", ".join(method_label(n, values[n], sw.axes[n]) for n in sw.method_axes)
        combos.append((values, per_axis, overrides, method))

    refs: dict[str, Run] = {}
    runs = []
    ref = sw.reference
    for values, per_axis, overrides, method in combos:
        ref_id = None
        if ref.single_material is not None:
            sm = ref.single_material
            deck = (loaded.path.parent / sm.deck).resolve() if sm.deck else base
            keep = sm.axes if sm.axes is not None else names
            ref_over = {k: v for n in keep for k, v in per_axis[n].items()}
            ref_over.update(sm.overrides)
            ref_id = run_id(deck, ref_over)
            refs.setdefault(ref_id, Run(ref_id, deck, ref_over, {n: values[n] for n in keep},
                                        "single material", None, "reference"))
        elif ref.finest is not None:
            finest = min(sw.axes[ref.finest], key=float)
            finest_over = {k: v for n in names for k, v in per_axis[n].items() if n != ref.finest}
            finest_over.update(axis_choices(ref.finest, [finest])[0][1])
            ref_id = run_id(base, finest_over)
        runs.append(Run(run_id(base, overrides), base, overrides, values, method, ref_id))
    return runs, list(refs.values())
