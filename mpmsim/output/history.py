"""CSV history of global quantities: a header of plain column names, then one row per
history time, each appended (one whole line, flushed) as it is recorded; units, the deck
title, the resolved deck and the versions are in a JSON sidecar `<stem>_history.json`,
written once at the start. `pandas.read_csv(path)` reads the CSV as it is. Values are written
at full double precision, each as the shortest string that reads back as the same float64
(`csv_value`), so the file holds exactly the rows in memory.

Every sum comes from the body sets (mpmsim/bodies: each kind sums its own arrays); the
history adds them up and adds the run's accounts. Columns, in order:
- time, step, dt, wall_s (wall-clock seconds since the run started: not reproducible);
- the volume-weighted Cauchy stress average over deformable material, kinetic and strain
  energy, the work put in (walls, rigid bodies, gravity, loads), internal energy (with
  Mie–Grüneisen or artificial viscosity), energy dissipated inside materials (plastic_work,
  with J2 plasticity), linear momentum p<axis>, angular momentum about the origin (L, or Lx,
  Ly, Lz in 3D; with APIC's affine part), spin (angular momentum about the centre of mass,
  L - c x p: spin, or spinx, spiny, spinz in 3D), interface energy;
- particle velocity noise (and its null-space part when asked for);
- with output.energy_ledger: transfer_loss, contact_loss, friction_loss, condition_loss, force_gap_loss,
  fracture_loss and energy_residual (mpmsim/tasks/ledger.py);
- reaction forces of constrained faces (what the face exerts on the material, from the last
  step: instantaneous, not averaged), F_<face>_<axis>, each followed by its impulse since t = 0,
  J_<face>_<axis> (the sum of force x dt over every step: a body's momentum balance closes with it);
- each body kind's own columns (rigid materials: reaction force and displacement);
- chosen materials' own average stress (output.material_stress): s<ij>_mat_<material>;
- per body, when the scene has two or more bodies with mass: ke_, se_, p<axis>_, L_, spin_ and
  the centre of mass c<axis>_, followed by the body's name;
- per deformable material, when two or more have mass: ke_mat_, se_mat_, p<axis>_mat_
  followed by the material's name (sums of its bodies' rows);
- per ordered pair of deformable material groups meeting through grid contact (explicit
  runs): contact_f<axis>_<a>_<b>, the force b exerted on a in the last step, and
  contact_impulse_<axis>_<a>_<b>, its impulse since t = 0 (contact.ContactTasks).
Names taken from the deck have every character other than letters, digits and '_' replaced
by '_'. In 2D, forces, energies and momenta are for the deck's thickness; in an axisymmetric
run (x = r, y = z) they are per radian, as the sidecar's `measure` says, and each energy and
each axial (y) momentum, force and impulse is repeated for the whole body (x 2 pi) as
<column>_whole, after all the others.
"""

from __future__ import annotations

import json
import os
import re
import time as wallclock
from pathlib import Path

import numpy as np

from ..bodies import ANGULAR, FIRST_MOMENT, INTERNAL, KINETIC, MASS, MOMENTUM, STRAIN, VOLUME
from ..deck.units import unit_system
from ..noise import null_space_noise, velocity_noise
from ..scene.grid import FACES
from ..tasks.ledger import LOSSES, energy_residual
from .atomic import write_text

STRESS_NAMES = ("sxx", "syy", "szz", "sxy", "syz", "sxz")


def angular_names(dim: int) -> list[str]:
    return ["L"] if dim == 2 else ["Lx", "Ly", "Lz"]


def spin_names(dim: int) -> list[str]:
    return ["spin"] if dim == 2 else ["spinx", "spiny", "spinz"]


def plain(name: str) -> str:
    """A deck name as part of a column name: letters, digits and '_' only."""
    return re.sub(r"\W", "_", str(name), flags=re.ASCII)


def sidecar_path(path: str | Path) -> Path:
    """The units sidecar of a history CSV: `<stem>_history.json` beside `<stem>_history.csv`."""
    return Path(path).with_suffix(".json")


class History:
    """Rows in memory (`rows`, `column`, `names`), and in the CSV at `path` as they are recorded."""

    def __init__(self, scene, state, path: Path | None = None):
        self.path = Path(path) if path is not None else None
        self.deck = scene.record  # the validated deck, for the sidecar (a restart takes it from the scene again)
        run = scene.settings
        self.title = " ".join(str(run.title).split())  # one line
        self.measure = ("per radian: masses, momenta, forces, impulses, energies and work of the axisymmetric "
                        "run (x = r, y = z); the columns ending _whole are the whole body's (x 2 pi): energies "
                        "and the axial (y) momenta, forces and impulses" if run.axisymmetric else None)
        u = unit_system(scene.settings.units)
        dim = state.dim
        axes = "xyz"[:dim]
        self.columns: list[tuple[str, str]] = [("time", u.time), ("step", "-"), ("dt", u.time), ("wall_s", "s")]
        stress_cols = STRESS_NAMES[:4] if dim == 2 else STRESS_NAMES
        self._stress_idx = [STRESS_NAMES.index(s) for s in stress_cols]
        self.columns += [(s, u.stress) for s in stress_cols]
        self.columns += [("kinetic_energy", u.energy), ("strain_energy", u.energy), ("external_work", u.energy)]
        self._internal = state.materials.tracks_energy
        if self._internal:  # Mie–Grüneisen or artificial viscosity: sum of m U
            self.columns += [("internal_energy", u.energy)]
        self._dissipation = list(state.materials.state_slots("dissipation"))  # plastic_work
        self.columns += [(name, u.energy) for name in self._dissipation]
        momentum = u.momentum.split(" (")[0]
        self.columns += [(f"p{a}", momentum) for a in axes]
        self._angular = [2] if dim == 2 else [0, 1, 2]
        self.columns += [(n, f"{momentum} {u.length}") for n in angular_names(dim)]
        self.columns += [(n, f"{momentum} {u.length}") for n in spin_names(dim)]
        self._interface = state.contact is not None and state.contact.spec.has_interface
        if self._interface:
            self.columns += [("interface_energy", u.energy)]
        self._cohesive = self._interface and state.contact.spec.cohesive is not None
        if self._cohesive:  # per radian in r-z, per thickness in plane strain (as the contact areas)
            self.columns += [("fracture_energy", u.energy), ("debonded_area", f"{u.length}^2")]
        self._noise = state.particles.n > 0
        if self._noise:
            self.columns += [("velocity_noise", "-")]
        self._null_space = run.output.null_space_noise and self._noise
        if self._null_space:
            self.columns += [("null_space_noise", "-")]
        self._ledger = run.output.energy_ledger
        if self._ledger:
            self.columns += [(n, u.energy) for n in (*LOSSES, "energy_residual")]
        walls = state.grid is not None and run.integrator == "explicit"  # implicit runs hold nodes, no reactions
        faces = state.grid.face_type[: 2 * dim] if walls else np.zeros(2 * dim)
        self._faces = [f for f, t in zip(FACES[: 2 * dim], faces) if t != 0]
        for f in self._faces:
            self.columns += [(f"F_{f}_{a}", u.force) for a in axes]
            self.columns += [(f"J_{f}_{a}", momentum) for a in axes]
        for body in state.bodies:
            self.columns += [(plain(n), unit) for n, unit in body.history_columns(u, dim)]
        names = state.materials.deformable
        self._material_ids = [names.index(m) for m in run.output.material_stress]
        for m in run.output.material_stress:
            self.columns += [(f"{sname}_mat_{plain(m)}", u.stress) for sname in stress_cols]
        massive = [(b, info) for b in state.bodies if b.has_mass for info in b.bodies]
        self._per_body = len(massive) >= 2
        if self._per_body:
            for _, info in massive:
                name = plain(info.name)
                self.columns += [(f"ke_{name}", u.energy), (f"se_{name}", u.energy)]
                self.columns += [(f"p{a}_{name}", momentum) for a in axes]
                self.columns += [(f"{n}_{name}", f"{momentum} {u.length}") for n in angular_names(dim)]
                self.columns += [(f"{n}_{name}", f"{momentum} {u.length}") for n in spin_names(dim)]
                self.columns += [(f"c{a}_{name}", u.length) for a in axes]
        # per material: each massive body's row goes to its material's
        body_mat = [info.material for _, info in massive]  # (None: a body kind of no deck body)
        self._materials = [m for m in state.materials.names if m in body_mat]  # deck order
        if len(self._materials) < 2:
            self._materials = []
        self._body_material = [self._materials.index(m) if m in self._materials else -1 for m in body_mat]
        for m in self._materials:
            self.columns += [(f"ke_mat_{plain(m)}", u.energy), (f"se_mat_{plain(m)}", u.energy)]
            self.columns += [(f"p{a}_mat_{plain(m)}", momentum) for a in axes]
        self._pairs = contact_pairs(scene, state)
        groups = state.contact.spec.group_names if self._pairs else []
        for kind, unit in (("f", u.force), ("impulse_", momentum)):
            for a, b in self._pairs:
                self.columns += [(f"contact_{kind}{x}_{plain(groups[a])}_{plain(groups[b])}", unit) for x in axes]
        # axisymmetric: each energy and each axial (y) momentum, force and impulse again for the whole
        # body of revolution (x 2 pi), named <column>_whole
        self._whole = [i for i, (n, unit) in enumerate(self.columns) if run.axisymmetric and whole_body(n, unit, u)]
        self.columns += [(f"{self.columns[i][0]}_whole", self.columns[i][1]) for i in self._whole]
        check_unique(self.names, [info for _, info in massive], scene.loaded)
        self.rows: list[list[float]] = []
        self.started = wallclock.time()  # the run's start (a restart keeps the checkpoint's)
        self.in_file: int | None = None  # rows the CSV holds (None: not written by this run yet)

    @property
    def names(self) -> list[str]:
        return [n for n, _ in self.columns]

    def record(self, state) -> None:
        """Add the state's row, and append it to the CSV."""
        dim = state.dim
        sums = [s for s in (b.sums(state) for b in state.bodies) if s is not None]
        s = sums[0].total
        for more in sums[1:]:
            s = s + more.total
        row = [state.t, state.step, state.dt, wallclock.time() - self.started]
        row += [s[i] / s[VOLUME] for i in self._stress_idx]
        row += [s[KINETIC], s[STRAIN], state.work_in]
        if self._internal:
            row.append(s[INTERNAL])
        if self._dissipation:
            dissipated = state.particles.dissipation(state.materials)
            row += [dissipated[name] for name in self._dissipation]
        row += list(s[MOMENTUM][:dim])
        row += [s[ANGULAR][a] for a in self._angular]
        row += self._spin(s, dim)
        if self._interface:
            row.append(state.interface_energy)
        if self._cohesive:
            row += [state.fracture_energy, state.debonded_area]
        if self._noise:
            row.append(velocity_noise(state))
        if self._null_space:
            row.append(null_space_noise(state))
        if self._ledger:
            row += list(state.ledger)
            row.append(energy_residual(state))
        face_index = {f: i for i, f in enumerate(FACES)}
        for f in self._faces:
            row += list(state.reaction[face_index[f]]) + list(state.impulse[face_index[f]])
        for body in state.bodies:
            row += body.history_values(state)
        P = state.particles
        for m in self._material_ids:
            sel = P.mat == m
            w = P.vol[sel]
            row += list((P.stress[sel][:, self._stress_idx] * w[:, None]).sum(axis=0) / max(w.sum(), 1e-300))
        per_body = np.concatenate([part.per_body for part in sums]) if self._per_body else np.zeros((0, 0))
        for b in per_body:
            row += [b[KINETIC], b[STRAIN]] + list(b[MOMENTUM][:dim]) + [b[ANGULAR][a] for a in self._angular]
            row += self._spin(b, dim)
            row += list(b[FIRST_MOMENT][:dim] / b[MASS])
        if self._materials:
            mat = np.zeros((len(self._materials), 2 + dim))
            for i, b in zip(self._body_material, per_body):
                if i >= 0:
                    mat[i] += [b[KINETIC], b[STRAIN], *b[MOMENTUM][:dim]]
            row += [float(v) for v in mat.ravel()]
        if self._pairs:
            cs = state.contact
            for arr in (cs.pair_force, cs.pair_impulse):
                for a, b in self._pairs:
                    row += [float(v) for v in arr[a, b, :dim]]
        row += [2.0 * np.pi * row[i] for i in self._whole]
        self.rows.append(row)
        self.flush()

    def _spin(self, sums, dim: int) -> list[float]:
        """Angular momentum about the centre of mass of `sums` (a body's or the scene's):
        L - c x p with c = first moment / mass (zero without mass)."""
        mass = sums[MASS]
        c = np.zeros(3)
        if mass > 0.0:
            c[:dim] = sums[FIRST_MOMENT][:dim] / mass
        p = np.zeros(3)
        p[:dim] = sums[MOMENTUM][:dim]
        spin = np.asarray(sums[ANGULAR][:3], dtype=float) - np.cross(c, p)
        return [float(spin[a]) for a in self._angular]

    def frame(self):
        """The rows recorded so far as a pandas DataFrame (the CSV's columns)."""
        import pandas as pd

        return pd.DataFrame(self.rows, columns=self.names)

    def column(self, name: str) -> np.ndarray:
        return np.array([r[self.names.index(name)] for r in self.rows])

    def flush(self) -> None:
        """Bring the CSV up to the rows in memory: append the rows it lacks, each one whole line
        in one write; the first time (or after `rewrite`), the sidecar and the CSV's header and
        rows are written whole instead."""
        if self.path is None:
            return
        if self.in_file is None:
            self.write_sidecar()
            write_text(self.path, ",".join(self.names) + "\n" + "".join(map(csv_line, self.rows)))
        elif self.in_file < len(self.rows):
            data = "".join(map(csv_line, self.rows[self.in_file:])).encode()
            fd = os.open(self.path, os.O_WRONLY | os.O_APPEND)
            try:
                while data:
                    data = data[os.write(fd, data):]
            finally:
                os.close(fd)
        self.in_file = len(self.rows)

    def rewrite(self) -> None:
        """Write the CSV anew from the rows in memory (a restart: exactly the checkpoint's rows)."""
        self.in_file = None
        self.flush()

    def write_sidecar(self) -> None:
        from .runlog import versions

        meta = {"title": self.title, "columns": dict(self.columns), "deck": self.deck,
                **({"measure": self.measure} if self.measure else {}), **versions()}
        write_text(sidecar_path(self.path), json.dumps(meta, indent=1) + "\n")


AXIAL = re.compile(r"^(p|F_.+_|J_.+_|contact_f|contact_impulse_)y(_.+)?$")  # y (= z) components


def whole_body(name: str, unit: str, u) -> bool:
    """Whether an axisymmetric history column has a whole-body total (x 2 pi): energies and work,
    and the axial components of momenta, forces and impulses (radial ones sum to zero around
    the axis)."""
    return unit == u.energy or bool(AXIAL.match(name))


def check_unique(names: list[str], bodies, loaded) -> None:
    """A DeckError when deck names give one column twice (a body named like a material's
    columns, or names that differ only in characters `plain` replaces)."""
    seen: set[str] = set()
    twice = sorted({n for n in names if n in seen or seen.add(n)})
    if not twice:
        return
    from ..deck.loader import raise_at

    path = next((("bodies", b.index, "name") for b in bodies if any(n.endswith(f"_{plain(b.name)}") for n in twice)),
                ("materials",))
    raise_at([(path, f"gives history columns that another name gives too ({', '.join(twice)}); rename it")], loaded)


def csv_value(v) -> str:
    """One CSV field: an integer as it is (the step), any other value as the shortest string
    that reads back as the same float64 (Python's float repr: round-trip exact, so sums
    conserved to 1e-13 show as such in the file; 'nan', 'inf' and '-inf' as they are)."""
    if isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_)):
        return str(int(v))
    return repr(float(v))


def csv_line(row) -> str:
    return ",".join(map(csv_value, row)) + "\n"


def contact_pairs(scene, state) -> list[tuple[int, int]]:
    """Ordered pairs (a, b) of deformable contact groups with particles, a != b, when the
    explicit step's contact passes run (they record the pair forces)."""
    cs = state.contact
    if cs is None or scene.settings.integrator != "explicit":
        return []
    present = sorted(set(np.unique(cs.group).tolist()))
    return [(a, b) for a in present for b in present if a != b]


def read_history(path: str | Path) -> dict[str, np.ndarray]:
    """Columns of a history CSV by name. '#' lines are skipped and a ' [unit]' suffix of a
    header name dropped, so CSVs with a title comment and 'name [unit]' headers read too."""
    with open(path) as fh:
        lines = [ln for ln in fh if not ln.startswith("#")]
    if not lines:
        raise ValueError(f"{path}: no header line")
    header = [h.split(" [")[0] for h in lines[0].strip().split(",")]
    body = [ln for ln in lines[1:] if ln.strip()]
    data = np.loadtxt(body, delimiter=",", ndmin=2) if body else np.zeros((0, len(header)))
    return {h: data[:, i] for i, h in enumerate(header)}


def history_meta(path: str | Path) -> dict:
    """The sidecar of a history CSV ({} when it is missing or unreadable)."""
    try:
        meta = json.loads(sidecar_path(path).read_text())
    except (OSError, ValueError):
        return {}
    return meta if isinstance(meta, dict) else {}


def history_title(path: str | Path) -> str:
    """The deck title ('' without a sidecar)."""
    return str(history_meta(path).get("title", ""))


def history_units(path: str | Path) -> dict[str, str]:
    """{column: unit} ({} without a sidecar)."""
    columns = history_meta(path).get("columns", {})
    return {str(k): str(v) for k, v in columns.items()} if isinstance(columns, dict) else {}
