"""The sweep file: a base deck, axes to vary, a reference, metrics (docs/sweep.md).

    base: ../two_blocks.yaml          # relative to the sweep file
    axes:
      contact.passes: [1, 2]          # a deck key (dotted, numbers index lists): values
      update:                         # a named axis: label -> overrides of several keys
        flip: {update.scheme: flip}
        xpic5: {update.scheme: xpic, update.order: 5}
      grid.cell_size: [10.0, 5.0]
    method: [contact.passes, update]  # axes that make one marker on the chart (default: all
                                      # but the last axis, usually the resolution)
    reference: {single_material: {overrides: {contact.default: {law: none}}, axes: [update, grid.cell_size]}}
    metrics:
      - {name: err, type: max_rel_error, column: syy, x: -u_platen_y / 100, range: [0.002, 0.2]}

`load_sweep(path)` validates and raises DeckError naming the file, the line and the key path.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal, Union

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from ..errors import DeckError


def at(path: str, msg: str) -> ValueError:
    """A model-level problem located at a key path (load_sweep turns it into path + line)."""
    return ValueError(f"@{path}|{msg}")


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Curve(Strict):
    """An analytic y(x): a numpy expression of x (e.g. `2.0 * x - x**2`) or a table to interpolate."""
    expression: str | None = None
    x: list[float] | None = None
    y: list[float] | None = None

    @model_validator(mode="after")
    def _one_form(self):
        table = self.x is not None or self.y is not None
        if (self.expression is None) == (not table):
            raise ValueError("give either expression or a table (x and y), not both or neither")
        if table and (self.x is None or self.y is None or len(self.x) != len(self.y) or len(self.x) < 2):
            raise ValueError("a table needs x and y lists of the same length (2 or more points)")
        return self


class Analytic(Strict):
    values: dict[str, float] = Field(default_factory=dict,
                                     description="Named exact values (e.g. period) that metrics use via `expected`.")
    curve: Curve | None = Field(default=None, description="Exact curve y(x) for max_rel_error.")


class SingleMaterial(Strict):
    deck: str | None = Field(default=None, description="Another deck (relative to the sweep file); default: base.")
    overrides: dict = Field(default_factory=dict, description="Overrides that make the deck one material.")
    axes: list[str] | None = Field(default=None, description="Axes that also apply to the reference "
                                                             "(default: all); others are dropped, so references are shared.")


class Reference(Strict):
    analytic: Analytic | None = None
    single_material: SingleMaterial | None = None
    finest: str | None = Field(default=None, description="Axis whose smallest value is the reference for the rest.")

    @model_validator(mode="after")
    def _exactly_one(self):
        given = [k for k in ("analytic", "single_material", "finest") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError(f"give exactly one of analytic, single_material, finest (got {given or 'none'})")
        return self

    @property
    def kind(self) -> str:
        return next(k for k in ("analytic", "single_material", "finest") if getattr(self, k) is not None)


class MetricBase(Strict):
    name: str = Field(description="Column name in the table.")
    label: str | None = Field(default=None, description="Axis label on the chart (default: the name).")


class MaxRelError(MetricBase):
    type: Literal["max_rel_error"]
    column: str = Field(description="History column (or numpy expression of columns) compared with the reference.")
    x: str = Field(default="time", description="Abscissa: a column or expression, e.g. `-u_platen_y / 100`.")
    range: tuple[float, float] | None = Field(default=None, description="Only x in [a, b].")


class PeriodError(MetricBase):
    type: Literal["period_error"]
    column: str = Field(description="An oscillating column; its zero crossings are half a period apart.")
    expected: str | float | None = Field(default=None, description="The exact period, or the name of an analytic "
                                        "value; default: the reference run's period.")


class EnergyChange(MetricBase):
    type: Literal["energy_change"]
    columns: list[str] = Field(default_factory=lambda: ["kinetic_energy", "strain_energy"])
    at: Literal["end", "max"] = Field(default="end", description="|E(end) - E(0)| / E(0), or the max over time.")


class AccelerationError(MetricBase):
    type: Literal["acceleration_error"]
    column: str | list[str] = Field(description="A position or velocity column (or expression), or a list of them "
                                    "of which the first that a run's history has is used.")
    of: Literal["position", "velocity"] = Field(
        default="position", description="What the column is: a parabola (position) or a line (velocity) in time "
        "is fitted to it.")
    range: tuple[float, float] | None = Field(default=None, description="Only times in [a, b].")
    expected: str | float = Field(description="The exact acceleration, or the name of an analytic value.")


Metric = Annotated[Union[MaxRelError, PeriodError, EnergyChange, AccelerationError], Field(discriminator="type")]


class Sweep(Strict):
    title: str | None = None
    base: str = Field(description="The base deck, relative to the sweep file.")
    axes: dict[str, Union[list, dict[str, dict]]] = Field(
        description="Deck key -> list of values, or axis name -> {label: {key: value, ...}}.")
    method: list[str] | None = Field(default=None, description="Axes whose values make one chart marker.")
    reference: Reference
    metrics: list[Metric] = Field(min_length=1)
    chart_metric: str | None = Field(default=None, description="Metric on the chart's y axis (default: the first).")
    outputs: str | None = Field(default=None, description="Results directory, relative to the sweep file "
                                                          "(default: results/sweeps/<sweep name> under the cwd).")

    @model_validator(mode="after")
    def _consistent(self):
        reserved = {"id", "role", "method", "status", "stopped_at", "message", *(m.name for m in self.metrics)}
        for name, values in self.axes.items():
            if len(values) == 0:
                raise at(f"axes.{name}", "needs at least one value")
            if name in reserved:
                raise at(f"axes.{name}", "the name of a table column; give the axis another name")
        names = list(self.axes)
        for i, key in enumerate(self.method or []):
            if key not in names:
                raise at(f"method.{i}", f"'{key}' is not an axis (axes: {', '.join(names)})")
        ref = self.reference
        if ref.finest is not None and ref.finest not in names:
            raise at("reference.finest", f"'{ref.finest}' is not an axis (axes: {', '.join(names)})")
        if ref.single_material is not None:
            for i, key in enumerate(ref.single_material.axes or []):
                if key not in names:
                    raise at(f"reference.single_material.axes.{i}", f"'{key}' is not an axis")
        metric_names = [m.name for m in self.metrics]
        if self.chart_metric is not None and self.chart_metric not in metric_names:
            raise at("chart_metric", f"'{self.chart_metric}' is not a metric ({', '.join(metric_names)})")
        for i, m in enumerate(self.metrics):
            if isinstance(m, PeriodError) and isinstance(m.expected, str):
                if ref.analytic is None or m.expected not in ref.analytic.values:
                    raise at(f"metrics.{i}.expected", f"'{m.expected}' is not a value in reference.analytic.values")
            if isinstance(m, PeriodError) and m.expected is None and ref.analytic is not None:
                raise at(f"metrics.{i}", "give expected (a number or an analytic value's name)")
            if isinstance(m, MaxRelError) and ref.analytic is not None and ref.analytic.curve is None:
                raise at(f"metrics.{i}", "max_rel_error against an analytic reference needs reference.analytic.curve")
        return self

    @property
    def method_axes(self) -> list[str]:
        return self.method if self.method is not None else list(self.axes)[:-1] or list(self.axes)

    @property
    def chart(self) -> str:
        return self.chart_metric or self.metrics[0].name


class LoadedSweep:
    def __init__(self, sweep: Sweep, path: Path):
        self.sweep, self.path = sweep, path

    @property
    def base(self) -> Path:
        return (self.path.parent / self.sweep.base).resolve()

    def out_dir(self) -> Path:
        if self.sweep.outputs is not None:
            return (self.path.parent / self.sweep.outputs).resolve()
        return Path.cwd() / "results" / "sweeps" / self.path.stem


def load_sweep(path: str | Path) -> LoadedSweep:
    from ..deck.loader import _line_of  # same key-path -> YAML line lookup as decks

    path = Path(path)
    source = str(path)
    try:
        text = path.read_text()
        root = yaml.compose(text, Loader=yaml.SafeLoader)
        data = yaml.safe_load(text)
    except OSError as exc:
        raise DeckError(((), f"cannot read sweep file: {exc.strerror or exc}"), source=source) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        raise DeckError(((), f"YAML syntax error: {getattr(exc, 'problem', None) or exc}"), source=source,
                        lines=[mark.line + 1 if mark else None]) from None
    if not isinstance(data, dict):
        raise DeckError(((), "a sweep file is a mapping (base:, axes:, reference:, metrics:)"), source=source, lines=[1])
    try:
        sweep = Sweep.model_validate(data)
    except ValidationError as exc:
        problems = []
        for e in exc.errors():
            # pydantic puts union-branch names into paths; keep only real keys and indices
            loc = tuple(k for k in e["loc"] if isinstance(k, int) or k in _keys_of(data, e["loc"]))
            msg = e["msg"].removeprefix("Value error, ")
            if msg.startswith("@"):  # located by the model validator
                where, msg = msg[1:].split("|", 1)
                loc = tuple(int(k) if k.isdigit() else k for k in where.split("."))
            if e["type"] == "extra_forbidden":
                msg = f"unknown key '{e['loc'][-1]}'"
            elif e["type"] == "union_tag_invalid":
                loc, ctx = loc + ("type",), e.get("ctx", {})
                msg = f"'{ctx.get('tag')}' is not one of {ctx.get('expected_tags')}"
            elif e["type"] == "missing":
                msg = "required key is missing"
            problems.append((loc, msg[0].lower() + msg[1:]))
        problems = list(dict.fromkeys(problems))
        raise DeckError(problems, source=source, lines=[_line_of(root, p) for p, _ in problems]) from None
    loaded = LoadedSweep(sweep, path)
    if not loaded.base.is_file():
        raise DeckError(((("base",), f"no deck at {loaded.base}"),), source=source, lines=[_line_of(root, ("base",))])
    return loaded


def _keys_of(data, loc) -> set:
    """Every string key met along `loc` in the data, plus the field names of the schema (so a
    missing required key is still named)."""
    keys = {name for m in (Sweep, Reference, SingleMaterial, Analytic, Curve, MaxRelError, PeriodError,
                           EnergyChange) for name in m.model_fields}
    node = data
    for k in loc:
        if isinstance(node, dict):
            keys.update(str(x) for x in node)
            node = node.get(k)
        elif isinstance(node, list) and isinstance(k, int) and 0 <= k < len(node):
            node = node[k]
    if isinstance(node, dict):
        keys.update(str(x) for x in node)
    return keys
