"""Checks that span several keys or depend on the analysis dimension.

Each check returns (key path, message) pairs; the loader adds the YAML line.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..materials.model import MODELS
from .schema import (SHAPES_2D, SHAPES_3D, Deck, Image, Rigid, RotationVelocity, SineVelocity,
                     VelocityTable)
from .contact import no_material
from .units import MAX_WAVE_SPEED, unit_system

FIELD_LAWS = ("frictionless", "coulomb", "stick", "none")  # the laws augury field contact applies


AXISYMMETRIC_SHAPES = ("linear", "gimp")  # shape functions with an r-z form (mpmsim/shapes/axisymmetric.py)


def _check_axisymmetric(deck: Deck) -> list[tuple[tuple, str]]:
    """What an axisymmetric deck (x = r >= 0, y = z) cannot ask for: one line each, naming the key."""
    out = []
    add = lambda path, msg: out.append((tuple(path), msg))  # noqa: E731
    if deck.integrator != "explicit":
        add(["integrator"], "axisymmetric analysis runs the explicit MPM step; the implicit integrator is plane "
                            "strain or 3d only")
    for i, b in enumerate(deck.bodies):
        if b.discretization == "fem":
            add(["bodies", i, "discretization"], "axisymmetric analysis takes particle bodies; FEM bodies are plane "
                                                 "strain or 3d only")
    if deck.shape_function not in AXISYMMETRIC_SHAPES:
        add(["shape_function"], f"axisymmetric analysis takes shape_function {' or '.join(AXISYMMETRIC_SHAPES)} "
                                f"(their r-weighted forms), not {deck.shape_function}")
    if "thickness" in deck.model_fields_set:
        add(["thickness"], "axisymmetric masses, volumes and forces are per radian: thickness does not apply")
    if deck.grid is not None and deck.grid.domain is not None and deck.grid.domain.min and deck.grid.domain.min[0] < 0:
        add(["grid", "domain", "min", 0], f"x is the radius r in axisymmetric analysis: the domain starts at r >= 0, "
                                          f"not {deck.grid.domain.min[0]:g}")
    if deck.gravity is not None and len(deck.gravity) == 2 and deck.gravity[0] != 0:
        add(["gravity", 0], "gravity along r breaks the axial symmetry: give [0, g_z]")
    return out


def check_deck(deck: Deck, base_dir: Path) -> list[tuple[tuple, str]]:
    problems: list[tuple[tuple, str]] = []
    add = lambda path, msg: problems.append((tuple(path), msg))  # noqa: E731
    if deck.analysis == "axisymmetric":
        problems += _check_axisymmetric(deck)
    dim = deck.dim
    axes = "xyz"[:dim]

    def vec(path, v, n=dim, what="vector"):
        if v is not None and len(v) != n:
            add(path, f"{what} needs {n} components for {deck.analysis} analysis, got {len(v)}")

    fem = [i for i, b in enumerate(deck.bodies) if b.discretization == "fem"]
    particle_bodies = [i for i, b in enumerate(deck.bodies) if b.discretization == "particles"]
    if particle_bodies and deck.grid is None:
        add(["grid"], f"particle bodies (bodies.{particle_bodies[0]}) need the background grid: give grid.cell_size")
        return problems
    if deck.contact.augury is not None and (not fem or len(fem) + len(particle_bodies) < 2):
        add(["contact", "augury"], "augury contact acts between an FEM body (discretization: fem) and other FEM or "
                                   f"particle bodies; the deck has {len(fem)} FEM and {len(particle_bodies)} particle "
                                   "bodies")
    a = deck.contact.augury
    if a is not None and a.method == "field":
        for path, law in [(["contact", "default", "law"], deck.contact.default.law)] + \
                [(["contact", "pairs", k, "law"], p.law) for k, p in enumerate(deck.contact.pairs)]:
            if law not in FIELD_LAWS:
                add(path, f"augury contact by method field takes the laws {', '.join(FIELD_LAWS)}, not '{law}'")
    problems += _check_fem_bodies(deck, fem, base_dir)
    if fem or deck.integrator == "implicit":
        for path, law in [(["contact", "default", "law"], deck.contact.default.law)] + \
                [(["contact", "pairs", k, "law"], p.law) for k, p in enumerate(deck.contact.pairs)]:
            if law == "cohesive":
                add(path, "cohesive interfaces act between particle bodies in the explicit step (no FEM bodies, "
                          "integrator: explicit)")
    if deck.integrator == "implicit":
        if particle_bodies:
            if deck.update.scheme not in ("pic", "flip", "apic"):
                add(["update", "scheme"], f"implicit particle bodies take pic, flip or apic transfers, not "
                                          f"{deck.update.scheme}")
            if deck.shape_function in ("cpdi", "cpdi_q", "b2cpdi"):
                add(["shape_function"], "implicit particle bodies take a tensor-product shape function "
                                        "(linear, gimp, bspline2, bspline3)")
        if deck.time.dt is None:
            add(["time", "dt"], "implicit integration takes a fixed time step: give time.dt")
        if (len(fem) > 1 or (fem and particle_bodies)) and (deck.implicit is None or deck.implicit.dhat is None):
            add(["implicit", "dhat"], "bodies meet through the barrier: give implicit.dhat")
        if deck.contact.augury is not None:
            add(["contact", "augury"], "augury contact is explicit; implicit integration uses the barrier")
    elif deck.implicit is not None:
        add(["implicit"], "settings for integrator: implicit, but the deck's integrator is explicit")
    if deck.gravity_ramp > 0.0 and not any(deck.gravity or []):
        add(["gravity_ramp"], "a gravity ramp needs gravity: give gravity")
    if deck.output.energy_ledger and (deck.integrator != "explicit" or fem or not particle_bodies):
        add(["output", "energy_ledger"], "the energy ledger follows the explicit MPM step: it needs "
                                         "integrator: explicit and particle bodies only (no FEM bodies)")
    if deck.output.contact_traction and (deck.integrator != "explicit"
                                         or len({deck.bodies[i].material for i in particle_bodies}) < 2):
        add(["output", "contact_traction"], "contact tractions come from the explicit step's grid contact: they need "
                                            "integrator: explicit and particle bodies of two or more materials")
    # grid
    cs = deck.grid.cell_size if deck.grid is not None else 1.0
    if not isinstance(cs, list) and cs <= 0:
        add(["grid", "cell_size"], "cell size must be > 0")
    if isinstance(cs, list):
        vec(["grid", "cell_size"], cs, what="cell_size list")
        for i, h in enumerate(cs):
            if h <= 0:
                add(["grid", "cell_size", i], "cell size must be > 0")
    if deck.grid is not None and deck.grid.domain is not None:
        d = deck.grid.domain
        vec(["grid", "domain", "min"], d.min)
        vec(["grid", "domain", "max"], d.max)
        if len(d.min) == dim and len(d.max) == dim:
            for k in range(dim):
                if d.max[k] <= d.min[k]:
                    add(["grid", "domain", "max", k], f"domain max {axes[k]} must exceed min")
    if dim == 2 and deck.grid is not None:
        for face in ("zmin", "zmax"):
            if getattr(deck.grid.boundaries, face) != "free":
                add(["grid", "boundaries", face], "z faces exist only in 3d analysis")

    upd = deck.update
    if not upd.reextrapolate and upd.stress == "usf":
        add(["update", "reextrapolate"], "reextrapolate applies to usl and usavg (usf has no second update)")
    if upd.order is not None and upd.scheme not in ("xpic", "fmpm"):
        add(["update", "order"], f"order applies to xpic and fmpm, not {upd.scheme}")
    if dim == 3 and deck.shape_function == "cpdi_q":
        add(["shape_function"], "cpdi_q (9-point qCPDI) is 2D only; use cpdi or b2cpdi in 3d")
    vec(["gravity"], deck.gravity)
    for i, load in enumerate(deck.loads):
        vec(["loads", i, "center"], load.center)
        if load.center is not None and deck.analysis == "axisymmetric" and load.center[0] != 0:
            add(["loads", i, "center", 0], "an axisymmetric pressure surface is a sphere centred on the axis: "
                                           "center r must be 0")
        vec(["loads", i, "traction"], load.traction)
        vec(["loads", i, "force"], load.force)
        vec(["loads", i, "normal"], load.normal)
        if load.normal is not None and len(load.normal) == dim and not any(load.normal):
            add(["loads", i, "normal"], "the normal must not be the zero vector")
        for key in ("min", "max"):
            vec(["loads", i, "region", key], getattr(load.region, key))
        if dim == 2 and load.face in ("zmin", "zmax"):
            add(["loads", i, "face"], "z faces exist only in 3d analysis")
    if deck.time.cfl is not None and deck.time.dt is not None:
        add(["time", "dt"], "give either time.cfl or time.dt, not both")

    for i, name in enumerate(deck.output.material_stress):
        if name not in deck.materials:
            add(["output", "material_stress", i], no_material(name, deck.materials))
        elif isinstance(deck.materials[name], Rigid):
            add(["output", "material_stress", i], f"'{name}' is rigid: it has no stress")

    # materials
    units = unit_system(deck.units)
    for name, mat in deck.materials.items():
        if hasattr(mat, "axis"):
            vec(["materials", name, "axis"], mat.axis)
            if len(mat.axis) == dim and not any(mat.axis):
                add(["materials", name, "axis"], "the axis must not be the zero vector")
        model = MODELS.get(mat.type)
        if model is not None and model.check is not None:
            for key, message in model.check(mat, dim):
                add(["materials", name, *key], message)
        density = getattr(mat, "density", None)
        if density is not None and not units.min_density <= density <= units.max_density:
            add(["materials", name, "density"],
                f"density {density:g} is implausible in {units.name} units: density is in {units.density}")
        elif density is not None and model is not None:
            modulus = float(model.wave_modulus(model.row(mat)))  # (an unstable set of constants: <= 0)
            speed = np.sqrt(modulus / density) if modulus > 0.0 and np.isfinite(modulus) else 0.0
            if speed > MAX_WAVE_SPEED:
                add(["materials", name], f"its elastic wave speed sqrt(modulus / density) = {speed:.3g} m/s is faster "
                    f"than any solid's (diamond: 1.8e4 m/s): moduli are in {units.stress} in {units.name} units"
                    + (" (E in Pa gives 1e6 times too stiff)" if units.stress == "MPa" else ""))
        if isinstance(mat, Rigid):
            if isinstance(mat.velocity, VelocityTable):
                tab = mat.velocity
                if len(tab.times) != len(tab.values):
                    add(["materials", name, "velocity", "values"],
                        f"{len(tab.values)} values for {len(tab.times)} times")
                if any(b <= a for a, b in zip(tab.times, tab.times[1:])):
                    add(["materials", name, "velocity", "times"], "times must be strictly increasing")
                for i, v in enumerate(tab.values):
                    vec(["materials", name, "velocity", "values", i], v)
            elif "velocity" in mat.model_fields_set:
                vec(["materials", name, "velocity"], mat.velocity)
            for c in mat.constrain or []:
                if c not in axes:
                    add(["materials", name, "constrain"], f"'{c}' is not a direction of a {dim}D analysis")

    if not any(not isinstance(m, Rigid) for m in deck.materials.values()):
        add(["materials"], "at least one deformable (non-rigid) material is needed")
    av = deck.artificial_viscosity
    for i, name in enumerate(av.materials or [] if av is not None else []):
        if name not in deck.materials:
            add(["artificial_viscosity", "materials", i], no_material(name, deck.materials))
        elif isinstance(deck.materials[name], Rigid):
            add(["artificial_viscosity", "materials", i], f"'{name}' is rigid: it has no stress")
    from .contact import check_contact

    problems += check_contact(deck, [n for n, m in deck.materials.items() if not isinstance(m, Rigid)])

    # bodies
    seen_names: dict[str, int] = {}
    for i, body in enumerate(deck.bodies):
        path = ["bodies", i]
        name = body_name(body, i)
        if not name.replace("_", "").replace("-", "").replace(".", "").isalnum():
            add(path + ["name"], f"body name '{name}' may hold only letters, digits, '_', '-' and '.'")
        elif name in seen_names:
            add(path + ["name"], f"body name '{name}' is already used by bodies.{seen_names[name]}")
        seen_names.setdefault(name, i)
        shape = body.shape
        if dim == 2 and shape in SHAPES_3D:
            add(path + ["shape"], f"'{shape}' is a 3D shape; this is a plane_strain deck")
        if dim == 2 and body.z_range is not None:
            add(path + ["z_range"], "z_range is only for 3D analysis")
        if dim == 3 and (shape in SHAPES_2D or shape == "mesh"):  # a mesh given z_range is extruded too
            if body.z_range is None and shape != "mesh":
                add(path + ["z_range"], f"a '{shape}' in a 3d deck needs z_range: [z0, z1] to extrude it")
            elif body.z_range is not None and (len(body.z_range) != 2 or body.z_range[1] <= body.z_range[0]):
                add(path + ["z_range"], "z_range must be [z0, z1] with z1 > z0")
        if body.extrude_axis != "z" and (dim != 3 or shape not in SHAPES_2D or body.discretization != "particles"):
            add(path + ["extrude_axis"], "extrude_axis turns a 2D shape of a 3d deck's particle body (not a mesh, "
                "not an FEM body); leave it out here")
        if shape == "mesh":
            if not (base_dir / body.file).is_file():
                add(path + ["file"], f"mesh file not found: {base_dir / body.file}")
            mesh_dim = 2 if dim == 2 or (body.z_range is not None and body.discretization == "particles") else 3
            vec(path + ["translate"], body.translate, n=mesh_dim)
        if body.clip is not None:  # a box in the scene's space
            vec(path + ["clip", "min"], body.clip.min)
            vec(path + ["clip", "max"], body.clip.max)
        pdim = 2 if shape in SHAPES_2D else 3
        for key in ("min", "max", "center", "semi_axes", "origin"):
            if hasattr(body, key):
                vec(path + [key], getattr(body, key), n=pdim)
        if shape in ("rectangle", "box") and len(body.min) == len(body.max):
            for k in range(len(body.min)):
                if body.max[k] <= body.min[k]:
                    add(path + ["max", k], f"max {'xyz'[k]} must exceed min")
        if shape in ("ellipse", "ellipsoid"):
            if any(a <= 0 for a in body.semi_axes):
                add(path + ["semi_axes"], "semi-axes must be > 0")
        if shape == "polygon":
            for j, v in enumerate(body.vertices):
                vec(path + ["vertices", j], v, n=2)
        if shape == "annulus" and body.inner_radius >= body.outer_radius:
            add(path + ["inner_radius"], "inner_radius must be smaller than outer_radius")
        if isinstance(body.velocity, SineVelocity):
            vec(path + ["velocity", "amplitude"], body.velocity.amplitude)
            if body.velocity.axis not in axes:
                add(path + ["velocity", "axis"], f"'{body.velocity.axis}' is not an axis of a {dim}D analysis")
        elif isinstance(body.velocity, RotationVelocity):
            rv = body.velocity
            vec(path + ["velocity", "center"], rv.center)
            vec(path + ["velocity", "translation"], rv.translation)
            if dim == 2 and not isinstance(rv.angular_velocity, float):
                add(path + ["velocity", "angular_velocity"], "in 2D the angular velocity is a number")
            if dim == 3:
                vec(path + ["velocity", "angular_velocity"],
                    rv.angular_velocity if isinstance(rv.angular_velocity, list) else [rv.angular_velocity])
        else:
            vec(path + ["velocity"], body.velocity)

        names = [e.material for e in body.map] if isinstance(body, Image) else [body.material]
        for j, mname in enumerate(names):
            mpath = path + (["map", j, "material"] if isinstance(body, Image) else ["material"])
            if mname not in deck.materials:
                add(mpath, no_material(mname, deck.materials))
            elif isinstance(deck.materials[mname], Rigid) and body.velocity is not None:
                add(path + ["velocity"], f"material '{mname}' is rigid: its velocity is set in the material")
        if isinstance(body, Image):
            _check_image(body, base_dir, path, add)
    return problems


def fem_materials() -> tuple[str, ...]:
    """The material models with FEM forms (MaterialModel.fem)."""
    return tuple(n for n, m in MODELS.items() if m.fem)


def _check_fem_bodies(deck, fem: list[int], base_dir: Path) -> list[tuple[tuple, str]]:
    """FEM bodies: shape, element size, material, transforms and constraints."""
    from .schema import FEM_SHAPES

    problems = []
    add = lambda path, msg: problems.append((tuple(path), msg))  # noqa: E731
    dim = deck.dim
    for i, body in enumerate(deck.bodies):
        path = ["bodies", i]
        if body.discretization != "fem":
            for key in ("element_size", "transform", "constraints"):
                if key in body.model_fields_set:
                    add(path + [key], "applies to FEM bodies (discretization: fem)")
            mat = deck.materials.get(body.material)
            if deck.integrator == "implicit":
                if mat is not None and mat.type not in fem_materials():
                    add(path + ["material"], f"implicit particle bodies use {' or '.join(fem_materials())}, "
                                             f"not {mat.type}")
            elif mat is not None and mat.type in MODELS and MODELS[mat.type].stress(dim) is None:
                add(path + ["material"], f"{mat.type} has no explicit MPM update: it is for FEM bodies and implicit "
                                         "particle bodies; explicit particles use another model (neo_hookean)")
            continue
        if body.shape not in FEM_SHAPES:
            add(path + ["shape"], f"an FEM body is one of {', '.join(sorted(FEM_SHAPES))}, not '{body.shape}'")
        elif body.shape != "mesh" and body.element_size is None:
            add(path + ["element_size"], "a generated FEM mesh needs element_size")
        elif body.shape != "mesh" and (body.shape == "box") != (dim == 3):
            add(path + ["shape"], f"an FEM '{body.shape}' is {'3D' if body.shape == 'box' else '2D'} only")
        mat = deck.materials.get(body.material)
        if mat is not None and mat.type not in fem_materials():
            add(path + ["material"], f"an FEM body's material is {' or '.join(fem_materials())}, not {mat.type}")
        for j, t in enumerate(body.transform):
            if (t.rotate is None) == (t.translate is None):
                add(path + ["transform", j], "give either rotate or translate")
            if t.translate is not None and len(t.translate) != dim:
                add(path + ["transform", j, "translate"], f"needs {dim} components")
            if t.center is not None and len(t.center) != dim:
                add(path + ["transform", j, "center"], f"needs {dim} components")
            if dim == 2 and t.axis != "z":
                add(path + ["transform", j, "axis"], "in 2D rotations are about z")
        for j, c in enumerate(body.constraints):
            if (c.region is None) == (c.node_set is None):
                add(path + ["constraints", j], "select nodes by region or by node_set")
            if c.node_set is not None and body.shape != "mesh":
                add(path + ["constraints", j, "node_set"], "node sets come from mesh files")
            if c.region is not None:
                for key in ("min", "max"):
                    if len(getattr(c.region, key)) != dim:
                        add(path + ["constraints", j, "region", key], f"needs {dim} components")
            if c.velocity is not None and len(c.velocity) != dim:
                add(path + ["constraints", j, "velocity"], f"needs {dim} components")
            for a in c.axes or []:
                if a not in "xyz"[:dim]:
                    add(path + ["constraints", j, "axes"], f"'{a}' is not a direction of a {dim}D analysis")
            if c.motion is not None:
                _check_motion(c, path + ["constraints", j], dim, deck.integrator, add)
    return problems


def _check_motion(c, path, dim: int, integrator: str, add) -> None:
    """A constraint's prescribed rigid motion: alone (no velocity, no axes), implicit, phases in
    increasing time with vectors of the analysis's size."""
    if integrator != "implicit":
        add(path + ["motion"], "a prescribed motion is followed by the implicit integrator only (integrator: implicit)")
    if c.velocity is not None:
        add(path + ["velocity"], "give either velocity or motion, not both")
    if c.axes is not None:
        add(path + ["axes"], "a prescribed motion holds every component: leave axes out")
    if not c.motion:
        add(path + ["motion"], "give at least one phase")
    before = 0.0
    for k, ph in enumerate(c.motion):
        where = path + ["motion", k]
        if ph.until <= before:
            add(where + ["until"], f"phases end in increasing time: {ph.until:g} is not after {before:g}")
        before = max(before, ph.until)
        if ph.velocity is not None and len(ph.velocity) != dim:
            add(where + ["velocity"], f"needs {dim} components")
        w = ph.angular_velocity
        if w is not None:
            if dim == 2 and not isinstance(w, float | int):
                add(where + ["angular_velocity"], "in 2D the angular velocity is a number (about z)")
            elif dim == 3 and (isinstance(w, float | int) or len(w) != 3):
                add(where + ["angular_velocity"], "in 3D the angular velocity is a vector [wx, wy, wz]")
            if ph.center is None:
                add(where + ["center"], "a rotation needs center (a point on its axis)")
        if ph.center is not None and len(ph.center) != dim:
            add(where + ["center"], f"needs {dim} components")


def body_name(body, index: int) -> str:
    """The body's name in history columns and messages."""
    return body.name if body.name is not None else f"body{index}"


def _check_image(body: Image, base_dir: Path, path, add):
    for j, entry in enumerate(body.map):
        epath = path + ["map", j]
        if (entry.grey is None) == (entry.color is None):
            add(epath, "give exactly one of grey: [low, high] or color: [r, g, b]")
        if entry.grey is not None and (len(entry.grey) != 2 or not 0 <= entry.grey[0] <= entry.grey[1] <= 255):
            add(epath + ["grey"], "grey must be [low, high] with 0 <= low <= high <= 255")
        if entry.color is not None and (len(entry.color) != 3 or not all(0 <= c <= 255 for c in entry.color)):
            add(epath + ["color"], "color must be [r, g, b] with each 0..255")
    file = (base_dir / body.file)
    if not file.is_file():
        add(path + ["file"], f"image file not found: {file}")
        return
    try:
        from PIL import Image as PILImage

        with PILImage.open(file) as im:
            im.verify()
    except Exception as exc:  # Pillow raises many types for unreadable images
        add(path + ["file"], f"cannot read image {file}: {exc}")
