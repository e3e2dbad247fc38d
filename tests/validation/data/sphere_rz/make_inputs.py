"""Write the NairnMPM inputs of the axisymmetric sphere impact (python make_inputs.py)."""

import math


def xml(name: str, h: float, mu: float) -> str:
    pts = "\n".join(f'        <pt x="{max(0.0, 5 * math.cos(t)):.9f}" y="{11.05 + 5 * math.sin(t):.9f}"/>'
                    for t in [(-math.pi / 2 + math.pi * k / 720) for k in range(721)])
    return f"""<?xml version='1.0'?>
<!DOCTYPE JANFEAInput SYSTEM "NairnMPM.dtd">
<JANFEAInput version='3'>
  <Header>
    <Description>Steel sphere (R 5 mm, 2 m/s) on an aluminium disc (radius 8, 6 mm, fixed base), axisymmetric, h={h}, mu={mu}</Description>
    <Analysis>13</Analysis>
    <ConsistentUnits length="mm" mass="g" time="ms"/>
  </Header>
  <MPMHeader>
    <MPMMethod>2</MPMMethod>
    <GIMP type="uGIMP"/>
    <MatlPtsPerElement>4</MatlPtsPerElement>
    <Timing CFL="0.4" max="0.1"/>
    <ArchiveGroup time="0.1"/>
    <ArchiveRoot>{name}_out/{name}.</ArchiveRoot>
    <MPMArchiveOrder>iYYYYNNNNNNNNNNNNN</MPMArchiveOrder>
    <GlobalArchiveTime>0.001</GlobalArchiveTime>
    <GlobalArchive type="velx" matname="Steel"/>
    <GlobalArchive type="vely" matname="Steel"/>
    <GlobalArchive type="px" matname="Steel"/>
    <GlobalArchive type="py" matname="Steel"/>
    <GlobalArchive type="contactx" matname="Steel"/>
    <GlobalArchive type="contacty" matname="Steel"/>
    <GlobalArchive type="Kinetic Energy"/>
    <GlobalArchive type="Step number"/>
    <MultiMaterialMode Normals="6">
    <Friction>{mu if mu else 0}</Friction>
    </MultiMaterialMode>
  </MPMHeader>
  <Mesh output="file">
    <Grid xmin="-{h}" xmax="9" ymin="0" ymax="17">
      <Horiz cellsize="{h}"/>
      <Vert cellsize="{h}"/>
    </Grid>
  </Mesh>
  <MaterialPoints>
    <Body matname="Steel" vx="0" vy="-2">
      <Polygon>
{pts}
      </Polygon>
    </Body>
    <Body matname="Aluminum" vx="0" vy="0">
      <Rect xmin="0" xmax="8" ymin="0" ymax="6"/>
    </Body>
  </MaterialPoints>
  <Material Type="1" Name="Steel">
    <rho>7.85e-3</rho>
    <E>200000</E>
    <nu>0.3</nu>
    <alpha>0</alpha>
  </Material>
  <Material Type="1" Name="Aluminum">
    <rho>2.7e-3</rho>
    <E>70000</E>
    <nu>0.33</nu>
    <alpha>0</alpha>
  </Material>
  <GridBCs>
    <BCLine x1="-1" y1="0" x2="10" y2="0" tolerance="0.05">
      <DisBC dir="1" style="1" vel="0"/>
      <DisBC dir="2" style="1" vel="0"/>
    </BCLine>
  </GridBCs>
</JANFEAInput>
"""


if __name__ == "__main__":
    for name, h, mu in (("sphere_rz_h0.5_frictionless", 0.5, 0), ("sphere_rz_h0.5_mu0.3", 0.5, 0.3)):
        with open(name + ".xml", "w") as f:
            f.write(xml(name, h, mu))
