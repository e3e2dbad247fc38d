"""Read a YAML deck, validate it, and report problems by key path and YAML line.

`load_deck(path)` returns a `LoadedDeck` or raises `DeckError` whose message names the
file, the line, the key path (e.g. `materials.steel.nu`) and what is wrong.
"""

from __future__ import annotations

import difflib
import hashlib
import json
import re
import typing
from dataclasses import dataclass
from pathlib import Path

import yaml
from pydantic import BaseModel, ValidationError

from ..errors import DeckError
from . import schema
from .schema import Deck


@dataclass
class LoadedDeck:
    deck: Deck
    path: Path
    data: dict  # the raw mapping, for tools that vary keys (sweeps)
    text: str = ""  # the YAML as read, to locate problems found after loading
    label: str | None = None  # a deck given as a mapping: how errors name it (no file, no lines)

    @property
    def base_dir(self) -> Path:
        return self.path.parent

    @property
    def stem(self) -> str:
        return self.path.stem


def load_deck(path: str | Path) -> LoadedDeck:
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise DeckError(((), f"cannot read deck file: {exc.strerror or exc}"), source=str(path)) from None
    if len(raw) > MAX_DECK_BYTES:
        raise DeckError(((), f"the deck is {len(raw)} bytes; a deck is a short text (at most {MAX_DECK_BYTES})"),
                        source=str(path))
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise DeckError(((), f"the deck is not UTF-8 text (byte {exc.start})"), source=str(path),
                        lines=[line]) from None
    return load_deck_text(text, path)


MAX_DECK_BYTES = 1_000_000  # a deck is text written by hand; meshes and images are separate files
MAX_EXPANDED_NODES = 100_000  # values a deck may hold once aliases are expanded (no alias bombs)


def _expanded_size(node, memo: dict) -> int:
    """Number of YAML values under `node` with every alias expanded (memoized per node, so an
    alias bomb is measured without being built)."""
    if node is None:
        return 0
    key = id(node)
    if key in memo:
        return memo[key]
    memo[key] = 1  # cycles count once
    if isinstance(node, yaml.MappingNode):
        n = 1 + sum(_expanded_size(k, memo) + _expanded_size(v, memo) for k, v in node.value)
    elif isinstance(node, yaml.SequenceNode):
        n = 1 + sum(_expanded_size(v, memo) for v in node.value)
    else:
        n = 1
    memo[key] = n
    return n


def load_deck_text(text: str, path: Path) -> LoadedDeck:
    source = str(path)
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
        size = _expanded_size(root, {})
        if size > MAX_EXPANDED_NODES:
            raise DeckError(((), f"the deck's YAML aliases (*name) expand to {size:.3g} values; at most "
                                 f"{MAX_EXPANDED_NODES} are read"), source=source)
        data = yaml.safe_load(text)
    except RecursionError:
        raise DeckError(((), "the deck is nested too deeply to read"), source=source) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        problem = getattr(exc, "problem", None) or str(exc)
        raise DeckError(((), f"YAML syntax error: {problem}"), source=source, lines=[line]) from None
    if data is None:
        raise DeckError(((), "the deck is empty"), source=source, lines=[1])
    if not isinstance(data, dict):
        raise DeckError(((), "the deck must be a mapping of keys (title:, grid:, ...)"),
                        source=source, lines=[1])
    _reject_duplicate_keys(root, source)
    try:
        deck = Deck.model_validate(data)
    except ValidationError as exc:
        problems = _problems_from_validation(exc, root)
        raise _with_lines(problems, root, source) from None
    from .semantics import check_deck  # late import: semantics needs the scene helpers

    problems = check_deck(deck, path.parent)
    if problems:
        raise _with_lines(problems, root, source)
    return LoadedDeck(deck=deck, path=path, data=data, text=text)


def as_loaded_deck(deck, name: str = "deck", base_dir: str | Path | None = None) -> LoadedDeck:
    """A deck from a YAML file's path, a mapping of its keys or a Deck model (a mapping or a
    model is validated as a file named <base_dir>/<name>.yaml would be)."""
    if isinstance(deck, LoadedDeck):
        return deck
    if isinstance(deck, (str, Path)):
        return load_deck(deck)
    if isinstance(deck, Deck):
        deck = deck.model_dump(mode="json", exclude_unset=True)  # only what was given: a file's keys
    if not isinstance(deck, dict):
        raise DeckError(((), f"a deck is a file path, a mapping or a Deck, not {type(deck).__name__}"), source=name)
    path = Path(base_dir if base_dir is not None else ".") / f"{name}.yaml"
    label = f"deck '{name}' (a mapping)"
    try:
        loaded = load_deck_text(yaml.safe_dump(deck, sort_keys=False, allow_unicode=True), path)
    except DeckError as exc:  # the lines are those of a YAML dump the caller never saw: key paths only
        raise DeckError(exc.problems, source=label) from None
    loaded.label = label
    return loaded


def raise_at(problems: list[tuple[tuple, str]], loaded: LoadedDeck) -> typing.NoReturn:
    """Raise DeckError for problems found after loading (e.g. by the scene builder)."""
    if loaded.label is not None:
        raise DeckError(problems, source=loaded.label)
    root = yaml.compose(loaded.text, Loader=yaml.SafeLoader)
    raise _with_lines(problems, root, str(loaded.path))


# --------------------------------------------------------------------------- helpers
def _with_lines(problems, root, source) -> DeckError:
    lines = [_line_of(root, path) for path, _ in problems]
    return DeckError(problems, source=source, lines=lines)


def _reject_duplicate_keys(node, source):
    if isinstance(node, yaml.MappingNode):
        seen = {}
        for key, value in node.value:
            k = key.value
            if k in seen:
                raise DeckError(((k,), f"duplicate key '{k}' (first given on line {seen[k]})"),
                                source=source, lines=[key.start_mark.line + 1])
            seen[k] = key.start_mark.line + 1
            _reject_duplicate_keys(value, source)
    elif isinstance(node, yaml.SequenceNode):
        for item in node.value:
            _reject_duplicate_keys(item, source)


def _line_of(root, path) -> int | None:
    """Line of the deepest node of `path` present in the YAML (1-based)."""
    if root is None:
        return None
    node, line = root, root.start_mark.line + 1
    for key in path:
        if isinstance(node, yaml.MappingNode):
            for k, v in node.value:
                if k.value == str(key):
                    node, line = v, k.start_mark.line + 1
                    break
            else:
                break
        elif isinstance(node, yaml.SequenceNode) and isinstance(key, int) and 0 <= key < len(node.value):
            node = node.value[key]
            line = node.start_mark.line + 1
        else:
            break
    return line


def _all_models() -> list[type[BaseModel]]:
    """The deck's models: those of the schema module and every registered material model's."""
    from ..materials.model import schemas

    own = [c for c in vars(schema).values() if isinstance(c, type) and issubclass(c, BaseModel) and c is not BaseModel]
    return own + [c for c in schemas() if c not in own]


def _names() -> tuple[set, set, list]:
    """(discriminator tags, union-branch names, every key of any model): read when a deck is
    wrong, so material models registered since import count."""
    from ..materials.model import MODELS

    models = _all_models()
    tags = {"rigid", *MODELS, *schema.SHAPES_2D, *schema.SHAPES_3D, "box", "mesh"}
    branches = {c.__name__ for c in models} | {"list[float]", "list[int]", "float", "int"}
    return tags, branches, sorted({name for c in models for name in deck_keys(c)})


def deck_keys(model: type[BaseModel]) -> list[str]:
    """A schema model's keys as a deck spells them (a field's alias where it has one: `yield`)."""
    return [f.alias or name for name, f in model.model_fields.items()]


def _clean_loc(loc, data) -> tuple:
    """Drop the discriminator tags and union-branch names pydantic puts into error paths."""
    known, branches, _ = _names()
    out = []
    node = data
    for i, key in enumerate(loc):
        is_last = i == len(loc) - 1
        if isinstance(key, str) and (key in branches or "[" in key) and (
                not is_last or not (isinstance(node, dict) and key in node)):
            continue  # a union branch's name (last: the branch of a plain value, `float`, `list[float]`)
        if isinstance(key, str) and not is_last and key in known and not (isinstance(node, dict) and key in node):
            continue
        if (isinstance(key, str) and not is_last and isinstance(node, dict) and key not in node
                and key in [v for v in node.values() if isinstance(v, str)]):
            continue  # the tag of a nested discriminated union (a hardening law's `law`)
        out.append(key)
        if isinstance(node, dict):
            node = node.get(key)
        elif isinstance(node, list) and isinstance(key, int) and 0 <= key < len(node):
            node = node[key]
        else:
            node = None
    return tuple(out)


def _model_of_tag(tag: str) -> type[BaseModel] | None:
    """The schema model a discriminator value (a material `type`, a body `shape`) selects."""
    for c in _all_models():
        for name in ("type", "shape"):
            f = c.model_fields.get(name)
            if f is not None and getattr(f.annotation, "__args__", None) == (tag,):
                return c
    return None


def _message(err) -> str:
    kind, msg, loc = err["type"], err["msg"], err["loc"]
    known, _, field_names = _names()
    if kind == "extra_forbidden":
        key = str(loc[-1]) if loc else "?"
        tags = [k for k in loc[:-1] if isinstance(k, str) and k in known]
        model = _model_of_tag(tags[-1]) if tags else None
        names = sorted(deck_keys(model)) if model is not None else field_names
        close = difflib.get_close_matches(key, [n for n in names if n != key], n=1, cutoff=0.75)
        if model is not None and key in field_names and not close:  # a key of another kind
            return f"unknown key '{key}' for '{tags[-1]}' (its keys: {', '.join(names)})"
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        return f"unknown key '{key}'{hint}"
    if kind == "missing":
        return "required key is missing"
    if kind == "union_tag_invalid":
        ctx = err.get("ctx", {})
        tag, expected = ctx.get("tag"), ctx.get("expected_tags", "")
        close = difflib.get_close_matches(str(tag), [t.strip(" '") for t in str(expected).split(",")], n=1)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        return f"'{tag}' is not one of {expected}{hint}"
    if kind == "union_tag_not_found":
        return f"needs a '{err.get('ctx', {}).get('discriminator', 'type').strip(chr(39))}' key"
    if kind == "value_error" and msg.startswith("Value error, "):  # a validator's own words
        return msg[len("Value error, "):]
    return msg[0].lower() + msg[1:] if msg else kind


# what a union's plain branches accept, in words (a model branch: a mapping of its keys)
_BRANCH_WORDS = {"float": "a number", "int": "an integer", "str": "a string", "bool": "true or false",
                 "list[float]": "a list of numbers (one per axis)", "list[int]": "a list of integers",
                 "list[list[float]]": "a list of lists of numbers"}


def _branch(loc, path: tuple) -> str | None:
    """The union branch an error's location went through at the end of its deck path: the first
    location entry after the path's keys that names a branch (pydantic's `float`, `list[float]`,
    a model's name), or None."""
    _, branches, _ = _names()
    keys = [k for k in loc]
    for key in path:  # walk the deck keys; what is left after the last one is pydantic's
        if key in keys:
            keys = keys[keys.index(key) + 1:]
    for key in keys:
        if isinstance(key, str) and (key in branches or "[" in key):
            return key
    return None


def _accepted(branch: str) -> str:
    if branch in _BRANCH_WORDS:
        return _BRANCH_WORDS[branch]
    model = next((c for c in _all_models() if c.__name__ == branch), None)
    return f"a mapping with keys {', '.join(deck_keys(model))}" if model is not None else branch


def _union_message(value, branches: list[str]) -> str:
    """One message for a value no branch of a union accepts: what it is, what is accepted; for
    a number written with a unit, that the deck's numbers are plain."""
    shown = repr(value) if isinstance(value, str) else yaml.safe_dump(value, default_flow_style=True).strip()
    words = [_accepted(b) for b in branches]
    accepted = ", ".join(words[:-1]) + " or " + words[-1] if len(words) > 1 else words[0]
    hint = ""
    number = re.match(r"^\s*([-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?)\s*[A-Za-z]", value) if isinstance(value, str) \
        else None
    if number:
        hint = f" (numbers are plain, in the units the deck's `units:` sets: write {number.group(1)})"
    return f"{shown} is not {accepted}{hint}"


def _problems_from_validation(exc: ValidationError, root) -> list[tuple[tuple, str]]:
    data = yaml.safe_load(yaml.serialize(root)) if root is not None else {}
    merged: dict[tuple, list[str]] = {}
    unions: dict[tuple, tuple] = {}  # path -> (the value, the union branches that refused it)
    for err in exc.errors():
        path = _clean_loc(err["loc"], data)
        msg = _message(err)
        msgs = merged.setdefault(path, [])
        if msg not in msgs:
            msgs.append(msg)
        branch = _branch(err["loc"], path)
        if branch is not None and err["type"] not in ("extra_forbidden", "missing"):
            value, seen = unions.setdefault(path, (err.get("input"), []))
            if branch not in seen:
                seen.append(branch)
    problems = []
    for path, msgs in merged.items():
        value, seen = unions.get(path, (None, []))
        if len(seen) == 1 and any(len(q) > len(path) and q[:len(path)] == path for q in merged):
            continue  # one branch refused the value whole where another found a fault inside it: that one speaks
        if len(seen) >= 2:  # every branch of a union refused the value: say what is accepted
            problems.append((path, _union_message(value, seen)))
        else:
            problems.append((path, msgs[0] if len(msgs) == 1 else
                             "does not match any allowed form: " + "; or ".join(msgs)))
    return problems


def deck_digest(deck) -> str:
    """sha256 of the validated deck (all values; not the output folder, which a restart may move)."""
    data = deck.model_dump(mode="json")
    data.get("output", {}).pop("directory", None)
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()
