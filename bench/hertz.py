"""Hertz contact, plane strain: an elastic cylinder pressed on a rigid flat, frictionless LR
contact, the pressure read from the contact traction output (output.contact_traction).

    python bench/hertz.py run --rh 20 40 [--set contact.normal=average_gradient ...]
    python bench/hertz.py run --rh 20 40 --seeding rings --pair --end 0.9   # two cylinders
    python bench/hertz.py run --rh 20 --sphere [--seeding shells]             # 3D, a quarter sphere
    python bench/hertz.py run --rh 40 80 --sphere --rz --a 1 --seeding rings_half_step  # the sphere, axisymmetric
    python bench/hertz.py run --rh 20 40 --half --seeding rings_half_step     # the half cylinder x >= 0
    python bench/hertz.py run --rh 20 40 --augury [--hc 1]    # an FEM cylinder on an FEM block, augury contact
    python bench/hertz.py run --rh 20 40 80 --barrier         # an MPM cylinder on an FEM block, barrier contact
    python bench/hertz.py chart          # docs/figures/hertz_pressure.png from saved runs
    python bench/hertz.py table          # the docs/contact.md table from saved runs

The cylinder (R = 10 mm, E = 1000 MPa, nu = 0.3, 1 g/cm^3, mm-g-ms) rests on a rigid
contact-material flat and is loaded by a body force (gravity) ramped by the platen-free
route: gravity is held constant and grid damping brings the cylinder to rest; the load is
P = m g per unit thickness, chosen so that the Hertz half-width is a = 2 mm:
a = sqrt(4 P R / (pi E*)), E* = E / (1 - nu^2) (rigid flat), p0 = 2 P / (pi a),
p(x) = p0 sqrt(1 - x^2 / a^2).

Measured from the last output frame's contact nodes (the rigid flat's contact targets):
each grid column x_i gets the pressure p_i = sum of the normal forces of its contact nodes
/ sum of their contact areas (the traction output's own definition, per column); the
load carried is the sum of the normal forces; the half-width from the force's second
moment, a_m = 2 sqrt(sum x^2 F / sum F) (= a for the Hertz distribution), and from the
outermost loaded column; the centre pressure is p at x = 0 (a grid line).
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FIGURES = ROOT / "docs" / "figures"
RESULTS = ROOT / "results" / "bench_hertz"

R, E, NU, RHO = 10.0, 1000.0, 0.3, 0.001
A_TARGET = 2.0
E_STAR = E / (1.0 - NU**2)
P_TARGET = math.pi * A_TARGET**2 * E_STAR / (4.0 * R)  # N per mm of thickness
P0 = 2.0 * P_TARGET / (math.pi * A_TARGET)


def run_settings(alpha: float, end: float) -> dict:
    """What every Hertz deck shares: grid damping alpha, frictionless contact, FLIP with USAVG,
    CFL 0.5 to `end`, ten frames and 100 history rows with the contact tractions."""
    return {"damping": {"grid": alpha}, "contact": {"default": {"law": "frictionless"}},
            "time": {"end": end, "cfl": 0.5}, "update": {"scheme": "flip", "stress": "usavg"},
            "output": {"vtu_interval": end / 10, "history_interval": end / 100, "contact_traction": True,
                       "checkpoint_interval": "off"}}

def hertz(P: float, e_star: float = E_STAR) -> tuple[float, float]:
    """(a, p0) for a load P per unit thickness (E* the rigid flat's unless given)."""
    a = math.sqrt(4.0 * P * R / (math.pi * e_star))
    return a, 2.0 * P / (math.pi * a)


def deck(rh: float, end: float | None = None, damping: float | None = None, overrides: dict | None = None,
         pair: bool = False, a_target: float = A_TARGET, seeding: str = "lattice", half: bool = False) -> dict:
    """The Hertz scene at R/h = rh (a mapping for Simulation.from_deck). pair: a second,
    identical cylinder (material `upper`) stacked on the first (`lower`): their contact at
    y = 2R carries the upper one's weight P; for two identical cylinders R* = R/2 and
    E* = E / (2 (1 - nu^2)), so a = sqrt(4 P R* / (pi E*)) is the same as on the rigid flat.
    half: the symmetry model, the cylinder clipped to x >= 0 on a roller wall at x = 0 (the
    grid's xmin), carrying half the load."""
    h = R / rh
    c = math.sqrt(E * (1 - NU) / ((1 + NU) * (1 - 2 * NU)) / RHO)  # P-wave speed, mm/ms
    load = math.pi * a_target**2 * E_STAR / (4.0 * R)  # the Hertz load of half-width a_target
    g = load / (RHO * math.pi * R**2)  # gravity that gives it (N/mm: thickness 1)
    # the fundamental (bouncing) mode on the contact is slow; damp it near critically
    alpha = damping if damping is not None else c / R
    end = end if end is not None else 40.0 * R / c
    w = 3.0 * A_TARGET
    data = {
        "title": f"Hertz cylinder on a rigid flat, R/h = {rh:g}",
        "units": "mm-g-ms",
        "analysis": "plane_strain",
        "grid": {"cell_size": h, "domain": {"min": [-R - 2 * h, -2 * h],
                                            "max": [R + 2 * h, (4 if pair else 2) * R + 2 * h]}},
        "shape_function": "gimp",
        "particles_per_direction": 2,
        "materials": {
            "cylinder": {"type": "linear_elastic", "E": E, "nu": NU, "density": RHO},
            "flat": {"type": "rigid", "mode": "contact", "velocity": [0.0, 0.0]},
        },
        "bodies": [
            {"name": "cylinder", "shape": "circle", "center": [0.0, R], "radius": R, "material": "cylinder",
             **({} if seeding == "auto" else {"seeding": seeding})},  # auto: written plainly, the default
            {"name": "flat", "shape": "rectangle", "min": [-w, -2 * h], "max": [w, 0.0], "material": "flat"},
        ],
        "gravity": [0.0, -g],
        **run_settings(alpha, end),
        "stability": {},
    }
    if half:
        data["title"] = f"Hertz half cylinder on a rigid flat, R/h = {rh:g}"
        data["grid"]["domain"]["min"][0] = 0.0
        data["grid"]["boundaries"] = {"xmin": "roller"}
        data["bodies"][0]["clip"] = {"min": [0.0, -1.0], "max": [R + 1.0, 2 * R + 1.0]}
        data["bodies"][1]["min"][0] = 0.0
    if pair:
        data["title"] = f"Two Hertz cylinders on a rigid flat, R/h = {rh:g}"
        data["materials"] = {"lower": dict(data["materials"]["cylinder"]), "upper": dict(data["materials"]["cylinder"]),
                             "flat": data["materials"]["flat"]}
        data["bodies"] = [{**data["bodies"][0], "material": "lower", "name": "lower"},
                          {"name": "upper", "shape": "circle", "center": [0.0, 3 * R], "radius": R, "material": "upper",
                           "seeding": seeding},
                          {**data["bodies"][1], "min": [-w * 1.5, -2 * h], "max": [w * 1.5, 0.0]}]
    return apply_overrides(data, overrides)


def apply_overrides(data: dict, overrides: dict | None) -> dict:
    """Set the dotted keys of `overrides` (deck.key.sub: value) in the deck mapping `data`."""
    for key, value in (overrides or {}).items():
        node = data
        parts = key.split(".")
        for p in parts[:-1]:
            node = node.setdefault(p, {})
        node[parts[-1]] = value
    return data


def pressure_profile(contact_mesh, flat_group: int | None = None) -> dict:
    """Per grid column: x, normal force, area, pressure (force / area), from one frame of the
    contact part (a meshio mesh). Targets against the rigid flat only (partner_group)."""
    pd = contact_mesh.point_data
    x = contact_mesh.points[:, 0]
    n = np.asarray(pd["normal"])[:, :2]
    f = np.asarray(pd["contact_force"])[:, :2]
    area = np.asarray(pd["contact_area"])
    keep = np.ones(len(x), dtype=bool) if flat_group is None else np.asarray(pd["partner_group"]) == flat_group
    fy = -np.sum(f * n, axis=1)[keep]  # the normal force, > 0 in compression
    xs = np.round(x[keep], 9)
    cols = np.unique(xs)
    F = np.array([fy[xs == c].sum() for c in cols])
    A = np.array([area[keep][xs == c].sum() for c in cols])
    p = np.divide(F, A, out=np.zeros_like(F), where=A > 0)
    pn = np.asarray(pd["contact_pressure"])[keep]
    h = float(np.diff(cols).min()) if len(cols) > 1 else 1.0
    big = area[keep] >= 0.1 * h  # nodes with a tenth of a column's area or more (thickness 1)
    return {"x": cols, "F": F, "A": A, "p": p, "node_p_max": float(pn.max()) if len(pn) else 0.0,
            "node_p_max_area": float(area[keep][np.argmax(pn)]) if len(pn) else 0.0,
            "node_p_max_big": float(pn[big].max()) if big.any() else 0.0}


def particle_pressures(out: Path, files: list[str], y0: float = 0.0) -> dict:
    """The particles' contact_pressure averaged over frames (same particles in every frame),
    for the particles within R/2 of the contact level y0 that carry some: x (last frame), p."""
    import meshio

    ps = [meshio.read(out / f) for f in files]
    p = np.mean([np.asarray(m.point_data["contact_pressure"]) for m in ps], axis=0)
    on = (p > 0.0) & (np.abs(ps[-1].points[:, 1] - y0) < 0.5 * R)
    return {"x": ps[-1].points[on, 0], "p": p[on]}


def bottom_row(P, data: dict, half: bool, a: float, p0: float) -> dict:
    """The pressure read as a user reads it from the particles: -sigma_yy of the bottom row (the
    particles within one particle spacing of the lowest surface, their centres half a spacing above
    the contact, where Hertz's sigma_yy is within 0.2% of p(x) at R/h >= 20), at the end of the run;
    the half model's mirrored. Centre: the mean of the particles within a spacing of x = 0; half-width:
    Hertz's ellipse fitted to those above a tenth of the peak (p^2 linear in x^2)."""
    s = data["grid"]["cell_size"] / data["particles_per_direction"]
    x, y, p = P.x[:, 0], P.x[:, 1], -P.stress[:, 1]
    r = np.hypot(x, y - R)
    row = (y < R) & (r > R - s)  # the outer layer of the lower half: one spacing deep, lattice or rings
    x, p = x[row], p[row]
    if half:
        x, p = np.concatenate([x, -x]), np.concatenate([p, p])
    centre = float(p[np.abs(x) < s].mean())
    fit = p > 0.1 * p.max()
    c = np.linalg.lstsq(np.stack([np.ones(fit.sum()), x[fit] ** 2], 1), p[fit] ** 2, rcond=None)[0]
    a_fit = math.sqrt(-c[0] / c[1]) if c[0] > 0 > c[1] else float("nan")
    return {"row_centre_error": centre / p0 - 1.0, "row_a_fit_error": a_fit / a - 1.0}


def average_profiles(profiles: list[dict]) -> dict:
    """Column forces and areas averaged over frames (columns missing from a frame count 0)."""
    cols = np.unique(np.concatenate([p["x"] for p in profiles]))
    F, A = np.zeros(len(cols)), np.zeros(len(cols))
    for p in profiles:
        at = np.searchsorted(cols, p["x"])
        F[at] += p["F"] / len(profiles)
        A[at] += p["A"] / len(profiles)
    top = max(profiles, key=lambda p: p["node_p_max"])
    return {"x": cols, "F": F, "A": A, "p": np.divide(F, A, out=np.zeros_like(F), where=A > 0),
            "node_p_max": top["node_p_max"], "node_p_max_area": top["node_p_max_area"],
            "node_p_max_big": max(p.get("node_p_max_big", np.nan) for p in profiles)}


def measure(prof: dict, P_applied: float, e_star: float = E_STAR) -> dict:
    """Half-width, centre pressure, load balance and peak against Hertz for the applied load."""
    a, p0 = hertz(P_applied, e_star)
    x, F, p = prof["x"], prof["F"], prof["p"]
    load = float(F.sum())
    on = F > 1e-6 * max(abs(F).max(), 1e-300)
    a_moment = 2.0 * math.sqrt(float((x**2 * F).sum() / load))
    a_extent = float(np.abs(x[on]).max()) if on.any() else 0.0
    centre = float(np.interp(0.0, x, p))
    # Hertz's ellipse fitted to the columns that carry load (p^2 = p0^2 (1 - x^2 / a^2),
    # least squares over the columns above a tenth of the largest pressure)
    fit = p > 0.1 * p.max()
    c = np.linalg.lstsq(np.stack([np.ones(fit.sum()), x[fit] ** 2], 1), p[fit] ** 2, rcond=None)[0]
    a_fit = math.sqrt(-c[0] / c[1]) if c[0] > 0 > c[1] else float("nan")
    inner = np.abs(x) < 0.8 * a
    ph = p0 * np.sqrt(np.clip(1 - (x / a) ** 2, 0, None))
    return {"a_hertz": a, "p0_hertz": p0, "load_applied": P_applied, "load_carried": load,
            "load_error": load / P_applied - 1.0, "a_moment": a_moment, "a_moment_error": a_moment / a - 1.0,
            "a_fit": a_fit, "a_fit_error": a_fit / a - 1.0, "p0_fit_error": math.sqrt(max(c[0], 0.0)) / p0 - 1.0,
            "a_extent": a_extent, "centre_p": centre, "centre_error": centre / p0 - 1.0,
            "p_max_over_p0": float(p.max() / p0), "node_p_max_over_p0": prof["node_p_max"] / p0,
            "node_p_max_area": prof["node_p_max_area"],
            "node_p_max_big_over_p0": float(prof.get("node_p_max_big", np.nan)) / p0, "profile_max_error": float(np.abs(p[inner] - ph[inner]).max() / p0)
            if inner.any() else float("nan")}


def run_case(rh: float, overrides: dict | None = None, out: Path | None = None, end: float | None = None,
             threads: int | None = None, seeding: str = "lattice", pair: bool = False,
             a_target: float = A_TARGET, half: bool = False) -> dict:
    """Run one resolution; returns the measurement and the profile (also saved as JSON).
    seeding: the circles' deck option, lattice (the grid-aligned lattice sites inside the circle,
    a staircase surface) or rings (rings that follow the surface)."""
    import meshio

    from mpmsim.deck import as_loaded_deck
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation

    data = deck(rh, end=end, overrides=overrides, pair=pair, a_target=a_target, seeding=seeding, half=half)
    tag = ("pair_" if pair else "") + ("half_" if half else "") + f"rh{rh:g}" + ("" if seeding == "lattice" else f"_{seeding}") + (
        "" if a_target == A_TARGET else f"_a{a_target:g}") + "".join(
        f"_{k.split('.')[-1]}-{v}" for k, v in (overrides or {}).items())
    tag = re.sub(r"[^\w.-]", "", tag)
    out = out or RESULTS / tag
    t0 = time.perf_counter()
    scene = build_scene(as_loaded_deck(data, "hertz", None))
    sim = Simulation(scene, out_dir=out, threads=threads)
    sim.run()
    wall = time.perf_counter() - t0
    hist = sim.history
    pvd = out / "hertz_contact.pvd"
    end_t = data["time"]["end"]
    # the frames of the last third of the run (0.7, 0.8, 0.9 end), without the final one (its step is shortened
    # to land on time.end, and a contact force over that sliver of a step is not the state's)
    frames = [(float(t), f) for t, f in re.findall(r'timestep="([^"]+)"[^>]*file="([^"]+)"', pvd.read_text())
              if 0.65 * end_t <= float(t) < end_t * (1 - 1e-9)]
    names = sim.state.contact.spec.group_names
    partner = names.index("upper" if pair else "flat")
    meshes = [meshio.read(out / f) for _, f in frames]
    prof = average_profiles([pressure_profile(mesh, partner) for mesh in meshes])
    if half:  # the whole contact: the columns x > 0 mirrored, the symmetry line's (its nodes' half) doubled
        x, side = prof["x"], prof["x"] > 0.0
        on_axis = np.where(x == 0.0, 2.0, 1.0)
        for k in ("F", "A"):
            prof[k] = np.concatenate([prof[k][side][::-1], prof[k] * on_axis])
        prof["x"] = np.concatenate([-x[side][::-1], x])
        prof["p"] = np.divide(prof["F"], prof["A"], out=np.zeros_like(prof["F"]), where=prof["A"] > 0)
    prof["frames"] = np.array([t for t, _ in frames])
    y0 = 2 * R if pair else 0.0
    part = particle_pressures(out, [f.replace("_contact_", "_") for _, f in frames], y0)
    P = sim.state.particles
    m = P.mass[P.body == P.body.max()].sum() if pair else P.mass.sum()  # the upper cylinder's, or the one's
    m *= 2.0 if half else 1.0  # (the load of the whole cylinder)
    g = -data["gravity"][1]
    result = measure(prof, float(m * g))
    if pair:  # where the contact sits: the force's centroid, and its level, against the symmetry x = 0
        xc, yc = [], []
        for mesh in meshes:
            pd = mesh.point_data
            on = np.asarray(pd["partner_group"]) == partner
            fn = -np.sum(np.asarray(pd["contact_force"])[on, :2] * np.asarray(pd["normal"])[on, :2], axis=1)
            xc.append(float((mesh.points[on, 0] * fn).sum() / fn.sum()))
            yc.append(float((mesh.points[on, 1] * fn).sum() / fn.sum()))
        result["contact_x_over_h"] = float(np.max(np.abs(xc)) / (R / rh))
        result["contact_y"] = float(np.mean(yc))
    a_h, p0_h = result["a_hertz"], result["p0_hertz"]
    inner = np.abs(part["x"]) < 0.8 * a_h
    hz = p0_h * np.sqrt(np.clip(1 - (part["x"] / a_h) ** 2, 0, None))
    result["particle_p_max_over_p0"] = float(part["p"].max() / p0_h)
    result["particle_profile_max_error"] = float(np.abs(part["p"][inner] - hz[inner]).max() / p0_h)
    if not pair:
        result.update(bottom_row(sim.state.particles, data, half, a_h, p0_h))
    result.update({"seeding": seeding, "rh": rh, "h": R / rh, "overrides": overrides or {}, "wall_s": wall, "steps": int(hist["step"].iloc[-1]),
                   "reaction_y": float(hist["F_flat_y"].iloc[-1]), "n_particles": int(sim.state.particles.n),
                   "ke_final": float(hist["kinetic_energy"].iloc[-1]) if "kinetic_energy" in hist else None})
    prof_json = {k: np.asarray(v).tolist() for k, v in prof.items()}
    result["frames"] = prof_json.pop("frames")
    (out / "hertz_result.json").write_text(json.dumps({"result": result, "profile": prof_json}, indent=1))
    return {"result": result, "profile": prof}


def sphere_load(a: float = A_TARGET) -> float:
    """The load on a sphere of radius R for the Hertz contact radius a on a rigid flat:
    a^3 = 3 P R / (4 E*); p0 = 3 P / (2 pi a^2), p(r) = p0 sqrt(1 - r^2 / a^2)."""
    return 4.0 * E_STAR * a**3 / (3.0 * R)


def sphere_deck(rh: float, end: float | None = None, a_target: float = A_TARGET, seeding: str = "lattice",
                rz: bool = False) -> dict:
    """A quarter of an elastic sphere (x, z >= 0; roller faces xmin and zmin are its symmetry
    planes) of the cylinder's material on a rigid flat, loaded by gravity for the Hertz contact
    radius a_target; seeding lattice (the grid-aligned sites inside the sphere: a stepped surface, a flat
    bottom facet) or shells (concentric shells that follow the surface, clipped to the quarter).
    rz: the same sphere axisymmetric (its half disk r >= 0; seeding lattice, rings or rings_half_step)."""
    h = R / rh
    c = math.sqrt(E * (1 - NU) / ((1 + NU) * (1 - 2 * NU)) / RHO)
    g = sphere_load(a_target) / (RHO * 4.0 / 3.0 * math.pi * R**3)
    end = end if end is not None else 40.0 * R / c
    w = 3.0 * a_target
    # the bouncing mode on the contact, k = dP/d(approach) = 2 E* a, damped critically: alpha = 2 sqrt(k / m)
    # (the cylinder's c / R is 1.8 times that here, and the load creeps to -4.9% in 40 R / c)
    alpha = 2.0 * math.sqrt(2.0 * E_STAR * a_target / (RHO * 4.0 / 3.0 * math.pi * R**3))
    return {
        "title": f"Hertz sphere on a rigid flat (quarter), R/h = {rh:g}",
        "units": "mm-g-ms",
        "analysis": "3d",
        "grid": {"cell_size": h, "domain": {"min": [0.0, -2 * h, 0.0], "max": [R + 2 * h, 2 * R + 2 * h, R + 2 * h]},
                 "boundaries": {"xmin": "roller", "zmin": "roller"}},
        "shape_function": "gimp",
        "particles_per_direction": 2,
        "materials": {"sphere": {"type": "linear_elastic", "E": E, "nu": NU, "density": RHO},
                      "flat": {"type": "rigid", "mode": "contact", "velocity": [0.0, 0.0, 0.0]}},
        "bodies": [{"name": "sphere", "shape": "sphere", "center": [0.0, R, 0.0], "radius": R, "material": "sphere",
                    "seeding": seeding, "clip": {"min": [0.0, -1.0, 0.0], "max": [R + 1.0, 2 * R + 1.0, R + 1.0]}},
                   {"name": "flat", "shape": "box", "min": [0.0, -2 * h, 0.0], "max": [w, 0.0, w], "material": "flat"}],
        "gravity": [0.0, -g, 0.0],
        **run_settings(alpha, end),
    } if not rz else {
        "title": f"Hertz sphere on a rigid flat (axisymmetric), R/h = {rh:g}",
        "units": "mm-g-ms",
        "analysis": "axisymmetric",
        "grid": {"cell_size": h, "domain": {"min": [0.0, -2 * h], "max": [R + 2 * h, 2 * R + 2 * h]}},
        "shape_function": "gimp",
        "particles_per_direction": 2,
        "materials": {"sphere": {"type": "linear_elastic", "E": E, "nu": NU, "density": RHO},
                      "flat": {"type": "rigid", "mode": "contact", "velocity": [0.0, 0.0]}},
        "bodies": [{"name": "sphere", "shape": "circle", "center": [0.0, R], "radius": R, "material": "sphere",
                    "seeding": seeding,
                    "clip": {"min": [0.0, -1.0], "max": [R + 1.0, 2 * R + 1.0]}},
                   {"name": "flat", "shape": "rectangle", "min": [0.0, -2 * h], "max": [w, 0.0], "material": "flat"}],
        "gravity": [0.0, -g],
        **run_settings(alpha, end),
    }


def run_sphere(rh: float, out: Path | None = None, end: float | None = None, threads: int | None = None,
               seeding: str = "lattice", rz: bool = False, a_target: float = A_TARGET) -> dict:
    """The quarter sphere at R/h = rh; the pressure per normal line of contact nodes (the traction
    output's contact_pressure: each node carries its line's), averaged over the frames of the
    last third; radius from the force's second moment, a_m = sqrt(5/2 sum r^2 F / sum F) (= a for
    Hertz's distribution), and from Hertz's ellipsoid fitted to the lines above a tenth of the
    peak; the load carried (4 x the quarter's) against the applied m g. rz: the axisymmetric
    sphere; forces and areas per radian (x 2 pi), a line per node column r_i; the centre pressure
    is the ellipsoid's p(0) = sqrt(c_0) fitted to the columns off the axis (the axis column stands
    for half a hat of shape function, its area per radian from a mean radius of about h/3, and
    reads low: 0.76 p0 at R/h = 20).
    The same read from the final frame alone: the final_* keys."""
    from mpmsim.deck import as_loaded_deck
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation

    data = sphere_deck(rh, end=end, seeding=seeding, rz=rz, a_target=a_target)
    out = out or RESULTS / (f"sphere{'_rz' if rz else ''}_rh{rh:g}" + ("" if seeding == "lattice" else f"_{seeding}")
                            + ("" if a_target == A_TARGET else f"_a{a_target:g}"))
    whole = 2.0 * math.pi if rz else 4.0  # the whole body's share: per radian, or a quarter
    t0 = time.perf_counter()
    sim = Simulation(build_scene(as_loaded_deck(data, "hertz", None)), out_dir=out, threads=threads)
    sim.run()
    wall = time.perf_counter() - t0
    end_t = data["time"]["end"]
    pvd = out / "hertz_contact.pvd"
    stamped = [(float(t), f) for t, f in re.findall(r'timestep="([^"]+)"[^>]*file="([^"]+)"', pvd.read_text())]
    P = sim.state.particles
    P_applied = whole * float(P.mass.sum()) * -data["gravity"][1]
    # the frames of the last third, and the final frame alone (the run's steps are of one length,
    # so its last step is a step like the others; the load still creeps up by a few percent over
    # the last third while the damping brings the sphere to rest)
    last_third = sphere_reading(out, [f for t, f in stamped if t >= 0.65 * end_t], rz, whole, P_applied)
    final = sphere_reading(out, [stamped[-1][1]], rz, whole, P_applied)
    hist = sim.history
    result = {**last_third["result"], **{f"final_{k}": v for k, v in final["result"].items()},
              "rh": rh, "h": R / rh, "analysis": "axisymmetric" if rz else "3d",
              "reaction_y": whole * float(hist["F_flat_y"].iloc[-1]),
              "n_particles": int(P.n), "steps": int(hist["step"].iloc[-1]), "wall_s": wall, "seeding": seeding}
    r, F, A, p = (last_third["profile"][k] for k in "rFAp")
    (out / "hertz_result.json").write_text(json.dumps({"result": result, "profile": {
        "r": r.tolist(), "F": F.tolist(), "A": A.tolist(), "p": p.tolist()}}, indent=1))
    return {"result": result, "profile": {"r": r, "F": F, "A": A, "p": p}, "final_profile": final["profile"]}


def sphere_reading(out: Path, files: list[str], rz: bool, whole: float, P_applied: float) -> dict:
    """run_sphere's measurement over the contact frames `files` (averaged): the pressure per
    node column (3D: per normal line), the load carried, the contact radius by the second
    moment and by Hertz's ellipsoid fitted above a tenth of the peak, the centre pressure
    (r-z: the fitted ellipsoid's, fitted off the axis), each against Hertz for the
    applied load."""
    import meshio

    lines: dict[tuple, list] = {}
    node_p_max = 0.0
    for f in files:
        pd = meshio.read(out / f)
        fn = -np.sum(np.asarray(pd.point_data["contact_force"]) * np.asarray(pd.point_data["normal"]), axis=1)
        area = np.asarray(pd.point_data["contact_area"])
        node_p_max = max(node_p_max, float(np.asarray(pd.point_data["contact_pressure"]).max()))
        xz = np.round(pd.points[:, [0, 2]], 9)  # (rz: (r, 0))
        for key in np.unique(xz, axis=0):
            on = np.all(xz == key, axis=1)
            acc = lines.setdefault(tuple(key), [0.0, 0.0])
            acc[0] += fn[on].sum() / len(files)
            acc[1] += area[on].sum() / len(files)
    keys = np.array(sorted(lines))
    F = np.array([lines[tuple(k)][0] for k in keys])
    A = np.array([lines[tuple(k)][1] for k in keys])
    r = np.hypot(keys[:, 0], keys[:, 1])
    p = np.divide(F, A, out=np.zeros_like(F), where=A > 0)
    a = (3.0 * P_applied * R / (4.0 * E_STAR)) ** (1 / 3)
    p0 = 3.0 * P_applied / (2.0 * math.pi * a**2)
    load = whole * float(F.sum())
    a_m = math.sqrt(2.5 * float((r**2 * F).sum() / F.sum()))
    fit = (p > 0.1 * p.max()) & ((r > 0.0) if rz else True)  # r-z: the axis column's half hat reads low
    c = np.linalg.lstsq(np.stack([np.ones(fit.sum()), r[fit] ** 2], 1), p[fit] ** 2, rcond=None)[0]
    a_fit = math.sqrt(-c[0] / c[1]) if c[0] > 0 > c[1] else float("nan")
    inner = r < 0.8 * a
    ph = p0 * np.sqrt(np.clip(1 - (r / a) ** 2, 0, None))
    centre = math.sqrt(c[0]) if rz and c[0] > 0 else (float(p[r == 0].max()) if np.any(r == 0) else float("nan"))
    return {"result": {"a_hertz": a, "p0_hertz": p0, "load_applied": P_applied, "load_carried": load,
                       "load_error": load / P_applied - 1, "a_moment_error": a_m / a - 1, "a_fit_error": a_fit / a - 1,
                       "centre_error": centre / p0 - 1, "p_max_over_p0": float(p.max() / p0),
                       "node_p_max_over_p0": node_p_max / p0,
                       "profile_max_error": float(np.abs(p[inner] - ph[inner]).max() / p0), "frames": len(files)},
            "profile": {"r": r, "F": F, "A": A, "p": p}}


E_FLAT = 10.0 * E  # the FEM flat of the augury and barrier scenes: ten times stiffer than the cylinder


def e_star_fem(e_flat: float) -> float:
    """Plane-strain E* of the cylinder on an elastic flat of the same nu: 1/E* = (1 - nu^2) (1/E + 1/E_flat)."""
    return 1.0 / ((1.0 - NU**2) * (1.0 / E + 1.0 / e_flat))


def fem_deck(rh: float, end: float | None = None, hc_ratio: float = 2.0, cfl: float = 0.4, e_flat: float = E_FLAT
             ) -> dict:
    """The Hertz scene with FEM bodies and augury contact: a plane-strain FEM disk (the mesher's
    concentric rings, element size h = R / rh, surface node spacing ~1.05 h) of the cylinder's
    material resting on a stiffer FEM block (20 x 8 mm, element size h, bottom held, E_flat, the
    cylinder's density),
    loaded by gravity for the Hertz half-width a = 2 mm with 1/E* = (1 - nu^2)(1/E + 1/E_flat);
    augury grid h_c = hc_ratio h, frictionless, APIC, one iteration. No grid damping here
    (FEM nodes have none): run_augury damps the node velocities itself."""
    h = R / rh
    c = math.sqrt(E * (1 - NU) / ((1 + NU) * (1 - 2 * NU)) / RHO)
    load = math.pi * A_TARGET**2 * e_star_fem(e_flat) / (4.0 * R)
    g = load / (RHO * math.pi * R**2)  # nominal: run_augury measures the mesh's own mass
    end = end if end is not None else 40.0 * R / c
    hc = hc_ratio * h
    gap = 0.25 * hc  # the cylinder's lowest node starts a quarter augury cell above the block
    return {
        "title": f"Hertz FEM cylinder on an FEM block, augury contact, R/h = {rh:g}",
        "units": "mm-g-ms", "analysis": "plane_strain",
        "materials": {"cylinder": {"type": "linear_elastic", "E": E, "nu": NU, "density": RHO},
                      "flat": {"type": "linear_elastic", "E": e_flat, "nu": NU, "density": RHO}},
        "bodies": [
            {"name": "cylinder", "shape": "circle", "center": [0.0, R + gap], "radius": R, "material": "cylinder",
             "discretization": "fem", "element_size": h},
            {"name": "flat", "shape": "rectangle", "min": [-R, -8.0], "max": [R, 0.0], "material": "flat",
             "discretization": "fem", "element_size": h,
             "constraints": [{"region": {"min": [-2 * R, -8.0 - 0.5 * h], "max": [2 * R, -8.0 + 0.5 * h]}}]}],
        "gravity": [0.0, -g],
        "contact": {"default": {"law": "frictionless"},
                    "augury": {"cell_size": hc, "transfer": "apic", "iterations": 1}},
        "time": {"end": end, "cfl": cfl},
        "output": {"history_interval": end / 100, "checkpoint_interval": "off"},
    }


def node_columns(x: np.ndarray, fn: np.ndarray, spacing: np.ndarray) -> dict:
    """A profile (measure's input) from per-node normal forces fn at positions x with tributary
    lengths `spacing` (thickness 1): each node is its own column, p = fn / spacing."""
    order = np.argsort(x)
    x, fn, spacing = x[order], fn[order], spacing[order]
    p = fn / spacing
    return {"x": x, "F": fn, "A": spacing, "p": p, "node_p_max": float(p.max()), "node_p_max_area": float(
        spacing[np.argmax(p)]), "node_p_max_big": float(p.max())}


def run_augury(rh: float, end: float | None = None, hc_ratio: float = 2.0, threads: int | None = 1,
               out: Path | None = None, e_flat: float = E_FLAT) -> dict:
    """The FEM Hertz scene through augury contact, brought to rest by mass-proportional damping
    of the FEM node velocities (v and the boundary nodes' affine B scaled by exp(-alpha dt) after
    every step, alpha = c / R as the MPM scene's grid damping). The contact force on each of the
    block's top nodes is its augury force m a_contact (the normal, y, part), averaged over the
    steps of the last third of the run (the nodes within 1.5 a of the centre); the tributary
    length is half its two boundary edges; the load applied is the FEM disk's mass times g (the inscribed polygon's area)."""
    from mpmsim.deck import as_loaded_deck
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation

    data = fem_deck(rh, end=end, hc_ratio=hc_ratio, e_flat=e_flat)
    t0 = time.perf_counter()
    sim = Simulation(build_scene(as_loaded_deck(data, "hertz", None)), out_dir=None, threads=threads)
    st, fem = sim.state, sim.state.fem
    c = math.sqrt(E * (1 - NU) / ((1 + NU) * (1 - 2 * NU)) / RHO)
    alpha = c / R
    end_t = data["time"]["end"]
    body = fem.node_body
    flat = [i.name for i in fem.infos].index("flat")
    top = np.flatnonzero((body == flat) & (np.abs(fem.X[:, 1]) < 1e-9))
    # tributary length of each top node: half its boundary edges along the top face
    edges = fem.facets[np.all(np.isin(fem.facets, top), axis=1)]
    trib = np.zeros(fem.n)
    length = np.linalg.norm(fem.X[edges[:, 1]] - fem.X[edges[:, 0]], axis=1)
    np.add.at(trib, edges[:, 0], 0.5 * length)
    np.add.at(trib, edges[:, 1], 0.5 * length)
    cyl = body == [i.name for i in fem.infos].index("cylinder")
    f_sum, n_avg, f_cyl = np.zeros(len(top)), 0, 0.0
    steps = 0
    while st.t < end_t * (1 - 1e-9):
        sim.step()
        steps += 1
        decay = math.exp(-alpha * st.dt)
        fem.v *= decay
        fem.B *= decay
        if st.t >= 0.65 * end_t:
            f_sum -= fem.mass[top] * fem.a_contact[top, 1]  # the force pressing the block down
            f_cyl += float((fem.mass[cyl] * fem.a_contact[cyl, 1]).sum())
            n_avg += 1
    wall = time.perf_counter() - t0
    g = -data["gravity"][1]
    P_applied = float(fem.mass[cyl].sum() * g)
    # the profile over |x| <= 1.5 a_Hertz: beyond it the top nodes touch nothing, and what the augury
    # transfers give them (a single body's own smoothing, of either sign) is reported as far_force
    f_top = f_sum / n_avg
    a_h = hertz(P_applied, e_star_fem(e_flat))[0]
    near = np.abs(fem.X[top, 0]) <= 1.5 * a_h
    prof = node_columns(fem.X[top[near], 0], f_top[near], trib[top[near]])
    result = measure(prof, P_applied, e_star_fem(e_flat))
    result["far_force"] = float(np.abs(f_top[~near]).sum() / P_applied)
    result.update({"load_on_cylinder_error": f_cyl / n_avg / P_applied - 1.0, "rh": rh, "h": R / rh,
                   "hc": hc_ratio * R / rh, "e_flat": e_flat, "wall_s": wall, "steps": steps,
                   "n_nodes": int(fem.n), "n_cells": int(len(fem.cells)),
                   "ke_final": float(0.5 * (fem.mass[cyl] * (fem.v[cyl] ** 2).sum(1)).sum()),
                   "gap_at_centre": float(fem.x[cyl, 1].min() - fem.x[top[np.argmin(np.abs(fem.X[top, 0]))], 1])})
    out = out or RESULTS / f"augury_rh{rh:g}_hc{hc_ratio:g}_flat{e_flat / E:g}"
    out.mkdir(parents=True, exist_ok=True)
    (out / "hertz_result.json").write_text(json.dumps({"result": result, "profile": {
        k: np.asarray(v).tolist() for k, v in prof.items()}}, indent=1))
    return {"result": result, "profile": prof}


def barrier_deck(rh: float, dt: float = 0.05, steps: int = 12, e_flat: float = E_FLAT) -> dict:
    """The Hertz scene through the implicit barrier contact (BFEMP, docs/bfemp.md): the MPM
    cylinder (ring-seeded, 2 particles per direction, B-spline 2, APIC) of the cylinder's
    material on a stiffer FEM block (20 x 8 mm, element size h, bottom held, E_flat, the cylinder's
    density), loaded by gravity for a = 2 mm (1/E* = (1 - nu^2)(1/E + 1/E_flat)); backward Euler with dt = 0.05 ms,
    six times the cylinder's R/c: the step's numerical damping brings the cylinder to rest in a
    few steps. d_hat = h/20; the block's face 2 d_hat under the lowest particle centre (R - s/2
    below the centre: the barrier acts on particle centres), frictionless."""
    h = R / rh
    dhat = h / 20.0
    load = math.pi * A_TARGET**2 * e_star_fem(e_flat) / (4.0 * R)
    g = load / (RHO * math.pi * R**2)
    top = h / 4.0 - 2.0 * dhat  # the lowest ring's centres sit at y = s / 2 = h / 4
    return {
        "title": f"Hertz MPM cylinder on an FEM block, barrier contact, R/h = {rh:g}",
        "units": "mm-g-ms", "analysis": "plane_strain",
        "grid": {"cell_size": h, "domain": {"min": [-R - 2 * h, top - 8.0 - h], "max": [R + 2 * h, 2 * R + 2 * h]}},
        "shape_function": "bspline2", "particles_per_direction": 2, "update": {"scheme": "apic"},
        "materials": {"cylinder": {"type": "linear_elastic", "E": E, "nu": NU, "density": RHO},
                      "flat": {"type": "linear_elastic", "E": e_flat, "nu": NU, "density": RHO}},
        "bodies": [
            {"name": "cylinder", "shape": "circle", "center": [0.0, R], "radius": R, "material": "cylinder",
             "seeding": "rings"},
            {"name": "flat", "shape": "rectangle", "min": [-R, top - 8.0], "max": [R, top], "material": "flat",
             "discretization": "fem", "element_size": h,
             "constraints": [{"region": {"min": [-2 * R, top - 8.0 - 0.5 * h], "max": [2 * R, top - 8.0 + 0.5 * h]}}]}],
        "gravity": [0.0, -g],
        "integrator": "implicit",
        "implicit": {"scheme": "backward_euler", "dhat": dhat, "newton_tolerance": 1.0e-3},
        "contact": {"default": {"law": "frictionless"}},
        "time": {"end": steps * dt, "dt": dt},
        "output": {"vtu_interval": 10 * steps * dt, "history_interval": 10 * steps * dt, "checkpoint_interval": "off"},
    }


def barrier_node_forces(sim, top: np.ndarray) -> np.ndarray:
    """The barrier's normal force on each of the block's top nodes (top: their indices, ordered
    by x): each particle centre within d_hat of the top face pushes with w_p (-b'(d)) (d its
    distance to the edge under it, w_p its barrier weight), shared by the edge's two nodes as
    the point-edge distance's gradient shares it, (1 - t) and t at the closest point's
    parameter t (the face is straight to within its deflection; the vertex correction of
    pairs whose closest point is an edge's end is left out)."""
    from mpmsim.contact.barrier.energy import BarrierContact
    from mpmsim.contact.barrier.potential import barrier_normal_force

    term = next(t for t in sim.integrator.terms if isinstance(t, BarrierContact))
    P, fem = sim.state.particles, sim.state.fem
    w = term.particle_weights(P.vol0, np.arange(P.n), False)
    xt = fem.x[top]
    k = np.clip(np.searchsorted(xt[:, 0], P.x[:, 0]) - 1, 0, len(top) - 2)
    a, b = xt[k], xt[k + 1]
    e = b - a
    t = np.clip(np.einsum("pc,pc->p", P.x - a, e) / np.einsum("pc,pc->p", e, e), 0.0, 1.0)
    d = np.linalg.norm(P.x - (a + t[:, None] * e), axis=1)
    near = (d < term.dhat) & (P.x[:, 1] > a[:, 1] - 0.5 * term.dhat)
    f = np.zeros(len(top))
    fp = w[near] * np.array([barrier_normal_force(x, term.dhat, term.kappa) for x in d[near]]) / term.thickness
    np.add.at(f, k[near], fp * (1.0 - t[near]))
    np.add.at(f, k[near] + 1, fp * t[near])
    return f


def run_barrier(rh: float, dt: float = 0.05, steps: int = 12, threads: int | None = 1, out: Path | None = None,
                e_flat: float = E_FLAT, overrides: dict | None = None) -> dict:
    """The MPM cylinder on the FEM block through the barrier contact; the per-node pressure of the
    block's top face (barrier_node_forces / the node's tributary length, half its two top edges)
    after the last step; the load applied is the particles' mass times g. Prints the load carried
    after every step (the approach to rest)."""
    from mpmsim.deck import as_loaded_deck
    from mpmsim.scene import build_scene
    from mpmsim.solver import Simulation

    data = apply_overrides(barrier_deck(rh, dt=dt, steps=steps, e_flat=e_flat), overrides)
    t0 = time.perf_counter()
    sim = Simulation(build_scene(as_loaded_deck(data, "hertz", None)), out_dir=None, threads=threads)
    st, fem = sim.state, sim.state.fem
    top_y = data["bodies"][1]["max"][1]
    top = np.flatnonzero(np.abs(fem.X[:, 1] - top_y) < 1e-9)
    top = top[np.argsort(fem.X[top, 0])]
    trib = np.zeros(len(top))
    dx = np.diff(fem.X[top, 0])
    trib[:-1] += 0.5 * dx
    trib[1:] += 0.5 * dx
    g = -data["gravity"][1]
    P_applied = float(st.particles.mass.sum() * g)
    history = []
    while st.t < data["time"]["end"] * (1 - 1e-9):
        sim.step()
        f = barrier_node_forces(sim, top)
        history.append((float(st.t), float(f.sum()) / P_applied - 1.0))
        print(f"R/h = {rh:g} t = {st.t:.3f} load carried / applied - 1 = {history[-1][1]:+.2e}", flush=True)
    wall = time.perf_counter() - t0
    prof = node_columns(fem.X[top, 0], f, trib)
    result = measure(prof, P_applied, e_star_fem(e_flat))
    result.update({"rh": rh, "h": R / rh, "dt": dt, "e_flat": e_flat, "steps": steps, "wall_s": wall,
                   "n_particles": int(st.particles.n),
                   "load_history": history, "dhat": R / rh / 20.0})
    out = out or RESULTS / re.sub(r"[^\w.-]", "", f"barrier_rh{rh:g}_flat{e_flat / E:g}" + "".join(
        f"_{k.split('.')[-1]}-{v}" for k, v in (overrides or {}).items()))
    out.mkdir(parents=True, exist_ok=True)
    (out / "hertz_result.json").write_text(json.dumps({"result": result, "profile": {
        k: np.asarray(v).tolist() for k, v in prof.items()}}, indent=1))
    return {"result": result, "profile": prof}


def chart(tags: list[str], path: Path, title: str = "") -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    xs = np.linspace(-1, 1, 201)
    ax.plot(xs, np.sqrt(1 - xs**2), "k-", lw=2, label="Hertz")
    for tag, marker in zip(tags, "os^dv<>"):
        d = json.loads((RESULTS / tag / "hertz_result.json").read_text())
        r, p = d["result"], d["profile"]
        ax.plot(np.array(p["x"]) / r["a_hertz"], np.array(p["p"]) / r["p0_hertz"], marker + "-", ms=4, lw=1,
                label=f"R/h = {r['rh']:g}")
    ax.set_xlim(-1.6, 1.6)
    ax.set_xlabel("x / a")
    ax.set_ylabel("p / p0")
    ax.grid(alpha=0.3)
    ax.legend()
    if title:
        ax.set_title(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def parse_set(items: list[str]) -> dict:
    import yaml

    return {k: yaml.safe_load(v) for k, v in (s.split("=", 1) for s in items)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=["run", "chart", "table"])
    ap.add_argument("--rh", type=float, nargs="+", default=[20.0, 40.0, 80.0])
    ap.add_argument("--set", nargs="*", default=[], help="deck overrides key=value (YAML values)")
    ap.add_argument("--seeding", choices=["lattice", "auto", "rings", "rings_half_step", "shells"], default="lattice",
                    help="circles: lattice, auto (no seeding key: the default), rings or rings_half_step; the sphere "
                         "(--sphere): lattice or shells")
    ap.add_argument("--pair", action="store_true", help="two identical cylinders stacked on the flat")
    ap.add_argument("--half", action="store_true", help="the half cylinder x >= 0 on a symmetry (roller) line")
    ap.add_argument("--sphere", action="store_true", help="3D: a quarter sphere on the flat (lattice-seeded)")
    ap.add_argument("--rz", action="store_true", help="with --sphere: the sphere axisymmetric (r-z)")
    ap.add_argument("--augury", action="store_true", help="an FEM cylinder on an FEM block, augury contact")
    ap.add_argument("--barrier", action="store_true", help="an MPM cylinder on an FEM block, implicit barrier contact")
    ap.add_argument("--flat", type=float, default=E_FLAT / E,
                    help="the FEM flat's E / the cylinder's (--augury, --barrier)")
    ap.add_argument("--hc", type=float, default=2.0, help="augury grid cell / element size (--augury)")
    ap.add_argument("--a", type=float, default=A_TARGET, help="Hertz half-width the load is set for (mm)")
    ap.add_argument("--end", type=float, help="simulated time (default 40 R / c)")
    ap.add_argument("--threads", type=int)
    ap.add_argument("--tags", nargs="*", help="saved runs for chart/table (default rh20 rh40 rh80)")
    ap.add_argument("--out", default=str(FIGURES / "hertz_pressure.png"))
    ap.add_argument("--title", default="")
    args = ap.parse_args(argv)
    if args.what == "run":
        for rh in args.rh:
            if args.barrier:
                print(json.dumps(run_barrier(rh, threads=args.threads, e_flat=args.flat * E,
                                             overrides=parse_set(args.set))["result"]))
                continue
            if args.augury:
                print(json.dumps(run_augury(rh, end=args.end, hc_ratio=args.hc, threads=args.threads,
                                            e_flat=args.flat * E)["result"]))
                continue
            if args.sphere:
                seeding = args.seeding if args.rz else ("shells" if args.seeding == "shells" else "lattice")
                print(json.dumps(run_sphere(rh, end=args.end, threads=args.threads, seeding=seeding, rz=args.rz,
                                            a_target=args.a)["result"]))
                continue
            r = run_case(rh, parse_set(args.set), end=args.end, threads=args.threads, seeding=args.seeding,
                         pair=args.pair, a_target=args.a, half=args.half)["result"]
            print(json.dumps(r))
            sys.stdout.flush()
        return 0
    tags = args.tags or sorted(p.parent.name for p in RESULTS.glob("*/hertz_result.json"))
    if args.what == "chart":
        chart(tags, Path(args.out), args.title)
        print(args.out)
        return 0
    print("| run | R/h | load carried vs applied | a (ellipse fit) | a (moment) | p(0) vs p0 | max column p / p0 | "
          "max \\|p − Hertz\\| / p0, \\|x\\| < 0.8a | max node p / p0 | same, A_c ≥ 0.1 h | "
          "particles: max p / p0, max \\|p − Hertz\\| / p0 |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for tag in tags:
        saved = json.loads((RESULTS / tag / "hertz_result.json").read_text())
        old, prof = saved["result"], {k: np.asarray(v) for k, v in saved["profile"].items()}
        prof.setdefault("node_p_max", np.nan)
        prof.setdefault("node_p_max_area", np.nan)
        prof.setdefault("node_p_max_big", np.nan)
        r = measure(prof, old["load_applied"])  # measured again: every row by the same rules
        print(f"| {tag} | {old['rh']:g} | {r['load_error']:+.3%} | {r['a_fit_error']:+.1%} | "
              f"{r['a_moment_error']:+.1%} | {r['centre_error']:+.1%} | {r['p_max_over_p0']:.2f} | "
              f"{r['profile_max_error']:.1%} | {float(r['node_p_max_over_p0']):.2f} | "
              f"{float(r['node_p_max_big_over_p0']):.2f} | {old.get('particle_p_max_over_p0', np.nan):.2f}, "
              f"{old.get('particle_profile_max_error', np.nan):.1%} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
