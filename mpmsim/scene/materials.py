"""The deck's materials resolved into the table the kernels take: each deformable material's
model code and property row from its registered model (mpmsim/materials/model.py)."""

from __future__ import annotations

import numpy as np

from ..deck.schema import Deck, Rigid, VelocityTable
from ..materials import NPROP, MaterialTable, RigidMotion
from ..materials.model import model_for


def build_material_table(deck: Deck) -> MaterialTable:
    dim = deck.dim
    names = list(deck.materials)
    deformable = [n for n in names if not isinstance(deck.materials[n], Rigid)]
    rigid = [n for n in names if isinstance(deck.materials[n], Rigid)]
    codes = np.zeros(len(deformable), dtype=np.int64)
    props = np.zeros((len(deformable), NPROP))
    density = np.zeros(len(deformable))
    for k, n in enumerate(deformable):
        m = deck.materials[n]
        model = model_for(m)
        density[k] = m.density
        codes[k], props[k] = model.code, model.row(m)
    motions, constrain = [], np.zeros((len(rigid), dim), dtype=np.bool_)
    for k, n in enumerate(rigid):
        m = deck.materials[n]
        if isinstance(m.velocity, VelocityTable):
            motion = RigidMotion(np.array(m.velocity.times, float), np.array(m.velocity.values, float))
        else:
            v = np.zeros(dim)
            v[: min(dim, len(m.velocity))] = m.velocity[:dim]
            motion = RigidMotion(np.array([0.0]), v[None, :])
        motions.append(motion)
        if m.mode == "contact":  # acts only through contact: constrains no node
            continue
        axes = m.constrain if m.constrain is not None else list("xyz"[:dim])
        for a in axes:
            constrain[k, "xyz".index(a)] = True
    av = np.zeros((len(deformable), 2))
    if deck.artificial_viscosity is not None:
        spec = deck.artificial_viscosity
        for k, n in enumerate(deformable):
            if spec.materials is None or n in spec.materials:
                av[k] = (spec.A1, spec.A2)
    own_eos = np.array([model_for(deck.materials[n]).internal_energy for n in deformable], dtype=bool)
    energy = own_eos | (av.sum(axis=1) > 0.0)
    rigid_bc = [deck.materials[n].mode == "bc" for n in rigid]
    state0, fields, dissipations = material_state(deck, deformable)
    return MaterialTable(names, deformable, rigid, codes, props, density, motions, constrain, av, energy, rigid_bc,
                         state0, fields, dissipations)


def material_state(deck: Deck, deformable: list[str]) -> tuple[np.ndarray, dict, dict]:
    """Each deformable material's initial material state row (padded to the widest), and
    {name: (n,) slot, -1 where absent} of the VTU fields and the dissipated energies its model
    takes from the state (mpmsim/materials/model.py)."""
    n = len(deformable)
    entries = [deck.materials[name] for name in deformable]
    models = [model_for(m) for m in entries]
    rows = [tuple(m.state(e) if callable(m.state) else m.state) for m, e in zip(models, entries)]
    state0 = np.zeros((n, max((len(r) for r in rows), default=0)))
    fields: dict[str, np.ndarray] = {}
    dissipations: dict[str, np.ndarray] = {}
    for k, (m, e, r) in enumerate(zip(models, entries, rows)):
        state0[k, :len(r)] = r
        out = m.state_output(e) if callable(m.state_output) else m.state_output
        for table, names in ((fields, out), (dissipations, m.dissipation)):
            for name, slot in names.items():
                table.setdefault(name, np.full(n, -1, dtype=np.int64))[k] = slot
    return state0, fields, dissipations
