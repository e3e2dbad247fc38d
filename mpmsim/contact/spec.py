"""From the deck to what the contact kernels need: material groups, a group law table, and
method codes.

A *group* is one velocity field. Deformable materials joined by law `none` (perfect
interface, "the same body") form one group; every rigid contact material is a group of its
own. Contact work happens only where two or more groups meet.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..deck.schema import Deck, Rigid

STICK, FRICTIONLESS, COULOMB, INTERFACE = 0, 1, 2, 3
LAW_CODES = {"stick": STICK, "frictionless": FRICTIONLESS, "coulomb": COULOMB, "none": STICK, "interface": INTERFACE}
PERFECT = -1.0  # interface stiffness code for a perfect direction
OSCILLATOR, FORCE_LIMIT, FIRST_ORDER, TRAPEZOIDAL, BACKWARD_EULER = 0, 1, 2, 3, 4
INTEGRATION_CODES = {"oscillator": OSCILLATOR, "force_limit": FORCE_LIMIT, "first_order": FIRST_ORDER,
                     "trapezoidal": TRAPEZOIDAL, "backward_euler": BACKWARD_EULER}

LOGISTIC, LINEAR_REGRESSION, AVERAGE_GRADIENT, MAX_GRADIENT, MAX_VOLUME, SPECIFIED = range(6)
NORMAL_CODES = {"logistic_regression": LOGISTIC, "linear_regression": LINEAR_REGRESSION,
                "average_gradient": AVERAGE_GRADIENT, "max_gradient": MAX_GRADIENT, "max_volume": MAX_VOLUME,
                "specified": SPECIFIED}
SEP_LR, SEP_DISPLACEMENT, SEP_CUTOFF, SEP_FIT, SEP_VELOCITY = range(5)
SEPARATION_CODES = {"logistic_regression": SEP_LR, "displacement": SEP_DISPLACEMENT, "cutoff": SEP_CUTOFF,
                    "fit": SEP_FIT, "velocity": SEP_VELOCITY}
MAX_GROUPS = 64  # node group sets are 64-bit masks


class PairLaws(NamedTuple):
    """Group-by-group tables of the contact laws."""

    law: np.ndarray  # (G, G) law code
    mu: np.ndarray  # (G, G) kinetic friction
    mus: np.ndarray  # (G, G) static friction, -1 when not given
    stiffness: np.ndarray  # (G, G, 3) interface [Dn tension, Dn compression, Dt], PERFECT = -1


class Wants(NamedTuple):
    """Which per-slot sums the scene's contact methods read (fields.scatter_slot_extras)."""

    disp: bool  # mass-weighted displacement (displacement separation)
    pos: bool  # mass-weighted position (CP cutoff, DF fit)
    grad: bool  # volume gradient (gradient normals)
    open: bool  # interface openings
    carry: bool  # openings carried to the interface point (else at the node)


class Method(NamedTuple):
    """How the geometry and the passes work, as kernel parameters."""

    normal: int  # normal method code
    separation: int  # separation method code
    normal_vec: np.ndarray  # (3,) specified normal
    radial: bool  # specified normal radial from `centre`
    centre: np.ndarray  # (3,)
    rigid_bias: float
    cutoff: float  # CP cutoff, cells
    fit_r: float  # DF fit exponent
    spline: bool  # B-spline grid functions weight the contact area with the spline
    warm: bool  # logistic regression warm-started from the last fit
    integration: int  # interface integrator code
    area_correction: bool
    use_h_perp: bool
    screen: float  # edge-screening volume (0: off)
    touch: float  # touching tolerance, a length
    h_min: float  # smallest cell edge


@dataclass
class ContactSpec:
    n_groups: int
    n_def_groups: int  # deformable groups are 0..n_def_groups-1, rigid contact groups follow
    mat_group: np.ndarray  # (n_deformable_materials,) group of each deformable material
    rigid_group: np.ndarray  # (n_rigid_materials,) group of each rigid material, -1 for velocity-BC ones
    rigid_of_group: np.ndarray  # (n_groups,) rigid material index of a rigid group, -1 otherwise
    law: np.ndarray  # (G, G) law code
    mu: np.ndarray  # (G, G) kinetic friction
    mu_static: np.ndarray  # (G, G) static friction, -1 when not given
    stiffness: np.ndarray  # (G, G, 3) interface [Dn tension, Dn compression, Dt], PERFECT = -1
    normal: int
    separation: int
    normal_vector: np.ndarray  # (3,)
    rigid_bias: float
    cutoff: float
    touch: float  # touching tolerance, cells
    fit_exponent: float
    passes: int
    recheck: bool  # pass 3 recomputes the geometry and re-tests contact (the reference code's passes)
    xpic_term: bool
    warm_start: bool
    shape_weights: bool  # point-cloud regression weights: shape function at the node (else 1)
    group_names: list[str]
    normal_center: np.ndarray  # (3,) centre of a radial specified normal
    radial: bool
    interface_integration: int
    area_correction: bool
    use_h_perp: bool
    edge_screening: float  # fraction of a cell's volume; 0: off
    consistent_bond: bool  # bonded normals held where the interface crosses grid edges (contact.bond)
    opening_at_interface: bool  # interface openings carried to the interface point (else: at the node)

    def laws(self) -> PairLaws:
        return PairLaws(self.law, self.mu, self.mu_static, self.stiffness)

    def method(self, h_min: float, spline: bool, screen: float) -> Method:
        """The kernels' parameters for a grid of smallest cell edge h_min."""
        return Method(self.normal, self.separation, self.normal_vector, self.radial, self.normal_center,
                      self.rigid_bias, self.cutoff, self.fit_exponent, spline, self.warm_start,
                      self.interface_integration, self.area_correction, self.use_h_perp, screen, self.touch * h_min,
                      h_min)

    def wants(self) -> Wants:
        return Wants(self.needs_displacement, self.needs_position, self.needs_gradients, self.has_interface,
                     self.opening_at_interface)

    @property
    def has_interface(self) -> bool:
        return bool((self.law == INTERFACE).any())

    @property
    def needs_gradients(self) -> bool:
        return self.normal in (AVERAGE_GRADIENT, MAX_GRADIENT, MAX_VOLUME) or (
            self.normal == LOGISTIC and self.rigid_bias >= 10.0)

    @property
    def needs_cloud(self) -> bool:
        return self.normal in (LOGISTIC, LINEAR_REGRESSION) or self.separation == SEP_LR

    @property
    def needs_displacement(self) -> bool:
        return self.separation == SEP_DISPLACEMENT

    @property
    def needs_position(self) -> bool:
        return self.separation in (SEP_CUTOFF, SEP_FIT)


def _find(parent, a):
    while parent[a] != a:
        parent[a] = parent[parent[a]]
        a = parent[a]
    return a


def material_groups(deck: Deck, deformable: list[str]) -> list[int]:
    """Group index per deformable material: union of the pairs whose law is `none`."""
    c = deck.contact
    parent = list(range(len(deformable)))
    if c.default.law == "none":
        parent = [0] * len(deformable)
    for pair in c.pairs:
        a, b = pair.between
        if pair.law == "none" and a in deformable and b in deformable:
            ra, rb = _find(parent, deformable.index(a)), _find(parent, deformable.index(b))
            parent[ra] = rb
    roots = [_find(parent, i) for i in range(len(deformable))]
    order = sorted(set(roots), key=roots.index)
    return [order.index(r) for r in roots]


def build_contact_spec(deck: Deck, materials) -> ContactSpec | None:
    """None when the scene has a single velocity field (nothing to contact)."""
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
    law = np.full((n_groups, n_groups), LAW_CODES[c.default.law], dtype=np.int64)
    mu = np.full((n_groups, n_groups), c.default.friction)
    mus = np.full((n_groups, n_groups), -1.0 if c.default.static_friction is None else c.default.static_friction)
    stiff = np.zeros((n_groups, n_groups, 3))
    stiff[:, :] = interface_stiffness(c.default)
    for pair in c.pairs:
        a, b = (group_of[m] for m in pair.between)
        for i, j in ((a, b), (b, a)):
            law[i, j] = LAW_CODES[pair.law]
            mu[i, j] = pair.friction
            mus[i, j] = -1.0 if pair.static_friction is None else pair.static_friction
            stiff[i, j] = interface_stiffness(pair)
    sep = c.separation or ("logistic_regression" if c.normal == "logistic_regression" else "displacement")
    nv = np.zeros(3)
    if c.normal_vector is not None and any(c.normal_vector):
        nv[: len(c.normal_vector)] = c.normal_vector
        nv /= np.abs(nv).max()  # first to order one: the norm of (1e-300, 0) would underflow
        nv /= np.linalg.norm(nv)
    centre = np.zeros(3)
    if c.normal_center is not None:
        centre[: len(c.normal_center)] = c.normal_center
    return ContactSpec(n_groups, n_def, np.array(groups, dtype=np.int64), rigid_group, rigid_of_group, law, mu, mus,
                       stiff, NORMAL_CODES[c.normal], SEPARATION_CODES[sep], nv, c.rigid_bias, c.cutoff,
                       c.touch_tolerance, c.fit_exponent, c.passes, c.pass_3 == "recheck", c.xpic_contact_term,
                       c.warm_start, c.cloud_weights == "shape_function", names, centre, c.normal_center is not None,
                       INTEGRATION_CODES[c.interface_integration], c.area_correction, c.h_perp,
                       c.edge_screening or 0.0, c.interface_bond == "consistent", c.interface_opening == "interface")


def interface_stiffness(law) -> tuple[float, float, float]:
    """[Dn tension, Dn compression, Dt] with PERFECT for 'perfect'; Dnc defaults to Dn."""
    code = lambda v: PERFECT if v == "perfect" else float(v)
    dn = code(law.Dn)
    return dn, dn if law.Dnc is None else code(law.Dnc), code(law.Dt)


def check_contact(deck: Deck, deformable: list[str]) -> list[tuple[tuple, str]]:
    """Deck problems in the contact block (called by the deck semantics)."""
    problems = []
    c = deck.contact
    for i, pair in enumerate(c.pairs):
        for j, m in enumerate(pair.between):
            if m not in deck.materials:
                problems.append((("contact", "pairs", i, "between", j), f"no material named '{m}'"))
        if len(set(pair.between)) == 1:
            problems.append((("contact", "pairs", i, "between"), "a pair needs two different materials"))
    for path, law in [(("contact", "default"), c.default)] + [(("contact", "pairs", i), p) for i, p in enumerate(c.pairs)]:
        if law.static_friction is not None and law.static_friction < law.friction:
            problems.append(((*path, "static_friction"), f"static friction {law.static_friction} is below the "
                                                         f"kinetic friction {law.friction}"))
    if problems:
        return problems
    if c.normal == "specified":
        if c.normal_center is not None:
            if len(c.normal_center) != deck.dim:
                problems.append((("contact", "normal_center"), f"needs {deck.dim} components"))
        elif c.normal_vector is None:
            problems.append((("contact", "normal_vector"), "normal: specified needs normal_vector or normal_center"))
        elif len(c.normal_vector) != deck.dim or not any(c.normal_vector):
            problems.append((("contact", "normal_vector"), f"needs {deck.dim} components, not all zero"))
    # materials merged by `none` must not disagree about a third material's law
    groups = material_groups(deck, deformable)
    n_rigid_contact = sum(1 for m in deck.materials.values() if isinstance(m, Rigid) and m.mode == "contact")
    if (max(groups) + 1 if groups else 0) + n_rigid_contact > MAX_GROUPS:
        problems.append((("materials",), f"at most {MAX_GROUPS} contact groups (materials not joined by law none)"))
    seen: dict[tuple, tuple] = {}
    group_of = dict(zip(deformable, groups))
    for i, pair in enumerate(c.pairs):
        a, b = pair.between
        if pair.law == "none" or a not in group_of or b not in group_of:
            continue
        key = tuple(sorted((group_of[a], group_of[b])))
        val = (pair.law, pair.friction, pair.static_friction, pair.Dn, pair.Dnc, pair.Dt)
        if key[0] == key[1]:
            problems.append((("contact", "pairs", i), f"'{a}' and '{b}' are one body (joined by law none); "
                                                      "they cannot also have a contact law"))
        elif key in seen and seen[key][1] != val:
            problems.append((("contact", "pairs", i), f"conflicts with pairs {seen[key][0]}: materials joined by "
                                                      "law none must share one law with each other material"))
        seen.setdefault(key, (i, val))
    return problems
