"""Write NairnMPM XML inputs for the two benchmark decks bench/column.yaml and
bench/two_blocks.yaml, so that NairnMPM can be timed against mpmsim on the same problems.

    python bench/nairnmpm/make_inputs.py                       # the four standard inputs
    python bench/nairnmpm/make_inputs.py --cell 0.5 --steps 100 [--scene column|two_blocks|both]
        [--out DIR]

Each input takes a fixed number of steps of a fixed time step, dt = 0.5 h / c with
c = sqrt((K + 4G/3)/rho) (mpmsim's CFL 0.5 time step at the start of the run). NairnMPM runs
while t <= max, so max = (steps - 1/2) dt gives exactly `steps` steps. Output: one archive at
t = 0 and one after the last step (NairnMPM always writes these two), no global archive.
The settings and where they differ from mpmsim's are in README.md beside this file.
Plain Python; no mpmsim import.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

HERE = Path(__file__).resolve().parent

# bench/column.yaml and bench/two_blocks.yaml (units mm-g-ms: MPa, g/mm^3, mm/ms = m/s)
K, G, RHO = 2450.0, 940.0, 0.001
WIDTH, HEIGHT, PLATEN = 40.0, 100.0, 2.0
PLATEN_V = -0.9622
FRICTION = 0.2
MARGIN_CELLS = 2  # mpmsim's grid.margin default: the domain is the bodies' box + 2 cells on free faces
STANDARD = ((1.0, 400), (0.25, 30))  # (cell mm, steps)


def wave_speed() -> float:
    return math.sqrt((K + 4.0 * G / 3.0) / RHO)  # mm/ms


def time_step(cell: float) -> float:
    return 0.5 * cell / wave_speed()


def tag(cell: float) -> str:
    return f"h{cell:g}"


def fmt(x: float) -> str:
    return repr(float(x))


def material(name: str) -> str:
    # Mooney-Rivlin with G2 = 0 and U(J) option 0: W = G1/2 (I1 J^(-2/3) - 3) + K/2 ((J^2 - 1)/2 - ln J)
    return f"""  <Material Type="8" Name="{name}">
    <rho>{fmt(RHO)}</rho>
    <G1>{fmt(G)}</G1>
    <G2>0</G2>
    <K>{fmt(K)}</K>
    <UJOption>0</UJOption>
    <alpha>0</alpha>
  </Material>
"""


def xml(scene: str, cell: float, steps: int) -> str:
    h = cell
    dt = time_step(h)
    tmax = (steps - 0.5) * dt
    name = f"{scene}_{tag(cell)}"
    n_cols, n_rows = round(WIDTH / h), round(HEIGHT / h)
    n_part = 4 * n_cols * n_rows
    n_platen = 4 * n_cols * round(PLATEN / h)
    m = MARGIN_CELLS * h
    xmin, xmax, ymin, ymax = -m, WIDTH + m, 0.0, HEIGHT + PLATEN + m
    tol = 0.1 * h

    if scene == "column":
        desc = (f"mpmsim bench/column.yaml: 40 x 100 mm neo-Hookean column, plane strain, h = {h:g} mm, "
                f"{n_part} + {n_platen} platen particles, {steps} steps of dt = {dt:.6g} ms")
        multi = ""
        bodies = f"""    <Body matname="polymer" thick="1" vx="0" vy="0">
      <Rect xmin="0" xmax="{fmt(WIDTH)}" ymin="0" ymax="{fmt(HEIGHT)}"/>
    </Body>
"""
        mats = material("polymer")
    elif scene == "two_blocks":
        desc = (f"mpmsim bench/two_blocks.yaml: two 40 x 50 mm neo-Hookean blocks, LR contact, Coulomb "
                f"{FRICTION:g}, plane strain, h = {h:g} mm, {n_part} + {n_platen} platen particles, "
                f"{steps} steps of dt = {dt:.6g} ms")
        multi = f"""    <MultiMaterialMode Normals="6">
      <Friction>{fmt(FRICTION)}</Friction>
    </MultiMaterialMode>
"""
        half = HEIGHT / 2
        bodies = f"""    <Body matname="lower" thick="1" vx="0" vy="0">
      <Rect xmin="0" xmax="{fmt(WIDTH)}" ymin="0" ymax="{fmt(half)}"/>
    </Body>
    <Body matname="upper" thick="1" vx="0" vy="0">
      <Rect xmin="0" xmax="{fmt(WIDTH)}" ymin="{fmt(half)}" ymax="{fmt(HEIGHT)}"/>
    </Body>
"""
        mats = material("lower") + material("upper")
    else:
        raise ValueError(scene)

    bodies += f"""    <Body matname="platen" thick="1" vx="0" vy="{fmt(PLATEN_V)}">
      <Rect xmin="0" xmax="{fmt(WIDTH)}" ymin="{fmt(HEIGHT)}" ymax="{fmt(HEIGHT + PLATEN)}"/>
    </Body>
"""
    # rigid BC material: its particles impose their (constant) x and y velocity on the nodes they touch
    mats += """  <Material Type="11" Name="platen">
    <SetDirection>3</SetDirection>
  </Material>
"""
    # ymin fixed: the grid line y = 0 and the GIMP layer below it (y = -h), both velocity components
    bcs = ""
    for y in (0.0, -h):
        bcs += f"""    <BCLine x1="{fmt(xmin - 2 * h)}" y1="{fmt(y)}" x2="{fmt(xmax + 2 * h)}" y2="{fmt(y)}" tolerance="{fmt(tol)}">
      <DisBC dir="1" style="1" vel="0"/>
      <DisBC dir="2" style="1" vel="0"/>
    </BCLine>
"""
    return f"""<?xml version='1.0'?>
<!DOCTYPE JANFEAInput SYSTEM "NairnMPM.dtd">
<!-- written by bench/nairnmpm/make_inputs.py: cell {cell:g} mm, {steps} steps; dt = 0.5 h / c, c = {wave_speed():.6f} mm/ms -->
<JANFEAInput version='3'>
  <Header>
    <Description>
{desc}
    </Description>
    <Analysis>10</Analysis>
    <ConsistentUnits length="mm" mass="g" time="ms"/>
  </Header>
  <MPMHeader>
    <MPMMethod>2</MPMMethod>
    <GIMP type="uGIMP"/>
    <MatlPtsPerElement>4</MatlPtsPerElement>
    <DefGradTerms>1</DefGradTerms>
    <Timing step="{fmt(dt)}" CFL="0.5" max="{fmt(tmax)}"/>
    <ArchiveGroup time="1e6"/>
    <ArchiveRoot>{name}_out/{name}.</ArchiveRoot>
    <MPMArchiveOrder>iYYYNNNNNNNNNNNNNN</MPMArchiveOrder>
{multi}  </MPMHeader>
  <Mesh output="file">
    <Grid xmin="{fmt(xmin)}" xmax="{fmt(xmax)}" ymin="{fmt(ymin)}" ymax="{fmt(ymax)}" thickness="1">
      <Horiz cellsize="{fmt(h)}"/>
      <Vert cellsize="{fmt(h)}"/>
    </Grid>
  </Mesh>
  <MaterialPoints>
{bodies}  </MaterialPoints>
{mats}  <GridBCs>
{bcs}  </GridBCs>
</JANFEAInput>
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cell", type=float, help="cell size in mm (default: the standard 1 and 0.25)")
    ap.add_argument("--steps", type=int, help="number of time steps (default: 400 at 1 mm, 30 at 0.25 mm)")
    ap.add_argument("--scene", choices=("column", "two_blocks", "both"), default="both")
    ap.add_argument("--out", type=Path, default=HERE)
    args = ap.parse_args()
    if args.cell is None:
        runs = [(c, args.steps or s) for c, s in STANDARD]
    else:
        std = dict(STANDARD)
        if args.steps is None and args.cell not in std:
            ap.error("--steps is required for a non-standard --cell")
        runs = [(args.cell, args.steps or std[args.cell])]
    scenes = ("column", "two_blocks") if args.scene == "both" else (args.scene,)
    if any(n < 1 for _, n in runs):
        ap.error("--steps must be >= 1")
    args.out.mkdir(parents=True, exist_ok=True)
    for cell, steps in runs:
        for scene in scenes:
            path = args.out / f"{scene}_{tag(cell)}.xml"
            path.write_text(xml(scene, cell, steps))
            print(f"{path}: h = {cell:g} mm, {steps} steps, dt = {time_step(cell):.6g} ms")


if __name__ == "__main__":
    main()
