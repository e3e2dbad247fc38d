"""The suite's two tiers and the validation report (a pytest plugin, loaded by tests/conftest.py).

- `make test` runs `-m "not validation"`: every code path, every deck of inputs/ stepped, the
  fingerprints, the bad-deck and fault tests, and each validation at the coarsest resolution at
  which its bound still fails the wrong method.
- `make validate` runs `-m validation`: the tests marked `validation`, the papers' resolutions,
  reference-code comparisons and convergence studies.

A validation test states what it measured with the `measure` fixture:

    def test_x(measure):
        ...
        measure("final length", f"{L:.3f} mm", "within 1% of 21.435 mm")

The run then writes one table (case, bound, measured, time, outcome) to
results/validation.md (MPMSIM_VALIDATION_REPORT sets another path) and prints it. A
validation test that records nothing gets one row with its outcome and time.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def measure(request):
    """measure(case, measured, bound): one row of the validation report."""

    def add(case: str, measured, bound: str) -> None:
        request.node.user_properties.append(("measure", (str(case), str(measured), str(bound))))

    return add


def pytest_configure(config):
    if not hasattr(config, "workerinput"):  # the controller under xdist, or a plain run
        config.pluginmanager.register(Report(), "mpmsim-validation-report")


def pytest_collection_modifyitems(items):
    """Tags the validation tests' reports (a report's keywords hold its folders' names too:
    tests/validation/ is not the tier)."""
    for item in items:
        if item.get_closest_marker("validation") is not None:
            item.user_properties.append(("tier", "validation"))


class Report:
    """The validation tests' rows of one session (reports reach the controller under xdist)."""

    def __init__(self):
        self.entries: list[dict] = []

    def pytest_runtest_logreport(self, report):
        if ("tier", "validation") not in report.user_properties:
            return
        if report.when == "call" or (report.when == "setup" and not report.passed):
            rows = [v for k, v in report.user_properties if k == "measure"]
            self.entries.append({"test": report.nodeid, "outcome": report.outcome, "time": report.duration,
                                 "rows": rows})

    def pytest_terminal_summary(self, terminalreporter):
        if not self.entries:
            return
        path = Path(os.environ.get("MPMSIM_VALIDATION_REPORT", ROOT / "results" / "validation.md"))
        passed = sum(e["outcome"] == "passed" for e in self.entries)
        total = sum(e["time"] for e in self.entries)
        table = report_table(self.entries)
        text = (f"# Validation report\n\n{passed} of {len(self.entries)} validation tests passed; "
                f"{total:.0f} s of test time (`make validate`, tests/tiers.py).\n\n" + table)
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(path.suffix + ".part")
        tmp.write_text(text)
        tmp.replace(path)  # whole or not at all
        terminalreporter.write_sep("=", "validation report")
        terminalreporter.write(table)
        terminalreporter.write_line(f"written to {path}")


def report_table(entries: list[dict]) -> str:
    lines = ["| test | case | bound | measured | time (s) | outcome |", "|---|---|---|---|---|---|"]
    for e in sorted(entries, key=lambda e: e["test"]):
        rows = e["rows"] or [("", "", "")]
        for k, (case, measured, bound) in enumerate(rows):
            test, time, outcome = (e["test"], f"{e['time']:.1f}", e["outcome"]) if k == 0 else ("", "", "")
            lines.append(f"| {test} | {case} | {bound} | {measured} | {time} | {outcome} |")
    return "\n".join(lines) + "\n"


def tiered(cases, validation, ids=None, unpack=False):
    """Parametrize's cases with those for which `validation(case)` holds marked `validation`
    (the papers' resolutions of a scene whose coarse rows stay in `make test`). unpack: each case
    is a tuple of several arguments; ids: a function of the case."""
    out = []
    for case in cases:
        args = tuple(case) if unpack else (case,)
        marks = (pytest.mark.validation,) if validation(case) else ()
        out.append(pytest.param(*args, marks=marks, id=ids(case) if ids else None))
    return out
