"""FEM meshes as plain arrays: linear triangles (2D) and linear tetrahedra (3D).

Conventions (every FemMesh, generated or read):
- `points` (n, dim) float64 reference node positions; every point is used by some cell.
- `cells` (m, dim + 1) int64, positively oriented: signed area (2D) / volume (3D) > 0, i.e.
  counter-clockwise triangles and det[X1 - X0, X2 - X0, X3 - X0] > 0 for tetrahedra.
- `facets` (b, dim) int64 boundary edges (2D) / triangles (3D): the faces used by exactly one
  cell, ordered so the outward normal is right-handed. 2D: for edge (a, b), e = x_b - x_a, the
  outward normal is (e_y, -e_x) / |e| (the edge runs counter-clockwise round its parent).
  3D: (x_b - x_a) x (x_c - x_a) points outward. Local faces of a positive tetrahedron
  (0, 1, 2, 3) with outward order: (1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1).
- `boundary_nodes` sorted unique nodes of the facets.
- `node_sets` name -> sorted node indices (from a mesh file's point sets / cell sets /
  Gmsh physical groups; empty for generated meshes).

Generators take an element size h and use n = ceil(L / h) cells per length L, so no edge of
the structured part is longer than h. The normals helpers run numba kernels so the contact
code can call them every step.
"""

from __future__ import annotations

import contextlib
import io
import itertools
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numba import njit

from .. import linalg


class MeshError(ValueError):
    """A mesh that cannot be used: unreadable file, no triangles/tetrahedra, degenerate or
    non-manifold cells. The message is one line naming the file (and the cell, if any)."""


# faces of a positively oriented simplex, in outward (right-handed) order
LOCAL_FACETS = {
    2: np.array([[0, 1], [1, 2], [2, 0]], dtype=np.int64),
    3: np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]], dtype=np.int64),
}


# ----------------------------------------------------------------------------- normals
@njit(cache=True)
def facet_normal_kernel(x, facets, normals, areas):
    """Unit outward normals (b, dim) and lengths/areas (b,) of the facets at positions x.
    2D: n = (e_y, -e_x) / |e|; 3D: n = (xb - xa) x (xc - xa) / |...|, area = |...| / 2."""
    dim = x.shape[1]
    for f in range(facets.shape[0]):
        a = facets[f, 0]
        b = facets[f, 1]
        if dim == 2:
            nx = x[b, 1] - x[a, 1]
            ny = -(x[b, 0] - x[a, 0])
            s = np.sqrt(nx * nx + ny * ny)
            areas[f] = s
            normals[f, 0] = nx / s
            normals[f, 1] = ny / s
        else:
            c = facets[f, 2]
            u0, u1, u2 = x[b, 0] - x[a, 0], x[b, 1] - x[a, 1], x[b, 2] - x[a, 2]
            w0, w1, w2 = x[c, 0] - x[a, 0], x[c, 1] - x[a, 1], x[c, 2] - x[a, 2]
            nx = u1 * w2 - u2 * w1
            ny = u2 * w0 - u0 * w2
            nz = u0 * w1 - u1 * w0
            s = np.sqrt(nx * nx + ny * ny + nz * nz)
            areas[f] = 0.5 * s
            normals[f, 0] = nx / s
            normals[f, 1] = ny / s
            normals[f, 2] = nz / s


@njit(cache=True)
def node_normal_kernel(x, facets, out, unit=True):
    """Area-weighted mean of the adjacent facet normals at each node, normalised (unit=False:
    divided by the summed area instead, so that its length says how well the facets agree: 1 on
    a flat face, cos 45 degrees at a right-angled corner); rows of nodes on no facet stay zero.
    out (n, dim) is overwritten."""
    dim = x.shape[1]
    k = facets.shape[1]
    normals = np.empty((facets.shape[0], dim))
    areas = np.empty(facets.shape[0])
    facet_normal_kernel(x, facets, normals, areas)
    out[:] = 0.0
    total = np.zeros(out.shape[0])
    for f in range(facets.shape[0]):
        for j in range(k):
            i = facets[f, j]
            total[i] += areas[f]
            for a in range(dim):
                out[i, a] += areas[f] * normals[f, a]
    for i in range(out.shape[0]):
        s = 0.0
        for a in range(dim):
            s += out[i, a] * out[i, a]
        if s > 0.0:
            s = np.sqrt(s) if unit else total[i]
            for a in range(dim):
                out[i, a] /= s


# ----------------------------------------------------------------------------- FemMesh
def signed_volumes(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Signed area (2D) / volume (3D) of each cell (vectorised)."""
    p = np.asarray(points, float)
    x0 = p[cells[:, 0]]
    if cells.shape[1] == 3:
        u, w = p[cells[:, 1]] - x0, p[cells[:, 2]] - x0
        return 0.5 * (u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0])
    u, w, t = p[cells[:, 1]] - x0, p[cells[:, 2]] - x0, p[cells[:, 3]] - x0
    return np.einsum("ij,ij->i", np.cross(u, w), t) / 6.0


def orient_cells(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """A copy of cells with the negatively oriented ones flipped (last two nodes swapped)."""
    cells = np.array(cells, dtype=np.int64, copy=True)
    neg = signed_volumes(points, cells) < 0.0
    cells[neg, -2], cells[neg, -1] = cells[neg, -1].copy(), cells[neg, -2].copy()
    return cells


def boundary_facets(cells: np.ndarray) -> np.ndarray:
    """Faces used by exactly one cell, outward ordered (cells must be positively oriented).
    Raises MeshError for a face shared by three or more cells (non-manifold mesh)."""
    dim = cells.shape[1] - 1
    faces = cells[:, LOCAL_FACETS[dim]].reshape(-1, dim)
    keys = np.sort(faces, axis=1)
    _, first, counts = np.unique(keys, axis=0, return_index=True, return_counts=True)
    if counts.size and counts.max() > 2:
        k = int(np.argmax(counts > 2))
        cell = int(first[k] // (dim + 1))
        raise MeshError(f"a {'edge' if dim == 2 else 'face'} of cell {cell} is shared by {int(counts[k])} cells "
                        "(non-manifold mesh)")
    return faces[np.sort(first[counts == 1])]


@dataclass
class FemMesh:
    """A simplex mesh (see the module docstring for the conventions)."""

    points: np.ndarray  # (n, dim) float64
    cells: np.ndarray  # (m, dim + 1) int64, positive orientation
    facets: np.ndarray  # (b, dim) int64, outward oriented boundary edges / triangles
    boundary_nodes: np.ndarray  # (nb,) sorted unique nodes on facets
    node_sets: dict = field(default_factory=dict)  # name -> sorted node indices

    @classmethod
    def from_cells(cls, points, cells, node_sets=None) -> FemMesh:
        """Mesh from points and cells: orients the cells positively and finds the boundary."""
        points = np.ascontiguousarray(points, dtype=np.float64)
        cells = orient_cells(points, np.asarray(cells, dtype=np.int64))
        facets = np.ascontiguousarray(boundary_facets(cells))
        return cls(points, np.ascontiguousarray(cells), facets, np.unique(facets), dict(node_sets or {}))

    @property
    def dim(self) -> int:
        return self.points.shape[1]

    @property
    def n_nodes(self) -> int:
        return self.points.shape[0]

    @property
    def n_cells(self) -> int:
        return self.cells.shape[0]

    def volumes(self, x=None) -> np.ndarray:
        """Signed area (2D) / volume (3D) of each cell at positions x (default: reference)."""
        return signed_volumes(self.points if x is None else x, self.cells)

    def facet_normals(self, x=None) -> np.ndarray:
        """(b, dim) unit outward normals of the facets at positions x (default: reference)."""
        x = np.ascontiguousarray(self.points if x is None else x, dtype=np.float64)
        normals = np.empty((len(self.facets), self.dim))
        facet_normal_kernel(x, self.facets, normals, np.empty(len(self.facets)))
        return normals

    def facet_areas(self, x=None) -> np.ndarray:
        """(b,) facet lengths (2D) / areas (3D) at positions x (default: reference)."""
        x = np.ascontiguousarray(self.points if x is None else x, dtype=np.float64)
        areas = np.empty(len(self.facets))
        facet_normal_kernel(x, self.facets, np.empty((len(self.facets), self.dim)), areas)
        return areas

    def node_normals(self, x=None) -> np.ndarray:
        """(n, dim) unit outward normals at the nodes: the area-weighted mean of the adjacent
        facet normals, normalised; zero rows for interior nodes."""
        x = np.ascontiguousarray(self.points if x is None else x, dtype=np.float64)
        out = np.empty_like(x)
        node_normal_kernel(x, self.facets, out)
        return out

    def nodes_in_box(self, lo, hi, tol: float = 1e-9) -> np.ndarray:
        """Sorted indices of the reference nodes inside [lo, hi] (inclusive, widened by tol
        times the mesh extent)."""
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        pad = tol * max(float(np.ptp(self.points, axis=0).max()), 1e-300)
        inside = np.all((self.points >= lo - pad) & (self.points <= hi + pad), axis=1)
        return np.flatnonzero(inside)


# ----------------------------------------------------------------------------- generators
def _divisions(length: float, h: float) -> int:
    if not (h > 0.0):
        raise MeshError(f"element size must be > 0, got {h}")
    if not (length > 0.0):
        raise MeshError(f"extent must be > 0, got {length}")
    return max(1, math.ceil(length / h - 1e-9))


def rectangle(lo, hi, h: float) -> FemMesh:
    """Triangles on [lo, hi] (2D) with nx = ceil(Lx / h), ny = ceil(Ly / h) cells, each cell
    split by a diagonal whose direction alternates in a checkerboard ("union jack"): nodes stay
    on the regular grid (boundary spacing <= h, no extra centre nodes), every triangle is a right
    triangle, and unlike a single-diagonal pattern the mesh has no preferred shear direction
    (it is mirror symmetric about the centre lines when nx, ny are even)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    if lo.shape != (2,) or hi.shape != (2,):
        raise MeshError("rectangle needs 2D corners")
    nx, ny = (_divisions(hi[a] - lo[a], h) for a in range(2))
    xs, ys = np.linspace(lo[0], hi[0], nx + 1), np.linspace(lo[1], hi[1], ny + 1)
    X, Y = np.meshgrid(xs, ys, indexing="xy")  # node id = i + (nx + 1) j
    points = np.stack([X.ravel(), Y.ravel()], axis=1)
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="xy")
    i, j = i.ravel(), j.ravel()
    n00 = i + (nx + 1) * j
    n10, n01, n11 = n00 + 1, n00 + nx + 1, n00 + nx + 2
    even = (i + j) % 2 == 0
    # even cells: diagonal n00-n11; odd cells: diagonal n10-n01 (all counter-clockwise)
    t1 = np.where(even[:, None], np.stack([n00, n10, n11], 1), np.stack([n00, n10, n01], 1))
    t2 = np.where(even[:, None], np.stack([n00, n11, n01], 1), np.stack([n10, n11, n01], 1))
    cells = np.stack([t1, t2], axis=1).reshape(-1, 3)
    return FemMesh.from_cells(points, cells)


# Kuhn/Freudenthal split of the unit cube: one tetrahedron per ordering of the axes, the path
# 000 -> e_p0 -> e_p0 + e_p1 -> 111; all six share the main diagonal. The split of each face is
# the same in neighbouring cubes, so the mesh is conforming.
_KUHN_PERMS = ((0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0))


def box(lo, hi, h: float) -> FemMesh:
    """Tetrahedra on [lo, hi] (3D): ceil(L / h) cubes per direction, six Kuhn tetrahedra per
    cube (conforming; every tetrahedron has volume (cell volume) / 6)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    if lo.shape != (3,) or hi.shape != (3,):
        raise MeshError("box needs 3D corners")
    n = [_divisions(hi[a] - lo[a], h) for a in range(3)]
    axes = [np.linspace(lo[a], hi[a], n[a] + 1) for a in range(3)]
    Z, Y, X = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")  # node id = i + (nx+1)(j + (ny+1) k)
    points = np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)
    stride = np.array([1, n[0] + 1, (n[0] + 1) * (n[1] + 1)], dtype=np.int64)
    k, j, i = np.meshgrid(np.arange(n[2]), np.arange(n[1]), np.arange(n[0]), indexing="ij")
    base = (i.ravel() * stride[0] + j.ravel() * stride[1] + k.ravel() * stride[2]).astype(np.int64)
    local = []
    for p in _KUHN_PERMS:
        corner = np.zeros(3, dtype=np.int64)
        verts = [0]
        for a in p:
            corner[a] = 1
            verts.append(int(corner @ stride))
        local.append(verts)
    cells = (base[:, None, None] + np.array(local, dtype=np.int64)[None]).reshape(-1, 4)
    return FemMesh.from_cells(points, cells)


def _stitch(inner: np.ndarray, outer: np.ndarray, points: np.ndarray) -> list:
    """Triangles between two closed node rings (node indices in counter-clockwise order): walk
    both rings once, each time closing the triangle whose new cross edge is shorter."""
    na, nb = len(inner), len(outer)
    if na == 1:  # the centre of a disk: a fan
        return [(inner[0], outer[j], outer[(j + 1) % nb]) for j in range(nb)]
    tris = []
    i = j = 0
    while i < na or j < nb:
        a, b = inner[i % na], outer[j % nb]
        a1, b1 = inner[(i + 1) % na], outer[(j + 1) % nb]
        if i == na:
            step_outer = True
        elif j == nb:
            step_outer = False
        else:  # new edge a-b1 (advance the outer ring) or a1-b (advance the inner ring)
            step_outer = np.sum((points[a] - points[b1]) ** 2) <= np.sum((points[a1] - points[b]) ** 2)
        if step_outer:
            tris.append((a, b, b1))
            j += 1
        else:
            tris.append((a, b, a1))
            i += 1
    return tris


def _ring_mesh(center, radii, counts) -> FemMesh:
    center = np.asarray(center, float)
    if center.shape != (2,):
        raise MeshError("disk and ring need a 2D center")
    rings, pts = [], []
    start = 0
    for k, (r, n) in enumerate(zip(radii, counts)):
        phase = 0.0 if k % 2 == 0 else np.pi / n  # stagger neighbouring rings by half a step
        t = phase + 2.0 * np.pi * np.arange(n) / n
        pts.append(center + r * np.stack([np.cos(t), np.sin(t)], axis=1))
        rings.append(np.arange(start, start + n))
        start += n
    points = np.concatenate(pts)
    tris = []
    for a, b in itertools.pairwise(rings):
        tris += _stitch(a, b, points)
    return FemMesh.from_cells(points, np.array(tris, dtype=np.int64))


def disk(center, radius: float, h: float) -> FemMesh:
    """Triangles filling the disk: a centre node and nr = ceil(R / h) concentric rings, ring k
    at radius k R / nr with 6 k nodes (the hexagonal pattern: arc spacing ~1.05 times the ring
    spacing, near-equilateral triangles), neighbouring rings stitched. The boundary is the
    inscribed regular 6 nr-gon, area (6 nr / 2) R^2 sin(2 pi / (6 nr))."""
    nr = _divisions(radius, h)
    radii = [0.0] + [k * radius / nr for k in range(1, nr + 1)]
    counts = [1] + [6 * k for k in range(1, nr + 1)]
    return _ring_mesh(center, radii, counts)


def ring(center, r_inner: float, r_outer: float, h: float) -> FemMesh:
    """Triangles filling the annulus r_inner <= |x - c| <= r_outer: nr = ceil((ro - ri) / h)
    + 1 concentric node rings, ring of radius r with max(6, ceil(2 pi r / h)) nodes (arc spacing
    <= h), neighbouring rings stitched. Both boundaries are inscribed regular polygons."""
    if not (0.0 < r_inner < r_outer):
        raise MeshError(f"ring needs 0 < r_inner < r_outer, got {r_inner}, {r_outer}")
    nr = _divisions(r_outer - r_inner, h)
    radii = [r_inner + k * (r_outer - r_inner) / nr for k in range(nr + 1)]
    counts = [max(6, math.ceil(2.0 * np.pi * r / h - 1e-9)) for r in radii]
    return _ring_mesh(center, radii, counts)


def rotation_matrix(rotation_deg: float, axis="z", dim: int = 3) -> np.ndarray:
    """Counter-clockwise rotation by rotation_deg about a coordinate axis ('x', 'y', 'z' or
    0, 1, 2); in 2D only about z."""
    a = "xyz".index(axis) if isinstance(axis, str) else int(axis)
    t = np.deg2rad(rotation_deg)
    c, s = np.cos(t), np.sin(t)
    if dim == 2:
        if a != 2:
            raise MeshError("2D rotations are about z")
        return np.array([[c, -s], [s, c]])
    R = np.eye(3)
    p, q = [(1, 2), (2, 0), (0, 1)][a]
    R[p, p], R[p, q], R[q, p], R[q, q] = c, -s, s, c
    return R


def transformed(mesh: FemMesh, rotation_deg: float = 0.0, axis="z", about=None, translation=None,
                scale: float = 1.0) -> FemMesh:
    """A copy of mesh with its points mapped x -> about + R (scale x - about) + translation:
    first a uniform scale (> 0, about the origin), then a rotation by rotation_deg about `axis`
    through the point `about` (default: the origin), then the translation. Scales > 0 and
    rotations keep cell and facet orientations, so cells, facets and node sets are shared."""
    dim = mesh.dim
    if not (scale > 0.0):
        raise MeshError(f"scale must be > 0, got {scale}")
    x = mesh.points * float(scale)
    if rotation_deg:
        c = np.zeros(dim) if about is None else np.asarray(about, float)
        x = c + linalg.matmul(np.ascontiguousarray(x - c), np.ascontiguousarray(rotation_matrix(rotation_deg, axis, dim).T))
    if translation is not None:
        x = x + np.asarray(translation, float)
    return replace(mesh, points=np.ascontiguousarray(x), node_sets=dict(mesh.node_sets))


# ----------------------------------------------------------------------------- files
def _one_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _meshio_read(path: Path):
    """meshio.read with its console output captured and every failure as a MeshError: for a
    file no reader accepts meshio prints the reasons and calls sys.exit(1). numpy warnings of
    its readers are silenced (the STL reader's size test of an ASCII file overflows)."""
    import meshio

    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), np.errstate(all="ignore"):
            return meshio.read(str(path))
    except (Exception, SystemExit) as exc:  # meshio raises many exception types for bad input
        said = " ".join((out.getvalue() + " " + err.getvalue()).split())
        reason = said.removeprefix("Error: ") if isinstance(exc, SystemExit) and said else _one_line(exc)
        raise MeshError(f"{path}: cannot read the mesh ({reason})") from exc


def _file_node_sets(raw, dim: int, renumber: np.ndarray) -> dict:
    """Node sets of a meshio mesh: point sets, the nodes of named cell sets (any cell type:
    e.g. Gmsh physical lines or Abaqus element sets) and, for Gmsh 2.2 files, the nodes of the
    physical groups in cell_data['gmsh:physical']; renumbered, unused points dropped."""
    sets: dict[str, list] = {}
    for name, idx in (raw.point_sets or {}).items():
        sets.setdefault(name, []).append(np.asarray(idx, dtype=np.int64).ravel())
    for name, members in (raw.cell_sets or {}).items():
        if name.startswith("gmsh:"):
            continue
        for mem, block in zip(members, raw.cells):
            if mem is not None and len(mem):
                sets.setdefault(name, []).append(np.asarray(block.data)[np.asarray(mem, dtype=np.int64)].ravel())
    physical = raw.cell_data.get("gmsh:physical")
    if physical is not None and raw.field_data:
        for name, data in raw.field_data.items():
            if name in sets or len(data) < 2:
                continue
            tag, gdim = int(data[0]), int(data[1])
            for tags, block in zip(physical, raw.cells):
                if block.dim == gdim:
                    sel = np.asarray(tags) == tag
                    if sel.any():
                        sets.setdefault(name, []).append(np.asarray(block.data)[sel].ravel())
    out = {}
    for name, parts in sets.items():
        nodes = np.concatenate(parts).astype(np.int64)
        nodes = nodes[(nodes >= 0) & (nodes < len(renumber))]
        nodes = renumber[nodes]
        out[name] = np.unique(nodes[nodes >= 0])
    return out


def file_cells(path, dim: int, kinds: dict, need: str, what: str | None = None):
    """Read a mesh file meshio understands and keep its cells of the meshio types in `kinds`
    (type -> number of corner nodes kept: a quadratic cell keeps its corners). Returns (the
    meshio mesh, points (n, dim) of the used nodes, renumbered in file order, {type: cells
    (m, corners) int64 into those points}, renumber (file node -> kept node or -1)).
    Raises MeshError naming the file for a missing or unreadable file, a file without such
    cells (the message calls them `what`, default: the type names, and ends with `need`), bad
    node indices, non-finite coordinates or, for dim 2, points off a plane z = const (a
    constant z is dropped)."""
    path = Path(path)
    if dim not in (2, 3):
        raise MeshError(f"{path}: dimension must be 2 or 3, got {dim}")
    if not path.is_file():
        raise MeshError(f"{path}: mesh file not found")
    raw = _meshio_read(path)
    blocks = {}
    for c in raw.cells:
        if c.type in kinds and len(c.data):
            blocks.setdefault(c.type, []).append(np.asarray(c.data)[:, : kinds[c.type]])
    if not blocks:
        found = sorted({c.type for c in raw.cells})
        want = what or " or ".join(kinds)
        raise MeshError(f"{path}: no {want} cells (found: {', '.join(found) or 'none'}); {need}")
    blocks = {k: np.concatenate(v).astype(np.int64) for k, v in blocks.items()}
    pts = np.asarray(raw.points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3) or (dim == 3 and pts.shape[1] != 3):
        raise MeshError(f"{path}: points have {pts.shape[-1] if pts.ndim == 2 else '?'} coordinates; "
                        f"a {dim}D mesh needs {dim}")
    for kind, cells in blocks.items():
        bad_index = np.flatnonzero(np.any((cells < 0) | (cells >= len(pts)), axis=1))
        if bad_index.size:
            c = int(bad_index[0])
            raise MeshError(f"{path}: {kind} cell {c} refers to a node outside the {len(pts)} points")
    used = np.unique(np.concatenate([c.ravel() for c in blocks.values()]))
    if not np.all(np.isfinite(pts[used])):
        raise MeshError(f"{path}: non-finite point coordinates")
    if dim == 2 and pts.shape[1] == 3:
        z = pts[used, 2]
        extent = float(np.ptp(pts[used, :2], axis=0).max())
        if np.ptp(z) > 1e-9 * max(extent, 1e-300):
            noun = "triangles" if list(blocks) == ["triangle"] else "cells"
            raise MeshError(f"{path}: the {noun} are not in a plane z = const (z spans {z.min():.6g} to "
                            f"{z.max():.6g}); a 2D mesh must be flat")
        pts = pts[:, :2]
    renumber = np.full(len(pts), -1, dtype=np.int64)
    renumber[used] = np.arange(len(used))
    return raw, np.ascontiguousarray(pts[used]), {k: renumber[c] for k, c in blocks.items()}, renumber


def read_mesh(path, dim: int) -> FemMesh:
    """Read a mesh file meshio understands (.msh, .vtu, .vtk, .inp, ...): its `triangle` cells
    (dim 2; a z coordinate that is constant is dropped) or `tetra` cells (dim 3). Negatively
    oriented cells are flipped, unused points dropped (nodes renumbered in file order), and
    node sets kept. Raises MeshError naming the file for an unreadable file, a file without
    such cells, points off the plane (2D), non-finite coordinates, bad node indices, a degenerate
    cell (|signed volume| < 1e-12 x the mean; the message gives its 0-based index among the
    file's triangles/tetrahedra) or a non-manifold mesh."""
    path = Path(path)
    kind = "triangle" if dim == 2 else "tetra"
    raw, pts, blocks, renumber = file_cells(
        path, dim, {kind: dim + 1}, f"a {dim}D FEM body needs linear {'triangles' if dim == 2 else 'tetrahedra'}")
    cells = blocks[kind]
    vol = signed_volumes(pts, cells)
    mean = float(np.mean(np.abs(vol)))
    degenerate = np.flatnonzero(~(np.abs(vol) >= 1e-12 * mean) | (mean == 0.0))
    if degenerate.size:
        c = int(degenerate[0])
        what = "area" if dim == 2 else "volume"
        raise MeshError(f"{path}: {kind} cell {c} is degenerate ({what} {vol[c]:.3g}, mean {mean:.3g})")
    node_sets = _file_node_sets(raw, dim, renumber)
    try:
        return FemMesh.from_cells(pts, cells, node_sets)
    except MeshError as exc:
        raise MeshError(f"{path}: {exc}") from None
