"""The two tiers' tooling (tests/tiers.py): the validation report and the tiered parameters, on a
small suite of its own run by pytester."""

from __future__ import annotations

import pytest

from ..tiers import report_table, tiered

pytest_plugins = ["pytester"]

SUITE = '''
import pytest
from tests.tiers import tiered

@pytest.mark.validation
def test_fine(measure):
    measure("period", "0.2726 ms (+0.05%)", "within 1% of 0.2725 ms")
    measure("energy", "-0.01%", "within 0.5%")

@pytest.mark.validation
def test_fails(measure):
    measure("k", "199.3 N/mm", "within 3% of 168.0")
    assert False

def test_coarse(measure):
    measure("not reported", "1", "2")

@pytest.mark.parametrize("h", tiered([1.0, 0.5], lambda h: h < 1.0, lambda h: f"h={h:g}"))
def test_rows(h):
    pass
'''


def run(pytester, *args):
    pytester.makeconftest("pytest_plugins = ['tests.tiers']\n")
    pytester.makepyfile(test_suite=SUITE)
    pytester.mkpydir("validation").joinpath("test_in_a_validation_folder.py").write_text(
        "def test_plain():\n    pass\n")  # a folder named validation is not the tier
    return pytester.runpytest_inprocess("-p", "no:cacheprovider", "-p", "no:xdist", *args)


def test_validate_writes_one_row_per_measurement_with_bound_measured_time_and_outcome(pytester, tmp_path,
                                                                                    monkeypatch):
    report = tmp_path / "out" / "validation.md"
    monkeypatch.setenv("MPMSIM_VALIDATION_REPORT", str(report))
    result = run(pytester, "-m", "validation")
    result.assert_outcomes(passed=2, failed=1, deselected=3)  # test_fine, test_rows[h=0.5]; test_fails
    text = report.read_text()
    assert "2 of 3 validation tests passed" in text
    lines = [line for line in text.splitlines() if line.startswith("| test_suite.py")]
    assert len(lines) == 3 and "test_plain" not in text
    fine = next(line for line in lines if "::test_fine" in line)
    cells = [c.strip() for c in fine.split("|")[1:-1]]
    assert cells[1:4] == ["period", "within 1% of 0.2725 ms", "0.2726 ms (+0.05%)"]
    assert float(cells[4]) >= 0.0 and cells[5] == "passed"
    assert "|  | energy | within 0.5% | -0.01% |  |  |" in text  # the second row of the same test
    assert "199.3 N/mm" in text and "failed" in text
    assert "not reported" not in text  # make test's tests record nothing in the report
    assert "validation report" in result.stdout.str()


def test_the_test_tier_writes_no_report_and_runs_the_coarse_rows(pytester, tmp_path, monkeypatch):
    report = tmp_path / "validation.md"
    monkeypatch.setenv("MPMSIM_VALIDATION_REPORT", str(report))
    result = run(pytester, "-m", "not validation", "-v")
    result.assert_outcomes(passed=3, deselected=3)
    assert "test_rows[h=1]" in result.stdout.str() and "test_rows[h=0.5]" not in result.stdout.str()
    assert not report.exists()


def test_tiered_marks_only_the_chosen_cases():
    params = tiered([(1.0, 0.0), (0.5, 0.3)], lambda c: c[0] < 1.0, lambda c: f"h={c[0]:g}", unpack=True)
    assert [p.id for p in params] == ["h=1", "h=0.5"]
    assert [p.values for p in params] == [(1.0, 0.0), (0.5, 0.3)]
    assert [[m.name for m in p.marks] for p in params] == [[], ["validation"]]


def test_a_test_without_measurements_gets_one_row():
    table = report_table([{"test": "t.py::test_a", "outcome": "passed", "time": 1.25, "rows": []}])
    assert table.splitlines()[-1] == "| t.py::test_a |  |  |  | 1.2 | passed |"
