"""The run loop's check after every step: stop the run, with when/where/which body, when the
state goes bad.

Each body set reports its own faults (kernels flag the first bad particle they meet: NaN/Inf,
J <= 0, left the grid; a rigid body leaving the grid). Every `stability.check_every` steps
the total mechanical energy of all bodies (kinetic + strain + internal + energy stored in
interfaces) is compared with the energy supplied (initial energy + work of walls, rigid
bodies, gravity and loads); growth beyond `stability.energy_tolerance` stops the run.
"""

from __future__ import annotations

import numpy as np

from .bodies import INTERNAL, KINETIC, STRAIN
from .deck.units import unit_system
from .errors import InstabilityError

REMEDY = ("try a smaller time.cfl, update.scheme: pic, or update.stress: usavg; raise "
          "stability.energy_tolerance to accept the drift")


def excess_text(excess: float, supplied: float) -> str:
    return f"{100 * excess / supplied:.1f}%" if supplied > 0.0 else f"{excess:.4g}"


def total_sums(state, detail: bool = False):
    """Sums over every body set that carries mass (bodies.Sums layout), or None."""
    total = None
    for body in state.bodies:
        s = body.sums(state, detail)
        if s is None:
            continue
        total = s.total if total is None else total + s.total
    return total


class StabilityCheck:
    def __init__(self, scene):
        stab = scene.settings.stability
        self.tolerance = stab.energy_tolerance
        self.every = stab.check_every
        self.units = unit_system(scene.settings.units)
        self.sync = lambda state: None  # brings the host state up to date (a GPU run's: Simulation)

    def where(self, state) -> str:
        """The failing step: its number (1-based) and its end time."""
        return f"step {state.step + 1}, t = {state.t + state.dt:.6g} {self.units.time}"

    def __call__(self, state) -> None:
        if state.flags.bad_particle >= 0 or state.flags.bad_rigid >= 0:
            self.sync(state)  # (the message names the particle and where it is)
        for body in state.bodies:
            fault = body.check(state, self.units)
            if fault is not None:
                verb, what = fault
                raise InstabilityError(f"{verb} at {self.where(state)}: {what}", state.t, state.step)
        if (state.step + 1) % self.every:
            return
        sums = total_sums(state)
        if sums is None:
            return
        total = sums[KINETIC] + sums[STRAIN] + sums[INTERNAL] + state.interface_energy  # interfaces store energy
        supplied = state.energy0 + state.work_in
        excess = total - supplied
        if excess > self.tolerance * (state.energy0 + abs(state.work_in)) + state.energy_floor:
            self.sync(state)
            fastest = "; ".join(f for f in (b.fastest(state, self.units) for b in state.bodies) if f)
            stored = f" + {state.interface_energy:.4g} (interfaces)" if state.interface_energy else ""
            raise InstabilityError(
                f"unstable at {self.where(state)}: energy grew without a source: kinetic + strain + internal = "
                f"{sums[KINETIC]:.4g} + {sums[STRAIN]:.4g} + {sums[INTERNAL]:.4g}{stored} exceeds the energy supplied "
                f"({supplied:.4g}) by {excess_text(excess, supplied)}; fastest is {fastest}; {REMEDY}",
                state.t, state.step)


# a rigid body's travel towards the deformable material, as a fraction of the material's extent
# along that axis, above which `mpmsim check` warns about methods that lose track of volume
# under compaction (and, travelling away from it, about FLIP in large stretches)
COMPACTION_WARN_STRAIN = 0.1


def rigid_travel(scene, x) -> tuple[float, str, float, str]:
    """(compression, who, stretch, who): the largest travel of a rigid material towards the
    deformable particles (positions x) and away from them, each as a fraction of the
    particles' extent along the axis, and the rigid material that makes it. The side a rigid
    material is on along an axis is that of its particles' centroid against the deformable
    particles' centroid; moving towards that centroid compresses, moving away stretches; on
    neither side (centroids level on that axis) either way counts as compression."""
    mats, rigid = scene.materials, scene.rigid
    extent = np.maximum(x.max(axis=0) - x.min(axis=0), 1e-300)
    centre = x.mean(axis=0)
    found = [0.0, "", 0.0, ""]
    for k, (name, motion) in enumerate(zip(mats.rigid, mats.motions)):
        dmin, dmax = motion.displacement_envelope(scene.deck.time.end)
        own = rigid.x[rigid.mat == k]
        side = np.sign(own.mean(axis=0) - centre) if len(own) else np.zeros_like(centre)
        # towards the material: against the side it is on; away: along it
        toward = np.where(side > 0, -dmin, np.where(side < 0, dmax, np.maximum(-dmin, dmax)))
        away = np.where(side > 0, dmax, np.where(side < 0, -dmin, 0.0))
        for slot, travel in ((0, toward), (2, away)):
            fraction = float(np.max(np.maximum(travel, 0.0) / extent))
            if fraction > found[slot]:
                found[slot], found[slot + 1] = fraction, name
    return found[0], found[1], found[2], found[3]


def compaction_warnings(scene, x) -> list[str]:
    """Warnings for a deck whose rigid bodies travel towards the deformable particles
    (positions x) by more than COMPACTION_WARN_STRAIN of their extent with a method measured to
    let the particle volumes J V0 drift from the space the material fills (docs/stability.md,
    "High-rate compaction"; docs/contact.md, "Ellipses in a box"): any scheme but PIC where
    three or more deformable materials meet in contact; FLIP, XPIC or FMPM with the midpoint
    position updates; uGIMP with PIC; a rigid *contact* material meeting two or more deformable
    materials in contact (the rigid material takes the node, so the others are not kept apart
    there). A rigid body travelling away from the material stretches it: there only FLIP is
    warned about (docs/stability.md, "FLIP ringing in long quasi-static compressions": a bar
    pulled to 100% strain with FLIP tears for every shape function; XPIC(5) with CPDI,
    inputs/stretch.yaml, ends within 0.16% of the analytic stress)."""
    deck, mats = scene.deck, scene.materials
    upd = deck.update
    if not mats.rigid or len(x) == 0:
        return []
    worst, who, stretch, puller = rigid_travel(scene, x)
    out = []
    if stretch >= COMPACTION_WARN_STRAIN and upd.scheme == "flip":
        out.append(f"rigid '{puller}' pulls the material {100 * stretch:.0f}% of its extent with update.scheme flip: "
                   "in large stretches FLIP's ringing grows until the body tears (a bar pulled to 100% strain tore "
                   "with every shape function); use update.scheme: xpic with shape_function: cpdi "
                   "(docs/stability.md, \"FLIP ringing in long quasi-static compressions\")")
    if worst < COMPACTION_WARN_STRAIN:
        return out
    moves = f"rigid '{who}' travels {100 * worst:.0f}% of the material's extent towards it"
    in_contact = len(mats.deformable) >= 2 and scene.contact.default.law != "none"
    if in_contact and len(mats.deformable) >= 3 and upd.scheme != "pic":
        out.append(f"{moves} with update.scheme {upd.scheme} and {len(mats.deformable)} deformable materials in "
                   "contact: where grains of three or more materials meet and the voids between them close, only "
                   "PIC has been measured to keep the particle volumes within the space the material fills (ellipse "
                   "box: FLIP, XPIC(5) and APIC end 1.17-1.22 x the box area or stop on energy growth, PIC 1.00 x); "
                   "use update.scheme: pic (docs/contact.md, \"Ellipses in a box\")")
    elif upd.position == "midpoint" and upd.scheme in ("flip", "xpic", "fmpm"):
        out.append(f"{moves} with update.scheme {upd.scheme} and update.position midpoint: under large "
                   "compression these positions let the kinetic energy grow and the particle volumes stop adding "
                   "up; use update.position: updated (docs/stability.md, \"High-rate compaction\")")
    if deck.shape_function == "gimp" and upd.scheme == "pic":
        out.append(f"{moves} with shape_function gimp and update.scheme pic: uGIMP's particle domains keep their "
                   "initial size, and PIC's projection on them lets the particle volumes drift from the space the "
                   "material fills (0.9% at 75% confined compression); use shape_function: cpdi (docs/stability.md, "
                   "\"High-rate compaction\")")
    contact = [n for n, m in deck.materials.items() if getattr(m, "mode", None) == "contact"]
    if contact and in_contact:
        out.append(f"rigid contact material '{contact[0]}' with {len(mats.deformable)} deformable materials in "
                   "contact: at nodes the rigid material reaches, each material contacts it alone, so deformable "
                   "materials meeting there are not kept apart (measured on the ellipse box: the row under the "
                   "piston interpenetrates, and the particle volumes end 1.09 x the box area); a flat piston is "
                   "exact as a velocity condition (mode: bc, constrain) (docs/contact.md, \"Ellipses in a box\")")
    return out
