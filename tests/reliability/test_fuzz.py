"""Property: no deck of inputs/ with one thing broken gives a traceback, a hang, a warning or
a message without the file and key path (tests/reliability/fuzz.py; bench/fuzz.py runs
thousands and prints the table)."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from .fuzz import DECKS, run_case, workspace

pytestmark = pytest.mark.reliability


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return workspace(tmp_path_factory.mktemp("fuzz"))


@settings(max_examples=300, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_a_broken_deck_ends_with_a_clean_message(folder, data):
    name = data.draw(st.sampled_from(DECKS), label="deck")
    outcome = run_case(name, lambda options: data.draw(st.sampled_from(options)), folder, seconds=120.0)
    assert outcome.outcome in ("ok", "bad deck", "stopped (unstable)", "output fault"), outcome
