"""Every deck in inputs/ (and method variants of a few) gives the stored results to the last bit.

The reference was recorded from the code before the body/integrator seams went in; any change
meant to keep results must keep these digests. See fingerprint.py for what is compared.
"""

from __future__ import annotations

import json

import pytest

from .fingerprint import REFERENCE, cases, fingerprint

REF = json.loads(REFERENCE.read_text())


@pytest.mark.architecture
@pytest.mark.parametrize("name,deck,overrides", cases(), ids=[c[0] for c in cases()])
def test_results_are_bit_identical(name, deck, overrides):
    want = REF[name]
    got = fingerprint(deck, overrides, want["steps"], want["columns"])
    if got != want:
        rows = [(float.fromhex(a), float.fromhex(b)) for a, b in zip(got["last_row"], want["last_row"])]
        diff = max((abs(a - b) / max(abs(b), 1e-300) for a, b in rows), default=0.0)
        changed = sorted(k for k in want["arrays"] if got["arrays"].get(k) != want["arrays"][k])
        pytest.fail(f"{name}: results changed (history {got['history'] != want['history']}, arrays {changed}, "
                    f"largest relative change in the last history row {diff:.3g})")
