"""`mpmsim paraview RESULTS`: a ParaView Python script beside a run's VTU series.

The script opens `<stem>.pvd` (deformable particles and FEM bodies), colours it by material
with a categorical lookup table annotated with the names the files carry (field data
`material_names`), shows a second view of one stress component with its colour bar (FEM cell
stresses are averaged to the nodes so one colour map covers both), and draws the rigid
collection `<stem>_rigid.pvd`, when there is one, in grey. The script is plain ParaView
(`paraview.simple`, ParaView 5.10 or newer); `paraview --script=FILE` opens it in the GUI,
`pvbatch FILE --screenshot out.png` renders a picture, and `--report` prints what it shows
(JSON) for checks.
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
  pvbatch {script} --screenshot out.png [--time T] [--stress yy]
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


def main(argv):
    ap = argparse.ArgumentParser(prog=STEM + "_paraview.py")
    ap.add_argument("--screenshot", help="write a PNG of the layout and quit")
    ap.add_argument("--time", type=float, help="output time to show (default: the last)")
    ap.add_argument("--stress", default={stress!r}, choices=COMPONENTS, help="stress component of the right view")
    ap.add_argument("--report", action="store_true", help="print what is shown as JSON")
    args = ap.parse_args(argv)

    reader = PVDReader(registrationName=STEM, FileName=os.path.join(HERE, STEM + ".pvd"))
    reader.UpdatePipelineInformation()
    times = list(reader.TimestepValues) or [0.0]
    t = times[-1] if args.time is None else min(times, key=lambda s: abs(s - args.time))
    scene = GetAnimationScene()
    scene.UpdateAnimationUsingDataTimeSteps()
    scene.AnimationTime = t
    nodal = CellDatatoPointData(registrationName=STEM + " (nodal)", Input=reader)
    nodal.PassCellData = 1
    nodal.UpdatePipeline(t)

    left = CreateView("RenderView")
    right = CreateView("RenderView")
    layout = CreateLayout(STEM)
    layout.SplitHorizontal(0, 0.5)
    AssignViewToLayout(view=left, layout=layout, hint=1)
    AssignViewToLayout(view=right, layout=layout, hint=2)

    # left: material, categorical
    shown = Show(nodal, left)
    style(shown)
    ColorBy(shown, ("POINTS", "material"))
    lut = GetColorTransferFunction("material")
    lut.InterpretValuesAsCategories = 1
    annotations, colours = [], []
    for k, name in enumerate(MATERIALS):
        annotations += [str(k), name]
        colours += list(PALETTE[k % len(PALETTE)])
    lut.Annotations = annotations
    lut.IndexedColors = colours
    shown.SetScalarBarVisibility(left, True)

    # right: one stress component with its colour bar
    component = COMPONENTS.index(args.stress)
    stress_shown = Show(nodal, right)
    style(stress_shown)
    ColorBy(stress_shown, ("POINTS", "stress", ["XX", "YY", "ZZ", "XY", "YZ", "XZ"][component]))
    stress_shown.RescaleTransferFunctionToDataRange(True, False)
    stress_shown.SetScalarBarVisibility(right, True)
    stress_lut = GetColorTransferFunction("stress")
    bar = GetScalarBar(stress_lut, right)
    bar.Title = "stress " + args.stress
    bar.ComponentTitle = ""

    rigid_path = os.path.join(HERE, STEM + "_rigid.pvd")
    rigid = None
    if os.path.exists(rigid_path):
        rigid = PVDReader(registrationName=STEM + " rigid", FileName=rigid_path)
        for view in (left, right):
            r = Show(rigid, view)
            style(r)
            ColorBy(r, ("POINTS", None))
            r.AmbientColor = r.DiffuseColor = [0.6, 0.6, 0.6]
    for view in (left, right):
        if DIM == 2:
            view.InteractionMode = "2D"
        view.ResetCamera()
    AddCameraLink(left, right, "views")
    Render(left)
    Render(right)

    if args.report:
        info = nodal.GetDataInformation()
        rng = nodal.PointData["stress"].GetRange(component)
        print(json.dumps({{"time": t, "times": len(times), "materials": list(lut.Annotations),
                          "stress": args.stress, "stress_range": list(rng), "points": info.GetNumberOfPoints(),
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
                           stress=stress)
    write_text(script, text)
    return script


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
