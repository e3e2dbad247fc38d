"""docs/ explains the code as it is (issue 76): no line of docs/*.md dates a measurement (a date, a
sitting, a named VM or development machine), except docs/performance.md's tables, where each
measurement keeps its machine and date (the rows, and the one caption line above a table that says
where and when it was measured); and the two pages that read as lab notebooks,
docs/contact.md and docs/bfemp.md, are at most half as long as they were."""

from __future__ import annotations

import re

import pytest

from ..conftest import ROOT

pytestmark = pytest.mark.newcomer

DOCS = ROOT / "docs"

_MONTH = (r"(?:January|February|March|April|May|June|July|August|September|October|November|December"
          r"|Jan|Feb|Mar|Apr|Jun|Jul|Aug|Sep|Sept|Oct|Nov|Dec)")

# What dates a measurement. Reference years ("(2019)", "Li 2022"), DOIs, arXiv ids and version
# numbers carry no day, so none of these patterns reaches them; a month with a year but no day
# ("June 2019", as a proceedings' date may read) is not matched either.
DATED = re.compile("|".join([
    r"\b20\d\d-[01]\d-[0-3]\d\b",                                   # 2026-11-27
    rf"\b{_MONTH}\.? [0-3]?\d(?:st|nd|rd|th)?,? 20\d\d\b",          # November 27, 2026
    rf"\b[0-3]?\d(?:st|nd|rd|th)? {_MONTH}\.? 20\d\d\b",            # 27 November 2026
    r"\bsittings?\b",                                               # "in the same sitting"
    r"`vm`",                                                        # the development VM's host name
    r"\b\d+-core\b[^.|;]*?\b(?:VM|machine)s?\b",                    # "the 2-core Intel Xeon VM"
    r"\b(?:the|this|that|same|earlier|other|shared|busy|quiet|development)\s+(?:\d+-core\s+)?VMs?\b",
    r"\bdevelopment\s+machines?\b",                                 # "the development machine"
    r"\b(?:the|this|that|same|earlier|other)\s+(?:(?:busy|quiet|shared|\d+-core)\s+)+machines?\b",
    r"\b(?:Xeon|EPYC|Zen \d)\b[^.|;]{0,20}\bVMs?\b",                # "an AMD EPYC (Zen 5) VM"
    r"\b(?:the|that|same) day(?:'s)?\b|\btoday\b|\byesterday\b",    # "the day's runs"
    r"\b(?:at|from|until|after) [0-2]\d:[0-5]\d\b",                 # "measured at 07:58"
]), re.IGNORECASE)


# A table's caption: one line, "Measured on <CPU>, <cores>, <date> (`command`):", ending in a colon.
CAPTION = re.compile(r"^Measured on \S.*:$")


def _is_table_row(line: str) -> bool:
    return line.lstrip().startswith("|")


def _captions(lines: list[str]) -> set[int]:
    """Indices of the caption lines: a line of CAPTION's form whose next non-blank line starts a
    table. Only that one line counts as the table's; a line above it is prose again."""
    found = set()
    for i, line in enumerate(lines):
        if not CAPTION.match(line.strip()):
            continue
        following = next((nxt for nxt in lines[i + 1:] if nxt.strip()), "")
        if _is_table_row(following):
            found.add(i)
    return found


def dated_lines_in(name: str, text: str) -> list[str]:
    """'file:line: text' for each line of the page `name` that dates a measurement. In
    performance.md a table's rows (lines starting with '|') and its caption line are where dated
    measurements belong; anywhere else, and on every other page, a dated line is reported."""
    lines = text.splitlines()
    table = _captions(lines) if name == "performance.md" else set()
    found = []
    for i, line in enumerate(lines):
        if name == "performance.md" and (_is_table_row(line) or i in table):
            continue
        if DATED.search(line):
            found.append(f"docs/{name}:{i + 1}: {line.strip()}")
    return found


def dated_lines(page) -> list[str]:
    return dated_lines_in(page.name, page.read_text())


@pytest.mark.parametrize("text", [
    "Measured with the default (2026-11-27, this 2-core VM, 1 thread): the 20 m/s MPM block",
    "the shared machine differ between sittings by several per cent, so each comparison below",
    "One sitting (machine otherwise idle):",
    "development VM (`vm`, 2026-11-27, one thread, as a default run of these decks uses; the",
    "lattice. Measured on the 2-core Intel Xeon VM, one thread (the other core busy):",
    "alternated in the same process, the 2-core AMD EPYC VM:",
    "day's runs on this shared VM).",
    "follow it are from earlier sittings on other VMs, without the choices that section describes.",
    "checkout, measured at 07:58, when the VM ran both codes about 10% slower",
    "`python bench/fuzz.py --cases 5000` (2-core development machine, one thread)",
    "measured on November 27, 2026",
    "measured on 27 Nov 2026",
])
def test_the_pattern_catches_dated_measurements(text):
    assert DATED.search(text), text


@pytest.mark.parametrize("text", [
    "Li 2022, https://doi.org/10.1016/j.cma.2021.114350 (preprint arXiv:2108.03349)",
    "[Bardenhagen 2004](references.md#bardenhagen2004) (2004) 477-495",
    "Proceedings of the 2005 ACM SIGGRAPH/Eurographics Symposium, June 2005, pp. 181-190",
    "this is ipctk's IMPROVED_MAX_APPROX set (ipctk 1.6); cholespy 2.2.0; numba 0.60.0",
    "Kubernetes, cloud VMs and the like reach the same scheduler",
    "Two threads do not help on two cores: the solve's BLAS stays on one thread",
    "On a shared machine timings vary with the load: compare runs of one sweep",
    "a ratio of 10:1 between the stiffnesses; at t = 0.25 s",
])
def test_the_pattern_passes_references_dois_and_versions(text):
    assert not DATED.search(text), text


_CAPTION_LINE = ("Measured on AMD EPYC (Zen 5), 2 cores, idle, 2026-12-01 "
                 "(`python bench/coldstart.py two_blocks disks`):")
_TABLE = "| deck | wall (s) |\n|---|---:|\n| disks | 5.3 |\n"


def test_a_caption_directly_above_a_table_may_date_it():
    """The caption line counts as its table's, blank lines between them or not; the same text as
    prose (no table next), two lines above a table, or on another page, is reported."""
    for gap in ("\n", "\n\n"):
        assert dated_lines_in("performance.md", f"Prose.\n{_CAPTION_LINE}{gap}{_TABLE}") == []
    as_prose = f"{_CAPTION_LINE}\nthe text goes on.\n\n{_TABLE}"
    assert dated_lines_in("performance.md", as_prose) == [f"docs/performance.md:1: {_CAPTION_LINE}"]
    at_the_end = f"Prose.\n{_CAPTION_LINE}\n"
    assert dated_lines_in("performance.md", at_the_end) == [f"docs/performance.md:2: {_CAPTION_LINE}"]
    two_lines = f"{_CAPTION_LINE}\nMeasured on the same machine:\n{_TABLE}"
    assert dated_lines_in("performance.md", two_lines) == [f"docs/performance.md:1: {_CAPTION_LINE}"]
    not_a_caption = "On AMD EPYC, 2 cores, 2026-12-01, the step took 2.5 ms:"
    assert dated_lines_in("performance.md", f"{not_a_caption}\n{_TABLE}") == [
        f"docs/performance.md:1: {not_a_caption}"]
    assert dated_lines_in("architecture.md", f"{_CAPTION_LINE}\n{_TABLE}") == [
        f"docs/architecture.md:1: {_CAPTION_LINE}"]


def test_no_line_in_docs_dates_a_measurement():
    """Every dated line in docs/*.md outside performance.md's tables, named file:line. A
    measurement is written undated with the command that reproduces it (a make target, a bench
    command, a pytest selection); its machine and date go to a table of docs/performance.md (a row
    or the caption above it)."""
    found = [hit for page in sorted(DOCS.glob("*.md")) for hit in dated_lines(page)]
    assert not found, f"{len(found)} lines date a measurement:\n" + "\n".join(found)


# The two pages at commit 25e4ebd (`git show 25e4ebd:docs/<page> | wc -lw`), before issue 76
# cut them: (lines, words). Each must now be at most half of both.
BEFORE = {"contact.md": (1399, 19608), "bfemp.md": (1032, 14034)}


@pytest.mark.parametrize("page", sorted(BEFORE))
def test_the_lab_notebook_pages_are_at_most_half_as_long(page):
    text = (DOCS / page).read_text()
    lines, words = text.count("\n"), len(text.split())
    old_lines, old_words = BEFORE[page]
    assert 2 * lines <= old_lines and 2 * words <= old_words, (
        f"docs/{page}: {lines} lines, {words} words; at most {old_lines // 2} lines and "
        f"{old_words // 2} words (half of 25e4ebd's {old_lines}, {old_words})")
