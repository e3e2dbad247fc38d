"""The deck's materials resolved into the table the kernels take: each deformable material's
model code and property row from its registered model (mpmsim/materials/model.py)."""

from __future__ import annotations

import numpy as np

from ..deck.schema import Deck, Rigid, VelocityTable
from ..materials import MODELS, NPROP, MaterialTable, RigidMotion


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
        model = MODELS[m.type]
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
    own_eos = np.array([MODELS[deck.materials[n].type].internal_energy for n in deformable], dtype=bool)
    energy = own_eos | (av.sum(axis=1) > 0.0)
    rigid_bc = [deck.materials[n].mode == "bc" for n in rigid]
    rows = [MODELS[deck.materials[n].type].state for n in deformable]
    state0 = np.zeros((len(deformable), max((len(r) for r in rows), default=0)))
    for k, r in enumerate(rows):
        state0[k, :len(r)] = r
    return MaterialTable(names, deformable, rigid, codes, props, density, motions, constrain, av, energy, rigid_bc,
                         state0)
