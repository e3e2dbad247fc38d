"""What a material model is, and the registry of them.

A model is one module (mpmsim/materials/linear_elastic.py, neo_hookean.py, ...) that defines
everything about it and registers a `MaterialModel`:

- `schema`: its deck entry (a pydantic model with `type: Literal["<name>"]`); the deck's
  `materials:` accept every registered model;
- `row`: the property row the kernels read (NPROP floats) from a deck entry;
- `wave_modulus`: rho c^2 of the material at rest (first time step, energy round-off scale);
- `stress_2d`, `stress_3d`: the MPM stress update, compiled functions with one signature
  (pr, L, dt, F3, J, f00, f01, f10, f11, s, W, A, Ai, Q, eos, hs) -> wave modulus; pr the row,
  L the velocity gradient (3x3), F3 the new deformation gradient (3x3, F33 = 1 in 2D), J its
  determinant, f00..f11 its in-plane entries (2D), s the particle's stress (Voigt, updated in
  place), W, A, Ai, Q 3x3 scratch, eos the internal-energy row (mpmsim/materials/kernels.py),
  hs the particle's material state row (below; updated in place); None where the model has
  no explicit MPM form;
- `energy`: strain energy per current volume (pr, F3, s, J) (compiled);
- `bulk_modulus`: tangent bulk modulus J dp/deta (pr, J, p) for the artificial viscosity
  (compiled);
- flags the stress kernel compiles in: `internal_energy` (the model updates U and p itself,
  an equation of state), `reads_L_2d`, `reads_F3_2d` (its 2D update reads L or F3, else
  only J and f00..f11);
- `fem`: the model has the FEM forms (energy, first Piola stress, tangent) that FEM bodies
  and implicit particles use (mpmsim/fem/elements.py dispatches on the built-in codes);
- `check`: deck checks of an entry, (entry, dim) -> [(key, message)];
- per-particle material state (history variables): `state`, the initial row of the floats
  each particle of the model carries, or a function of the deck entry that gives it (its
  length is the width the model asks for; a scene's particles carry the widest row its
  models ask for, none when no model asks); the stress update reads and updates it (`hs`);
  `state_output`: VTU point fields the output takes from it, {name: slot} (or a function of
  the deck entry giving that); `dissipation`: history totals of energy dissipated, {name: slot
  of the energy per unit mass}, summed as sum m_p hs[slot] and booked by the energy ledger;
- `variant`: a function of the deck entry naming another registered model (sharing this one's
  schema) that runs that entry instead, or None (`model_for`): one deck type whose entries
  need different kernel flags (an equation of state that tracks internal energy).

`register(model)` gives a model its type code and adds its schema to the deck's; the built-in
models keep the codes the kernels and tests name. An unknown code is an error
(`model_of`), never a fallback.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable

NPROP = 72  # property row length
# the built-in models' codes (tests and the FEM element kernels name them)
LINEAR_ELASTIC, NEO_HOOKEAN, MIE_GRUNEISEN, ANISOTROPIC, COMPRESSIBLE_NH, J2_PLASTICITY, J2_MIE_GRUNEISEN = range(7)
FIRST_PLUGIN_CODE = 16  # codes of models registered outside mpmsim start here


@dataclass(frozen=True)
class MaterialModel:
    name: str
    schema: type
    row: Callable
    wave_modulus: Callable
    energy: Callable
    bulk_modulus: Callable
    stress_2d: Callable | None = None
    stress_3d: Callable | None = None
    internal_energy: bool = False
    reads_L_2d: bool = True
    reads_F3_2d: bool = True
    fem: bool = False
    check: Callable | None = None
    code: int = -1
    tag: str = ""  # names the model's compiled kernels (its module's source digest for plugins)
    extra: dict = field(default_factory=dict)
    state: tuple | Callable = ()
    state_output: dict | Callable = field(default_factory=dict)
    dissipation: dict = field(default_factory=dict)
    variant: Callable | None = None  # deck entry -> the name of the registered model that runs it, or None

    def stress(self, dim: int) -> Callable | None:
        return self.stress_2d if dim == 2 else self.stress_3d


MODELS: dict[str, MaterialModel] = {}
_BY_CODE: dict[int, MaterialModel] = {}


def register(model: MaterialModel, code: int | None = None) -> MaterialModel:
    """Add a model (a built-in gives its fixed code; others get the next free one from
    FIRST_PLUGIN_CODE) and make the deck schema accept it. Registering a name again replaces
    that model."""
    import inspect
    import hashlib

    old = MODELS.get(model.name)
    if code is None:
        code = old.code if old is not None else max([FIRST_PLUGIN_CODE - 1, *_BY_CODE]) + 1
    tag = model.tag
    if not tag:  # a digest of the defining module: an edited model compiles anew
        src = inspect.getsourcefile(getattr(model.energy, "py_func", model.energy)) or ""
        digest = hashlib.sha1(open(src, "rb").read()).hexdigest()[:8] if src else "0"
        tag = f"{model.name}_{digest}"
    model = replace(model, code=code, tag=tag)
    MODELS[model.name] = model
    _BY_CODE[code] = model
    import sys

    schema = sys.modules.get("mpmsim.deck.schema")
    if schema is not None and hasattr(schema, "rebuild_materials"):  # (else: it builds the union when loaded)
        schema.rebuild_materials()
    return model


def model_of(code: int) -> MaterialModel:
    try:
        return _BY_CODE[int(code)]
    except KeyError:
        raise KeyError(f"no material model has type code {code}") from None


def model_named(name: str) -> MaterialModel:
    return MODELS[name]


def model_for(entry) -> MaterialModel:
    """The model that runs a deck entry: its type's, or the variant that type names for it (a
    J2 entry with a Mie-Grüneisen `eos` runs the model whose kernel tracks internal energy)."""
    model = MODELS[entry.type]
    name = model.variant(entry) if model.variant is not None else None
    return MODELS[name] if name else model


def schemas() -> list[type]:
    """The deck entries of the registered models, each once (a variant shares its type's)."""
    return list(dict.fromkeys(m.schema for m in MODELS.values()))
