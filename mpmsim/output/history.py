"""CSV history of global quantities: one row per history time, header 'name [unit]', after
a first line `# title: <deck title>` (for plot labels; readers skip '#' lines).

Every sum comes from the body sets (mpmsim/bodies: each kind sums its own arrays); the
history adds them up and adds the run's accounts. Columns, in order:
- time, step, dt;
- the volume-weighted Cauchy stress average over deformable material, kinetic and strain
  energy, the work put in (walls, rigid bodies, gravity, loads), internal energy (with
  Mie–Grüneisen or artificial viscosity), linear momentum p<axis>, angular momentum about
  the origin (L, or Lx, Ly, Lz in 3D; with APIC's affine part), interface energy;
- particle velocity noise (and its null-space part when asked for);
- reaction forces of constrained faces (what the face exerts on the material, from the last
  step: instantaneous, not averaged);
- each body kind's own columns (rigid materials: reaction force and displacement);
- chosen materials' own average stress (output.material_stress);
- per body, when the scene has two or more bodies with mass: ke_, se_, p<axis>_, L_ and the
  centre of mass c<axis>_, followed by the body's name.
In 2D, forces, energies and momenta are for the deck's thickness.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..bodies import ANGULAR, FIRST_MOMENT, INTERNAL, KINETIC, MASS, MOMENTUM, STRAIN, VOLUME
from ..deck.units import unit_system
from ..noise import null_space_noise, velocity_noise
from ..scene.grid import FACES
from .atomic import write_text

STRESS_NAMES = ("sxx", "syy", "szz", "sxy", "syz", "sxz")


def angular_names(dim: int) -> list[str]:
    return ["L"] if dim == 2 else ["Lx", "Ly", "Lz"]


class History:
    """Rows in memory; `flush` rewrites the CSV whole."""

    def __init__(self, scene, state, path: Path | None = None):
        self.path = Path(path) if path is not None else None
        deck = scene.deck
        self.title = " ".join(str(deck.title).split())  # one line
        u = unit_system(deck.units)
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
        momentum = u.momentum.split(" (")[0]
        self.columns += [(f"p{a}", momentum) for a in axes]
        self._angular = [2] if dim == 2 else [0, 1, 2]
        self.columns += [(n, f"{momentum} {u.length}") for n in angular_names(dim)]
        self._interface = state.contact is not None and state.contact.spec.has_interface
        if self._interface:
            self.columns += [("interface_energy", u.energy)]
        self._noise = state.particles.n > 0
        if self._noise:
            self.columns += [("velocity_noise", "-")]
        self._null_space = deck.output.null_space_noise and self._noise
        if self._null_space:
            self.columns += [("null_space_noise", "-")]
        faces = state.grid.face_type[: 2 * dim] if state.grid is not None else np.zeros(2 * dim)
        self._faces = [f for f, t in zip(FACES[: 2 * dim], faces) if t != 0]
        for f in self._faces:
            self.columns += [(f"F_{f}_{a}", u.force) for a in axes]
        for body in state.bodies:
            self.columns += body.history_columns(u, dim)
        names = state.materials.deformable
        self._material_ids = [names.index(m) for m in deck.output.material_stress]
        for m in deck.output.material_stress:
            self.columns += [(f"{sname}@{m}", u.stress) for sname in stress_cols]
        massive = [(b, info) for b in state.bodies if b.has_mass for info in b.bodies]
        self._per_body = len(massive) >= 2
        if self._per_body:
            for _, info in massive:
                self.columns += [(f"ke_{info.name}", u.energy), (f"se_{info.name}", u.energy)]
                self.columns += [(f"p{a}_{info.name}", momentum) for a in axes]
                self.columns += [(f"{n}_{info.name}", f"{momentum} {u.length}") for n in angular_names(dim)]
                self.columns += [(f"c{a}_{info.name}", u.length) for a in axes]
        self.rows: list[list[float]] = []

    @property
    def names(self) -> list[str]:
        return [n for n, _ in self.columns]

    def record(self, state) -> None:
        dim = state.dim
        sums = [s for s in (b.sums(state) for b in state.bodies) if s is not None]
        s = sums[0].total
        for more in sums[1:]:
            s = s + more.total
        row = [state.t, state.step, state.dt]
        row += [s[i] / s[VOLUME] for i in self._stress_idx]
        row += [s[KINETIC], s[STRAIN], state.work_in]
        if self._internal:
            row.append(s[INTERNAL])
        row += list(s[MOMENTUM][:dim])
        row += [s[ANGULAR][a] for a in self._angular]
        if self._interface:
            row.append(state.interface_energy)
        if self._noise:
            row.append(velocity_noise(state))
        if self._null_space:
            row.append(null_space_noise(state))
        face_index = {f: i for i, f in enumerate(FACES)}
        for f in self._faces:
            row += list(state.reaction[face_index[f]])
        for body in state.bodies:
            row += body.history_values(state)
        P = state.particles
        for m in self._material_ids:
            sel = P.mat == m
            w = P.vol[sel]
            row += list((P.stress[sel][:, self._stress_idx] * w[:, None]).sum(axis=0) / max(w.sum(), 1e-300))
        if self._per_body:
            for part in sums:
                for b in part.per_body:
                    row += [b[KINETIC], b[STRAIN]] + list(b[MOMENTUM][:dim]) + [b[ANGULAR][a] for a in self._angular]
                    row += list(b[FIRST_MOMENT][:dim] / b[MASS])
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
