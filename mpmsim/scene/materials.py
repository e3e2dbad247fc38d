"""The deck's materials resolved into the table the kernels take (mpmsim/materials)."""

from __future__ import annotations

import numpy as np

from ..deck.schema import (CompressibleNeoHookean, Deck, LinearElastic, MieGruneisen, NeoHookean, Rigid,
                           TransverselyIsotropic, VelocityTable)
from ..materials import (ANISOTROPIC, COMPRESSIBLE_NH, LINEAR_ELASTIC, MIE_GRUNEISEN, NEO_HOOKEAN, NPROP,
                         MaterialTable, RigidMotion, transversely_isotropic_compliance)


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
        density[k] = m.density
        if isinstance(m, LinearElastic):
            lam = m.E * m.nu / ((1 + m.nu) * (1 - 2 * m.nu))
            mu = m.E / (2 * (1 + m.nu))
            codes[k], props[k, :4] = LINEAR_ELASTIC, (lam, mu, m.E, m.nu)
        elif isinstance(m, CompressibleNeoHookean):
            lam = m.E * m.nu / ((1 + m.nu) * (1 - 2 * m.nu))
            mu = m.E / (2 * (1 + m.nu))
            codes[k], props[k, :4] = COMPRESSIBLE_NH, (lam, mu, m.E, m.nu)
        elif isinstance(m, NeoHookean):
            codes[k], props[k, :2] = NEO_HOOKEAN, (m.K, m.G)
        elif isinstance(m, TransverselyIsotropic):
            S = transversely_isotropic_compliance(m.EA, m.ET, m.GA, m.nuA, m.nuT, m.axis)
            codes[k] = ANISOTROPIC
            props[k, :36] = np.linalg.inv(S).ravel()
            props[k, 36:] = S.ravel()
        elif isinstance(m, MieGruneisen):
            codes[k], props[k, :4] = MIE_GRUNEISEN, (m.K, m.G, m.gamma0, m.S1)
        else:  # pragma: no cover
            raise TypeError(type(m))
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
    energy = (codes == MIE_GRUNEISEN) | (av.sum(axis=1) > 0.0)
    rigid_bc = [deck.materials[n].mode == "bc" for n in rigid]
    return MaterialTable(names, deformable, rigid, codes, props, density, motions, constrain, av, energy, rigid_bc)
