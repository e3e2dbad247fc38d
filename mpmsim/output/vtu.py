"""The output time series: each body kind contributes pieces of named parts (particles as
VTK vertex cells; mesh bodies as their cells); pieces of one part are written together as
one .vtu per output time. The .pvd collection `<stem>.pvd` lists the deformable parts
(particles and FEM bodies, as blocks), so ParaView opens the whole series in one step and its
colour ranges come from deformable material only; rigid bodies (zero stress, prescribed
motion) have their own collection `<stem>_rigid.pvd`.

Every file carries the names of the deck's materials as field data: `material_names` holds
the UTF-8 bytes of the names, each ended by a NUL byte, in the order of the `material` ids
(VTK's XML format has string arrays, but meshio and most readers of numeric arrays do not
read them; `material_names(mesh)` decodes the bytes)."""

from __future__ import annotations

import io
import re
from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

from .atomic import atomic_path, write_text

MAIN_PART = "particles"  # its files keep the plain <stem>_NNNNNN.vtu name
OTHER_PARTS = ("fem", "rigid", "contact")  # parts written as <stem>_<part>_NNNNNN.vtu (body sets' vtu_pieces;
# contact: the contact tractions of output.contact_traction)
OWN_COLLECTION = ("rigid", "contact")  # parts listed in <stem>_<part>.pvd instead of <stem>.pvd
NAMES_FIELD = "material_names"


def names_field(names: list[str]) -> np.ndarray:
    """The names as one uint8 array: UTF-8 bytes, each name ended by NUL."""
    return np.frombuffer("".join(f"{n}\0" for n in names).encode(), dtype=np.uint8).copy()


def material_names(mesh: meshio.Mesh) -> list[str]:
    """The material names a written file carries (index = the `material` id)."""
    raw = np.asarray(mesh.field_data[NAMES_FIELD], dtype=np.uint8).tobytes().decode()
    return raw.split("\0")[:-1]


def merge_pieces(pieces: list[dict]) -> meshio.Mesh:
    """One mesh from pieces of one part, in order. A field missing from a piece is zero there
    (e.g. internal energy on rigid particles)."""
    points = np.concatenate([p["points"] for p in pieces])
    counts = [len(p["points"]) for p in pieces]
    names: list[str] = []
    for p in pieces:
        names += [k for k in p["point_data"] if k not in names]
    data = {}
    for name in names:
        ref = next(p["point_data"][name] for p in pieces if name in p["point_data"])
        data[name] = np.concatenate([p["point_data"].get(name, np.zeros((c,) + ref.shape[1:], ref.dtype))
                                     for p, c in zip(pieces, counts)])
    if all(p.get("cells") is None for p in pieces):
        cells = [("vertex", np.arange(len(points), dtype=np.int64).reshape(-1, 1))]
        return meshio.Mesh(points, cells, point_data=data)
    cells, cell_data, offset = [], {}, 0
    for p, c in zip(pieces, counts):
        for ctype, conn in p["cells"]:
            cells.append((ctype, conn + offset))
        for k, v in p.get("cell_data", {}).items():
            cell_data.setdefault(k, []).extend(v)
        offset += c
    return meshio.Mesh(points, cells, point_data=data, cell_data=cell_data or None)


def write_vtu(path: Path, mesh: meshio.Mesh) -> None:
    """Write a mesh's VTU file whole or not at all (meshio's writer, binary and zlib-compressed),
    with its integer field data, which that writer leaves out, as a <FieldData> block appended
    to the grid (VTK and meshio find it wherever it stands among the grid's children)."""
    with atomic_path(path) as tmp:
        meshio.write(tmp, mesh, file_format="vtu")
        if mesh.field_data:
            arrays = "".join(f'<DataArray type="{_VTK_INT[np.dtype(v.dtype).name]}" Name={quoteattr(k)} '
                             f'NumberOfTuples="{len(v)}" format="ascii">{" ".join(str(int(x)) for x in v)}'
                             "</DataArray>" for k, v in mesh.field_data.items())
            with open(tmp, "r+b") as fh:
                fh.seek(max(0, fh.seek(0, 2) - 256))
                tail = fh.read()
                at = tail.rindex(b"</UnstructuredGrid>")
                fh.seek(-len(tail) + at, 2)
                fh.write(f"<FieldData>{arrays}</FieldData>".encode() + tail[at:])


_VTK_INT = {"uint8": "UInt8", "int32": "Int32", "int64": "Int64"}


def part_meshes(state) -> dict[str, meshio.Mesh]:
    """{part name: mesh} of every body set's pieces (parts in first-seen order), each with the
    material names as field data."""
    parts: dict[str, list[dict]] = {}
    for body in state.bodies:
        for part, piece in body.vtu_pieces(state):
            parts.setdefault(part, []).append(piece)
    meshes = {name: merge_pieces(pieces) for name, pieces in parts.items()}
    names = names_field(state.materials.names)
    for mesh in meshes.values():
        mesh.field_data[NAMES_FIELD] = names
    return meshes


class VtuSeries:
    """Numbered VTU files (one per part and output time) plus the .pvd collections, rewritten
    whole after each output time."""

    def __init__(self, directory: Path, stem: str, clear: bool = True):
        """`clear`: remove an earlier run's files of this deck now (a restart instead keeps the
        frames its checkpoint lists: `remove_stale(keep=...)` once they are known)."""
        self.directory = Path(directory)
        self.stem = stem
        self.entries: list[tuple[float, int, str]] = []  # (time, part index, file)
        self.parts: list[str] = []
        self.count = 0
        self.removed = self.remove_stale() if clear else 0

    def remove_stale(self, keep: frozenset[str] = frozenset()) -> int:
        """Delete the numbered VTU files an earlier run of this deck left in the folder (same
        stem, `<stem>[_part]_NNNNNN.vtu`, and `.<name>.tmp` files of a killed run), except the
        names in `keep`, so the folder holds one consistent series. Returns how many were removed."""
        parts = "|".join(re.escape(p) for p in OTHER_PARTS)
        own = "|".join(re.escape(p) for p in OWN_COLLECTION)
        # (and the hidden temporary files of a run that was killed mid-write; the collections of
        # parts with their own .pvd are rewritten from the entries kept)
        pattern = re.compile(r"\.?" + re.escape(self.stem)
                             + rf"((_({parts}))?_\d{{6}}\.vtu|_({own})\.pvd)(\.tmp)?")
        n = 0
        if self.directory.is_dir():
            for path in self.directory.iterdir():
                if pattern.fullmatch(path.name) and path.name not in keep and path.is_file():
                    path.unlink()
                    n += 1
        return n

    def resumed(self) -> None:
        """After a restart restored `entries`: only the listed frames stay, and the .pvd lists them."""
        self.remove_stale(keep=frozenset(f for _, _, f in self.entries))
        self._write_pvd()

    @property
    def pvd_path(self) -> Path:
        return self.collection_path(MAIN_PART)

    def collection_path(self, part: str) -> Path:
        """The .pvd that lists a part's files."""
        label = f"_{part}" if part in OWN_COLLECTION else ""
        return self.directory / f"{self.stem}{label}.pvd"

    def write(self, state) -> list[Path]:
        paths = []
        meshes = part_meshes(state)
        add_contact_tractions(state, meshes)
        for part, mesh in meshes.items():
            if part not in self.parts:
                self.parts.append(part)
            label = "" if part == MAIN_PART else f"_{part}"
            name = f"{self.stem}{label}_{self.count:06d}.vtu"
            path = self.directory / name
            write_vtu(path, mesh)
            self.entries.append((state.t, self.parts.index(part), name))
            paths.append(path)
        self.count += 1
        self._write_pvd()
        return paths

    def _write_pvd(self) -> None:
        """Each collection lists its parts' files; a part's block number counts within its
        collection. The main collection is written even before any frame."""
        collections: dict[Path, list[str]] = {self.pvd_path: []}
        for part in self.parts:
            collections.setdefault(self.collection_path(part), []).append(part)
        for path, parts in collections.items():
            rows = "\n".join(f'    <DataSet timestep="{t:.10g}" group="" part="{parts.index(self.parts[k])}" '
                             f'file={quoteattr(f)}/>' for t, k, f in self.entries if self.parts[k] in parts)
            text = ('<?xml version="1.0"?>\n'
                    '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
                    f"  <Collection>\n{rows}\n  </Collection>\n</VTKFile>\n")
            write_text(path, text)


def add_contact_tractions(state, meshes: dict[str, meshio.Mesh]) -> None:
    """With output.contact_traction: the last step's contact targets as the part `contact`
    (vertex cells at their grid nodes; none in a frame without contact nodes, e.g. t = 0: its
    collection then lists only the frames that have some), and each particle's
    contact_traction and contact_pressure added to the particles' mesh (docs/output.md)."""
    cs = getattr(state, "contact", None)
    if cs is None or not cs.spec.traction or cs.slot_force is None:
        return
    from ..contact.grid.traction import node_tractions, particle_tractions, slot_shares

    g = state.grid
    nt = node_tractions(cs, g.shape)
    if len(nt.slot):
        shape = g.shape
        ijk = np.stack([nt.node % shape[0], (nt.node // shape[0]) % shape[1], nt.node // (shape[0] * shape[1])], 1)
        pts = g.origin + ijk[:, : g.dim] * g.h
        data = {"contact_pressure": nt.pressure, "tangential_traction": _pad3(nt.tangential),
                "traction": _pad3(nt.traction), "normal": _pad3(nt.normal), "contact_area": nt.area,
                "contact_force": _pad3(nt.force), "group": nt.group.astype(np.int32),
                "partner_group": nt.partner.astype(np.int32), "in_contact": nt.in_contact.astype(np.int32)}
        mesh = meshio.Mesh(_pad3(pts), [("vertex", np.arange(len(pts), dtype=np.int64).reshape(-1, 1))],
                           point_data=data)
        mesh.field_data[GROUP_NAMES_FIELD] = names_field(list(cs.spec.group_names))
        meshes["contact"] = mesh
    particles = meshes.get(MAIN_PART)
    P = state.particles
    if particles is not None and len(particles.points) >= P.n:
        t, p = particle_tractions(cs, state.sd.S, g.n_nodes, *slot_shares(cs, nt))
        rows = len(particles.points)
        particles.point_data["contact_traction"] = np.zeros((rows, 3))
        particles.point_data["contact_traction"][: P.n] = _pad3(t)
        particles.point_data["contact_pressure"] = np.zeros(rows)
        particles.point_data["contact_pressure"][: P.n] = p


GROUP_NAMES_FIELD = "group_names"  # the contact part's material groups (names joined by '+'), as material_names


def _pad3(a: np.ndarray) -> np.ndarray:
    out = np.zeros((a.shape[0], 3))
    out[:, : a.shape[1]] = a
    return out
