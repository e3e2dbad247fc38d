"""What a newcomer reads first: the README as a front page, links that resolve, a licence and a
citation (issue 76).

- README.md names the two commands (`make run`, `make test`); every picture in it exists and is
  named beside the make target or bench script that draws it, whose recipe or source names the
  picture's file; it carries no dated measurement (a date such as 2026-11-27, a "sitting").
- Every relative link and image of README.md, docs/*.md and inputs/README.md resolves, and an
  anchor into a Markdown file names one of its headings (GitHub's slug rules) or an explicit
  `<a id=...>` in it.
- LICENSE, pyproject.toml's licence and CITATION.cff's name one SPDX licence; CITATION.cff is
  YAML with the fields a citation needs, its version the package's.
"""

from __future__ import annotations

import re
import tomllib
import unicodedata
from pathlib import Path

import pytest
import yaml

from ..conftest import ROOT

pytestmark = pytest.mark.newcomer

README = ROOT / "README.md"
MAKEFILE = ROOT / "Makefile"
PAGES = [README, *sorted((ROOT / "docs").glob("*.md")), *[p for p in [ROOT / "inputs" / "README.md"] if p.exists()]]

FENCE = re.compile(r"^(```|~~~).*?^\1[ \t]*$", re.S | re.M)
INLINE_CODE = re.compile(r"`[^`\n]*`")
LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\[\]]*\])*\]\(\s*<?([^()\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
IMAGE = re.compile(r"!\[[^\]]*\]\(\s*<?([^()\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
HEADING = re.compile(r"^(#{1,6})[ \t]+(.+?)[ \t#]*$", re.M)
EXPLICIT_ANCHOR = re.compile(r"<a\s+(?:id|name)=\"([^\"]+)\"", re.I)
DATED = re.compile(r"\b20\d\d-[01]\d-[0-3]\d\b|\bsittings?\b|\b\d\d:\d\d UTC\b", re.I)


def prose(text: str) -> str:
    """The text without fenced code blocks and inline code (links there are not links)."""
    return INLINE_CODE.sub("", FENCE.sub("", text))


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: inline Markdown dropped, lower case, every character but
    letters, marks, numbers, '_', '-' and spaces removed, spaces made hyphens."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # links and images: their text
    text = re.sub(r"<[^>]+>", "", text)  # inline HTML
    keep = [c for c in text.lower() if c in " -_" or unicodedata.category(c)[0] in "LMN"]
    return "".join(keep).replace(" ", "-")


def anchors(page: Path) -> set[str]:
    text = FENCE.sub("", page.read_text())
    seen: dict[str, int] = {}
    out = set(EXPLICIT_ANCHOR.findall(text))
    for _, title in HEADING.findall(text):
        base = slug(title)
        n = seen.get(base, 0)
        seen[base] = n + 1
        out.add(base if n == 0 else f"{base}-{n}")
    return out


def broken_links(page: Path) -> list[str]:
    bad = []
    for target in LINK.findall(prose(page.read_text())):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I):  # http:, https:, mailto:
            continue
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.exists():
            bad.append(f"{page.relative_to(ROOT)}: {target} (no such file)")
        elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
            bad.append(f"{page.relative_to(ROOT)}: {target} (no heading or anchor '{anchor}' in {dest.name})")
    return bad


def make_targets() -> dict[str, str]:
    """{target: its recipe} of the Makefile's explicit rules."""
    out: dict[str, str] = {}
    current = None
    for line in MAKEFILE.read_text().splitlines():
        rule = re.match(r"^([A-Za-z0-9_.-]+)\s*:(?!=)", line)
        if rule:
            current = rule.group(1)
            out.setdefault(current, "")
        elif line.startswith("\t") and current:
            out[current] += line + "\n"
        elif line.strip() and not line.startswith("#"):
            current = None
    return out


def makers(target: str, targets: dict[str, str], seen=frozenset()) -> str:
    """The recipe of a make target with the recipes of the targets it depends on through
    FIGURES-style aliases (`figure-x: bench-x`) and the sources of the bench scripts it runs."""
    text = targets.get(target, "")
    for line in MAKEFILE.read_text().splitlines():
        rule = re.match(rf"^{re.escape(target)}\s*:(?!=)(.*)$", line)
        if rule:
            for dep in rule.group(1).split():
                if dep in targets and dep not in seen:
                    text += makers(dep, targets, seen | {target})
    for script in re.findall(r"bench/[\w/]+\.py", text):
        if (ROOT / script).exists():
            text += (ROOT / script).read_text()
    return text


# --- (a) the README ----------------------------------------------------------------------------


def test_readme_names_the_two_commands():
    text = README.read_text()
    targets = make_targets()
    for command in ("make run", "make test"):
        assert re.search(rf"\b{command}\b", text), f"README.md does not name `{command}`"
        assert command.split()[1] in targets, f"the Makefile has no target for `{command}`"


def test_readme_pictures_exist_and_are_made_by_a_named_command():
    text = README.read_text()
    lines = text.splitlines()
    targets = make_targets()
    images = [(i, m) for i, line in enumerate(lines) for m in IMAGE.findall(line)]
    assert images, "README.md shows no picture"
    for i, image in images:
        path = (README.parent / image).resolve()
        assert path.is_file(), f"README.md shows {image}, which does not exist"
        beside = "\n".join(lines[max(i - 3, 0): i + 6])
        named = re.findall(r"make ([A-Za-z0-9_.-]+)", beside)
        scripts = re.findall(r"bench/[\w/]+\.py", beside)
        assert named or scripts, f"no make target or bench script is named beside {image}"
        for t in named:
            assert t in targets, f"`make {t}`, named beside {image}, is not a target of the Makefile"
        for s in scripts:
            assert (ROOT / s).is_file(), f"{s}, named beside {image}, does not exist"
        sources = "".join(makers(t, targets) for t in named) + "".join((ROOT / s).read_text() for s in scripts)
        assert path.name in sources, (
            f"{image}: none of {named + scripts}, named beside it, writes a file of that name")


def test_readme_has_no_dated_measurement():
    hits = [f"line {n}: {line.strip()}" for n, line in enumerate(README.read_text().splitlines(), 1)
            if DATED.search(line)]
    assert not hits, "README.md dates a measurement or narrates a sitting (those belong in " \
                     "docs/performance.md's tables and the git history):\n" + "\n".join(hits)


# --- (b) links -----------------------------------------------------------------------------------


def test_slug_follows_github():
    assert slug("Oblique impact — `inputs/oblique_impact.yaml`") == "oblique-impact--inputsoblique_impactyaml"
    assert slug("Beside the reference code, one thread") == "beside-the-reference-code-one-thread"
    assert slug("Fig. 5: two identical blocks compressed to 20% — `x`") == "fig-5-two-identical-blocks-compressed-to-20--x"
    assert slug("Hertz contact: a cylinder on a rigid flat") == "hertz-contact-a-cylinder-on-a-rigid-flat"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_and_images_resolve(page):
    bad = broken_links(page)
    assert not bad, "links that do not resolve:\n" + "\n".join(bad)


# --- (c) licence and citation --------------------------------------------------------------------


def spdx_of_license_text(text: str) -> str | None:
    if "Redistribution and use in source and binary forms" in text:
        return "BSD-3-Clause" if "Neither the name of" in text else "BSD-2-Clause"
    if "Permission is hereby granted, free of charge" in text:
        return "MIT"
    if "Apache License" in text and "Version 2.0" in text:
        return "Apache-2.0"
    return None


def pyproject() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]


def test_license_matches_pyproject_and_citation():
    license_file = ROOT / "LICENSE"
    assert license_file.is_file(), "no LICENSE"
    spdx = spdx_of_license_text(license_file.read_text())
    assert spdx is not None, "LICENSE is not a licence text this test knows"
    declared = pyproject().get("license")
    declared = declared.get("text") if isinstance(declared, dict) else declared
    assert declared == spdx, f"pyproject.toml's licence {declared!r} is not LICENSE's {spdx}"
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert cff.get("license") == spdx, f"CITATION.cff's licence {cff.get('license')!r} is not LICENSE's {spdx}"


def test_citation_has_what_a_citation_needs():
    path = ROOT / "CITATION.cff"
    assert path.is_file(), "no CITATION.cff"
    cff = yaml.safe_load(path.read_text())
    for key in ("cff-version", "message", "title", "authors", "version", "license"):
        assert cff.get(key), f"CITATION.cff has no {key}"
    assert str(cff["cff-version"]) == "1.2.0"
    assert isinstance(cff["authors"], list) and all(
        a.get("name") or a.get("family-names") for a in cff["authors"]), "every author needs a name"
    assert str(cff["version"]) == pyproject()["version"], "CITATION.cff's version is not pyproject.toml's"
    for ref in cff.get("references", []):
        assert ref.get("title") and ref.get("authors") and ref.get("type"), f"incomplete reference {ref}"
        if "doi" in ref:
            assert re.fullmatch(r"10\.\d{4,9}/\S+", str(ref["doi"])), f"not a DOI: {ref['doi']}"
    try:  # the full schema where cffconvert is installed (it is not a dependency)
        from cffconvert.cli.create_citation import create_citation
    except ImportError:
        return
    create_citation(str(path), None).validate()
