"""Rules of the deck's contact block that the deck's semantics check and the scene resolves:
which deformable materials form one group (joined by law `none`), and the checks of the
pairs and the normal settings."""

from __future__ import annotations

import difflib

from .schema import Deck, Rigid


def no_material(name: str, materials) -> str:
    """The message for a material name the deck does not define, with the closest name or
    the list of names."""
    close = difflib.get_close_matches(str(name), list(materials), n=1, cutoff=0.6)
    hint = f"did you mean '{close[0]}'?" if close else f"materials: {', '.join(materials)}"
    return f"no material named '{name}' ({hint})"

MAX_GROUPS = 64  # node group sets are 64-bit masks


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


def check_contact(deck: Deck, deformable: list[str]) -> list[tuple[tuple, str]]:
    """Deck problems in the contact block (called by the deck semantics)."""
    problems = []
    c = deck.contact
    for i, pair in enumerate(c.pairs):
        for j, m in enumerate(pair.between):
            if m not in deck.materials:
                problems.append((("contact", "pairs", i, "between", j), no_material(m, deck.materials)))
        if len(set(pair.between)) == 1:
            problems.append((("contact", "pairs", i, "between"), "a pair needs two different materials"))
    for path, law in [(("contact", "default"), c.default)] + [(("contact", "pairs", i), p) for i, p in enumerate(c.pairs)]:
        problems += cohesive_problems(path, law)
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


def cohesive_problems(path: tuple, law) -> list[tuple[tuple, str]]:
    """A cohesive law's block present exactly with law cohesive; the bilinear law's finite
    stiffnesses, stiff enough for its triangle (K > peak^2 / (2 G_c))."""
    c = law.cohesive
    if law.law != "cohesive":
        return [((*path, "cohesive"), f"a cohesive block needs law: cohesive (the law is {law.law})")] if c else []
    if c is None:
        return [((*path, "cohesive"), "law cohesive needs a cohesive block {peak_traction, G_Ic, ...}")]
    out = []
    if c.shape == "bilinear":
        for key, peak, G in (("Dn", c.peak_traction, c.G_Ic), ("Dt", c.shear_peak_traction, c.G_IIc)):
            K = getattr(law, key)
            if K == "perfect":
                out.append(((*path, key), "a bilinear cohesive law needs a finite intact stiffness (stress/length)"))
            elif float(K) <= peak * peak / (2.0 * G):
                out.append(((*path, key), f"{K:g} is too soft for the law: the peak traction {peak:g} and toughness "
                                          f"{G:g} need a stiffness above peak^2 / (2 G_c) = {peak * peak / (2 * G):g}"))
    if c.after == "frictionless" and c.friction > 0:
        out.append(((*path, "cohesive", "friction"), "friction after failure needs after: coulomb"))
    for k, box in enumerate(c.precrack):
        if len(box.min) != len(box.max) or any(lo >= hi for lo, hi in zip(box.min, box.max)):
            out.append(((*path, "cohesive", "precrack", k), "a pre-crack box needs as many components in min as in "
                        "max, each below its max"))
    return out
