"""The explicit MPM step as a list of named tasks, built once from the resolved scene.

Only what the scene needs is in the list: no stress-first task for USL, no rigid motion
without rigid materials, no contact tasks for one material. Each entry says why it is there,
and `plan_tasks` also says why each task left out is not needed (`mpmsim check` prints both).
A task is a function of the state; whatever it needs from the deck (scheme, fractions,
tolerances) is bound when the list is built, so nothing reads the deck while a run steps.
The explicit integrator (mpmsim/integrators/explicit.py) runs the list each step.
"""

from __future__ import annotations

from ..contact.cohesive_history import CohesiveInterfaces
from ..contact.grid import ContactTasks, material_fields
from ..contact.grid.spec import COULOMB
from .extrapolate import extrapolate, reextrapolate
from .forces import forces
from .grid_update import grid_update
from .ledger import EnergyLedger
from .particle_update import move_rigid, particle_update
from .setup import compute_shape_functions, gravity_ramp, prescribed_motion
from .stress import stress_kernels, update_stress_first, update_stress_last
from .xpic import xpic
from ..contact.augury import AuguryContact
from .fem import fem_tasks
from .task import Task
from ..shapes import shape_function


def build_task_list(scene) -> list[Task]:
    return plan_tasks(scene)[0]


def plan_tasks(scene) -> tuple[list[Task], list[tuple[str, str]]]:
    """(the step's tasks, [(task left out, why it is not needed)]): the prescribed motions,
    the MPM step when the scene has particle bodies, the FEM step when it has FEM bodies."""
    dt = scene.settings.time.dt
    tasks = [Task("time step", prescribed_motion(scene.materials.motions),
                  f"fixed dt = {dt:g}" if dt else "CFL rule on current wave speeds, every step")]
    skipped: list[tuple[str, str]] = []
    ramp = scene.settings.gravity_ramp
    if ramp > 0.0:
        tasks.append(Task("gravity ramp", gravity_ramp(scene.settings.gravity, ramp),
                          f"gravity grows linearly to its full value over {ramp:g}"))
    augury = AuguryContact(scene) if scene.contact.augury is not None else None
    if scene.has_particles:
        if augury is not None:
            tasks.append(Task("augury carry", augury.carry,
                              "second half of the last augury correction of surface particles"))
        more, skip = mpm_tasks(scene)
        tasks += more
        skipped += skip
    else:
        skipped.append(("particle tasks", "no particle body"))
    if scene.fem is not None:
        tasks += fem_tasks(scene, augury)
    return tasks, skipped


def mpm_tasks(scene) -> tuple[list[Task], list[tuple[str, str]]]:
    """The MPM part of the step (after the time step)."""
    run = scene.settings
    skipped: list[tuple[str, str]] = []
    upd = run.update
    n_rigid = len(scene.materials.rigid)
    faces = [f for f in ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")[: 2 * scene.dim]
             if getattr(run.boundaries, f) != "free"]
    tasks = [
        Task("shape functions", compute_shape_functions,
             f"{run.shape_function} weights and the active node box"),
    ]
    contact = scene.contact.grid
    if contact is not None:
        ct = ContactTasks(contact, scene.grid, shape_function(run.shape_function).grid_kind >= 2, scene.thickness,
                          pass_1_moves_particles=upd.scheme in ("pic", "apic", "fmpm")
                          or (upd.scheme == "xpic" and contact.xpic_term), axisymmetric=run.axisymmetric,
                          history=CohesiveInterfaces(contact.cohesive) if contact.cohesive is not None else None)
        tasks.append(Task("material fields", material_fields,
                          f"{contact.n_groups} material groups: own velocity fields where they meet"))
    else:
        why = ("one material" if len(scene.materials.deformable) < 2 else "all materials joined by contact law none")
        skipped.append(("contact (fields, geometry, passes)", f"{why}: a single velocity field"))
    tasks.append(Task("extrapolate", extrapolate,
                      "mass and momentum to the grid" + (f"; volumes of {n_rigid} rigid material(s)" if n_rigid else "")))
    if contact is not None:
        tasks.append(Task("contact geometry", ct.geometry,
                          f"{contact.normal_name} normals, {contact.describe_separation()}, contact areas"
                          + ("; cohesive damage read from the particles, grown by the openings, carried back"
                             if contact.cohesive is not None else "")))
    if contact is not None and contact.passes == 2:
        tasks.append(Task("contact pass 1", ct.pass_1, "contact laws on the extrapolated momenta"))
    elif contact is not None:
        skipped.append(("contact pass 1", "contact.passes: 1"))
    energy = "; internal energy" + (", artificial viscosity" if run.artificial_viscosity else "") \
        if scene.materials.tracks_energy else ""
    fraction = 0.5 if upd.stress == "usavg" else 1.0
    stress = stress_kernels(scene.materials, scene.dim, run.axisymmetric)  # one per material model in the scene
    if upd.stress in ("usf", "usavg"):
        tasks.append(Task("update stress first", update_stress_first(fraction, stress),
                          f"{upd.stress}: {'half' if upd.stress == 'usavg' else 'full'} step from extrapolated velocities"
                          + energy))
    else:
        skipped.append(("update stress first", f"stress update {upd.stress}"))
    extra = [what for what, on in (("gravity", run.has_gravity),
                                   (f"{len(run.loads)} traction load(s)", run.loads),
                                   ("grid damping", run.damping > 0)) if on]
    tasks.append(Task("forces", forces, "internal forces" + "".join(f", {e}" for e in extra)))
    bc_rigid = [r for r, acts in zip(scene.materials.rigid, scene.materials.rigid_bc) if acts]
    bc = ", ".join(faces + [f"rigid '{r}'" for r in bc_rigid]) or "none"
    tasks.append(Task("grid update", grid_update, f"momentum update; velocity conditions: {bc}"))
    ledger = None
    if run.output.energy_ledger:
        coulomb = contact is not None and bool((contact.law == COULOMB).any())
        pass_1_friction = None if contact is None else "dp1" if ct.pass_1_counts else "hold" if ct.hold_force else None
        ledger = EnergyLedger(upd.stress, upd.reextrapolate, contact is not None and contact.passes == 2, coulomb,
                              pass_1_friction)
        tasks.append(Task("energy ledger: update", ledger.updated,
                          "output.energy_ledger: keep the update's velocities; transfer and pass 1 losses"))
    else:
        skipped.append(("energy ledger", "output.energy_ledger: false"))
    if contact is not None:
        tasks.append(Task("contact pass 2", ct.pass_2, "contact laws on the updated momenta: contact forces"
                          + ("; interface forces and energy" if contact.has_interface else "")))
        if ledger is not None:
            tasks.append(Task("energy ledger: contact", ledger.contact, "rigid contact materials' work in pass 2"))
    if upd.scheme in ("xpic", "fmpm"):
        what = "start-of-step" if upd.scheme == "xpic" else "updated"
        tasks.append(Task("xpic", xpic(upd.scheme, upd.order, contact), f"{upd.scheme.upper()}({upd.order}): filter the {what} grid velocity, "
                                        f"{upd.order - 1} extra grid passes"))
    else:
        skipped.append(("xpic", f"{upd.scheme} update needs no grid filter"))
    name = f"{upd.scheme}({upd.order})" if upd.order else upd.scheme
    tasks.append(Task("particle update", particle_update(upd.scheme, upd.position, scene.dim),
                      f"{name} velocity and position update"
                      + ("; positions by the updated grid velocity" if upd.position == "updated" else "")))
    if n_rigid:
        tasks.append(Task("move rigid", move_rigid, "rigid materials follow their prescribed velocity"))
    else:
        skipped.append(("move rigid", "no rigid materials"))
    if upd.stress in ("usl", "usavg") and upd.reextrapolate:
        tasks.append(Task("re-extrapolate", reextrapolate, "momenta from the updated particles (usl+/usavg+)"))
        if contact is not None:
            how = ("pass 2's decisions kept" if not ct.recheck
                   else "geometry recomputed, pass 2's contacts kept unless separating, new ones tested"
                   if ct.spec.persist else "geometry recomputed from the moved particles, contact re-tested")
            tasks.append(Task("contact pass 3", ct.pass_3, f"contact laws on the re-extrapolated momenta ({how})"))
    if upd.stress in ("usl", "usavg"):
        source = "re-extrapolated momenta" if upd.reextrapolate else "updated grid velocities"
        tasks.append(Task("update stress last", update_stress_last(fraction, upd.reextrapolate, stress),
                          f"{upd.stress}: {'half' if upd.stress == 'usavg' else 'full'} step from {source}" + energy))
    else:
        skipped.append(("update stress last", f"stress update {upd.stress}"))
    if ledger is not None:
        tasks.append(Task("energy ledger: step", ledger.step_end,
                          "transfer, contact, condition and force-gap losses of the step"))
    return tasks, skipped
