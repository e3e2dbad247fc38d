"""Generate the deck reference (Markdown) from the pydantic schema.

    python -m mpmsim.deck.reference > docs/deck-reference.md
"""

from __future__ import annotations

import inspect
import types
import typing

from pydantic import BaseModel
from pydantic_core import PydanticUndefined

from . import schema
from .units import UNIT_SYSTEMS


def _own(ann) -> bool:
    """Not a model of a user's module (a registered material model is documented there)."""
    return not (inspect.isclass(ann) and issubclass(ann, BaseModel)) or ann.__module__.startswith("mpmsim")


def _type_name(ann) -> str:
    origin = typing.get_origin(ann)
    if origin is typing.Annotated:
        return _type_name(typing.get_args(ann)[0])
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_type_name(a) for a in typing.get_args(ann) if a is not type(None) and _own(a))
    if origin is typing.Literal:
        return " \\| ".join(f"`{a}`" for a in typing.get_args(ann))
    if origin is list:
        return f"list of {_type_name(typing.get_args(ann)[0])}"
    if origin is dict:
        return f"mapping name → {_type_name(typing.get_args(ann)[1])}"
    if inspect.isclass(ann) and issubclass(ann, BaseModel):
        return f"[{ann.__name__}](#{ann.__name__.lower()})"
    return getattr(ann, "__name__", str(ann))


def _default(field) -> str:
    if field.is_required():
        return "**required**"
    if field.default_factory is not None:
        value = field.default_factory()
        return "see below" if isinstance(value, BaseModel) else f"`{value}`"
    if field.default is None or field.default is PydanticUndefined:
        return "—"
    return f"`{field.default}`"


def _models_in(ann, seen: list) -> None:
    for arg in typing.get_args(ann) or ():
        _models_in(arg, seen)
    if inspect.isclass(ann) and issubclass(ann, BaseModel) and ann not in seen and _own(ann):
        seen.append(ann)
        for f in ann.model_fields.values():
            _models_in(f.annotation, seen)


def _table(model: type[BaseModel]) -> str:
    rows = ["| key | type | default | meaning |", "|---|---|---|---|"]
    for name, f in model.model_fields.items():
        desc = (f.description or "").replace("\n", " ").replace("|", "\\|")
        rows.append(f"| `{f.alias or name}` | {_type_name(f.annotation)} | {_default(f)} | {desc} |")
    return "\n".join(rows)


def render() -> str:
    models: list[type[BaseModel]] = []
    _models_in(schema.Deck, models)
    out = [
        "# Deck reference",
        "",
        "Generated from `mpmsim/deck/schema.py` by `python -m mpmsim.deck.reference`; do not edit by hand.",
        "Every mapping rejects unknown keys. Vectors have 2 components in `plane_strain` decks and 3 in `3d` decks.",
        "Numbers are in the deck's unit system (see [units.md](units.md)):",
        "",
        "| units | length | time | stress | density | energy |",
        "|---|---|---|---|---|---|",
    ]
    for u in UNIT_SYSTEMS.values():
        out.append(f"| `{u.name}` | {u.length} | {u.time} | {u.stress} | {u.density} | {u.energy} |")
    for m in models:
        out += ["", f"## {m.__name__}", ""]
        doc = m.__dict__.get("__doc__")  # the model's own docstring, not BaseModel's
        if doc:
            out += [inspect.cleandoc(doc).replace("\n", " "), ""]
        out.append(_table(m))
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    print(render(), end="")
