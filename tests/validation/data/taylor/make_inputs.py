#!/usr/bin/env python3
"""Write NairnMPM XML inputs for the Taylor bar (copper, 227 m/s, frictionless rigid anvil).
Units: ConsistentUnits mm, g, ms  ->  velocity mm/ms = m/s, stress MPa, density g/mm^3."""
import os, sys
here = os.path.dirname(os.path.abspath(__file__))
out = os.path.join(here, "nairnmpm")
os.makedirs(out, exist_ok=True)

L, R, V, TEND = 32.4, 3.2, 227.0, 0.08   # mm, mm, mm/ms (=m/s), ms (=80 us)

MATERIAL = """  <Material Type="9" Name="Copper">
    <largeRotation>LRFLAG</largeRotation>
    <rho>8.93e-3</rho>
    <E>117000</E>
    <nu>0.35</nu>
    <alpha>0</alpha>
    <Hardening>Linear</Hardening>
    <yield>400</yield>
    <Ep>100</Ep>
  </Material>
"""

def header(name, desc, analysis, ppe):
    return f"""<?xml version='1.0'?>
<!DOCTYPE JANFEAInput SYSTEM "NairnMPM.dtd">
<JANFEAInput version='3'>
  <Header>
    <Description>{desc}</Description>
    <Analysis>{analysis}</Analysis>
    <ConsistentUnits length="mm" mass="g" time="ms"/>
  </Header>
  <MPMHeader>
    <MPMMethod>2</MPMMethod>
    <GIMP type="uGIMP"/>
    <MatlPtsPerElement>{ppe}</MatlPtsPerElement>
    <Timing CFL="0.5" max="{TEND}"/>
    <ArchiveTime>0.01</ArchiveTime>
    <ArchiveRoot>{name}_out/{name}.</ArchiveRoot>
    <MPMArchiveOrder>iYYYYYNNNNNNNYNNNNNNNNNN</MPMArchiveOrder>
    <GlobalArchiveTime>0.001</GlobalArchiveTime>
    <GlobalArchive type="Step number"/>
    <GlobalArchive type="Kinetic Energy"/>
    <GlobalArchive type="Strain Energy"/>
    <GlobalArchive type="Plastic Energy"/>
    <GlobalArchive type="{'velz' if analysis == 12 else 'vely'}"/>
    <GlobalArchive type="Elapsed time"/>
  </MPMHeader>
"""

def axisym(h, lr=0):
    name = f"taylor_axi_h{h:g}" + ("_lr" if lr else "")
    s = header(name, f"Taylor bar, copper, 227 m/s, axisymmetric (x=r, y=z), cell {h} mm, "
                     "frictionless rigid anvil = symmetry (zero normal velocity) plane at z=0", 13, 4)
    s += f"""  <Mesh output="file">
    <Grid xmin="-0.8" xmax="10.4" ymin="-0.8" ymax="34.4">
      <Horiz cellsize="{h}"/>
      <Vert cellsize="{h}" symmin="0"/>
    </Grid>
  </Mesh>
  <MaterialPoints>
    <Body matname="Copper" vx="0" vy="{-V}">
      <Rect xmin="0" xmax="{R}" ymin="0" ymax="{L}"/>
    </Body>
  </MaterialPoints>
""" + MATERIAL.replace("LRFLAG", str(lr)) + "</JANFEAInput>\n"
    open(os.path.join(out, name + ".xml"), "w").write(s)
    return name

def quarter3d(h, lr=0):
    name = f"taylor_3dq_h{h:g}" + ("_lr" if lr else "")
    s = header(name, f"Taylor bar, copper, 227 m/s, 3D quarter model (symmetry x=0, y=0), cell {h} mm, "
                     "frictionless rigid anvil = symmetry (zero normal velocity) plane at z=0", 12, 8)
    s += f"""  <Mesh output="file">
    <Grid xmin="-0.8" xmax="10.4" ymin="-0.8" ymax="10.4" zmin="-0.8" zmax="34.4">
      <Horiz cellsize="{h}" symmin="0"/>
      <Vert cellsize="{h}" symmin="0"/>
      <Depth cellsize="{h}" symmin="0"/>
    </Grid>
  </Mesh>
  <MaterialPoints>
    <Body matname="Copper" vx="0" vy="0" vz="{-V}">
      <Cylinder xmin="{-R}" xmax="{R}" ymin="{-R}" ymax="{R}" zmin="0" zmax="{L}" axis="z">
        <Box xmin="-5" xmax="0" ymin="-5" ymax="5" zmin="-1" zmax="40"/>
        <Box xmin="-5" xmax="5" ymin="-5" ymax="0" zmin="-1" zmax="40"/>
      </Cylinder>
    </Body>
  </MaterialPoints>
""" + MATERIAL.replace("LRFLAG", str(lr)) + "</JANFEAInput>\n"
    open(os.path.join(out, name + ".xml"), "w").write(s)
    return name

if __name__ == "__main__":
    for lr in (0, 1):
        for h in (0.4, 0.2, 0.1):
            print(axisym(h, lr))
        for h in (0.8, 0.4, 0.2):
            print(quarter3d(h, lr))
