"""Particle bodies from mesh files (shape: mesh): every mesh is generated here with numpy and
written with meshio. Checked against exact numbers: a voxel body whose faces lie between
lattice planes must get exactly its volume over the particle volume as particles, whichever
file holds it (STL, OBJ, hexahedra, tetrahedra; 2D quads and triangles); curved bodies (a
torus, a plate with a hole) their mesh volume within 2%. Bad meshes end `mpmsim check` with
exit 2 and a one-line message naming the file."""

from __future__ import annotations

import importlib.util
import itertools

import meshio
import numpy as np
import pytest
from typer.testing import CliRunner

from mpmsim.cli import app
from mpmsim.scene import build_scene
from tests.conftest import ROOT, deck_from

pytestmark = pytest.mark.ecosystem


# ----------------------------------------------------------------------------- meshes
def _load_torus():
    """The torus generator of inputs/meshes/torus.py (a script, not a package)."""
    spec = importlib.util.spec_from_file_location("torus_mesh", ROOT / "inputs" / "meshes" / "torus.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.torus


torus = _load_torus()  # (R, r, nu, nv) -> (points, outward triangles)


def enclosed_volume(pts, tris) -> float:
    """Divergence theorem: sum over the faces of x0 . (x1 x x2) / 6 (outward faces: > 0)."""
    p0, p1, p2 = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
    return float(np.einsum("ij,ij->i", p0, np.cross(p1, p2)).sum() / 6.0)


def enclosed_area(pts, tris) -> float:
    """Sum of the triangles' areas (2D, any orientation)."""
    a, b, c = pts[tris[:, 0], :2], pts[tris[:, 1], :2], pts[tris[:, 2], :2]
    return float(0.5 * np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]).sum())


def l_block_with_hole() -> np.ndarray:
    """Occupied unit voxels (nx, ny, nz) of an L-shaped block with a square hole through it:
    arm 6 x 3 with the hole at x 3..4, y 1..2, leg 3 x 3 above it, 3 voxels thick."""
    occ = np.zeros((6, 6, 3), dtype=bool)
    occ[:, :3] = True
    occ[:3, 3:] = True
    occ[3, 1] = False  # the through hole (all z)
    return occ


def voxel_nodes(occ: np.ndarray) -> np.ndarray:
    """Integer node coordinates of the voxel grid, node id = i + (nx+1) (j + (ny+1) k)."""
    nx, ny, nz = occ.shape
    k, j, i = np.meshgrid(np.arange(nz + 1), np.arange(ny + 1), np.arange(nx + 1), indexing="ij")
    return np.stack([i.ravel(), j.ravel(), k.ravel()], 1).astype(float)


def voxel_hexahedra(occ: np.ndarray) -> np.ndarray:
    nx, ny, _ = occ.shape
    nid = lambda i, j, k: i + (nx + 1) * (j + (ny + 1) * k)  # noqa: E731
    i, j, k = np.nonzero(occ)
    return np.stack([nid(i, j, k), nid(i + 1, j, k), nid(i + 1, j + 1, k), nid(i, j + 1, k),
                     nid(i, j, k + 1), nid(i + 1, j, k + 1), nid(i + 1, j + 1, k + 1), nid(i, j + 1, k + 1)], 1)


def voxel_tetrahedra(occ: np.ndarray) -> np.ndarray:
    """Six tetrahedra per voxel along its main diagonal (conforming between voxels)."""
    nx, ny, _ = occ.shape
    i, j, k = np.nonzero(occ)
    tets = []
    for perm in itertools.permutations(range(3)):
        corner = np.zeros((len(i), 3), dtype=np.int64)
        verts = [corner.copy()]
        for a in perm:
            corner[:, a] += 1
            verts.append(corner.copy())
        tets.append(np.stack([(i + v[:, 0]) + (nx + 1) * ((j + v[:, 1]) + (ny + 1) * (k + v[:, 2])) for v in verts], 1))
    return np.concatenate(tets)


def voxel_surface(occ: np.ndarray) -> np.ndarray:
    """Outward quads of the faces between occupied and empty voxels."""
    nx, ny, _ = occ.shape
    pad = np.pad(occ, 1)
    nid = lambda i, j, k: i + (nx + 1) * (j + (ny + 1) * k)  # noqa: E731
    quads = []
    for axis in range(3):
        for side in (0, 1):
            shift = [0, 0, 0]
            shift[axis] = 1 if side else -1
            nb = pad[1 + shift[0]: pad.shape[0] - 1 + shift[0], 1 + shift[1]: pad.shape[1] - 1 + shift[1],
                     1 + shift[2]: pad.shape[2] - 1 + shift[2]]
            i, j, k = np.nonzero(occ & ~nb)
            base = np.stack([i, j, k], 1)
            base[:, axis] += side
            u, w = (axis + 1) % 3, (axis + 2) % 3  # (u, w, axis) right-handed: u x w = +axis
            eu, ew = np.eye(3, dtype=np.int64)[u], np.eye(3, dtype=np.int64)[w]
            corners = [base, base + eu, base + eu + ew, base + ew]
            if not side:
                corners = corners[::-1]
            quads.append(np.stack([nid(*c.T) for c in corners], 1))
    return np.concatenate(quads)


def quads_as_triangles(quads: np.ndarray) -> np.ndarray:
    return np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])


def plate_with_hole(side: float, radius: float, n: int):
    """Triangles of the square [0, side]^2 less a circle (an inscribed n-gon) at its centre:
    rays from the centre, 6 nodes per ray from the circle to the square."""
    c = side / 2
    t = 2 * np.pi * (np.arange(n) + 0.5) / n
    d = np.stack([np.cos(t), np.sin(t)], 1)
    outer = c + d * (c / np.abs(d).max(axis=1))[:, None]
    s = np.linspace(0, 1, 6)
    pts = (c + radius * d)[:, None] * (1 - s)[None, :, None] + outer[:, None] * s[None, :, None]
    # the square's corners, between the rays that straddle them
    corners = np.array([[side, side], [0, side], [0, 0], [side, 0]])
    pts = np.concatenate([pts.reshape(-1, 2), corners])
    node = lambda k, m: (k % n) * 6 + m  # noqa: E731
    tris = [[node(k, m), node(k + 1, m), node(k + 1, m + 1)] for k in range(n) for m in range(5)]
    tris += [[node(k, m), node(k + 1, m + 1), node(k, m + 1)] for k in range(n) for m in range(5)]
    for q in range(4):  # corner q lies between rays k and k + 1 where the ray angle passes q pi/2 + pi/4
        k = int(np.floor((q * np.pi / 2 + np.pi / 4) / (2 * np.pi / n) - 0.5)) % n
        tris.append([node(k, 5), node(k + 1, 5), 6 * n + q])
    return np.column_stack([pts, np.zeros(len(pts))]), np.array(tris)


# ----------------------------------------------------------------------------- decks
def deck(body: dict, dim: int, cell: float, ppd: int = 2) -> dict:
    return {
        "title": "mesh body",
        "units": "SI",
        "analysis": "3d" if dim == 3 else "plane_strain",
        "grid": {"cell_size": cell},
        "particles_per_direction": ppd,
        "materials": {"steel": {"type": "linear_elastic", "E": 2e11, "nu": 0.3, "density": 7800.0}},
        "bodies": [{"shape": "mesh", "material": "steel", **body}],
        "time": {"end": 1e-5},
    }


def particles(tmp_path, body: dict, dim: int, cell: float, ppd: int = 2):
    scene = build_scene(deck_from(deck(body, dim, cell, ppd), tmp_path))
    return scene.deformable, cell / ppd


# ----------------------------------------------------------------------------- 3D
def test_torus_stl_is_filled_to_its_volume(tmp_path):
    R, r = 0.5, 0.2
    pts, tris = torus(R, r, 96, 48)
    exact = enclosed_volume(pts, tris)
    analytic = 2 * np.pi**2 * R * r**2
    assert abs(exact / analytic - 1) < 0.005  # the inscribed polyhedron: -0.36%
    meshio.write(tmp_path / "torus.stl", meshio.Mesh(pts, [("triangle", tris)]), binary=True)
    seed, s = particles(tmp_path, {"file": "torus.stl", "scale": 2.0, "translate": [3.0, 2.0, 1.0]}, 3, 0.1)
    volume = seed.vol.sum()
    assert abs(volume / (8 * exact) - 1) < 0.02
    assert abs(volume / (8 * analytic) - 1) < 0.02
    # every particle lies in the torus: none in its hole, none off the tube
    x = (seed.x - [3.0, 2.0, 1.0]) / 2.0
    assert np.hypot(np.hypot(x[:, 0], x[:, 1]) - R, x[:, 2]).max() <= r


@pytest.mark.parametrize("kind", ["stl", "obj", "hexahedron", "tetra"])
def test_l_block_with_a_hole_gets_exactly_its_volume(tmp_path, kind):
    """Faces between lattice planes: every ray through the triangles' shared edges and vertices
    must count once, so the particle count is exact."""
    occ = l_block_with_hole()
    nodes = voxel_nodes(occ)
    quads = voxel_surface(occ)
    tris = quads_as_triangles(quads)
    assert enclosed_volume(nodes, tris) == occ.sum() == 6 * 3 * 3 + 3 * 3 * 3 - 3
    if kind == "stl":
        meshio.write(tmp_path / "block.stl", meshio.Mesh(nodes, [("triangle", tris)]))
        file = "block.stl"
    elif kind == "obj":
        meshio.write(tmp_path / "block.obj", meshio.Mesh(nodes, [("quad", quads)]))
        file = "block.obj"
    else:
        cells = voxel_hexahedra(occ) if kind == "hexahedron" else voxel_tetrahedra(occ)
        meshio.write(tmp_path / "block.msh", meshio.Mesh(nodes, [(kind, cells)]), file_format="gmsh22", binary=False)
        file = "block.msh"
    h = 0.125  # voxel edge after scaling; lattice spacing 1/32: binary fractions, so lattice points lie
    # exactly on the diagonals of the split faces
    seed, s = particles(tmp_path, {"file": file, "scale": h, "translate": [1.0, -2.0, 0.5]}, 3, 0.0625)
    assert len(seed.x) == occ.sum() * round(h / s) ** 3
    assert seed.vol.sum() == pytest.approx(occ.sum() * h**3, rel=1e-12)
    ijk = np.floor((seed.x - [1.0, -2.0, 0.5]) / h).astype(int)
    assert occ[tuple(ijk.T)].all()  # each particle in an occupied voxel (none in the hole)


def test_rays_through_vertices_and_edges_count_once(tmp_path):
    """Points whose vertical ray runs exactly through the surface's vertices, along its edges
    and across the split quads' diagonals: inside exactly when every voxel touching the point
    is occupied, outside when none is (points on a face are left out)."""
    from types import SimpleNamespace

    from mpmsim.scene.meshbody import mesh_region

    occ = l_block_with_hole()
    nodes = voxel_nodes(occ)
    order = np.random.default_rng(1).permutation(len(nodes))  # node numbers unrelated to position
    new_id = np.argsort(order)
    for name, quads in (("a.vtu", voxel_surface(occ)), ("b.vtu", voxel_surface(occ)[:, [1, 2, 3, 0]])):  # diagonals
        meshio.write(tmp_path / name, meshio.Mesh(nodes[order], [("triangle", new_id[quads_as_triangles(quads)])]))
        region = mesh_region(SimpleNamespace(file=name, scale=1.0, translate=None, z_range=None), tmp_path, 3)
        g = np.arange(-0.5, 7.0, 0.5)
        X, Y, Z = np.meshgrid(g, g, np.arange(-0.5, 4.0, 1.0), indexing="ij")
        q = np.stack([X.ravel(), Y.ravel(), Z.ravel()], 1)
        pad = np.pad(occ, 1)  # voxel (i, j, k) at pad[i + 1, j + 1, k + 1]
        touching = []
        for dx, dy in itertools.product((0.25, -0.25), repeat=2):  # the voxels around each point
            idx = np.floor(q + [dx, dy, 0.0]).astype(int) + 1
            touching.append(pad[idx[:, 0], idx[:, 1], idx[:, 2]])
        touching = np.array(touching)
        full, empty = touching.all(axis=0), ~touching.any(axis=0)
        got = region.contains(q)
        assert full.sum() > 50 and empty.sum() > 500
        np.testing.assert_array_equal(got[full | empty], full[full | empty])


def test_tetra_volume_mesh_of_a_curved_body(tmp_path):
    """A sphere's tetrahedra (fem.mesh generators make a box; cut to a ball by its centroid):
    particles fill the tetrahedra's union to within 2% of its volume."""
    from mpmsim.fem.mesh import box

    m = box([-1, -1, -1], [1, 1, 1], 0.2)
    centroid = m.points[m.cells].mean(axis=1)
    cells = m.cells[np.linalg.norm(centroid, axis=1) < 0.8]
    meshio.write(tmp_path / "ball.vtu", meshio.Mesh(m.points, [("tetra", cells)]))
    p = m.points[cells]
    exact = np.abs(np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])).sum() / 6
    seed, _ = particles(tmp_path, {"file": "ball.vtu"}, 3, 0.1)
    assert abs(seed.vol.sum() / exact - 1) < 0.02


# ----------------------------------------------------------------------------- 2D
def test_plate_with_hole_msh_is_filled_to_its_area(tmp_path):
    pts, tris = plate_with_hole(1.0, 0.25, 64)
    area = enclosed_area(pts, tris)
    assert area == pytest.approx(1.0 - 0.5 * 64 * 0.25**2 * np.sin(2 * np.pi / 64), rel=1e-12)
    assert abs(area / (1 - np.pi * 0.25**2) - 1) < 0.002
    meshio.write(tmp_path / "plate.msh", meshio.Mesh(pts, [("triangle", tris)]), file_format="gmsh22", binary=False)
    seed, s = particles(tmp_path, {"file": "plate.msh"}, 2, 0.02)
    assert abs(seed.vol.sum() / area - 1) < 0.02  # thickness 1
    assert np.linalg.norm(seed.x - 0.5, axis=1).min() >= 0.25 * np.cos(np.pi / 64)
    assert len(seed.x) > 0.98 * area / s**2


def test_quad_vtu_2d_and_extruded_in_3d(tmp_path):
    """Quads of an L with a square hole, faces on lattice cell boundaries: the exact area, and
    extruded over z_range in a 3d deck the exact volume."""
    occ = l_block_with_hole()[:, :, 0]
    nx, ny = occ.shape
    j, i = np.meshgrid(np.arange(ny + 1), np.arange(nx + 1), indexing="ij")
    nodes = np.stack([i.ravel(), j.ravel(), np.zeros(i.size)], 1).astype(float)
    nid = lambda i, j: i + (nx + 1) * j  # noqa: E731
    ci, cj = np.nonzero(occ)
    quads = np.stack([nid(ci, cj), nid(ci + 1, cj), nid(ci + 1, cj + 1), nid(ci, cj + 1)], 1)
    meshio.write(tmp_path / "ell.vtu", meshio.Mesh(nodes, [("quad", quads)]))
    seed, s = particles(tmp_path, {"file": "ell.vtu", "scale": 0.1}, 2, 0.05, ppd=4)
    assert len(seed.x) == occ.sum() * round(0.1 / s) ** 2
    ij = np.floor(seed.x / 0.1).astype(int)
    assert occ[tuple(ij.T)].all()
    seed3, s3 = particles(tmp_path, {"file": "ell.vtu", "scale": 0.1, "z_range": [0.0, 0.2]}, 3, 0.05)
    assert len(seed3.x) == occ.sum() * round(0.1 / s3) ** 2 * round(0.2 / s3)


def test_translate_places_an_fem_mesh_body(tmp_path):
    from mpmsim.fem.mesh import rectangle

    m = rectangle([0, 0], [1, 0.5], 0.25)
    meshio.write(tmp_path / "plate.vtu", meshio.Mesh(np.column_stack([m.points, np.zeros(m.n_nodes)]),
                                                     [("triangle", m.cells)]))
    data = deck({"file": "plate.vtu", "scale": 2.0, "translate": [1.0, -1.0], "discretization": "fem",
                 "material": "steel"}, 2, 0.1)
    del data["grid"]
    scene = build_scene(deck_from(data, tmp_path))
    np.testing.assert_array_equal(scene.fem.points, 2.0 * m.points + [1.0, -1.0])


# ----------------------------------------------------------------------------- errors and a run
def _check(tmp_path, body: dict, dim: int = 3):
    import yaml

    (tmp_path / "deck.yaml").write_text(yaml.safe_dump(deck(body, dim, 0.1)))
    return CliRunner().invoke(app, ["check", str(tmp_path / "deck.yaml")])


def test_bad_mesh_files_exit_2_naming_the_file(tmp_path):
    pts, tris = torus(0.5, 0.2, 24, 12)
    meshio.write(tmp_path / "open.stl", meshio.Mesh(pts, [("triangle", tris[5:])]))
    (tmp_path / "junk.stl").write_text("solid nothing\nthis is not an stl\n")
    (tmp_path / "junk.msh").write_bytes(bytes(range(256)) * 4)
    meshio.write(tmp_path / "lines.vtu", meshio.Mesh(pts[:3], [("line", np.array([[0, 1], [1, 2]]))]))
    meshio.write(tmp_path / "tet.vtu", meshio.Mesh(np.eye(4, 3), [("tetra", np.array([[0, 1, 2, 3]]))]))
    meshio.write(tmp_path / "tiny.vtu", meshio.Mesh(0.01 * np.eye(4, 3) + 0.003, [("tetra", np.array([[0, 1, 2, 3]]))]))
    cases = [
        ({"file": "open.stl"}, 3, "bodies.0.file", r"open.stl: the surface is not closed: 15 edges"),
        ({"file": "junk.stl"}, 3, "bodies.0.file", "junk.stl: cannot read the mesh"),
        ({"file": "junk.msh"}, 3, "bodies.0.file", "junk.msh: cannot read the mesh"),
        ({"file": "missing.stl"}, 3, "bodies.0.file", "mesh file not found"),
        ({"file": "lines.vtu"}, 3, "bodies.0.file", "lines.vtu: no volume or surface cells (found: line)"),
        ({"file": "tet.vtu"}, 2, "bodies.0.file", "tet.vtu: no triangle or quadrilateral cells (found: tetra)"),
        ({"file": "tiny.vtu"}, 3, "bodies.0", "tiny.vtu holds no particle centre"),
        ({"file": "tet.vtu", "translate": [1.0, 2.0]}, 3, "bodies.0.translate", "needs 3 components"),
    ]
    for body, dim, key, message in cases:
        result = _check(tmp_path, body, dim)
        assert result.exit_code == 2, (body, result.output)
        lines = [ln for ln in result.output.splitlines() if ln.strip()]
        assert len(lines) == 2 and lines[0] == "mpmsim: bad deck", result.output
        assert f"{key}: " in lines[1] and message in lines[1], result.output
        assert "Traceback" not in result.output


def test_a_mesh_body_runs(tmp_path):
    pts, tris = torus(0.5, 0.2, 32, 16)
    meshio.write(tmp_path / "torus.stl", meshio.Mesh(pts, [("triangle", tris)]))
    import yaml

    data = deck({"file": "torus.stl", "velocity": [0.0, 0.0, -1.0]}, 3, 0.1)
    (tmp_path / "deck.yaml").write_text(yaml.safe_dump(data))
    result = CliRunner().invoke(app, ["run", str(tmp_path / "deck.yaml"), "--steps", "3", "--out",
                                      str(tmp_path / "out"), "--quiet", "--threads", "1"])
    assert result.exit_code == 0, result.output
    n = len(build_scene(deck_from(data, tmp_path)).deformable.x)
    last = sorted((tmp_path / "out").glob("deck*.vtu"))[-1]
    assert len(meshio.read(last).points) == n > 0
