"""CSV history of global quantities: one row per history time, header 'name [unit]', after
a first line `# title: <deck title>` (for plot labels; readers skip '#' lines).

Stress is the volume-weighted Cauchy average over deformable particles (notes §8).
Reaction forces are what each constrained face or rigid material exerts on the material,
from the last step (instantaneous, not averaged). In 2D, forces and energies are for the
deck's thickness.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..deck.units import unit_system
from ..globals import INTERNAL, KINETIC, MOMENTUM, STRAIN, VOLUME, null_space_noise, particle_sums, velocity_noise
from ..scene.grid import FACES
from .atomic import write_text

STRESS_NAMES = ("sxx", "syy", "szz", "sxy", "syz", "sxz")


class History:
    """Rows in memory; `flush` rewrites the CSV whole."""

    def __init__(self, state, path: Path | None = None):
        self.path = Path(path) if path is not None else None
        self.title = " ".join(str(state.scene.deck.title).split())  # one line
        u = unit_system(state.scene.deck.units)
        dim = state.dim
        axes = "xyz"[:dim]
        self.columns: list[tuple[str, str]] = [("time", u.time), ("step", "-"), ("dt", u.time)]
        stress_cols = STRESS_NAMES[:4] if dim == 2 else STRESS_NAMES
        self._stress_idx = [STRESS_NAMES.index(s) for s in stress_cols]
        self.columns += [(s, u.stress) for s in stress_cols]
        self.columns += [("kinetic_energy", u.energy), ("strain_energy", u.energy), ("external_work", u.energy)]
        self._internal = state.materials.tracks_energy
        if self._internal:  # Mie–Grüneisen or artificial viscosity: sum of m U
            self.columns += [("internal_energy", u.energy)]
        self.columns += [(f"p{a}", u.momentum.split(" (")[0]) for a in axes]
        self._interface = state.contact is not None and state.contact.spec.has_interface
        if self._interface:
            self.columns += [("interface_energy", u.energy)]
        self.columns += [("velocity_noise", "-")]
        self._null_space = state.scene.deck.output.null_space_noise
        if self._null_space:
            self.columns += [("null_space_noise", "-")]
        self._faces = [f for f, t in zip(FACES[: 2 * dim], state.grid.face_type[: 2 * dim]) if t != 0]
        for f in self._faces:
            self.columns += [(f"F_{f}_{a}", u.force) for a in axes]
        for r in state.materials.rigid:
            self.columns += [(f"F_{r}_{a}", u.force) for a in axes]
            self.columns += [(f"u_{r}_{a}", u.length) for a in axes]
        names = state.materials.deformable
        self._material_ids = [names.index(m) for m in state.scene.deck.output.material_stress]
        for m in state.scene.deck.output.material_stress:
            self.columns += [(f"{sname}@{m}", u.stress) for sname in stress_cols]
        self.rows: list[list[float]] = []

    @property
    def names(self) -> list[str]:
        return [n for n, _ in self.columns]

    def record(self, state) -> None:
        s = particle_sums(state)
        row = [state.t, state.step, state.dt]
        row += [s[i] / s[VOLUME] for i in self._stress_idx]
        row += [s[KINETIC], s[STRAIN], state.work_in]
        if self._internal:
            row.append(s[INTERNAL])
        row += list(s[MOMENTUM][: state.dim])
        if self._interface:
            row.append(state.interface_energy)
        row.append(velocity_noise(state))
        if self._null_space:
            row.append(null_space_noise(state))
        face_index = {f: i for i, f in enumerate(FACES)}
        for f in self._faces:
            row += list(state.reaction[face_index[f]])
        for r in range(state.n_rigid_materials):
            row += list(state.reaction[6 + r]) + list(state.rigid_disp[r])
        P = state.particles
        for m in self._material_ids:
            sel = P.mat == m
            w = P.vol[sel]
            row += list((P.stress[sel][:, self._stress_idx] * w[:, None]).sum(axis=0) / max(w.sum(), 1e-300))
        self.rows.append(row)

    def column(self, name: str) -> np.ndarray:
        return np.array([r[self.names.index(name)] for r in self.rows])

    def flush(self) -> None:
        if self.path is None:
            return
        header = ",".join(f"{n} [{u}]" for n, u in self.columns)
        body = "\n".join(",".join(f"{v:.10g}" for v in row) for row in self.rows)
        write_text(self.path, f"# title: {self.title}\n" + header + "\n" + body + ("\n" if body else ""))


def read_history(path: str | Path) -> dict[str, np.ndarray]:
    """Columns of a history CSV by name (unit suffix dropped)."""
    comments, header = read_header(path)
    header = header.split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=len(comments) + 1, ndmin=2)
    return {h.split(" [")[0]: data[:, i] for i, h in enumerate(header)}


def history_title(path: str | Path) -> str:
    """The deck title from the `# title:` line ('' for a file without one)."""
    comments = read_header(path)[0]
    return next((c.split(":", 1)[1].strip() for c in comments if c.startswith("# title:")), "")


def read_header(path) -> tuple[list[str], str]:
    """(leading '#' lines, the header line)."""
    comments = []
    with open(path) as fh:
        for line in fh:
            if not line.startswith("#"):
                return comments, line.strip()
            comments.append(line.strip())
    raise ValueError(f"{path}: no header line")
