"""The problem deck: pydantic models. The schema is the documentation.

Every model forbids unknown keys. Field descriptions are what `docs/deck-reference.md`
prints (regenerate it with `python -m mpmsim.deck.reference`). Checks that need more
than one field, or the analysis dimension, live in `mpmsim.deck.semantics`.
"""

from __future__ import annotations

import difflib

from typing import Annotated, Literal, Union

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, field_validator, model_validator

from ..schema_base import MAX_MAGNITUDE, Strict, Vector  # noqa: F401  (Vector, Strict: the models' bases)

Face = Literal["free", "fixed", "roller", "slip"]


class VelocityTable(Strict):
    """Piecewise-linear velocity in time: held at the first value before `times[0]` and at
    the last value after `times[-1]`."""

    times: list[float] = Field(min_length=1, description="Strictly increasing times.")
    values: list[Vector] = Field(min_length=1, description="One velocity vector per time.")


class Rigid(Strict):
    """Rigid material moving with a prescribed velocity. With `mode: bc` its particles impose
    that velocity on every grid node they touch (non-zero shape function), in the constrained
    directions. With `mode: contact` it acts only through contact (its own velocity field and
    the contact law), like NairnMPM's rigid contact materials."""

    type: Literal["rigid"]
    mode: Literal["bc", "contact"] = Field(default="bc", description="bc (velocity condition) or contact.")
    velocity: Vector | VelocityTable = Field(
        default_factory=lambda: [0.0, 0.0, 0.0],
        description="Constant velocity vector, or a table {times, values} (piecewise linear).",
    )
    constrain: list[Literal["x", "y", "z"]] | None = Field(
        default=None,
        description="Velocity components imposed on the nodes it touches (default: all).",
    )


def material_union():
    """Every registered material model's deck entry (mpmsim/materials/model.py), and rigid."""
    from ..materials.model import schemas

    return Annotated[Union[tuple(schemas()) + (Rigid,)], Field(discriminator="type")]


Material = Annotated[Union[Rigid], Field(discriminator="type")]  # (completed by rebuild_materials)


# --------------------------------------------------------------------------- contact
def _stiffness(value):
    if value == "perfect":
        return value
    try:  # YAML reads 1.0e5 (no exponent sign) as a string
        number = float(value)
    except ValueError:
        number = -1.0
    if number >= 0.0:
        return number
    raise ValueError(f"{value!r} is not an interface stiffness: give a number >= 0 (stress per length) or 'perfect'")


# one message for a bad stiffness instead of one per union member
Stiffness = Annotated[Union[float, str], AfterValidator(_stiffness)]


class Domain(Strict):
    """An axis-aligned box (grid.domain: the region material may occupy; particles leaving it
    stop the run)."""

    min: Vector = Field(description="Lower corner.")
    max: Vector = Field(description="Upper corner.")


class Cohesive(Strict):
    """A cohesive law with damage (law: cohesive; docs/interfaces.md "Cohesive interfaces"):
    the interface carries Dn [u_n], Dt [u_t] until a peak traction, softens to failure after
    dissipating its toughness, unloads to the origin, never heals, and, failed, is handed to
    the contact law `after`. Compression never softens."""

    shape: Literal["bilinear", "exponential"] = Field(
        default="bilinear", description="bilinear (triangular; intact stiffness Dn, Dt) or exponential (Xu-Needleman "
        "in the effective opening; its stiffness follows from the peak and the toughness).")
    peak_traction: float = Field(gt=0, description="Mode I peak traction sigma_c (stress).")
    shear_peak_traction: float | None = Field(default=None, gt=0,
                                              description="Mode II peak traction tau_c (stress); default sigma_c.")
    G_Ic: float = Field(gt=0, description="Mode I toughness (energy per area).")
    G_IIc: float | None = Field(default=None, gt=0, description="Mode II toughness; default G_Ic.")
    mixed_mode: Literal["bk", "power_law"] = Field(
        default="bk", description="Mixed-mode toughness: bk (Benzeggagh-Kenane, G_c = G_Ic + (G_IIc - G_Ic) B^exponent) "
        "or power_law ((G_I/G_Ic)^exponent + (G_II/G_IIc)^exponent = 1).")
    exponent: float = Field(default=2.0, gt=0, description="BK's eta or the power law's exponent.")
    after: Literal["frictionless", "coulomb"] = Field(
        default="frictionless", description="The contact law of a failed interface.")
    friction: float = Field(default=0.0, ge=0.0, description="Friction after failure (after: coulomb).")
    precrack: list[Domain] = Field(
        default_factory=list, description="Boxes {min, max}: the pair's particles inside start debonded (a pre-crack; "
        "they meet through `after` from the start).")

    @model_validator(mode="after")
    def _defaults(self):
        if self.shear_peak_traction is None:
            self.shear_peak_traction = self.peak_traction
        if self.G_IIc is None:
            self.G_IIc = self.G_Ic
        return self


class ContactLaw(Strict):
    """A contact law: `stick` (bonded: always moves with the centre of mass, never separates),
    `frictionless`, `coulomb` (kinetic `friction`, optional `static_friction`), `none`
    (perfect interface: the materials share one velocity field, exactly single-material MPM), or
    `interface` (imperfect interface: tractions Dn [u_n] and Dt [u_t] in tension and
    compression alike; docs/interfaces.md), or `cohesive` (an interface that softens and fails
    by its `cohesive` block, then touches and slides)."""

    law: str = Field(description="stick, frictionless, coulomb, none, interface, cohesive, or a law registered with "
                     "mpmsim.contact.grid.laws.register_law.")

    @field_validator("law")
    @classmethod
    def _known_law(cls, v):
        from ..contact.grid.spec import LAW_CODES

        if v not in LAW_CODES:
            close = difflib.get_close_matches(v, list(LAW_CODES), n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            raise ValueError(f"unknown law '{v}'{hint}: one of {', '.join(LAW_CODES)}")
        return v
    friction: float = Field(default=0.0, ge=0.0, description="Kinetic friction coefficient (coulomb).")
    static_friction: float | None = Field(default=None, ge=0.0, description="Static coefficient (coulomb).")
    Dn: Stiffness = Field(
        default="perfect", description="Interface normal stiffness in tension (stress/length), or perfect.")
    Dnc: Stiffness | None = Field(
        default=None, description="Interface normal stiffness in compression (bilinear law); default Dn.")
    Dt: Stiffness = Field(default="perfect", description="Interface tangential stiffness, or perfect.")
    cohesive: Cohesive | None = Field(default=None, description="The cohesive law (law: cohesive).")


class ContactPair(ContactLaw):
    between: list[str] = Field(min_length=2, max_length=2, description="Two material names.")


class Augury(Strict):
    """APIC augury contact between FEM bodies, and between FEM bodies and particle bodies
    (docs/fem-contact.md): FEM boundary nodes and surface particles meet through grid transfers on
    a background grid of their own."""

    method: Literal["augury", "field"] = Field(
        default="augury", description="augury: the paper's augury iterations through the transfer H. field: one "
        "velocity field per body on the augury grid, pair normals from both bodies' boundaries, the approaching "
        "normal change applied and the tangential change capped by Coulomb (transfer and iterations unused); "
        "sliding is not damped. docs/fem-contact.md.")
    cell_size: float = Field(gt=0, description="Spacing h_c of the augury grid (length unit).")
    transfer: Literal["apic", "pic"] = Field(default="apic", description="APIC (affine part kept) or PIC transfers.")
    iterations: int = Field(
        default=1, ge=0, le=20,
        description="Augury iterations N: 0 makes bodies stick; 1 (default) lets them rebound and slide.")
    tau: float | None = Field(default=None, gt=0, description="Augury time tau (time unit). Default: the time step.")
    kernel: Literal["bspline2", "linear", "four_node"] = Field(
        default="four_node", description="Grid functions: four_node (default): the paper's adjusted quadratic "
        "B-spline on 4 nodes per axis (its Appendix B, used in all its examples); bspline2: the standard quadratic "
        "B-spline on 3 (grid-aligned sliding rows lose (3/4)*4^-N of their relative speed per step); linear: hats "
        "on 2. docs/fem-contact.md.")
    overlap_tolerance: float = Field(
        default=0.01, gt=0, le=0.3,
        description="How deep (fraction of an element, in barycentric terms) a boundary node may sit inside another "
        "body before the run stops as interpenetrated.")


class Contact(Strict):
    """Multimaterial contact (LR paper). Used when two or more material groups meet; materials
    joined by law `none` form one group (one velocity field)."""

    passes: Literal[1, 2] = Field(
        default=2, description="2: correct after extrapolation and after the momentum update (the "
        "paper's method); 1: only after the update (the paper's 'LR once' comparison).")
    pass_3: Literal["persist", "keep", "recheck"] = Field(
        default="persist", description="Contact after the re-extrapolation of USL+/USAVG+ (pass 3), and where pass 2 "
        "advances the point-cloud separation to the end of the step. persist (the default): pass 2 takes the "
        "separation as measured except at grid nodes where it made contact in the previous step (there advanced, "
        "so a compressed interface stays closed), and pass 3 recomputes normals and separations from the moved "
        "particles, keeps pass 2's contacts unless the re-extrapolated momenta separate the surfaces by more than a "
        "tenth of pass 2's normal impulse, and adds contact where the moved surfaces touch and approach; pass 1 "
        "holds a pair of materials that pass 2 held in the previous step whatever its normal velocity, so that "
        "contact makes no energy: right for impacts (the oblique cylinder within 2% of the reference code, no "
        "energy gained) "
        "and for quasi-static compression (XPIC(5) two-block column, ellipses in a box) alike. keep: pass 2's "
        "decision enforced with pass 1's geometry, the separation advanced everywhere (an oblique cylinder at "
        "R/h = 20 rebounds 9% slower). recheck: the reference code's passes (separation as measured, pass 3 "
        "re-tests every node from the recomputed geometry); unstable on the compressed XPIC(5) column and the "
        "ellipse box. docs/contact.md.")
    normal: Literal["logistic_regression", "linear_regression", "average_gradient", "max_gradient",
                    "max_volume", "specified"] = Field(default="logistic_regression", description="Normal method.")
    normal_vector: Vector | None = Field(
        default=None, description="For normal: specified; points from the lower-numbered material to the higher.")
    rigid_bias: float = Field(
        default=1.0, ge=1.0, description="Favour a rigid material's volume gradient as the normal "
        "(gradient methods: bias factor; logistic regression: >= 10 uses the rigid gradient).")
    separation: Literal["logistic_regression", "displacement", "cutoff", "fit", "velocity"] | None = Field(
        default=None, description="Contact detection: logistic_regression (d_LR from the point cloud, "
        "particle domains deformed by F), displacement (extrapolated displacements), cutoff (positions "
        "minus cutoff x h, the CP method), fit (positions through the d(x) power law, DF), velocity "
        "(approach only). Default: logistic_regression with LR normals, else displacement.")
    cutoff: float = Field(default=0.8, gt=0.0, description="CP cutoff in cells (separation: cutoff).")
    touch_tolerance: float = Field(
        default=1e-5, ge=0.0, description="Surfaces closer than this (cells) count as touching. Flush, "
        "compressed surfaces meet only to within round-off (d_LR ~ +1e-7 mm was seen on 5 mm cells), and a "
        "contact skipped there kicks XPIC particles. Keep it small: a surface that opens by less than the "
        "tolerance is held open at that gap (1e-3 cell froze a 5 um opening into the two-block column, "
        "+0.58% stress error with XPIC(5); 1e-5 gives 0.14%).")
    fit_exponent: float = Field(
        default=0.5757, gt=0.0, description="DF exponent r in d = 2(|q|/1.25h)^r - 1 (separation: fit). "
        "0.5757 = ln 0.5 / ln 0.3 puts the edge of a uGIMP, 2-particle-per-cell material on the node when "
        "its centre is 0.375 cells away, as it is exactly, so flush surfaces on a grid line touch (a "
        "least-squares fit to the whole curve gives 0.57, which leaves a 0.014-cell false gap there).")
    default: ContactLaw = Field(default_factory=lambda: ContactLaw(law="frictionless"),
                                description="Law for pairs not listed in `pairs`.")
    pairs: list[ContactPair] = Field(default_factory=list, description="Laws for particular material pairs.")
    xpic_contact_term: bool = Field(
        default=True, description="Multimaterial XPIC(m) with the contact term of Eq. (37); false gives "
        "the paper's 'uncorrected XPIC'.")
    warm_start: bool = Field(default=False, description="Start logistic regression from the last step's fit.")
    normal_center: Vector | None = Field(
        default=None, description="For normal: specified: a radial normal from this centre point "
        "(spheres, cylinders) instead of normal_vector; points from the lower-numbered material to "
        "the higher.")
    interface_integration: Literal["backward_euler", "trapezoidal", "oscillator", "force_limit", "first_order"] = Field(
        default="backward_euler", description="Imperfect interfaces: backward_euler (force D A times the end "
        "opening, solved with the step's update; damps the interface's own oscillation, stable in every "
        "specimen), trapezoidal (D A times the mean of the start and end openings; energy-neutral for an "
        "isolated pair, unstable on the sphere specimen at D = 3e5 and 1e6 MPa/mm), oscillator (the reference "
        "code: exact harmonic oscillator per direction for the end opening; an isolated pair gains energy "
        "every step, 2 sin(phi)/phi - cos(phi)); with these three, a "
        "direction with (D A dt^2 / m_red) > 1 acts as perfect), force_limit "
        "(the 2013 paper: first-order force D A delta, a direction whose force exceeds the force that "
        "would bring both materials to the centre of mass acts as perfect) or first_order (the force "
        "without any limit: unstable for stiff interfaces, kept to show that failure).")
    interface_bond: Literal["consistent", "nodal"] = Field(
        default="consistent", description="Imperfect interfaces, how a bonded normal (perfect, or too stiff for "
        "the step) with a free tangential direction is held: consistent (no relative normal velocity where "
        "the interface crosses each grid edge; location independent) or nodal (at every contact node, the "
        "reference code's way: on cell mid-planes it clamps both nodes of the crossed cell and stiffens "
        "the interface, -16% interfacial energy at 1 mm cells on the two-layer specimen).")
    interface_opening: Literal["interface", "node"] = Field(
        default="interface", description="Imperfect interfaces, where the opening is measured: interface "
        "(each side's displacement carried to the interface point along its particles' displacement "
        "gradients; a continuous strain field opens nothing) or node (the two materials' mass-weighted "
        "displacements at the node, the reference code's way: the strain between the two sides' particles "
        "counts as opening, about eps h; unstable for stiff normals below the bonding switch on a grid line).")
    area_correction: bool = Field(
        default=True, description="Contact area from the two materials' nodal volumes (2013 paper Eq. 20; "
        "logistic regression: from the edge distance). false: the uncorrected area Omega_i / h_perp, "
        "for comparisons.")
    h_perp: bool = Field(
        default=True, description="Cell size normal to the contact plane for uneven cells (2013 paper "
        "Eq. 22, method 1) in the contact area and the CP cutoff. false: the x cell size (the paper's "
        "'no correction', for comparisons).")
    edge_screening: float | None = Field(
        default=None, gt=0.0, lt=1.0, description="Skip contact and interface work at nodes whose total "
        "nodal volume is below this fraction of a cell's volume (free-edge nodes with unreliable normals; "
        "0.75-0.85 in the 2013 paper).")
    augury: Augury | None = Field(
        default=None, description="APIC augury contact between FEM bodies {cell_size, transfer, iterations, tau, "
        "kernel}; their laws come from `default` and `pairs` (frictionless, coulomb, stick).")
    cloud_weights: Literal["uniform", "shape_function"] = Field(
        default="uniform", description="Regression weight of each particle in a node's point cloud. "
        "uniform: 1, as in the LR paper and the reference code. shape_function: its shape function at the "
        "node, each material's weights scaled to the same total; it lets a particle that drifts into a "
        "node's support count gradually (a closing flat gap touches at -0.18% instead of -1.2% of the "
        "exact time), but favours the particles nearest the node, which tilts the normal along a curved "
        "surface and at a block's corners: without friction a lattice-seeded cylinder striking a block "
        "obliquely loses 22% of its tangential velocity, and a block sliding on a slab a quarter of its "
        "speed in 0.5 ms (docs/contact.md, choice 1).")


# --------------------------------------------------------------------------- bodies
class SineVelocity(Strict):
    """v(x) = amplitude * sin(2 pi (x[axis] - origin) / wavelength): a vibration mode."""

    amplitude: Vector = Field(description="Velocity vector at the crest.")
    axis: Literal["x", "y", "z"] = Field(description="Coordinate the sine varies along.")
    wavelength: float = Field(gt=0, description="Wavelength (length unit).")
    origin: float = Field(default=0.0, description="Coordinate of the sine's zero.")


class RotationVelocity(Strict):
    """Rigid rotation about `center` (plus an optional translation): v = w x (x - center) + translation."""

    angular_velocity: float | Vector = Field(
        description="Angular velocity (rad per time unit): a number in 2D, a vector [wx, wy, wz] in 3D.")
    center: Vector = Field(description="A point on the rotation axis.")
    translation: Vector | None = Field(default=None, description="Added uniform velocity.")


class MotionPhase(Strict):
    """One phase of a prescribed rigid motion, from the previous phase's `until` (0 for the first)
    to its own: a translation at `velocity` plus a rotation at `angular_velocity` about the axis
    through `center`. The motion carries the held nodes' initial positions (and the centre) from
    phase to phase; after the last phase they stay where it left them."""

    until: float = Field(gt=0, description="End time of the phase (phases in increasing order).")
    velocity: Vector | None = Field(default=None, description="Translation velocity (default 0).")
    angular_velocity: float | Vector | None = Field(
        default=None, description="Angular velocity (rad per time unit): [wx, wy, wz] in 3D, a number "
        "(about z) in 2D (default 0).")
    center: Vector | None = Field(
        default=None, description="A point on the rotation axis, in the initial (t = 0) world coordinates; it "
        "moves with the held nodes (the earlier phases and this phase's velocity). Needed with angular_velocity.")


class NodeConstraint(Strict):
    """FEM nodes held: those inside `region` or in the mesh's `node_set`; fixed in `axes`
    (default: all), or moving there at a prescribed `velocity`, or following a prescribed
    rigid `motion` in all components (integrator: implicit)."""

    region: Domain | None = Field(default=None, description="Box selecting the nodes.")
    frame: Literal["world", "body"] = Field(
        default="world", description="Coordinates of `region`: world (after the body's transforms) or body "
        "(the shape's own, before them: a tilted ramp's bottom face).")
    node_set: str | None = Field(default=None, description="Name of a node set of the mesh file.")
    axes: list[Literal["x", "y", "z"]] | None = Field(default=None, description="Components held (default: all).")
    velocity: Vector | None = Field(default=None, description="Prescribed velocity of the held components (default 0).")
    motion: list[MotionPhase] | None = Field(
        default=None, description="Prescribed rigid motion of the held nodes (all components; not with velocity "
        "or axes): phases of constant translation and rotation, each {until, velocity, angular_velocity, center}; "
        "the nodes' target at time t is the motion applied to their initial positions. Implicit integrator only.")


class Transform(Strict):
    """One step of placing an FEM body: a rotation (degrees, about `axis` through `center`) or
    a translation; steps apply in order."""

    rotate: float | None = Field(default=None, description="Angle in degrees (counter-clockwise about the axis).")
    axis: Literal["x", "y", "z"] = Field(default="z", description="Rotation axis (2D: z).")
    center: Vector | None = Field(default=None, description="A point on the axis (default: the origin).")
    translate: Vector | None = Field(default=None, description="Translation vector.")


class BodyBase(Strict):
    """Keys every body takes."""

    name: str | None = Field(
        default=None, description="Name used in per-body history columns and messages (default: body<index>).")
    material: str = Field(description="Name of a material in `materials`.")
    discretization: Literal["particles", "fem"] = Field(
        default="particles", description="Material points on the background grid, or a finite element mesh "
        "(linear triangles in 2D, tetrahedra in 3D; rectangle, box, circle, annulus or mesh shapes).")
    element_size: float | None = Field(default=None, gt=0, description="FEM: element edge length of a generated mesh.")
    transform: list[Transform] = Field(default_factory=list, description="FEM: rotations and translations, in order.")
    constraints: list[NodeConstraint] = Field(default_factory=list, description="FEM: held nodes.")
    velocity: Vector | SineVelocity | RotationVelocity | None = Field(
        default=None,
        description="Initial velocity: a vector, a sine mode {amplitude, axis, wavelength, origin}, "
        "or a rigid rotation {angular_velocity, center, translation}. "
        "Not allowed for rigid materials (their velocity is prescribed).",
    )
    z_range: list[float] | None = Field(
        default=None,
        description="3D only, 2D shapes: extrude the shape between z_range[0] and z_range[1] (along "
        "`extrude_axis`, z unless it says otherwise).",
    )
    extrude_axis: Literal["x", "y", "z"] = Field(
        default="z", description="3D particle bodies of a 2D shape: the axis the shape is extruded along, "
        "over z_range. The shape's two coordinates are the other two axes in their order: (x, y) for z, "
        "(x, z) for y (a disc lying flat, its axis vertical), (y, z) for x.")
    clip: Domain | None = Field(
        default=None, description="Keep only the part of the shape inside this box (symmetry models: "
        "an eighth of a sphere).")
    overwrites: bool = Field(
        default=False, description="Particle bodies: this body is laid over earlier ones on purpose (an inclusion, "
        "a platen across a corner): where it takes their particles, no warning.")


class Corners(BodyBase):
    """An axis-aligned rectangle (2D) or box (3D) by its corners."""

    min: Vector = Field(description="Lower corner [x, y] ([x, y, z] in 3D).")
    max: Vector = Field(description="Upper corner [x, y] ([x, y, z] in 3D).")


class Rectangle(Corners):
    shape: Literal["rectangle"]


class Box(Corners):
    shape: Literal["box"]


class Round(BodyBase):
    """A circle (2D) or sphere (3D) by its centre and radius."""

    center: Vector = Field(description="Centre [x, y] ([x, y, z] in 3D).")
    radius: float = Field(gt=0)


AUTO_SEEDING = (
    "auto (the default): rings_half_step (shells for a sphere) when the scene has grid contact (an explicit "
    "deck with two or more velocity fields) and the body can be so seeded "
    "(a particle body, a square grid cell, no `overwrites`, a clip through its centre or missing it, no "
    "overlap with another particle body); lattice otherwise. `mpmsim check` says which it chose and why. ")
SEEDING_DESCRIPTION = (
    "How particles fill the body (2D decks). " + AUTO_SEEDING + "lattice: the sites of the grid-aligned lattice inside the shape "
    "(its surface a staircase of particle-sized steps). rings: rings that follow the surface, one particle "
    "spacing (cell_size / particles_per_direction) apart, each ring's particles spaced as close to it as a "
    "whole number allows, one at the bottom of every ring, each with its ring sector's exact area (the areas "
    "sum to the shape's); the particles' domains stay squares of the lattice spacing (the same area to within "
    "a few percent). rings_half_step: the same rings, each turned by half its particle spacing (none at the "
    "bottom: the two lowest half a spacing either side of the vertical through the centre). For curved bodies in "
    "contact: the staircase's corners bias contact pressure and width; with a deformable partner "
    "rings_half_step keeps the pressure of neighbouring grid columns from alternating "
    "(docs/contact.md, docs/bfemp.md). A rings body may not overlap another particle body; it may be clipped "
    "by lines through its centre (a half or quarter symmetry model: rings_half_step, each ring's count a "
    "multiple of 4 so the clip keeps whole sectors) or lines that miss it; "
    "the grid cell size must be the same along x and y.")


def _seeding():
    return Field(default="auto", description=SEEDING_DESCRIPTION)


class Circle(Round):
    shape: Literal["circle"]
    seeding: Literal["auto", "lattice", "rings", "rings_half_step"] = _seeding()


SHELLS_DESCRIPTION = (
    "How particles fill the sphere (3D decks). " + AUTO_SEEDING + "lattice: the sites of the grid-aligned lattice inside it (its "
    "surface a staircase, its bottom a flat facet). shells: concentric shells one particle spacing (cell_size / "
    "particles_per_direction) apart, each cut into bands of polar angle from the bottom pole (-y) and each band "
    "into a multiple of 4 particles spaced as close to the spacing as whole numbers allow, mirror-symmetric "
    "about the planes x = center_x and z = center_z with no particle on them; each particle carries its band "
    "sector's exact volume (the volumes sum to the sphere's). For curved bodies in contact (docs/contact.md). A "
    "shells body may not overlap another particle body; it may be clipped only by planes through its centre "
    "normal to x or z (a half or quarter sphere on symmetry planes keeps an exact half or quarter) or by planes "
    "that miss it; the grid cell size must be the same along x, y and z.")


class Sphere(Round):
    shape: Literal["sphere"]
    seeding: Literal["auto", "lattice", "shells"] = Field(default="auto", description=SHELLS_DESCRIPTION)


class Ellipse(BodyBase):
    shape: Literal["ellipse"]
    center: Vector
    semi_axes: Vector = Field(description="Semi-axes [a, b] along the rotated x and y axes.")
    angle: float = Field(default=0.0, description="Rotation of the a axis from x, in degrees.")


class Ellipsoid(BodyBase):
    shape: Literal["ellipsoid"]
    center: Vector = Field(description="Centre [x, y, z] (3D).")
    semi_axes: Vector = Field(description="Semi-axes [a, b, c] along x, y, z.")


class Polygon(BodyBase):
    shape: Literal["polygon"]
    vertices: list[Vector] = Field(min_length=3, description="Vertices [[x, y], ...] in order.")


class Annulus(BodyBase):
    shape: Literal["annulus"]
    center: Vector
    inner_radius: float = Field(ge=0)
    outer_radius: float = Field(gt=0)
    seeding: Literal["auto", "lattice", "rings", "rings_half_step"] = _seeding()


class MeshFile(BodyBase):
    """A mesh file meshio reads (Gmsh .msh, .vtu/.vtk, Abaqus .inp, .stl, .obj, .ply, .off,
    ...), its coordinates mapped x -> scale x + translate. FEM bodies use its triangles (2D) or
    tetrahedra (3D) as elements. Particle bodies fill the region it bounds with particles. 2D
    (and a 3d deck's body given z_range, extruded over it): the file's triangles and
    quadrilaterals (quadratic ones by their corners, a constant z dropped); a point is inside
    when it lies in one of them, located by matplotlib's TrapezoidMapTriFinder, so holes and
    non-convex outlines are exact. 3D: the surface bounding the body: the faces of its volume
    cells (tetrahedra, hexahedra, wedges, pyramids) that no other cell shares, or else its
    triangles and quadrilaterals (.stl, .obj, surface meshes), which must close (watertight:
    every edge shared by an even number of faces). A point is inside when a ray from it along
    +z crosses that surface an odd number of times: holes, cavities and tori need no
    orientation, and rays through edges and vertices count once (a symbolic perturbation).
    Measured: 3.9e6 points against a 65,536-triangle surface in 1.5 s after 1.2 s of reading
    and binning; 1e6 points in a 5,124-triangle 2D mesh in 0.15 s. Lattice-filled volumes
    match the mesh's within 1% (tests/unit/test_mesh_bodies.py)."""

    shape: Literal["mesh"]
    file: str = Field(description="Mesh path, relative to the deck's directory.")
    scale: float = Field(default=1.0, gt=0, description="Factor on the file's coordinates.")
    translate: Vector | None = Field(
        default=None, description="Added to the scaled coordinates (the body's dimension: 2 for a mesh extruded "
        "over z_range). FEM bodies apply `transform` after it.")


class ImageMapEntry(Strict):
    """One pixel class. Give `grey` (an inclusive range of grey levels 0–255) or `color`
    (an exact [r, g, b]); pixels matching no entry are empty."""

    material: str
    grey: list[int] | None = Field(default=None, description="[low, high] grey levels, inclusive.")
    color: list[int] | None = Field(default=None, description="[r, g, b], each 0–255.")


class Image(BodyBase):
    """A PNG (or any image Pillow reads); each pixel becomes material by its grey level or colour.
    `material` is not used: the map assigns materials."""

    shape: Literal["image"]
    material: str = Field(default="", description="Unused for images (the map assigns materials).")
    file: str = Field(description="Image path, relative to the deck's directory.")
    pixel_size: float = Field(gt=0, description="Edge length of one pixel (length unit).")
    origin: Vector = Field(description="Model coordinates of the image's lower-left corner.")
    map: list[ImageMapEntry] = Field(min_length=1, description="Pixel classes to materials.")


Body = Annotated[
    Union[Rectangle, Box, Circle, Sphere, Ellipse, Ellipsoid, Polygon, Annulus, Image, MeshFile],
    Field(discriminator="shape"),
]

SHAPES_2D = {"rectangle", "circle", "ellipse", "polygon", "annulus", "image"}
FEM_SHAPES = {"rectangle", "box", "circle", "annulus", "mesh"}
SHAPES_3D = {"box", "sphere", "ellipsoid"}


# --------------------------------------------------------------------------- grid
class Boundaries(Strict):
    """Condition on each face of the domain: `free`, `fixed` (all velocity components zero),
    `roller` or its synonym `slip` (normal component zero). Constrained faces act on the
    face's grid line and the ghost nodes beyond it."""

    xmin: Face = "free"
    xmax: Face = "free"
    ymin: Face = "free"
    ymax: Face = "free"
    zmin: Face = "free"
    zmax: Face = "free"


class Grid(Strict):
    """The background grid. It is sized from the scene: only where material can go."""

    cell_size: float | list[float] = Field(
        description="Cell edge length, or one length per direction (uneven cells).")
    domain: Domain | None = Field(
        default=None,
        description="Region material may occupy. Default: the bounding box of all bodies and "
        "of every rigid body's prescribed path, plus `margin` cells on free faces. "
        "A constrained face is placed on the bodies' edge.",
    )
    margin: int = Field(default=2, ge=0, description="Free-face margin, in cells, of the default domain.")
    boundaries: Boundaries = Field(default_factory=Boundaries)


# --------------------------------------------------------------------------- loads
class TractionLoad(Strict):
    """A load on one edge of a body: the outermost particles toward `face` (or `normal`) among
    those inside `region`. Either a traction on an axis-aligned face (each particle carries
    traction x its face area; 2D: x thickness), or a total `force` shared by particle volume
    over a band `depth` deep (tilted edges), or a `pressure` on a round surface about `center`
    (a cylinder's or sphere's inner or outer face: the particle layer nearest to it, each
    pushed along its radius by pressure x its share of the surface)."""

    region: Domain = Field(description="Box around the loaded edge (particle centres inside it).")
    face: Literal["xmin", "xmax", "ymin", "ymax", "zmin", "zmax"] | None = Field(
        default=None, description="Load the outermost particle layer on this side of the selected particles.")
    normal: Vector | None = Field(
        default=None, description="Instead of face: load the particles within `depth` of the outermost "
        "along this direction (edges not aligned with the grid).")
    depth: float | None = Field(
        default=None, gt=0.0, description="Band depth along `normal` (default: one particle spacing).")
    traction: Vector | None = Field(default=None, description="Force per area on a `face` (e.g. [0, -0.5] MPa).")
    force: Vector | None = Field(default=None, description="Total force, shared by particle volume (2D: on "
                                 "the deck's thickness, like every 2D force).")
    pressure: float | None = Field(
        default=None, description="Instead of traction or force: a pressure (force per area, > 0 pushes on the "
        "surface) on the round surface about `center` (a circle or annulus edge in 2D: a cylinder; a sphere in 3d and, "
        "centred on the axis, in axisymmetric analysis). Best with rings seeding, whose layers follow the surface.")
    center: Vector | None = Field(default=None, description="Centre of the round surface a `pressure` acts on.")
    side: Literal["inner", "outer"] = Field(
        default="inner", description="With pressure: the surface nearest the centre (a cavity's wall) or farthest "
        "from it (an outer face).")
    ramp: float = Field(default=0.0, ge=0.0, description="Ramp time: the load grows linearly from 0, then is held.")

    @model_validator(mode="after")
    def _one_of_each(self):
        if self.pressure is not None or self.center is not None:
            if self.pressure is None or self.center is None:
                raise ValueError("a pressure load needs both pressure and center")
            if self.face is not None or self.normal is not None or self.traction is not None or self.force is not None:
                raise ValueError("a pressure load (pressure, center) takes no face, normal, traction or force")
            return self
        if (self.face is None) == (self.normal is None):
            raise ValueError("give either face or normal")
        if (self.traction is None) == (self.force is None):
            raise ValueError("give either traction or force")
        if self.traction is not None and self.face is None:
            raise ValueError("traction needs a face (use force with normal for tilted edges)")
        return self


class Damping(Strict):
    """Damping to reach static results: a grid damping force -alpha p on every node."""

    grid: float = Field(default=0.0, ge=0.0, description="alpha (1/time): nodal force -alpha m v.")


# --------------------------------------------------------------------------- run control
class Time(Strict):
    """Simulated time and the time step rule."""

    end: float = Field(gt=0, description="End time (time unit). The run lands on it in steps of one length: "
                       "each the longest no longer than the rule's (cfl or dt) that splits the time left into "
                       "equal steps (docs/timestep.md).")
    cfl: float | None = Field(
        default=None, gt=0, le=1.0,
        description="Time step = cfl × min cell size / max(wave speed + |velocity|), recomputed "
        "every step from the current state. Default 0.5. Give either cfl or dt.",
    )
    dt: float | None = Field(default=None, gt=0, description="Fixed time step instead of the CFL rule (the "
                             "longest step: when time.end is not a whole number of them, the steps are shortened "
                             "evenly to land on it).")


class Implicit(Strict):
    """Implicit integration of FEM bodies (docs/bfemp.md): each step minimises the incremental
    potential with projected Newton; FEM bodies meet through a log barrier."""

    scheme: Literal["backward_euler", "newmark"] = Field(
        default="newmark", description="backward_euler (zeta, beta, gamma = 1, 1/2, 1) or midpoint newmark "
        "(1/2, 1/4, 1/2).")
    newton_tolerance: float = Field(
        default=1e-5, gt=0, description="Newton stops when max |p| / dt falls below this (velocity unit).")
    max_newton_iterations: int = Field(default=100, ge=1, le=10000, description="Newton iterations per step.")
    dhat: float | None = Field(
        default=None, gt=0, description="Barrier distance (length unit): bodies push apart closer than this. "
        "Needed with two or more FEM bodies, or FEM and particle bodies.")
    kappa: float | None = Field(
        default=None, gt=0, description="Barrier stiffness (stress unit). Default: adaptive, IPC's rule: bounds from "
        "the mean mass, the scene's size, the time step and dhat; at the first step that starts in contact, the "
        "value that balances the barrier's gradient against the rest of the step's; doubled when the closest "
        "distance keeps shrinking below 1e-9 of the scene's size (docs/bfemp.md). A number here fixes it.")
    friction_velocity: float = Field(
        default=1e-3, gt=0, description="eps_v (velocity unit): slip slower than this is smoothed static friction "
        "(a sticking body creeps below it). Friction coefficients come from contact.default and contact.pairs "
        "(law: coulomb).")
    friction_lags: int = Field(
        default=1, ge=1, le=100, description="Friction lags per step (the paper's outer loop): after Newton "
        "converges, the friction's normal forces and sliding frames are taken again at the new positions and "
        "Newton reruns, until it converges at once or this many lags were taken. 1: lagged once, at the step's "
        "start.")
    linear_solver: Literal["auto", "cholmod", "ldl", "lu"] = Field(
        default="auto", description="The Newton step's sparse solve. cholmod: CHOLMOD's Cholesky factorisation "
        "(scikit-sparse, the extra `cholmod`), its analysis reused while the matrix pattern holds; ldl: mpmsim's "
        "own simplicial LDL^T with a reverse Cuthill-McKee ordering, no BLAS: the same bits on every CPU, its "
        "analysis reused likewise; slower than CHOLMOD on large problems; lu: scipy's SuperLU (its BLAS kernels, "
        "and so its last bits, depend on the CPU). auto: cholmod when installed, else ldl. A matrix that is not "
        "positive definite under cholmod or ldl is solved by SuperLU. The run log names the one used.")
    particle_quadrature: Literal["auto", "domain", "points"] = Field(
        default="auto", description="How the particles integrate the grid's quadratic B-splines (bspline2). "
        "points: their values at the particle centres (the paper's; first order with an odd particle count "
        "per cell direction, where the rows of basis functions cut by a body's end are integrated wrongly). "
        "domain: their averages over each particle's domain, exact where the domains tile the body (second "
        "order with any count; a stencil of 4 nodes per axis, a step 1.4x (2D) to 3.7x (3D) dearer). auto: "
        "domain with an odd particles_per_direction, points with an even one (second order there already).")
    particle_contact: Literal["centres", "corners"] = Field(
        default="centres", description="Where a particle meets FEM boundary edges. centres: at the particle "
        "(the paper's formulation; the load enters half a particle inside the body, first-order accurate). "
        "corners: at the corners of the particle's deformed domain, so the body's surface carries the "
        "contact (second order with 2 or 4 particles per cell direction; 4 contact points per particle in 2D).")


class Update(Strict):
    """Particle update and stress-update order (see docs/timestep.md)."""

    scheme: Literal["flip", "pic", "xpic", "fmpm", "apic"] = Field(
        default="flip",
        description="Particle update. flip: V += dt S a, x += dt S(v+ - a dt/2) (second order). "
        "pic: V = S v+. xpic: XPIC(order), V = S(v* + a dt) with v* the null-space-filtered "
        "grid velocity; xpic with order 1 is pic. fmpm: FMPM(order), V = S v*(v+). apic: affine "
        "PIC (exact angular momentum).",
    )
    order: int | None = Field(
        default=None, ge=1, le=20,
        description="Order m of xpic / fmpm (default 5): m - 1 extra grid passes per step.",
    )
    stress: Literal["usf", "usl", "usavg"] = Field(
        default="usavg",
        description="When the stress is updated: usf (before forces), usl (after the particle "
        "update, from re-extrapolated momenta), usavg (half at each).",
    )

    reextrapolate: bool = Field(
        default=True,
        description="USL/USAVG \"+\" (true): the second stress update re-extrapolates momenta from "
        "the updated particles. false (\"-\"): it uses the updated grid velocity directly; "
        "cheaper, and far less FLIP ringing in long quasi-static runs (docs/stability.md).",
    )
    position: Literal["midpoint", "updated"] = Field(
        default="midpoint",
        description="Particle positions. midpoint: each scheme's second-order form (flip: x += dt S(v+ - a dt/2)). "
        "updated: x += dt S v+, the updated grid velocity, for every scheme: what the stress update integrates "
        "into F, and stable where the stress is large against the moduli (high-rate compaction: the midpoint "
        "forms let FLIP, XPIC and FMPM blow up there; docs/stability.md, \"High-rate compaction\"). Not where "
        "grains of three or more materials are compacted in contact: there updated positions fail with every "
        "scheme, and PIC with the midpoint form is what keeps the volumes (docs/contact.md, \"Ellipses in a box\").",
    )

    @model_validator(mode="after")
    def _default_order(self):
        if self.order is None and self.scheme in ("xpic", "fmpm"):
            self.order = 5
        return self


class Output(Strict):
    """Where and how often to write the VTU series and the CSV history."""

    directory: str | None = Field(
        default=None,
        description="Output directory, relative to the deck's directory. Default: "
        "results/<deck name> under the current directory. `mpmsim run --out` overrides.",
    )
    vtu_interval: float | None = Field(
        default=None, gt=0, description="Simulated time between VTU files. Default: end/20.")
    history_interval: float | None = Field(
        default=None, gt=0, description="Simulated time between CSV history rows. Default: end/200.")
    checkpoint_interval: float | str = Field(
        default="10 min",
        description="How often to save a checkpoint (<stem>_checkpoint.npz, replaced each time; "
        "`mpmsim run DECK --restart DIR` continues from it): a number is simulated time, a string "
        "'N s', 'N min' or 'N h' is wall-clock time, 'off' saves none. A checkpoint is also saved "
        "when Ctrl-C or SIGTERM stops a run; a run that reaches time.end removes it.")
    material_stress: list[str] = Field(
        default_factory=list, description="Deformable materials whose own volume-averaged stress is "
        "added to the history (columns like syy_mat_<name>).")
    null_space_noise: bool = Field(
        default=False, description="Add the history column null_space_noise: the part of the particle "
        "velocities the grid cannot represent, ||V - S S+ V|| / ||V|| with S+ the mass-weighted "
        "pseudo-inverse (a sparse solve per history row). velocity_noise, always written, uses the "
        "transfers' lumped S+ instead and has a floor (docs/shape-functions.md).")
    energy_ledger: bool = Field(
        default=False, description="Add the history columns transfer_loss, contact_loss, friction_loss, "
        "condition_loss, force_gap_loss, fracture_loss and energy_residual: where the work put in goes besides kinetic and strain energy, "
        "booked where it happens in each step (explicit particle runs; three extra tasks per step; "
        "docs/validation.md, \"Energy ledger\").")
    contact_traction: bool = Field(
        default=False, description="Write the grid contact's tractions (docs/output.md): per contact node, "
        "the contact force of the step (pass 2's, as the history's contact_f* sums it) over the node's contact "
        "area A_c (stress unit; normal pressure > 0 in compression, tangential traction, normal, area, force) "
        "as the series <stem>_contact.pvd, and per particle the traction its surface carries "
        "(contact_traction, contact_pressure: its shape-function weights times its nodes' tractions). Explicit "
        "runs with grid contact between two or more material groups.")

    @field_validator("checkpoint_interval")
    @classmethod
    def _checkpoint_interval(cls, v):
        if isinstance(v, str):
            wall_clock_seconds(v)  # raises with the accepted forms
        elif not v > 0:
            raise ValueError("must be a positive simulated time, or 'N s', 'N min', 'N h' (wall clock), or 'off'")
        return v


WALL_UNITS = {"s": 1.0, "min": 60.0, "h": 3600.0}


def wall_clock_seconds(text: str) -> float | None:
    """'N s' / 'N min' / 'N h' in seconds; 'off' is None."""
    if text.strip().lower() == "off":
        return None
    number, _, unit = text.strip().partition(" ")
    try:
        value = float(number)
    except ValueError:
        value = float("nan")
    if unit.strip() not in WALL_UNITS or not 0 < value < 1e9:
        raise ValueError(f"{text!r}: write a wall-clock time as 'N s', 'N min' or 'N h' (N > 0), or 'off'")
    return value * WALL_UNITS[unit.strip()]


class Stability(Strict):
    """When to stop a run as unstable. NaN/Inf, an inverted particle (J <= 0) and a particle
    leaving the grid always stop it; the energy balance check is tunable."""

    energy_tolerance: float = Field(
        default=0.05, gt=0.0,
        description="Energy balance check: stop when kinetic + strain (+ internal) energy exceeds "
        "the initial energy plus the (signed) work of walls, rigid materials and gravity by more than this "
        "fraction of (initial energy + |work|).",
    )
    check_every: int = Field(
        default=10, ge=1,
        description="Steps between energy checks (NaN, inversion and leaving the grid are checked every step).",
    )
    rigid_penetration: bool = Field(
        default=True,
        description="Stop the run when a deformable particle is pushed into a rigid body: its centre more than "
        "half a particle spacing past the rigid body's surface (inside a cell of the rigid body's particle "
        "lattice whose corners are all its particles). Checked every step; false lets such a run go on "
        "(e.g. to measure how far a contact method lets material in).",
    )


class ArtificialViscosity(Strict):
    """Shock artificial viscosity, LR paper Eq. (52): a pressure q = rho dx |D_kk| (A1 C + A2 dx |D_kk|)
    added in compression only (D_kk = tr D < 0), with rho the current density, C the particle's
    current bulk wave speed and dx the smallest cell edge. Its work is added to the particle's
    internal energy, so total energy still balances (docs/shock.md)."""

    A1: float = Field(ge=0, description="Linear coefficient A1 (dimensionless).")
    A2: float = Field(ge=0, description="Quadratic coefficient A2 (dimensionless).")
    materials: list[str] | None = Field(
        default=None, description="Deformable materials it acts on. Default: all of them.")


class Deck(Strict):
    """The problem deck: one YAML file."""

    title: str = Field(description="One line saying what the scene is.")
    units: Literal["SI", "mm-g-ms"] = Field(
        default="SI", description="Named consistent unit system (see docs/units.md).")
    analysis: Literal["plane_strain", "3d", "axisymmetric"] = Field(
        default="plane_strain",
        description="plane_strain (2D), 3d, or axisymmetric: x is the radius r >= 0 and y the axis z; masses, "
        "volumes, forces and energies per radian (docs/axisymmetric.md).",
    )
    thickness: float = Field(default=1.0, gt=0, description="Out-of-plane thickness in 2D.")
    grid: Grid | None = Field(default=None, description="The MPM background grid (needed by particle bodies).")
    shape_function: Literal["linear", "gimp", "cpdi", "cpdi_q", "bspline2", "bspline3", "b2cpdi"] = Field(
        default="gimp",
        description="Particle–grid shape function: linear; gimp (uGIMP); cpdi (linear CPDI on the "
        "deformed particle domain); cpdi_q (9-point qCPDI, 2D); bspline2, bspline3 (quadratic, "
        "cubic B-splines); b2cpdi (CPDI corners with quadratic B-splines).")
    particles_per_direction: int = Field(
        default=2, ge=1, le=8,
        description="Particles per cell along each direction (2 gives 4 per cell in 2D, 8 in 3D).",
    )
    materials: dict[str, Material] = Field(min_length=1)
    bodies: list[Body] = Field(
        min_length=1, description="Bodies in order; a later body overwrites earlier ones where they overlap.")
    gravity: Vector | None = Field(default=None, description="Body acceleration vector.")
    gravity_ramp: float = Field(
        default=0.0, ge=0.0, description="Time over which gravity grows linearly from zero, then is held "
        "(0: all at once). Loading slower than a few wave transits keeps a body resting on another "
        "from ringing under its own weight (docs/timestep.md).")
    loads: list[TractionLoad] = Field(default_factory=list, description="Traction loads on particle edges.")
    damping: Damping | None = Field(default=None, description="Grid damping (static problems).")
    artificial_viscosity: ArtificialViscosity | None = Field(
        default=None, description="Shock artificial viscosity {A1, A2, materials} (Eq. 52). Default: none.")
    contact: Contact = Field(default_factory=Contact, description="Multimaterial contact settings.")
    integrator: Literal["explicit", "implicit"] = Field(
        default="explicit", description="Time integration: explicit (the MPM step as a list of tasks) or implicit "
        "(FEM and particle bodies: an incremental potential minimised by Newton, barrier contact on FEM "
        "boundaries; see `implicit`).")
    implicit: Implicit | None = Field(
        default=None, description="Settings of integrator: implicit (docs/bfemp.md).")
    time: Time
    update: Update = Field(default_factory=Update)
    output: Output = Field(default_factory=Output)
    stability: Stability = Field(default_factory=Stability)

    @property
    def dim(self) -> int:
        return 3 if self.analysis == "3d" else 2


def rebuild_materials() -> None:
    """Let the deck's `materials:` take every registered model (called when one registers)."""
    global Material
    Material = material_union()
    Deck.model_fields["materials"].annotation = dict[str, Material]
    Deck.model_rebuild(force=True)


from .. import materials as _materials  # noqa: E402,F401  (registers the built-in models)

rebuild_materials()
