"""Particles as VTK vertex cells (meshio), one .vtu per output time, and the .pvd collection
that ParaView opens as one time series."""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

from .atomic import atomic_path, write_text


def _pad3(a: np.ndarray) -> np.ndarray:
    out = np.zeros((a.shape[0], 3))
    out[:, : a.shape[1]] = a
    return out


def particle_mesh(state) -> meshio.Mesh:
    """Deformable then rigid particles with their fields (rigid: zero stress, F = I)."""
    P, R, mats = state.particles, state.rigid, state.materials
    dim = state.dim
    n, nr = P.n, R.n
    F9 = np.zeros((n + nr, 3, 3))
    F9[:, 2, 2] = 1.0
    F9[:n, :dim, :dim] = P.F
    F9[n:] = np.eye(3)
    J = np.concatenate([np.linalg.det(F9[:n]), np.ones(nr)])
    gid_def = np.array([mats.global_id(m) for m in mats.deformable], dtype=np.int32)
    gid_rig = np.array([mats.global_id(m) for m in mats.rigid], dtype=np.int32)
    material = np.concatenate([gid_def[P.mat], gid_rig[R.mat] if nr else np.zeros(0, np.int32)])
    x = np.concatenate([P.x, R.x])
    data = {
        "velocity": _pad3(np.concatenate([P.v, R.v])),
        "displacement": _pad3(np.concatenate([P.x - P.x0, R.x - R.x0])),
        "stress": np.concatenate([P.stress, np.zeros((nr, 6))]),
        "deformation_gradient": F9.reshape(-1, 9),
        "J": J,
        "material": material,
        "body": np.concatenate([P.body, R.body]).astype(np.int32),
        "rigid": np.concatenate([np.zeros(n, np.uint8), np.ones(nr, np.uint8)]),
        "mass": np.concatenate([P.mass, np.zeros(nr)]),
        "volume": np.concatenate([P.vol, R.vol]),
    }
    if mats.tracks_energy:  # zero on particles of materials without internal energy
        on = mats.energy[P.mat]
        data["internal_energy"] = np.concatenate([np.where(on, P.U, 0.0), np.zeros(nr)])
        data["pressure"] = np.concatenate([np.where(on, P.pressure, 0.0), np.zeros(nr)])
    cells = [("vertex", np.arange(n + nr, dtype=np.int64).reshape(-1, 1))]
    return meshio.Mesh(_pad3(x), cells, point_data=data)


class VtuSeries:
    """Numbered VTU files plus the .pvd collection, rewritten whole after each file."""

    def __init__(self, directory: Path, stem: str):
        self.directory = Path(directory)
        self.stem = stem
        self.entries: list[tuple[float, str]] = []

    @property
    def pvd_path(self) -> Path:
        return self.directory / f"{self.stem}.pvd"

    def write(self, state) -> Path:
        name = f"{self.stem}_{len(self.entries):06d}.vtu"
        path = self.directory / name
        with atomic_path(path) as tmp:
            meshio.write(tmp, particle_mesh(state), file_format="vtu")
        self.entries.append((state.t, name))
        self._write_pvd()
        return path

    def _write_pvd(self) -> None:
        rows = "\n".join(f'    <DataSet timestep="{t:.10g}" group="" part="0" file={quoteattr(f)}/>'
                         for t, f in self.entries)
        text = ('<?xml version="1.0"?>\n'
                '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
                f"  <Collection>\n{rows}\n  </Collection>\n</VTKFile>\n")
        write_text(self.pvd_path, text)
