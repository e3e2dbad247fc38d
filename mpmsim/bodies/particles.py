"""Deformable particle bodies: material points carrying mass, volume, F and stress.

Every deformable particle body of the deck lives in one struct-of-arrays set; `body` holds
each particle's deck body index and `local_body` its row among this set's bodies (for the
per-body sums). Kernels over particles never branch on rigidity: rigid particles are a kind
of their own (`rigid.py`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np
from numba import prange

from .. import linalg
from ..faults import MESSAGES
from ..gridops import chunk_range
from ..materials.dispatch import energy_dispatch
from ..materials.kernels import det3
from ..parallel import ChunkKernel, chunk_kernel, specialize
from ..views import ParticleView
from . import ANGULAR, FIRST_MOMENT, KINETIC, MASS, MOMENTUM, NSUMS, STRAIN, BodyInfo, BodySet, Sums


@dataclass
class Particles(BodySet):
    x: np.ndarray  # (n, dim) position
    v: np.ndarray  # (n, dim) velocity
    mass: np.ndarray  # (n,)
    vol0: np.ndarray  # (n,) initial volume
    vol: np.ndarray  # (n,) current volume = vol0 * J
    F: np.ndarray  # (n, dim, dim) deformation gradient (plane strain: F33 = 1); axisymmetric:
    # (n, 3, 3), F[2, 2] the hoop stretch (x = r, y = z, the third axis theta)
    stress: np.ndarray  # (n, 6) Cauchy stress, Voigt [xx, yy, zz, xy, yz, xz]
    mat: np.ndarray  # (n,) deformable material index
    body: np.ndarray  # (n,) deck body index
    x0: np.ndarray  # (n, dim) initial position
    B: np.ndarray  # (n, dim, dim) APIC affine matrix (a (1, dim, dim) placeholder otherwise)
    C: np.ndarray  # (n, dim, dim) APIC B D^-1 for the current step (placeholder otherwise)
    # with Mie–Grüneisen or artificial viscosity (else (1,) placeholders the kernels never read):
    U: np.ndarray  # (n,) internal energy per unit mass
    pressure: np.ndarray  # (n,) pressure (Mie–Grüneisen: the EOS pressure, without q)
    q: np.ndarray  # (n,) artificial-viscosity pressure in the stress since the last update
    xref: np.ndarray  # positions the shape functions were evaluated at (APIC: a copy kept
    # after the particles move; otherwise x itself)
    semi: np.ndarray  # (dim,) undeformed particle semi-lengths
    local_body: np.ndarray  # (n,) row of the particle's body in `infos`
    infos: list  # BodyInfo of each deformable particle body
    # (n, k) material state (history variables of the models that keep some, e.g. J2
    # plasticity's elastic left Cauchy-Green tensor and plastic strain; mpmsim/materials/model.py):
    # k is the widest row the scene's models ask for, 0 when none does
    mstate: np.ndarray = None
    interface_damage: np.ndarray = None  # (n,) cohesive interfaces' damage the particle carries
    # (contact/cohesive_history.py); None in scenes without cohesive laws
    interface_bonded: np.ndarray = None  # (n,) bool: the particle was on a bonded cohesive interface at the start
    interface_opening: np.ndarray = None  # (n,) the size of the cohesive opening at its nodes when last measured
    interface_area: np.ndarray = None  # (n,) its share of the cohesive interface's area when bonded (the first step)

    kind = "particles"
    device_sums = None  # the energy check's sums from a GPU's arrays (mpmsim/gpu/step.py), when on one

    @property
    def has_mass(self) -> bool:
        return self.n > 0

    @property
    def n(self) -> int:
        return len(self.mass)

    @property
    def stepped(self) -> int:
        return self.n

    def view(self) -> ParticleView:
        return ParticleView(self.x, self.v, self.mass, self.vol, self.vol0, self.F, self.stress, self.mat, self.x0,
                            self.B, self.C, self.U, self.pressure, self.q, self.xref, self.mstate)

    @property
    def affine(self) -> bool:
        """Particles carry an APIC affine velocity B."""
        return len(self.B) == self.n and self.n > 0

    @classmethod
    def from_seed(cls, seed, density, semi, infos: list[BodyInfo], affine: bool, energy: bool,
                  state0: np.ndarray | None = None, hoop: bool = False) -> "Particles":
        """state0: (n_deformable, k) each material's initial material state (None: k = 0);
        hoop: axisymmetric, F is 3x3 with the hoop stretch F[2, 2]."""
        dim = seed.x.shape[1]
        mass = seed.vol * density[seed.mat]
        n = len(mass)
        nf = 3 if hoop else dim
        F = np.zeros((n, nf, nf))
        for a in range(nf):
            F[:, a, a] = 1.0
        na = n if affine else 1
        ne = n if energy else 1
        x = seed.x.copy()
        row = {b.index: r for r, b in enumerate(infos)}
        local = np.array([row[int(b)] for b in seed.body], dtype=np.int64) if n else np.zeros(0, dtype=np.int64)
        return cls(x, seed.v.copy(), mass, seed.vol.copy(), seed.vol.copy(), F, np.zeros((n, 6)), seed.mat.copy(),
                   seed.body.copy(), seed.x.copy(), np.zeros((na, dim, dim)), np.zeros((na, dim, dim)), np.zeros(ne),
                   np.zeros(ne), np.zeros(ne), x.copy() if affine else x, np.asarray(semi, float), local, infos,
                   np.ascontiguousarray(state0[seed.mat]) if state0 is not None else np.zeros((n, 0)))

    def sums(self, state, detail: bool = True) -> Sums | None:
        if self.n == 0:
            return None
        if not detail and self.device_sums is not None:  # (a GPU run: from the device's arrays)
            return self.device_sums(state)
        m = state.materials
        nb = len(self.infos)
        out = np.zeros((state.nchunk, NSUMS))
        per_body = detail and nb > 1
        density = np.zeros(self.n if per_body else 0)
        kernel = particle_sums(tuple(int(c) for c in np.unique(m.type_code)))
        kernel(self.view(), m.view(), state.nchunk, out, density)
        total = out.sum(axis=0)
        if not detail:
            return Sums(total, np.zeros((0, NSUMS)))
        dim = self.x.shape[1]
        L = self.mass[:, None] * angular_density(self.x, self.v, self.B if self.affine else None)
        total[ANGULAR] = L.sum(axis=0)
        total[MASS] = self.mass.sum()
        total[FIRST_MOMENT.start:FIRST_MOMENT.start + dim] = linalg.weighted_rows(self.mass, self.x)
        rows = np.zeros((nb, NSUMS))
        if nb == 1:
            rows[0] = total
        elif nb > 1:
            b = self.local_body
            count = lambda w: np.bincount(b, weights=w, minlength=nb)  # noqa: E731
            rows[:, KINETIC] = count(0.5 * self.mass * np.sum(self.v**2, axis=1))
            rows[:, STRAIN] = count(density)
            rows[:, MASS] = count(self.mass)
            for d in range(dim):
                rows[:, MOMENTUM.start + d] = count(self.mass * self.v[:, d])
                rows[:, FIRST_MOMENT.start + d] = count(self.mass * self.x[:, d])
            for a in range(3):
                rows[:, ANGULAR.start + a] = count(L[:, a])
        return Sums(total, rows)

    def vtu_pieces(self, state) -> list[tuple[str, dict]]:
        mats, dim, n = state.materials, state.dim, self.n
        if n == 0:
            return []
        F9 = np.zeros((n, 3, 3))
        F9[:, 2, 2] = 1.0
        nf = self.F.shape[1]
        F9[:, :nf, :nf] = self.F
        gid = np.array([mats.global_id(m) for m in mats.deformable], dtype=np.int32)
        data = {
            "velocity": pad3(self.v),
            "displacement": pad3(self.x - self.x0),
            "stress": self.stress,
            "deformation_gradient": F9.reshape(-1, 9),
            "J": linalg.det(F9),
            "material": gid[self.mat],
            "body": self.body.astype(np.int32),
            "mass": self.mass,
            "volume": self.vol,
        }
        if nf == 3 and dim == 2:  # axisymmetric: the hoop (theta) components, named
            data["hoop_stress"] = self.stress[:, 2]
            data["hoop_stretch"] = self.F[:, 2, 2]
        if mats.tracks_energy:  # zero on particles of materials without internal energy
            on = mats.energy[self.mat]
            data["internal_energy"] = np.where(on, self.U, 0.0)
            data["pressure"] = np.where(on, self.pressure, 0.0)
        if state.contact is not None and state.contact.spec.cohesive is not None:  # (zero before the first step)
            started = self.interface_damage is not None
            data["interface_damage"] = self.interface_damage if started else np.zeros(n)
            data["interface_opening"] = self.interface_opening if started else np.zeros(n)
        for name, slots in mats.state_slots("output").items():  # zero on particles of models without them
            data[name] = self.state_values(slots)
        return [("particles", {"points": pad3(self.x), "point_data": data})]

    def state_values(self, slots: np.ndarray) -> np.ndarray:
        """(n,) each particle's material-state entry at its material's slot (slots: (n_deformable,),
        -1 where the material has none: 0 there)."""
        s = slots[self.mat]
        out = np.zeros(self.n)
        on = np.nonzero(s >= 0)[0]
        out[on] = self.mstate[on, s[on]]
        return out

    def dissipation(self, materials) -> dict[str, float]:
        """{name: energy} dissipated by the models' internal processes (plastic work: sum of
        m_p times the energy per unit mass its model keeps; MaterialModel.dissipation)."""
        return {name: float(linalg.dot(self.mass, self.state_values(slots)))
                for name, slots in materials.state_slots("dissipation").items()}

    def describe(self, state, p: int, units) -> str:
        name = state.materials.deformable[int(self.mat[p])]
        pos = ", ".join(f"{c:.6g}" for c in self.x[p])
        return f"particle {p} (material '{name}', body '{self.body_name(int(self.body[p]))}') at ({pos}) {units.length}"

    def check(self, state, units) -> tuple[str, str] | None:
        fl = state.flags
        if fl.bad_particle < 0:
            return None
        what = MESSAGES[fl.bad_code].format(value=fl.bad_value)
        return "unstable", f"{self.describe(state, fl.bad_particle, units)}: {what}"

    def fastest(self, state, units) -> str | None:
        if self.n == 0:
            return None
        return self.describe(state, int(np.argmax(np.sum(self.v**2, axis=1))), units)


def pad3(a: np.ndarray) -> np.ndarray:
    out = np.zeros((a.shape[0], 3))
    out[:, : a.shape[1]] = a
    return out


def angular_density(x, v, B):
    """(n, 3) angular momentum per unit mass about the origin, x cross v, plus APIC's affine
    part eps_abc B_cb when B is given (2D: only the z component)."""
    n, dim = x.shape
    L = np.zeros((n, 3))
    L[:, 2] = x[:, 0] * v[:, 1] - x[:, 1] * v[:, 0]
    if dim == 3:
        L[:, 0] = x[:, 1] * v[:, 2] - x[:, 2] * v[:, 1]
        L[:, 1] = x[:, 2] * v[:, 0] - x[:, 0] * v[:, 2]
    if B is not None:
        L[:, 2] += B[:, 1, 0] - B[:, 0, 1]
        if dim == 3:
            L[:, 0] += B[:, 2, 1] - B[:, 1, 2]
            L[:, 1] += B[:, 0, 2] - B[:, 2, 0]
    return L


ENERGY = None  # the scene's energy dispatcher (materials.dispatch), bound by `particle_sums`


@cache
def particle_sums(codes: tuple) -> ChunkKernel:
    """The sums kernel for a scene whose deformable materials have these model codes."""
    tag, energy = energy_dispatch(codes)
    return chunk_kernel(specialize(particle_sums_kernel, tag, ENERGY=energy))


def particle_sums_kernel(P, M, nchunk, out, density):
    """Per chunk, the first entries of the `bodies.Sums` layout (stress integral, volume,
    kinetic, strain, momentum, internal energy) over particles P (views.ParticleView) of
    materials M; each particle's strain energy into `density` when it has room."""
    stress, vol, v, mass, F, mat, U = P.stress, P.vol, P.v, P.mass, P.F, P.mat, P.U
    code, props, energy = M.code, M.props, M.energy
    n, dim = v.shape
    nf = F.shape[1]  # (axisymmetric: 3, the hoop stretch in F[2, 2])
    keep = density.size == n
    for c in prange(nchunk):
        start, stop = chunk_range(c, nchunk, n)
        F3 = np.zeros((3, 3))
        acc = np.zeros(NSUMS)
        for p in range(start, stop):
            vp = vol[p]
            for a in range(6):
                acc[a] += vp * stress[p, a]
            acc[6] += vp
            v2 = 0.0
            for d in range(dim):
                v2 += v[p, d] * v[p, d]
                acc[9 + d] += mass[p] * v[p, d]
            acc[7] += 0.5 * mass[p] * v2
            for a in range(3):
                for b in range(3):
                    F3[a, b] = F[p, a, b] if (a < nf and b < nf) else (1.0 if a == b else 0.0)
            J = det3(F3)
            mt = mat[p]
            e = vp * ENERGY(code[mt], props[mt], F3, stress[p], J)
            acc[8] += e
            if keep:
                density[p] = e
            if energy[mt]:
                acc[12] += mass[p] * U[p]
        for a in range(NSUMS):
            out[c, a] = acc[a]
