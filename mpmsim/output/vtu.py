"""The output time series: each body kind contributes pieces of named parts (particles as
VTK vertex cells; mesh bodies as their cells); pieces of one part are written together as
one .vtu per output time, and one .pvd collection lists every part's files, so ParaView
opens the whole series (all parts, as blocks) in one step."""

from __future__ import annotations

import re
from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

from .atomic import atomic_path, write_text

MAIN_PART = "particles"  # its files keep the plain <stem>_NNNNNN.vtu name
OTHER_PARTS = ("fem",)  # parts written as <stem>_<part>_NNNNNN.vtu (body sets' vtu_pieces)


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


def part_meshes(state) -> dict[str, meshio.Mesh]:
    """{part name: mesh} of every body set's pieces (parts in first-seen order)."""
    parts: dict[str, list[dict]] = {}
    for body in state.bodies:
        for part, piece in body.vtu_pieces(state):
            parts.setdefault(part, []).append(piece)
    return {name: merge_pieces(pieces) for name, pieces in parts.items()}


def particle_mesh(state) -> meshio.Mesh:
    """The particles part: deformable then rigid particles with their fields."""
    return part_meshes(state)[MAIN_PART]


class VtuSeries:
    """Numbered VTU files (one per part and output time) plus the .pvd collection, rewritten
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
        # (and the hidden temporary files of a run that was killed mid-write)
        pattern = re.compile(r"\.?" + re.escape(self.stem) + rf"(_({parts}))?_\d{{6}}\.vtu(\.tmp)?")
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
        return self.directory / f"{self.stem}.pvd"

    def write(self, state) -> list[Path]:
        paths = []
        for part, mesh in part_meshes(state).items():
            if part not in self.parts:
                self.parts.append(part)
            label = "" if part == MAIN_PART else f"_{part}"
            name = f"{self.stem}{label}_{self.count:06d}.vtu"
            path = self.directory / name
            with atomic_path(path) as tmp:
                meshio.write(tmp, mesh, file_format="vtu")
            self.entries.append((state.t, self.parts.index(part), name))
            paths.append(path)
        self.count += 1
        self._write_pvd()
        return paths

    def _write_pvd(self) -> None:
        rows = "\n".join(f'    <DataSet timestep="{t:.10g}" group="" part="{k}" file={quoteattr(f)}/>'
                         for t, k, f in self.entries)
        text = ('<?xml version="1.0"?>\n'
                '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
                f"  <Collection>\n{rows}\n  </Collection>\n</VTKFile>\n")
        write_text(self.pvd_path, text)
