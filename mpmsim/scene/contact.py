"""The deck's `contact:` block (and the barrier settings of `implicit:`) resolved once: the
`ContactModel` every contact family reads.

- one law per material pair (`law`, `friction`): contact.default, overridden by the
  contact.pairs listing the pair (the last one wins);
- `friction`: the Coulomb friction between deformable materials (0 where the law is not
  coulomb), the table the FEM contact families read;
- each family's own settings, None where the scene does not use it: `grid` (the
  multi-velocity grid methods, mpmsim/contact/grid/spec.py), `augury` (APIC augury contact of FEM
  bodies), `barrier` (the implicit step's barrier contact).

This module and mpmsim/deck/contact.py (the deck's checks) are the only readers of the deck's
contact block; the families below the scene read the model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import linalg
from ..contact.augury.transfers import FRICTION, KERNELS, STICK_SEPARATE, AuguryGrid
from ..contact.grid.spec import (FIRST_PLUGIN_LAW, INTEGRATION_CODES, LAW_CODES, NORMAL_CODES, PERFECT,
                                 SEPARATION_CODES, ContactSpec)
from ..contact.cohesive import law_parameters, stiffnesses
from ..deck.contact import material_groups
from ..deck.semantics import body_name
from ..deck.schema import Implicit, Rigid


@dataclass(frozen=True)
class PairLaw:
    """The law between two materials."""

    law: str  # stick, frictionless, coulomb, none, interface
    friction: float  # kinetic friction (coulomb)
    static_friction: float  # -1 when not given
    stiffness: tuple  # interface [Dn tension, Dn compression, Dt], PERFECT = -1
    cohesive: object = None  # the deck's Cohesive block (law: cohesive)

    @property
    def code(self) -> int:
        return LAW_CODES[self.law]

    @property
    def coulomb(self) -> float:
        """The friction a frictional-contact family applies: `friction` under coulomb, else 0."""
        return self.friction if self.law == "coulomb" else 0.0


@dataclass(frozen=True)
class AugurySettings:
    """APIC augury contact (contact.augury), with its friction resolved per material."""

    grid: AuguryGrid
    iterations: int
    tau: float | None  # None: the time step
    mu_of_material: np.ndarray  # (n_deformable,) friction of an augury particle of each material
    rule: int  # augury.FRICTION or STICK_SEPARATE
    transfer: str
    kernel: str
    overlap_tolerance: float
    method: str = "augury"  # or "field" (contact/augury/fields.py)
    # the field method's law per deformable material pair: grid law codes, friction, static friction
    law: np.ndarray | None = None
    mu: np.ndarray | None = None
    mu_static: np.ndarray | None = None

    @property
    def cell_size(self) -> float:
        return self.grid.h

    def describe(self) -> str:
        if self.method == "field":
            return f"field contact (one velocity field per body), {self.kernel} grid of {self.cell_size:g}"
        return (f"{self.transfer.upper()} augury, {self.iterations} iteration(s), {self.kernel} grid of "
                f"{self.cell_size:g}")


@dataclass(frozen=True)
class BarrierSettings:
    """Barrier contact of the implicit step (implicit.dhat, kappa, friction settings)."""

    dhat: float | None  # None: no contact
    kappa: float | None  # the deck's; None: adaptive (contact/barrier/stiffness.py)
    friction_velocity: float
    friction_lags: int
    particle_contact: str  # centres or corners


@dataclass
class ContactModel:
    default: PairLaw
    pairs: list  # [(material a, material b, PairLaw)] in deck order
    friction: np.ndarray  # (n_deformable, n_deformable) Coulomb friction between deformable materials
    grid: ContactSpec | None  # the grid methods' groups, tables and settings; None: one velocity field
    augury: AugurySettings | None = None
    barrier: BarrierSettings | None = None

    def law(self, a: str, b: str) -> PairLaw:
        """The law between materials a and b."""
        found = self.default
        for m, n, law in self.pairs:
            if {m, n} == {a, b}:
                found = law
        return found


def pair_law(law) -> PairLaw:
    code = lambda v: PERFECT if v == "perfect" else float(v)  # noqa: E731
    dn, dt = code(law.Dn), code(law.Dt)
    c = law.cohesive if law.law == "cohesive" else None
    if c is not None and c.shape == "exponential":  # its intact stiffness follows from the law
        dn, dt = stiffnesses(law_parameters("exponential", c.peak_traction, c.shear_peak_traction, c.G_Ic, c.G_IIc))
    return PairLaw(law.law, float(law.friction), -1.0 if law.static_friction is None else float(law.static_friction),
                   (dn, dn if law.Dnc is None else code(law.Dnc), dt), c)


def build_contact_model(deck, materials, fem=None, particle_mats=()) -> ContactModel:
    """The model of a deck whose materials are resolved (`materials`); `fem`: the FEM bodies'
    seed, `particle_mats`: the deformable materials particles carry (the augury's particles)."""
    c = deck.contact
    default = pair_law(c.default)
    pairs = [(p.between[0], p.between[1], pair_law(p)) for p in c.pairs]
    deformable = materials.deformable
    index = {name: k for k, name in enumerate(deformable)}
    friction = np.full((len(deformable),) * 2, default.coulomb)
    for a, b, law in pairs:
        if a in index and b in index:
            friction[index[a], index[b]] = friction[index[b], index[a]] = law.coulomb
    model = ContactModel(default, pairs, friction, grid_spec(deck, materials, default, pairs))
    if fem is not None and c.augury is not None:
        model.augury = augury_settings(c.augury, model, materials, fem, particle_mats)
    if deck.integrator == "implicit":
        model.barrier = barrier_settings(deck)
    return model


def augury_settings(a, model: ContactModel, materials, fem, particle_mats) -> AugurySettings:
    """Each augury particle (FEM boundary node, surface particle) takes the law between its
    material and the other participating material when exactly two take part, else
    contact.default."""
    rule = STICK_SEPARATE if model.default.law == "stick" else FRICTION
    used = sorted(set(int(m) for m in fem.cell_mat) | set(int(m) for m in particle_mats))
    mu_of = np.full(len(materials.deformable), model.default.coulomb)
    if len(used) == 2:
        names = [materials.deformable[m] for m in used]
        for m, n, law in model.pairs:
            if {m, n} == set(names):
                mu_of[used] = law.coulomb
                if law.law == "stick":
                    rule = STICK_SEPARATE
    grid = AuguryGrid(float(a.cell_size), KERNELS[a.kernel], a.transfer == "apic" and a.method == "augury")
    laws = [[model.law(m, n) for n in materials.deformable] for m in materials.deformable]
    table = lambda f, dtype=float: np.array([[f(pl) for pl in row] for row in laws], dtype=dtype)  # noqa: E731
    return AugurySettings(grid, int(a.iterations), a.tau, mu_of, rule, a.transfer, a.kernel,
                          float(a.overlap_tolerance), a.method, table(lambda pl: pl.code, np.int64),
                          table(lambda pl: pl.friction), table(lambda pl: pl.static_friction))


def barrier_settings(deck) -> BarrierSettings:
    imp = deck.implicit if deck.implicit is not None else Implicit()
    return BarrierSettings(imp.dhat, imp.kappa, imp.friction_velocity, imp.friction_lags, imp.particle_contact)


def grid_spec(deck, materials, default: PairLaw, pairs: list) -> ContactSpec | None:
    """The grid methods' groups and tables; None when the scene has a single velocity field
    (nothing to contact)."""
    c = deck.contact
    groups = material_groups(deck, materials.deformable)
    n_def = max(groups) + 1 if groups else 0
    rigid_group = np.full(len(materials.rigid), -1, dtype=np.int64)
    names = ["+".join(m for m, g in zip(materials.deformable, groups) if g == k) for k in range(n_def)]
    for r, name in enumerate(materials.rigid):
        m = deck.materials[name]
        if isinstance(m, Rigid) and m.mode == "contact":
            rigid_group[r] = n_def + int((rigid_group >= 0).sum())
            names.append(name)
    n_groups = len(names)
    # materials only FEM bodies use meet through the augury contact, not the grid's fields
    fem_only = ({b.material for b in deck.bodies if b.discretization == "fem"}
                - {b.material for b in deck.bodies if b.discretization != "fem"})
    on_grid = {g for m, g in zip(materials.deformable, groups) if m not in fem_only} | \
        {int(g) for g in rigid_group if g >= 0}
    if n_groups < 2 or len(on_grid) < 2:
        return None
    rigid_of_group = np.full(n_groups, -1, dtype=np.int64)
    for r, g in enumerate(rigid_group):
        if g >= 0:
            rigid_of_group[g] = r
    group_of = {m: g for m, g in zip(materials.deformable, groups)}
    group_of.update({m: int(g) for m, g in zip(materials.rigid, rigid_group) if g >= 0})
    law = np.full((n_groups, n_groups), default.code, dtype=np.int64)
    mu = np.full((n_groups, n_groups), default.friction)
    mus = np.full((n_groups, n_groups), default.static_friction)
    stiff = np.zeros((n_groups, n_groups, 3))
    stiff[:, :] = default.stiffness
    for a_name, b_name, pl in pairs:
        a, b = group_of[a_name], group_of[b_name]
        for i, j in ((a, b), (b, a)):
            law[i, j] = pl.code
            mu[i, j] = pl.friction
            mus[i, j] = pl.static_friction
            stiff[i, j] = pl.stiffness
    from ..contact.cohesive_history import cohesive_table  # (here: that module's package imports the scene's)

    cohesive = []  # (group a, group b, the Cohesive block, Dn, Dt) of each cohesive group pair
    if default.cohesive is not None:
        cohesive += [(i, j, default.cohesive, *default.stiffness[::2]) for i in range(n_def) for j in range(i + 1, n_def)]
    for a_name, b_name, pl in pairs:
        if pl.cohesive is not None:
            cohesive.append((group_of[a_name], group_of[b_name], pl.cohesive, *pl.stiffness[::2]))
    sep = c.separation or ("logistic_regression" if c.normal == "logistic_regression" else "displacement")
    nv = np.zeros(3)
    if c.normal_vector is not None and any(c.normal_vector):
        nv[: len(c.normal_vector)] = c.normal_vector
        nv /= np.abs(nv).max()  # first to order one: the norm of (1e-300, 0) would underflow
        nv /= linalg.norm(nv)
    centre = np.zeros(3)
    if c.normal_center is not None:
        centre[: len(c.normal_center)] = c.normal_center
    return ContactSpec(n_groups, n_def, np.array(groups, dtype=np.int64), rigid_group, rigid_of_group, law, mu, mus,
                       stiff, NORMAL_CODES[c.normal], SEPARATION_CODES[sep], nv, c.rigid_bias, c.cutoff,
                       c.touch_tolerance, c.fit_exponent, c.passes, c.pass_3 != "keep", c.xpic_contact_term,
                       c.warm_start, c.cloud_weights == "shape_function", names, centre, c.normal_center is not None,
                       INTEGRATION_CODES[c.interface_integration], c.area_correction, c.h_perp,
                       c.edge_screening or 0.0, c.interface_bond == "consistent", c.interface_opening == "interface",
                       sep, tuple(sorted(int(k) for k in np.unique(law) if k >= FIRST_PLUGIN_LAW)),
                       deck.output.contact_traction, c.pass_3 == "persist",
                       cohesive_table(n_groups, cohesive) if cohesive else None)


def near(xa: np.ndarray, xb: np.ndarray, dist: float) -> np.ndarray:
    """Which of the points xa lie within dist of some point of xb (none if either is empty)."""
    if not len(xa) or not len(xb):
        return np.zeros(len(xa), dtype=bool)
    from scipy.spatial import cKDTree

    return cKDTree(xb).query(xa, k=1, distance_upper_bound=dist)[0] < dist


def untouched_pairs(deck, deformable: list[str], mat: np.ndarray, x: np.ndarray, h: float) -> list[tuple[tuple, str]]:
    """Deck problems: a cohesive law on a pair of materials whose particles lie nowhere within
    two cells of each other at the start (it would never bond, never act): one per `pairs`
    entry, and for a cohesive `default` only when none of its pairs touches."""

    def touch(a: str, b: str) -> bool:
        xa, xb = x[mat == deformable.index(a)], x[mat == deformable.index(b)]
        return bool(near(xa, xb, 2.0 * h).any())

    c, out = deck.contact, []
    listed = set()
    for i, pair in enumerate(c.pairs):
        a, b = pair.between
        listed.add(frozenset((a, b)))
        if pair.law == "cohesive" and a in deformable and b in deformable and not touch(a, b):
            out.append((("contact", "pairs", i, "between"), f"'{a}' and '{b}' are bonded by a cohesive law but their "
                        "particles are nowhere within two cells of each other at the start"))
    if c.default.law == "cohesive":
        pairs = [(a, b) for k, a in enumerate(deformable) for b in deformable[k + 1:]
                 if frozenset((a, b)) not in listed]
        if pairs and not any(touch(a, b) for a, b in pairs):
            out.append((("contact", "default", "law"), "a cohesive default law, but no two materials' particles are "
                        "within two cells of each other at the start"))
    return out


def inverted_normals(deck, deformable: list[str], mat: np.ndarray, x: np.ndarray, h: float) -> list[str]:
    """Notices: a specified normal (vector or radial) that points, across a cohesive pair's
    interface, from the higher-numbered material into the lower (it points from the lower to the
    higher): the law would read every opening as compression and never soften. Judged from the
    pair's particles within two cells of each other at the start."""
    c = deck.contact
    if c.normal != "specified":
        return []
    pairs = {frozenset(p.between): p.law for p in c.pairs}
    out = []
    for k, a in enumerate(deformable):
        for b in deformable[k + 1:]:
            if pairs.get(frozenset((a, b)), c.default.law) != "cohesive":
                continue
            xa, xb = x[mat == k], x[mat == deformable.index(b)]
            near_a, near_b = xa[near(xa, xb, 2.0 * h)], xb[near(xb, xa, 2.0 * h)]
            if not len(near_a) or not len(near_b):
                continue
            if c.normal_center is not None:
                centre = np.asarray(c.normal_center, dtype=float)
                along = lambda y: np.linalg.norm(y - centre, axis=1)  # noqa: E731
                key = "normal_center"
            else:
                n = np.asarray(c.normal_vector, dtype=float)
                along = lambda y: y @ (n / np.linalg.norm(n))  # noqa: E731
                key = "normal_vector"
            if along(near_a).mean() > along(near_b).mean():
                out.append(f"contact.{key}: the specified normal points from '{a}' to '{b}' (from the material "
                           f"listed first to the other), but '{a}' lies beyond '{b}' along it: their cohesive law "
                           f"would read every opening as compression; list '{b}' first or reverse the normal")
    return out


# a round body moving into frictional grid contact with fewer cells across its radius is
# warned about (docs/contact.md, "Resolve the contact patch"; the oblique cylinder's rows in
# docs/contact-methods.md: vx within 2% of the continuum from R/h = 40)
RESOLVED_RADIUS_CELLS = 40.0


def patch_resolution_notices(deck, h: float) -> list[str]:
    """Notices: a circle or sphere of particles that moves at the start, in an explicit deck
    whose contact law for its material is Coulomb, with radius / h under RESOLVED_RADIUS_CELLS.
    An impact's contact patch is then under a cell wide, the nodes beside it carry its force,
    and their moment acts as a rolling resistance."""
    if deck.integrator == "implicit":
        return []
    c = deck.contact
    out = []
    for i, b in enumerate(deck.bodies):
        if b.discretization != "particles" or getattr(b, "shape", None) not in ("circle", "sphere"):
            continue
        v = b.velocity
        if v is None or (isinstance(v, (list, tuple)) and not any(v)):
            continue
        laws = [c.default.law] + [p.law for p in c.pairs if b.material in p.between]
        if "coulomb" not in laws:
            continue
        cells = b.radius / h
        if cells < RESOLVED_RADIUS_CELLS:
            out.append(f"bodies.{i}: '{body_name(b, i)}' is a {b.shape} of radius {cells:.3g} cells moving into "
                       "frictional contact: an impact's contact patch is then under a cell wide and the nodes "
                       "beside it, which carry its force, act as a rolling resistance (a cylinder struck "
                       "obliquely with friction 0.3 rebounds 16%, 5% and 0.3% off the continuum in vx at "
                       f"10, 20 and 40 cells); use {RESOLVED_RADIUS_CELLS:.0f} or more cells across the radius "
                       "where the rebound matters (docs/contact.md, \"Resolve the contact patch\")")
    return out
