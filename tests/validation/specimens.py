"""The 2013 imperfect-interface paper's specimens as deck dicts, for tests and bench/interfaces.py.

The untilted decks are shipped in inputs/ (two_layer.yaml, dls.yaml, sphere_composite.yaml);
these builders vary what a deck key cannot: the interface position in the grid and the tilt.
"""

from __future__ import annotations

import math

import yaml

from mpmsim.deck.overrides import with_overrides

from ..conftest import ROOT


def shipped(name: str) -> dict:
    return yaml.safe_load((ROOT / "inputs" / f"{name}.yaml").read_text())


def two_layer(cell: float, Dt, *, mid: bool = False, **overrides) -> dict:
    """Two-layer specimen with the interface on a grid line (x = 4) or, with mid, half a cell
    to the right (a cell mid-plane)."""
    s = 0.5 * cell if mid else 0.0
    return with_overrides(shipped("two_layer"), {
        "grid.cell_size": cell, "contact.default.Dt": Dt,
        "bodies.0.min": [s, 0.0], "bodies.0.max": [4.0 + s, 20.0],
        "bodies.1.min": [4.0 + s, 0.0], "bodies.1.max": [8.0 + s, 20.0],
        "loads.0.region.min": [4.0 + s, 19.0], "loads.0.region.max": [8.0 + s, 20.0], **overrides})


def two_layer_3d(cell: float, Dt, z_rollers: bool = False, **overrides) -> dict:
    """The two-layer specimen as the paper's 4 x 4 x 20 mm layers in 3D; with z_rollers the z
    faces are rollers, which makes it the plane-strain problem the 2D runs solve (free z faces
    are nearer plane stress)."""
    deck = shipped("two_layer")
    deck.update(analysis="3d", title=f"Two-layer specimen in 3D (Dt = {Dt})")
    deck.pop("thickness")
    deck["grid"] = {"cell_size": cell, "domain": {"min": [-1.0, 0.0, 0.0], "max": [9.0, 21.0, 4.0]},
                    "boundaries": {"ymin": "fixed", **({"zmin": "roller", "zmax": "roller"} if z_rollers else {})}}
    deck["bodies"] = [{"shape": "box", "min": [0.0, 0.0, 0.0], "max": [4.0, 20.0, 4.0], "material": "left"},
                      {"shape": "box", "min": [4.0, 0.0, 0.0], "max": [8.0, 20.0, 4.0], "material": "right"}]
    deck["contact"]["normal_vector"] = [1.0, 0.0, 0.0]
    deck["contact"]["default"]["Dt"] = Dt
    deck["loads"] = [{"region": {"min": [4.0, 19.0, 0.0], "max": [8.0, 20.0, 4.0]}, "face": "ymax",
                      "traction": [0.0, 0.5, 0.0], "ramp": 0.02}]
    return with_overrides(deck, overrides)


def dls_tilted(degrees: float, cell: list[float] | float, Dt, **overrides) -> dict:
    """The DLS specimen rotated by `degrees` about the origin: strands as polygons, the
    grain and the specified normal rotated, end loads as total forces on bands along the
    specimen axis."""
    deck = shipped("dls")
    a = math.radians(degrees)
    c, s = math.cos(a), math.sin(a)
    rot = lambda x, y: [c * x - s * y, s * x + c * y]  # noqa: E731
    axis = [-s, c]
    bodies = []
    for body in deck["bodies"]:
        (x0, y0), (x1, y1) = body["min"], body["max"]
        bodies.append({"shape": "polygon", "vertices": [rot(x0, y0), rot(x1, y0), rot(x1, y1), rot(x0, y1)],
                       "material": body["material"]})
    t = deck["thickness"]

    def end_load(x0, x1, y, outward, force):
        corners = [rot(x, yy) for x in (x0, x1) for yy in (y - 1.0 * outward, y)]
        lo = [min(p[k] for p in corners) - 1e-9 for k in range(2)]
        hi = [max(p[k] for p in corners) + 1e-9 for k in range(2)]
        direction = [outward * v for v in axis]
        return {"region": {"min": lo, "max": hi}, "normal": direction, "force": [force * d for d in direction],
                "ramp": deck["loads"][0]["ramp"]}

    loads = [end_load(1.0, 2.0, 0.0, -1, 2.0 * 1.0 * t),  # central strand, bottom: 2 MPa x 1 mm
             end_load(0.0, 1.0, 35.0, 1, 1.0 * 1.0 * t), end_load(2.0, 3.0, 35.0, 1, 1.0 * 1.0 * t)]
    pts = [rot(x, y) for x in (0.0, 3.0) for y in (0.0, 35.0)]
    h = max(cell) if isinstance(cell, list) else cell
    lo = [min(p[k] for p in pts) - 2 * h for k in range(2)]
    hi = [max(p[k] for p in pts) + 2 * h for k in range(2)]
    deck.update(bodies=bodies, loads=loads)
    deck["grid"] = {"cell_size": cell, "domain": {"min": lo, "max": hi}}
    for m in ("strand", "outer"):
        deck["materials"][m]["axis"] = axis
    deck["contact"]["normal_vector"] = rot(1.0, 0.0)
    deck["contact"]["default"]["Dt"] = Dt
    deck["title"] = f"DLS specimen tilted {degrees:g} degrees (Dt = {Dt})"
    return with_overrides(deck, overrides)
