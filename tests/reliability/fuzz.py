"""Deck fuzzing: mutate one thing in a deck of inputs/ (a value made NaN, +-inf, 0, negative,
huge, tiny, of the wrong type; a vector made longer or shorter; an unknown key; a key removed;
the text cut short, made non-UTF-8, nested too deep, turned into an alias bomb), then run
`mpmsim check` and, when the deck is still valid, `mpmsim run --steps 2`, in this process with
a time limit. Every case must end in a documented exit code with a clean message: no
traceback, no hang, no warning.

Used by tests/reliability/test_fuzz.py (Hypothesis picks the mutations) and bench/fuzz.py
(thousands of seeded cases and the table of outcomes)."""

from __future__ import annotations

import copy
import math
import re
import shutil
import signal
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import yaml
from typer.testing import CliRunner

ROOT = Path(__file__).resolve().parents[2]
INPUTS = ROOT / "inputs"
DECKS = sorted(p.stem for p in INPUTS.glob("*.yaml"))
VALUE_KINDS = ("nan", "inf", "-inf", "zero", "negative", "huge", "tiny", "string", "list", "mapping", "null",
               "longer", "shorter", "unknown key", "delete")
TEXT_KINDS = ("truncate", "not utf-8", "utf-16", "nul byte", "deep nesting", "alias bomb")
KINDS = VALUE_KINDS + TEXT_KINDS
CLEAN_EXITS = {0: "ok", 2: "bad deck", 3: "stopped (unstable)", 4: "output fault"}
DECK_MESSAGE = re.compile(r"\.yaml(, line \d+)?: (\(top level\)|[^\s:]+): ")  # file, line, key path

Pick = Callable[[list], object]


class TimeLimit(BaseException):
    """Raised by the alarm when a case runs past its time limit (not an Exception: nothing in
    the code under test may catch it)."""


@dataclass
class Outcome:
    deck: str
    mutation: str
    kind: str
    outcome: str  # ok, bad deck, stopped (unstable), output fault, traceback, hang, warning, message
    detail: str = ""


def paths(node, prefix=()) -> list[tuple]:
    """Every key path into a YAML document (containers and leaves)."""
    out = []
    if isinstance(node, dict):
        for k, v in node.items():
            out.append(prefix + (k,))
            out += paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out.append(prefix + (i,))
            out += paths(v, prefix + (i,))
    return out


def _get(node, path):
    for k in path:
        node = node[k]
    return node


def _value(kind: str, old):
    number = isinstance(old, (int, float)) and not isinstance(old, bool)
    return {"nan": math.nan, "inf": math.inf, "-inf": -math.inf, "zero": 0, "huge": 1e300, "tiny": 1e-300,
            "negative": -abs(old) if number and old else -1.0, "string": "oops", "list": [1.0, 2.0],
            "mapping": {"a": 1.0}, "null": None}[kind]


def mutate(name: str, pick: Pick) -> tuple[bytes, str, str]:
    """(deck bytes, what was done, kind) for deck `name` of inputs/, choices made by `pick`."""
    text = (INPUTS / f"{name}.yaml").read_text()
    kind = pick(list(KINDS))
    if kind == "truncate":
        cut = pick(list(range(0, len(text), max(1, len(text) // 64))))
        return text[:cut].encode(), f"cut at character {cut}", kind
    if kind == "not utf-8":
        at = pick(list(range(0, len(text), max(1, len(text) // 64))))
        raw = text.encode()
        return raw[:at] + b"\xe9\xff" + raw[at:], f"bytes 0xE9 0xFF at {at}", kind
    if kind == "utf-16":
        return text.encode("utf-16"), "encoded as UTF-16", kind
    if kind == "nul byte":
        at = pick(list(range(0, len(text), max(1, len(text) // 64))))
        return (text[:at] + "\0" + text[at:]).encode(), f"NUL at {at}", kind
    if kind == "deep nesting":
        return (text + "\nextra: " + "[" * 5000 + "]" * 5000 + "\n").encode(), "5000 nested lists", kind
    if kind == "alias bomb":
        lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
        lines += [f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]" for i in range(1, 9)]
        return (text + "\n" + "\n".join(lines) + "\n").encode(), "alias bomb (10^9 nodes)", kind
    data = yaml.safe_load(text)
    where = paths(data)
    if kind in ("longer", "shorter"):
        where = [p for p in where if isinstance(_get(data, p), list)] or where
    if kind == "unknown key":
        where = [()] + [p for p in where if isinstance(_get(data, p), dict)]
    path = pick(where)
    key = ".".join(map(str, path)) or "(top level)"
    parent = _get(data, path[:-1]) if path else None
    target = _get(data, path)
    if kind == "unknown key":
        (target if isinstance(target, dict) else data)["bogus_key"] = 1.0
    elif kind == "delete":
        del parent[path[-1]]
    elif kind == "longer" and isinstance(target, list) and target:
        target.append(copy.deepcopy(target[-1]))
    elif kind == "shorter" and isinstance(target, list) and target:
        target.pop()
    else:
        parent[path[-1]] = _value(kind if kind not in ("longer", "shorter") else "list", target)
    return yaml.safe_dump(data, sort_keys=False).encode(), f"{kind} at {key}", kind


def workspace(folder: Path) -> Path:
    """A folder holding what decks of inputs/ refer to (images, meshes), for mutated decks."""
    folder.mkdir(parents=True, exist_ok=True)
    for p in INPUTS.iterdir():
        if p.suffix != ".yaml" and not (folder / p.name).exists():
            (shutil.copytree if p.is_dir() else shutil.copy)(p, folder / p.name)
    return folder


def _invoke(args: list[str], seconds: float):
    from mpmsim.cli import app

    def alarm(signum, frame):
        raise TimeLimit()

    old = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result = CliRunner().invoke(app, args)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    return result, caught


def run_case(name: str, pick: Pick, folder: Path, seconds: float = 60.0) -> Outcome:
    """Mutate deck `name`, check it, and run two steps of it if it is valid."""
    raw, what, kind = mutate(name, pick)
    deck = folder / f"{name}.yaml"
    deck.write_bytes(raw)
    steps = (["check", str(deck)],
             ["run", str(deck), "--out", str(folder / "out"), "--quiet", "--threads", "1", "--steps", "2"])
    for args in steps:
        try:
            result, caught = _invoke(args, seconds)
        except TimeLimit:
            return Outcome(name, what, kind, "hang", f"{args[0]} ran past {seconds:g} s")
        text = result.output
        if result.exception is not None and not isinstance(result.exception, SystemExit) or "Traceback" in text:
            exc = result.exception
            return Outcome(name, what, kind, "traceback", f"{args[0]}: {type(exc).__name__}: {exc}"[:300])
        if caught or "Warning" in text:
            first = str(caught[0].message) if caught else text
            return Outcome(name, what, kind, "warning", f"{args[0]}: {first}"[:300])
        code = result.exit_code
        if code not in CLEAN_EXITS:
            return Outcome(name, what, kind, f"exit {code}", f"{args[0]}: {text.strip()[-300:]}")
        if code == 2 and not DECK_MESSAGE.search(text):
            return Outcome(name, what, kind, "message", f"{args[0]}: no file and key path in: {text.strip()[:300]}")
        if code != 0:
            return Outcome(name, what, kind, CLEAN_EXITS[code], text.strip().splitlines()[-1][:300])
    return Outcome(name, what, kind, "ok")
