"""`mpmsim paraview RESULTS`: a ParaView Python script beside a run's VTU series.

The script opens `<stem>.pvd` (deformable particles and FEM bodies), colours it by material
with a categorical lookup table annotated with the names the files carry (field data
`material_names`), shows a second view of one stress component with its colour bar (FEM cell
stresses are averaged to the nodes so one colour map covers both) with the run's stress unit,
and draws the rigid collection `<stem>_rigid.pvd`, when there is one, in grey (listed grey in the
material legend). Both views use a parallel camera that keeps the data in the left 75% of the
view and the colour bar in the strip on its right. 3D scenes are seen from an oblique (iso)
direction, or along an axis (`--view`), and the stress view shows the half below a middle plane
(`--cut`, default z), seen from its cut face, which opens the bodies and their contact. A
`--time` more than half the frames' interval from every frame is an error naming the nearest. The script is plain ParaView
(`paraview.simple`, ParaView 5.10 or newer); `paraview --script=FILE` opens it in the GUI,
`pvbatch FILE --screenshot out.png` renders a picture, and `--report` prints what it shows
(JSON) for checks. An axisymmetric series (its particles carry `hoop_stress`) is shown revolved
in the left view: the r-z plane turned upright (the axis along z) and swept three quarters round
the axis by ParaView's RotationalExtrusion, seen obliquely; the right view keeps the r-z section
with the stress (`--section`: both views the section).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import meshio
import numpy as np

from .atomic import write_text
from .vtu import NAMES_FIELD, OWN_COLLECTION, material_names

COMPONENTS = ("xx", "yy", "zz", "xy", "yz", "xz")  # the order of the `stress` array
# distinct colours (Okabe-Ito, then grey-free extras) for the categorical table
PALETTE = [(0.90, 0.62, 0.0), (0.34, 0.71, 0.91), (0.0, 0.62, 0.45), (0.94, 0.89, 0.26),
           (0.0, 0.45, 0.70), (0.84, 0.37, 0.0), (0.80, 0.47, 0.65), (0.55, 0.34, 0.16),
           (0.58, 0.40, 0.74), (0.09, 0.75, 0.81)]

class ResultsError(ValueError):
    """A results folder that holds no usable series (the command line: one line, exit 2)."""


TEMPLATE = '''\
"""ParaView script for the mpmsim results {stem!r}.

  paraview --script={script}                 (GUI)
  pvbatch {script} --screenshot out.png [--time T] [--stress yy] [--view iso|x|y|z] [--cut x|y|z|none]
  pvbatch {script} --report                  (what is shown, as JSON)
"""
import argparse
import json
import os
import sys

from paraview.simple import *  # noqa: F401,F403

STEM = {stem!r}
MATERIALS = {materials!r}  # index = the `material` id of the files
PALETTE = {palette!r}
COMPONENTS = {components!r}
DIM = {dim}
RIGID = {rigid!r}  # material ids of the rigid materials (drawn grey, listed grey)
AXISYMMETRIC = {axisymmetric!r}  # x = r, y = z: the left view revolves the section about the axis
GREY = (0.6, 0.6, 0.6)
UNIT = {unit!r}  # the stress unit of the run (from its history's sidecar; empty if none)
SPACING = {spacing!r}  # median distance between neighbouring particles at t = 0 (0: no particles)
HERE = os.path.dirname(os.path.abspath(__file__)) if "__file__" in globals() else {folder!r}


def style(display):
    """Particles as discs (2D) or spheres (3D) of the particle spacing; with FEM bodies in the
    series, surfaces (particles as points of a few pixels)."""
    if SPACING > 0:
        display.SetRepresentationType("Point Gaussian")
        display.GaussianRadius = 0.5 * SPACING
        display.ShaderPreset = "Plain circle" if DIM == 2 else "Sphere"
    else:  # particles beside mesh cells: points of a few pixels
        display.SetRepresentationType("Surface")
        display.PointSize = 5
        display.RenderPointsAsSpheres = 1


def frame_time(times, wanted):
    """The frame at `wanted`: the nearest, unless it is off by more than half the frames' usual
    interval (then None and the two nearest frames)."""
    nearest = sorted(times, key=lambda s: abs(s - wanted))
    if len(times) < 2:
        return nearest[0], nearest[:1]
    gaps = sorted(b - a for a, b in zip(times[:-1], times[1:]))
    interval = gaps[len(gaps) // 2]
    if abs(nearest[0] - wanted) > 0.5 * interval * (1.0 + 1e-9):
        return None, sorted(nearest[:2])
    return nearest[0], nearest[:1]


def camera_axes(view_name):
    """(direction the camera looks, view up) for a view along an axis, or the iso view."""
    if view_name == "x":
        return (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0)
    if view_name == "y":
        return (0.0, -1.0, 0.0), (0.0, 0.0, 1.0)
    if view_name == "z":
        return (0.0, 0.0, -1.0), (0.0, 1.0, 0.0)
    return (-1.0, -0.6, -1.2), (0.0, 1.0, 0.0)  # iso: from +x, +y, +z, y up


def frame_camera(view, bounds, direction, up, size):
    """A parallel projection looking along `direction` with the data's box in the left 75% of
    the view (the colour bar sits in the strip on the right) and 5% margins; returns the box's
    extent in normalised view coordinates (x0, x1, y0, y1)."""
    import math

    n = math.sqrt(sum(c * c for c in direction))
    d = [c / n for c in direction]
    dot = sum(a * b for a, b in zip(up, d))
    u = [a - dot * b for a, b in zip(up, d)]
    n = math.sqrt(sum(c * c for c in u))
    u = [c / n for c in u]
    r = [d[1] * u[2] - d[2] * u[1], d[2] * u[0] - d[0] * u[2], d[0] * u[1] - d[1] * u[0]]
    corners = [(x, y, z) for x in bounds[0:2] for y in bounds[2:4] for z in bounds[4:6]]
    px = [sum(a * b for a, b in zip(c, r)) for c in corners]
    py = [sum(a * b for a, b in zip(c, u)) for c in corners]
    w, h = max(px) - min(px), max(py) - min(py)
    aspect = size[0] / size[1]
    half = max(w / (0.7 * 2.0 * aspect), h / (0.9 * 2.0), 1e-30)  # parallel scale: half the height
    width = 2.0 * half * aspect
    cx = min(px) - 0.05 * width + 0.5 * width  # box from 5% of the width
    cy = 0.5 * (min(py) + max(py))
    centre = [0.5 * (bounds[0] + bounds[1]), 0.5 * (bounds[2] + bounds[3]), 0.5 * (bounds[4] + bounds[5])]
    pc = sum(a * b for a, b in zip(centre, r)), sum(a * b for a, b in zip(centre, u))
    focal = [c + (cx - pc[0]) * ri + (cy - pc[1]) * ui for c, ri, ui in zip(centre, r, u)]
    depth = 2.0 * max(w, h, bounds[5] - bounds[4], 1e-30)
    view.CameraParallelProjection = 1
    view.CameraFocalPoint = focal
    view.CameraPosition = [f - depth * di for f, di in zip(focal, d)]
    view.CameraViewUp = u
    view.CameraParallelScale = half
    view.ResetCameraClippingRange() if hasattr(view, "ResetCameraClippingRange") else None
    left = (min(px) - (cx - 0.5 * width)) / width
    right = (max(px) - (cx - 0.5 * width)) / width
    bottom = (min(py) - (cy - half)) / (2.0 * half)
    top = (max(py) - (cy - half)) / (2.0 * half)
    return [left, right, bottom, top]


def place_bar(bar):
    """The colour bar in the strip right of the data (frame_camera keeps it free)."""
    bar.WindowLocation = "Any Location"
    bar.Orientation = "Vertical"
    bar.Position = [0.85, 0.1]
    bar.ScalarBarLength = 0.8
    return [0.85, 0.1]


def main(argv):
    ap = argparse.ArgumentParser(prog=STEM + "_paraview.py")
    ap.add_argument("--screenshot", help="write a PNG of the layout and quit")
    ap.add_argument("--time", type=float, help="output time to show (default: the last)")
    ap.add_argument("--stress", default={stress!r}, choices=COMPONENTS, help="stress component of the right view")
    ap.add_argument("--view", choices=["iso", "x", "y", "z"], default=None,
                    help="camera of the left view: along an axis or iso (default: z in 2D, iso in 3D)")
    ap.add_argument("--cut", choices=["x", "y", "z", "none"], default=None,
                    help="3D: the stress view shows the half below the middle plane normal to this axis, seen "
                         "along it, which opens the bodies' inside and their contact (default: z; none: whole)")
    ap.add_argument("--report", action="store_true", help="print what is shown as JSON")
    ap.add_argument("--section", action="store_true",
                    help="axisymmetric: show the r-z section in both views (default: the left one revolved)")
    args = ap.parse_args(argv)

    reader = PVDReader(registrationName=STEM, FileName=os.path.join(HERE, STEM + ".pvd"))
    reader.UpdatePipelineInformation()
    times = list(reader.TimestepValues) or [0.0]
    if args.time is None:
        t = times[-1]
    else:
        t, near = frame_time(times, args.time)
        if t is None:
            sys.stderr.write("no output frame at --time %g: the nearest are %s (of %d frames from %g to %g)\\n"
                             % (args.time, " and ".join("%g" % s for s in near), len(times), times[0], times[-1]))
            sys.exit(2)
    view_name = args.view or ("z" if DIM == 2 else "iso")
    cut = (args.cut or ("none" if DIM == 2 else "z")) if DIM == 3 else "none"
    scene = GetAnimationScene()
    scene.UpdateAnimationUsingDataTimeSteps()
    scene.AnimationTime = t
    nodal = CellDatatoPointData(registrationName=STEM + " (nodal)", Input=reader)
    nodal.PassCellData = 1
    nodal.UpdatePipeline(t)
    revolve = AXISYMMETRIC and not args.section
    body = nodal
    if revolve:  # (r, z, 0) -> (r, 0, z), swept 270 degrees about z, turned back (the axis along y)
        upright = Transform(registrationName=STEM + " (upright)", Input=nodal)
        upright.Transform = "Transform"
        upright.Transform.Rotate = [90.0, 0.0, 0.0]
        surface = ExtractSurface(registrationName=STEM + " (surface)", Input=upright)
        swept = RotationalExtrusion(registrationName=STEM + " (swept)", Input=surface)
        swept.Resolution = 72
        swept.Angle = 270.0
        body = Transform(registrationName=STEM + " (revolved)", Input=swept)
        body.Transform = "Transform"
        body.Transform.Rotate = [-90.0, 0.0, 0.0]
        body.UpdatePipeline(t)

    left = CreateView("RenderView")
    right = CreateView("RenderView")
    layout = CreateLayout(STEM)
    layout.SplitHorizontal(0, 0.5)
    AssignViewToLayout(view=left, layout=layout, hint=1)
    AssignViewToLayout(view=right, layout=layout, hint=2)
    size = [800, 700]
    for view in (left, right):
        view.ViewSize = size
        view.OrientationAxesVisibility = 0 if DIM == 2 and not (revolve and view is left) else 1

    # left: material, categorical; rigid materials grey, as they are drawn
    shown = Show(body, left)
    style(shown)
    ColorBy(shown, ("POINTS", "material"))
    lut = GetColorTransferFunction("material")
    lut.InterpretValuesAsCategories = 1
    annotations, colours = [], []
    for k, name in enumerate(MATERIALS):
        annotations += [str(k), name]
        colours += list(GREY if k in RIGID else PALETTE[k % len(PALETTE)])
    lut.Annotations = annotations
    lut.IndexedColors = colours
    shown.SetScalarBarVisibility(left, True)
    material_bar = GetScalarBar(lut, left)
    material_bar.Title = "material"
    material_bar.ComponentTitle = ""
    place_bar(material_bar)

    # right: one stress component with its colour bar (3D: the half below a middle plane)
    component = COMPONENTS.index(args.stress)
    source = nodal
    bounds = nodal.GetDataInformation().GetBounds()
    if cut != "none":
        axis = "xyz".index(cut)
        origin = [0.5 * (bounds[0] + bounds[1]), 0.5 * (bounds[2] + bounds[3]), 0.5 * (bounds[4] + bounds[5])]
        normal = [0.0, 0.0, 0.0]
        normal[axis] = 1.0
        source = Clip(registrationName=STEM + " (cut)", Input=nodal)
        source.ClipType = "Plane"
        source.ClipType.Origin = origin
        source.ClipType.Normal = normal
        source.Crinkleclip = 1
        source.Invert = 1  # keep the side below the plane
        source.UpdatePipeline(t)
    stress_shown = Show(source, right)
    style(stress_shown)
    ColorBy(stress_shown, ("POINTS", "stress", ["XX", "YY", "ZZ", "XY", "YZ", "XZ"][component]))
    stress_shown.RescaleTransferFunctionToDataRange(True, False)
    stress_shown.SetScalarBarVisibility(right, True)
    stress_lut = GetColorTransferFunction("stress")
    bar = GetScalarBar(stress_lut, right)
    bar.Title = "stress " + args.stress + (" (" + UNIT + ")" if UNIT else "")
    bar.ComponentTitle = ""
    bar_at = place_bar(bar)

    rigid_path = os.path.join(HERE, STEM + "_rigid.pvd")
    rigid = None
    if os.path.exists(rigid_path):
        rigid = PVDReader(registrationName=STEM + " rigid", FileName=rigid_path)
        rigid.UpdatePipeline(t)
        for view in ((right,) if revolve else (left, right)):
            r = Show(rigid, view)
            style(r)
            ColorBy(r, ("POINTS", None))
            r.AmbientColor = r.DiffuseColor = list(GREY)
        rb = rigid.GetDataInformation().GetBounds()
        bounds = [min(bounds[0], rb[0]), max(bounds[1], rb[1]), min(bounds[2], rb[2]), max(bounds[3], rb[3]),
                  min(bounds[4], rb[4]), max(bounds[5], rb[5])]
    for view in (left, right):
        if DIM == 2 and not (revolve and view is left):
            view.InteractionMode = "2D"
        Render(view)  # a view's first render resets its camera: frame it after
    direction, up = camera_axes(view_name)
    if revolve:  # the revolved body obliquely, the section along z
        data_box = frame_camera(left, body.GetDataInformation().GetBounds(), *camera_axes(args.view or "iso"),
                                size)
        frame_camera(right, bounds, *camera_axes("z"), size)
    else:
        data_box = frame_camera(left, bounds, direction, up, size)
        if cut != "none":  # seen from above the plane: the kept half's cut face
            direction, up = camera_axes(cut)
        frame_camera(right, bounds, direction, up, size)
    if cut == "none" and not revolve:  # both views show the same: one camera
        AddCameraLink(left, right, "views")
    Render(left)
    Render(right)

    if args.report:
        info = source.GetDataInformation()
        rng = source.PointData["stress"].GetRange(component)
        print(json.dumps({{"time": t, "times": len(times), "materials": list(lut.Annotations),
                          "colours": list(lut.IndexedColors), "stress": args.stress, "stress_range": list(rng),
                          "stress_title": bar.Title, "points": nodal.GetDataInformation().GetNumberOfPoints(),
                          "shown_points": info.GetNumberOfPoints(), "view": view_name, "cut": cut,
                          "data_box": data_box, "bar_at": bar_at, "revolved": bool(revolve),
                          "revolved_points": body.GetDataInformation().GetNumberOfPoints() if revolve else 0,
                          "rigid_points": rigid.GetDataInformation().GetNumberOfPoints() if rigid else 0}}))
    if args.screenshot:
        SaveScreenshot(args.screenshot, layout, ImageResolution=[1600, 700])


main([a for a in sys.argv[1:] if a != "--"])
'''


def find_series(results: Path) -> Path:
    """The main .pvd of a results folder (or the .pvd given)."""
    results = Path(results)
    if results.is_file() and results.suffix == ".pvd":
        return results
    if not results.is_dir():
        raise ResultsError(f"no results folder or .pvd file {str(results)!r}")
    found = sorted(p for p in results.glob("*.pvd") if not p.stem.endswith(tuple(f"_{c}" for c in OWN_COLLECTION)))
    if not found:
        raise ResultsError(f"{str(results)!r} holds no .pvd series (run a deck first: mpmsim run DECK)")
    if len(found) > 1:
        names = ", ".join(p.name for p in found)
        raise ResultsError(f"{str(results)!r} holds several series ({names}): give the .pvd")
    return found[0]


def first_file(pvd: Path) -> Path:
    """The first VTU file the collection lists."""
    match = re.search(r'file="([^"]+)"', pvd.read_text())
    if match is None:
        raise ResultsError(f"{str(pvd)!r} lists no VTU file")
    return pvd.parent / match.group(1)


def write_script(results: Path, stress: str = "yy") -> Path:
    """Write `<stem>_paraview.py` beside the series; returns its path."""
    pvd = find_series(results)
    stem = pvd.stem
    first = first_file(pvd)
    try:
        mesh = meshio.read(first)
    except Exception as exc:  # noqa: BLE001 - any reader failure is a bad results folder
        raise ResultsError(f"cannot read {str(first)!r}: {exc}".splitlines()[0]) from None
    if NAMES_FIELD not in mesh.field_data:
        raise ResultsError(f"{str(first)!r} carries no material names (written by an older mpmsim: run the deck again)")
    dim = 2 if not np.any(mesh.points[:, 2]) else 3
    fem = "_fem_" in pvd.read_text()
    spacing = 0.0 if fem or len(mesh.points) < 2 else particle_spacing(mesh.points[:, :dim])
    script = pvd.parent / f"{stem}_paraview.py"
    text = TEMPLATE.format(stem=stem, script=script.name, materials=material_names(mesh), palette=PALETTE,
                           components=COMPONENTS, dim=dim, spacing=spacing, folder=str(pvd.parent.resolve()),
                           stress=stress, rigid=rigid_ids(pvd), unit=stress_unit(pvd),
                           axisymmetric="hoop_stress" in mesh.point_data)
    write_text(script, text)
    return script


def rigid_ids(pvd: Path) -> list[int]:
    """The material ids the rigid collection `<stem>_rigid.pvd` holds (none without one)."""
    rigid = pvd.with_name(pvd.stem + "_rigid.pvd")
    if not rigid.exists():
        return []
    try:
        mesh = meshio.read(first_file(rigid))
    except Exception as exc:  # noqa: BLE001 - any reader failure is a bad results folder
        raise ResultsError(f"cannot read the rigid series of {str(rigid)!r}: {exc}".splitlines()[0]) from None
    return sorted(int(k) for k in np.unique(mesh.point_data["material"]))


def stress_unit(pvd: Path) -> str:
    """The run's stress unit, from its history's sidecar (empty when there is none)."""
    sidecar = pvd.with_name(pvd.stem + "_history.json")
    try:
        return str(json.loads(sidecar.read_text())["columns"]["sxx"])
    except (OSError, ValueError, KeyError, TypeError):
        return ""


def particle_spacing(points: np.ndarray) -> float:
    """Median distance from a particle to its nearest neighbour."""
    from scipy.spatial import cKDTree

    d, _ = cKDTree(points).query(points, k=2)
    return float(np.median(d[:, 1]))


def parse_report(text: str) -> dict:
    """The JSON line `--report` prints (ParaView prints other lines around it)."""
    for line in text.splitlines()[::-1]:
        if line.startswith("{"):
            return json.loads(line)
    raise ValueError("no report line in the output")
