"""docs/contact.md is a guide, not a lab notebook (issue 76, Must show 6): at most half its former
length (1,399 lines, 19,608 words), its methods page included shorter than it was, no dated
measurement in either, and every section that code, tests and other pages cite still there."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

pytestmark = pytest.mark.newcomer

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
GUIDE, METHODS = DOCS / "contact.md", DOCS / "contact-methods.md"
FORMER_LINES, FORMER_WORDS = 1399, 19608

# a date, a development machine or a sitting: what dates a measurement
DATED = re.compile(r"\b20\d\d-\d\d-\d\d\b|\bsittings?\b|\bVMs?\b|`vm`|this (shared )?(2-core )?machine", re.IGNORECASE)


def size(path: Path) -> tuple[int, int]:
    text = path.read_text(encoding="utf-8")
    return len(text.splitlines()), len(text.split())


def test_the_guide_is_at_most_half_its_former_length():
    lines, words = size(GUIDE)
    assert lines <= FORMER_LINES // 2, f"docs/contact.md has {lines} lines"
    assert words <= FORMER_WORDS // 2, f"docs/contact.md has {words} words"


def test_guide_and_methods_together_are_shorter_than_the_former_page():
    lines, words = (sum(n) for n in zip(size(GUIDE), size(METHODS)))
    assert lines < FORMER_LINES and words < FORMER_WORDS, (lines, words)


@pytest.mark.parametrize("page", [GUIDE, METHODS], ids=lambda p: p.name)
def test_no_dated_measurement(page):
    dated = [f"{page.name}:{i}: {line.strip()}" for i, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1)
             if DATED.search(line)]
    assert not dated, "\n".join(dated)


def slug(heading: str) -> str:
    """GitHub's anchor for a heading."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def anchors(page: Path) -> set[str]:
    return {slug(m.group(1)) for m in re.finditer(r"^#+\s+(.*)$", page.read_text(encoding="utf-8"), re.MULTILINE)}


def citing_files():
    for pattern in ("*.md", "*.py", "Makefile"):
        for path in ROOT.rglob(pattern):
            if not {".venv", ".git", "node_modules"} & set(path.parts) and path != Path(__file__).resolve():
                yield path


def test_every_cited_section_exists():
    """Links `contact.md#anchor` anywhere in the repository, and citations `docs/contact.md,
    "Section"` (or `contact-methods.md`) in code, tests and pages: the anchor is a heading of the
    page and the quoted section's name is in it; `choice N` is one of the numbered choices."""
    pages = {"contact.md": GUIDE, "contact-methods.md": METHODS}
    texts = {name: page.read_text(encoding="utf-8") for name, page in pages.items()}
    missing = []
    for path in citing_files():
        text = path.read_text(encoding="utf-8", errors="replace")
        for name, page in pages.items():
            for m in re.finditer(rf"(?<![\w-]){re.escape(name)}#([\w-]+)", text):
                if m.group(1) not in anchors(page):
                    missing.append(f"{path.relative_to(ROOT)}: {name}#{m.group(1)}")
            for m in re.finditer(rf"(?<![\w-]){re.escape(name)},\s+\"([^\"]+)\"", text):
                section = re.sub(r"\s+", " ", m.group(1))
                if section.lower() not in re.sub(r"\s+", " ", texts[name]).lower():
                    missing.append(f"{path.relative_to(ROOT)}: {name}, \"{section}\"")
            for m in re.finditer(rf"(?<![\w-]){re.escape(name)},\s+choice (\d+)", text):
                if not re.search(rf"^{m.group(1)}\. \*\*", texts[name], re.MULTILINE):
                    missing.append(f"{path.relative_to(ROOT)}: {name}, choice {m.group(1)}")
    assert not missing, "\n".join(missing)
