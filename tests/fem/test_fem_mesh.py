"""FEM meshes (mpmsim/fem/mesh.py): generators are positively oriented, conforming, of the
exact area/volume, with outward facets; transforms; read_mesh through meshio and its errors."""

from __future__ import annotations

import math

import meshio
import numpy as np
import pytest

from mpmsim.fem.mesh import FemMesh, MeshError, box, disk, read_mesh, rectangle, ring, transformed

pytestmark = pytest.mark.fem


def facet_flux_checks(m: FemMesh, rel=1e-12):
    """Closed outward boundary: sum n dA = 0 and the divergence theorem sum (x_c . n) dA = d V
    (a single inward facet or a missing one breaks both)."""
    n = m.facet_normals()
    area = m.facet_areas()
    xc = m.points[m.facets].mean(axis=1)
    V = m.volumes().sum()
    scale = area.sum()
    assert np.abs((n * area[:, None]).sum(axis=0)).max() < rel * scale
    assert (np.einsum("ij,ij->i", xc, n) * area).sum() == pytest.approx(m.dim * V, rel=rel)


def interior_faces_match(m: FemMesh):
    """Conforming: every face is used once (boundary) or twice, in opposite orientations."""
    from mpmsim.fem.mesh import LOCAL_FACETS

    d = m.dim
    faces = m.cells[:, LOCAL_FACETS[d]].reshape(-1, d)
    key = np.sort(faces, axis=1)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    assert counts.max() <= 2
    assert (counts == 1).sum() == len(m.facets)
    # two uses of a face have opposite parity of the permutation that sorts them
    parity = np.array([np.linalg.det(np.eye(d)[np.argsort(f)]) for f in faces])
    sums = np.zeros(len(counts))
    np.add.at(sums, inv.ravel(), parity)
    assert np.all(sums[counts == 2] == 0.0)


@pytest.mark.parametrize("lo,hi,h", [((0.0, 0.0), (2.0, 1.0), 0.25), ((-1.0, 0.5), (0.3, 0.9), 0.1)])
def test_rectangle(lo, hi, h):
    m = rectangle(lo, hi, h)
    nx, ny = (math.ceil((hi[a] - lo[a]) / h - 1e-9) for a in range(2))
    assert m.points.shape == ((nx + 1) * (ny + 1), 2) and m.cells.shape == (2 * nx * ny, 3)
    assert m.cells.dtype == np.int64 and m.facets.dtype == np.int64
    v = m.volumes()
    assert v.min() > 0.0
    assert v.sum() == pytest.approx((hi[0] - lo[0]) * (hi[1] - lo[1]), rel=1e-13)
    assert len(m.boundary_nodes) == 2 * (nx + ny) and len(m.facets) == 2 * (nx + ny)
    # every outward normal is the axis normal of the side its facet lies on
    n = m.facet_normals()
    xc = m.points[m.facets].mean(axis=1)
    for a in range(2):
        on_lo = np.isclose(xc[:, a], lo[a])
        on_hi = np.isclose(xc[:, a], hi[a])
        assert np.allclose(n[on_lo, a], -1.0) and np.allclose(n[on_hi, a], 1.0)
    assert np.all(np.isclose(np.abs(n).max(axis=1), 1.0))
    facet_flux_checks(m)
    interior_faces_match(m)
    # the diagonals alternate: half the cells of each orientation of the hypotenuse
    p = m.points[m.cells]
    hyp = [np.argmax([np.linalg.norm(c[(k + 1) % 3] - c[k]) for k in range(3)]) for c in p]
    e = np.array([p[i, (k + 1) % 3] - p[i, k] for i, k in enumerate(hyp)])
    slope = np.sign(e[:, 0] * e[:, 1])
    assert abs((slope > 0).sum() - (slope < 0).sum()) <= 2 * max(nx, ny)


def test_box():
    lo, hi, h = (0.0, -1.0, 0.5), (1.0, 1.0, 1.5), 0.5
    m = box(lo, hi, h)
    nx, ny, nz = 2, 4, 2
    assert m.points.shape == ((nx + 1) * (ny + 1) * (nz + 1), 3) and m.cells.shape == (6 * nx * ny * nz, 4)
    v = m.volumes()
    assert v.min() > 0.0
    assert np.allclose(v, h ** 3 / 6.0, rtol=1e-13)
    assert v.sum() == pytest.approx(2.0 * 1.0 * 1.0, rel=1e-13)
    assert len(m.facets) == 4 * (nx * ny + ny * nz + nx * nz)
    assert len(m.boundary_nodes) == (nx + 1) * (ny + 1) * (nz + 1) - (nx - 1) * (ny - 1) * (nz - 1)
    n = m.facet_normals()
    xc = m.points[m.facets].mean(axis=1)
    for a in range(3):
        assert np.allclose(n[np.isclose(xc[:, a], lo[a]), a], -1.0)
        assert np.allclose(n[np.isclose(xc[:, a], hi[a]), a], 1.0)
    facet_flux_checks(m)
    interior_faces_match(m)


@pytest.mark.parametrize("h", [0.25, 0.1])
def test_disk(h):
    c, R = np.array([0.3, -0.2]), 1.5
    m = disk(c, R, h)
    nr = math.ceil(R / h - 1e-9)
    nb = 6 * nr
    assert m.n_nodes == 1 + 3 * nr * (nr + 1)
    v = m.volumes()
    assert v.min() > 0.0
    assert v.min() > 0.5 * v.max()  # no slivers: element areas within a factor 2
    polygon = 0.5 * nb * R * R * math.sin(2 * math.pi / nb)
    assert v.sum() == pytest.approx(polygon, rel=1e-12)  # exactly the inscribed polygon
    assert v.sum() == pytest.approx(math.pi * R * R, rel=(2 * math.pi / nb) ** 2 / 6 * 1.01)
    assert len(m.boundary_nodes) == nb and len(m.facets) == nb
    assert np.allclose(np.linalg.norm(m.points[m.boundary_nodes] - c, axis=1), R)
    facet_flux_checks(m)
    interior_faces_match(m)
    # node normals: radial on the boundary (regular polygon), zero inside
    nn = m.node_normals()
    r = m.points - c
    b = m.boundary_nodes
    assert np.allclose(nn[b], r[b] / np.linalg.norm(r[b], axis=1)[:, None], atol=1e-12)
    inner = np.setdiff1d(np.arange(m.n_nodes), b)
    assert np.all(nn[inner] == 0.0)


def test_ring():
    c, ri, ro, h = np.array([1.0, 2.0]), 0.5, 1.0, 0.1
    m = ring(c, ri, ro, h)
    v = m.volumes()
    assert v.min() > 0.0 and v.min() > 0.5 * v.max()
    ni, no = math.ceil(2 * math.pi * ri / h - 1e-9), math.ceil(2 * math.pi * ro / h - 1e-9)
    poly = lambda n, r: 0.5 * n * r * r * math.sin(2 * math.pi / n)
    assert v.sum() == pytest.approx(poly(no, ro) - poly(ni, ri), rel=1e-12)
    assert v.sum() == pytest.approx(math.pi * (ro ** 2 - ri ** 2), rel=0.01)
    assert len(m.boundary_nodes) == ni + no and len(m.facets) == ni + no
    rb = np.linalg.norm(m.points[m.boundary_nodes] - c, axis=1)
    assert np.all(np.isclose(rb, ri) | np.isclose(rb, ro))
    # outward: away from the centre on the outer circle, towards it on the inner one
    n = m.facet_normals()
    xc = m.points[m.facets].mean(axis=1) - c
    radial = np.einsum("ij,ij->i", n, xc / np.linalg.norm(xc, axis=1)[:, None])
    outer = np.linalg.norm(xc, axis=1) > 0.5 * (ri + ro)
    assert np.all(radial[outer] > 0.99) and np.all(radial[~outer] < -0.99)
    assert outer.sum() == no
    facet_flux_checks(m)
    interior_faces_match(m)


def test_transformed_2d_and_3d():
    m = rectangle((0.0, 0.0), (4.0, 1.5), 0.5)
    about = np.array([1.0, 0.5])
    t = transformed(m, rotation_deg=30.0, about=about, translation=(0.0, 2.0))
    R = np.array([[math.cos(math.pi / 6), -math.sin(math.pi / 6)], [math.sin(math.pi / 6), math.cos(math.pi / 6)]])
    assert np.allclose(t.points, about + (m.points - about) @ R.T + [0.0, 2.0], atol=1e-14)
    assert np.allclose(t.volumes(), m.volumes())
    assert np.allclose(t.facet_normals(), m.facet_normals() @ R.T, atol=1e-14)
    assert m.points[0, 0] == 0.0  # the original is untouched
    s = transformed(m, scale=2.0)
    assert s.volumes().sum() == pytest.approx(4.0 * m.volumes().sum())
    b = box((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), 0.5)
    for axis, k in (("x", 0), ("y", 1), ("z", 2)):
        bt = transformed(b, rotation_deg=90.0, axis=axis, about=(0.5, 0.5, 0.5))
        assert bt.volumes().min() > 0.0
        assert np.allclose(bt.points[:, k], b.points[:, k])  # the axis coordinate is kept
        assert np.allclose(np.sort(bt.points, axis=0), np.sort(b.points, axis=0), atol=1e-14)  # cube onto itself
        facet_flux_checks(bt)
    # x -> y under a +90 degree rotation about z
    bz = transformed(b, rotation_deg=90.0, axis="z")
    assert np.allclose(bz.points[:, 1], b.points[:, 0]) and np.allclose(bz.points[:, 0], -b.points[:, 1])


def test_nodes_in_box():
    m = rectangle((0.0, 0.0), (1.0, 1.0), 0.25)
    left = m.nodes_in_box((0.0, 0.0), (0.0, 1.0))
    assert np.allclose(m.points[left, 0], 0.0) and len(left) == 5
    assert len(m.nodes_in_box((-1.0, -1.0), (2.0, 2.0))) == m.n_nodes


# ----------------------------------------------------------------------------- files
def _tri_mesh():
    m = rectangle((0.0, 0.0), (2.0, 1.0), 0.5)
    return m, np.c_[m.points, np.full(m.n_nodes, 0.25)]  # constant z = 0.25 to drop


def test_read_vtu_round_trip(tmp_path):
    m, pts3 = _tri_mesh()
    path = tmp_path / "plate.vtu"
    meshio.write(path, meshio.Mesh(pts3, [("triangle", m.cells)]))
    r = read_mesh(path, 2)
    assert r.points.shape == m.points.shape
    assert np.allclose(r.points, m.points) and np.array_equal(r.cells, m.cells)
    assert np.array_equal(r.facets, m.facets) and np.array_equal(r.boundary_nodes, m.boundary_nodes)


def test_read_gmsh_round_trip_3d_with_inverted_cell_and_unused_point(tmp_path):
    b = box((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), 0.5)
    cells = b.cells.copy()
    cells[3] = cells[3, [0, 2, 1, 3]]  # inverted
    pts = np.vstack([[9.0, 9.0, 9.0], b.points])  # an unused point first: nodes renumber by -1
    path = tmp_path / "cube.msh"
    meshio.write(path, meshio.Mesh(pts, [("tetra", cells + 1)]), file_format="gmsh22", binary=False)
    r = read_mesh(path, 3)
    assert np.allclose(r.points, b.points)
    assert r.volumes().min() > 0.0
    assert np.array_equal(np.sort(r.cells, axis=1), np.sort(b.cells, axis=1))
    assert np.array_equal(r.cells[3], cells[3, [0, 1, 3, 2]])  # flipped by swapping the last two nodes
    assert r.volumes().sum() == pytest.approx(1.0, rel=1e-13)
    assert len(r.facets) == len(b.facets)


def test_read_gmsh41_physical_groups_as_node_sets(tmp_path):
    # a Gmsh 4.1 ASCII file as Gmsh writes it: a physical curve "bottom", a physical surface
    # "body", one clockwise triangle and an unused node 5
    text = """$MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
2
1 1 "bottom"
2 2 "body"
$EndPhysicalNames
$Entities
0 1 1 0
1 0 0 0 1 0 0 1 1 0
1 0 0 0 1 1 0 1 2 0
$EndEntities
$Nodes
2 5 1 5
1 1 0 2
1
2
0 0 0
1 0 0
2 1 0 3
3
4
5
1 1 0
0 1 0
7 7 0
$EndNodes
$Elements
2 3 1 3
1 1 1 1
1 1 2
2 1 2 2
2 1 2 3
3 1 4 3
$EndElements
"""
    path = tmp_path / "square.msh"
    path.write_text(text)
    r = read_mesh(path, 2)
    assert np.allclose(r.points, [[0, 0], [1, 0], [1, 1], [0, 1]])
    assert np.array_equal(r.cells, [[0, 1, 2], [0, 2, 3]])
    assert np.array_equal(r.node_sets["bottom"], [0, 1]) and np.array_equal(r.node_sets["body"], [0, 1, 2, 3])
    assert r.volumes().sum() == pytest.approx(1.0)


def test_read_errors(tmp_path):
    m, pts3 = _tri_mesh()
    # degenerate cell: three collinear nodes, reported with its index
    cells = m.cells.copy()
    cells[5] = [0, 1, 2]  # nodes 0, 1, 2 lie on y = 0
    bad = tmp_path / "flat_cell.vtu"
    meshio.write(bad, meshio.Mesh(pts3, [("triangle", cells)]))
    with pytest.raises(MeshError, match=r"flat_cell\.vtu.*cell 5 is degenerate") as info:
        read_mesh(bad, 2)
    assert "\n" not in str(info.value)
    # unreadable file
    junk = tmp_path / "junk.msh"
    junk.write_text("this is not a mesh\n")
    with pytest.raises(MeshError, match=r"junk\.msh: cannot read") as info:
        read_mesh(junk, 2)
    assert "\n" not in str(info.value)
    with pytest.raises(MeshError, match="not found"):
        read_mesh(tmp_path / "missing.vtu", 2)
    with pytest.raises(MeshError, match=r"junk\.xyz"):
        (tmp_path / "junk.xyz").write_text("1 2 3\n")
        read_mesh(tmp_path / "junk.xyz", 2)
    # no cells of the right kind
    quads = tmp_path / "quads.vtu"
    meshio.write(quads, meshio.Mesh(pts3[:4], [("quad", np.array([[0, 1, 2, 3]]))]))
    with pytest.raises(MeshError, match=r"quads\.vtu: no triangle cells \(found: quad\)"):
        read_mesh(quads, 2)
    tris = tmp_path / "tris.vtu"
    meshio.write(tris, meshio.Mesh(pts3, [("triangle", m.cells)]))
    with pytest.raises(MeshError, match=r"tris\.vtu: no tetra cells"):
        read_mesh(tris, 3)
    # a 2D mesh must be flat
    warped = pts3.copy()
    warped[:, 2] = m.points[:, 0] * 0.1
    wp = tmp_path / "warped.vtu"
    meshio.write(wp, meshio.Mesh(warped, [("triangle", m.cells)]))
    with pytest.raises(MeshError, match=r"warped\.vtu.*not in a plane"):
        read_mesh(wp, 2)
    # MeshError is a ValueError
    assert issubclass(MeshError, ValueError)
