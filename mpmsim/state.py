"""Simulation state as struct-of-arrays numpy data.

Particles (deformable) and rigid particles are separate sets: kernels over deformable
particles never branch on rigidity, and rigid particles only extrapolate volume for the
velocity conditions they impose. Grid fields cover the whole (scene-sized) grid but every
task touches only the active node box.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .contact import ContactState, build_contact_spec
from .loads import build_loads
from .gridops import ActiveBox, n_threads
from .materials import MaterialTable
from .materials.kernels import initial_modulus
from .scene import Scene
from .scene.grid import GridSpec
from .shapes import ShapeData, ShapeFunction, shape_function
from .tasks.particle_update import SCHEMES


@dataclass
class Particles:
    x: np.ndarray  # (n, dim) position
    v: np.ndarray  # (n, dim) velocity
    mass: np.ndarray  # (n,)
    vol0: np.ndarray  # (n,) initial volume
    vol: np.ndarray  # (n,) current volume = vol0 * J
    F: np.ndarray  # (n, dim, dim) deformation gradient (2D: F33 = 1)
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

    @property
    def n(self) -> int:
        return len(self.mass)


@dataclass
class RigidParticles:
    x: np.ndarray
    v: np.ndarray
    vol: np.ndarray
    mat: np.ndarray  # rigid material index
    body: np.ndarray
    x0: np.ndarray

    @property
    def n(self) -> int:
        return len(self.vol)


@dataclass
class GridFields:
    mass: np.ndarray  # (nn,)
    mom: np.ndarray  # (nn, dim) momentum p (after extrapolation; BCs never edit it)
    force: np.ndarray  # (nn, dim)
    vel: np.ndarray  # (nn, dim) velocity for the stress update (BCs applied)
    vnew: np.ndarray  # (nn, dim) updated velocity v+ = p+/m
    acc: np.ndarray  # (nn, dim) acceleration a = f/m (BC forces included)
    vstart: np.ndarray  # (nn, dim) start velocity with velocity conditions imposed (p/m elsewhere)
    rigid_vol: np.ndarray  # (nn, n_rigid) volume of each rigid material seen by the node
    vstar: np.ndarray  # (nn, dim) XPIC/FMPM filtered velocity; dv, tmp its scratch
    dv: np.ndarray
    tmp: np.ndarray

    def ensure(self, n_fields: int) -> None:
        """Grow the field arrays (material slots come after the nodes) to hold n_fields."""
        if self.mass.shape[0] >= n_fields:
            return
        for name in ("mass", "mom", "force", "vel", "vnew", "acc", "vstart"):
            old = getattr(self, name)
            setattr(self, name, np.zeros((n_fields,) + old.shape[1:]))
        if self.vstar.shape[0] > 1:  # XPIC/FMPM filter arrays exist
            for name in ("vstar", "dv", "tmp"):
                setattr(self, name, np.zeros((n_fields, self.vstar.shape[1])))

    @classmethod
    def allocate(cls, nn: int, dim: int, n_rigid: int, filtering: bool) -> "GridFields":
        """Filter arrays exist only when the scene uses XPIC or FMPM."""
        z = lambda *s: np.zeros(s)  # noqa: E731
        nf = nn if filtering else 1
        return cls(z(nn), z(nn, dim), z(nn, dim), z(nn, dim), z(nn, dim), z(nn, dim), z(nn, dim),
                   z(nn, max(n_rigid, 1)), z(nf, dim), z(nf, dim), z(nf, dim))


@dataclass
class StepFlags:
    """What kernels found wrong this step: (particle index, code, value) or none."""

    bad_particle: int = -1
    bad_code: int = 0
    bad_value: float = 0.0
    bad_rigid: int = -1  # a rigid particle whose support left the grid

    def set(self, p: int, code: int, value: float) -> None:
        if self.bad_particle < 0:
            self.bad_particle, self.bad_code, self.bad_value = p, code, value

    def set_rigid(self, p: int, code: int) -> None:
        if self.bad_rigid < 0:
            self.bad_rigid = p


@dataclass
class State:
    scene: Scene
    grid: GridSpec
    materials: MaterialTable
    shape: ShapeFunction
    particles: Particles
    rigid: RigidParticles
    sd: ShapeData  # shape data of deformable particles
    rigid_sd: ShapeData
    fields: GridFields
    box: ActiveBox
    gravity: np.ndarray  # (dim,)
    threads: int
    nchunk: int
    scheme_name: str  # particle update: flip, pic, xpic, fmpm, apic
    scheme: int  # its kernel code
    entry_offsets: np.ndarray  # (K, 3) node offset of shape entry k from the particle's lowest node
    xref: np.ndarray  # positions the shape functions were evaluated at (APIC needs them after moving)
    t: float = 0.0
    dt: float = 0.0
    dt_rule: float = 0.0  # the step the CFL rule (or the deck) allows, before the cut at the end time
    step: int = 0
    wave_max: float = 0.0  # max(c + |v|) over particles from the last stress update
    rigid_v_start: np.ndarray = None  # (n_rigid, dim) prescribed velocity at t
    rigid_v_end: np.ndarray = None  # at t + dt
    rigid_disp: np.ndarray = None  # (n_rigid, dim) displacement since t = 0
    reaction: np.ndarray = None  # (6 + n_rigid, dim) force walls/rigid bodies exert on material
    energy0: float = 0.0  # mechanical energy at the start of the run
    interface_energy: float = 0.0  # imperfect interfaces, end of the last step
    work_in: float = 0.0  # signed work done on the material by walls, rigid materials, gravity
    energy_floor: float = 0.0  # round-off scale of energy (sum m c^2 x 1e-12)
    flags: StepFlags = field(default_factory=StepFlags)
    particle_bounds: tuple = ()  # (lo, hi): where particle centres may go (GridSpec.particle_bounds)
    _noise_scratch: tuple | None = None  # shape data and grid arrays for the noise metric
    contact: object = None  # mpmsim.contact.ContactState for scenes where materials meet
    loads: object = None  # mpmsim.loads.Loads when the deck has traction loads
    damping: float = 0.0  # grid damping alpha (1/time)

    @property
    def dim(self) -> int:
        return self.grid.dim

    @property
    def field_index(self) -> np.ndarray:
        """(n, K) field each particle-node entry reads and writes: its node, or its material's
        slot at nodes where materials meet (mpmsim/contact)."""
        return self.sd.nodes if self.contact is None else self.contact.fidx

    @property
    def n_rigid_materials(self) -> int:
        return len(self.materials.rigid)

    @classmethod
    def from_scene(cls, scene: Scene, threads: int | None = None) -> "State":
        dim = scene.dim
        mats = scene.materials
        seed = scene.deformable
        mass = seed.vol * mats.density[seed.mat]
        n = len(mass)
        F = np.zeros((n, dim, dim))
        for a in range(dim):
            F[:, a, a] = 1.0
        scheme_name = scene.deck.update.scheme
        na = n if scheme_name == "apic" else 1
        ne = n if mats.tracks_energy else 1
        particles = Particles(seed.x.copy(), seed.v.copy(), mass, seed.vol.copy(), seed.vol.copy(), F,
                              np.zeros((n, 6)), seed.mat.copy(), seed.body.copy(), seed.x.copy(),
                              np.zeros((na, dim, dim)), np.zeros((na, dim, dim)), np.zeros(ne), np.zeros(ne),
                              np.zeros(ne))
        rs = scene.rigid
        rigid = RigidParticles(rs.x.copy(), rs.v.copy(), rs.vol.copy(), rs.mat.copy(), rs.body.copy(), rs.x.copy())
        sf = shape_function(scene.deck.shape_function)
        K = sf.nodes_per_particle(dim)
        threads = threads or n_threads()
        nr = len(mats.rigid)
        g = np.zeros(dim)
        if scene.deck.gravity is not None:
            g[:] = scene.deck.gravity
        per = sf.per_axis
        offsets = np.array([(k % per, (k // per) % per, k // (per * per)) for k in range(K)], dtype=np.int64)
        state = cls(
            scene=scene, grid=scene.grid, materials=mats, shape=sf, particles=particles, rigid=rigid,
            sd=ShapeData.empty(n, K, dim), rigid_sd=ShapeData.empty(rigid.n, K, dim),
            fields=GridFields.allocate(scene.grid.n_nodes, dim, nr, scheme_name in ("xpic", "fmpm")),
            box=ActiveBox(scene.grid.shape), gravity=g, threads=threads, nchunk=max(1, 4 * threads),
            scheme_name=scheme_name, scheme=SCHEMES[scheme_name], entry_offsets=offsets,
            xref=particles.x if scheme_name != "apic" else particles.x.copy(),
        )
        state.rigid_v_start = np.array([m.velocity(0.0) for m in mats.motions]).reshape(nr, dim)
        state.rigid_v_end = state.rigid_v_start.copy()
        state.rigid_disp = np.zeros((nr, dim))
        state.reaction = np.zeros((6 + nr, dim))
        state.particle_bounds = scene.grid.particle_bounds
        state.energy0 = 0.5 * float(np.sum(mass[:, None] * particles.v**2))
        spec = build_contact_spec(scene.deck, mats)
        if spec is not None:
            state.contact = ContactState.create(spec, state)
        state.loads = build_loads(scene, particles.x, particles.vol)
        state.damping = scene.deck.damping.grid if scene.deck.damping is not None else 0.0
        modulus = np.array([initial_modulus(c, row) for c, row in zip(mats.type_code, mats.props)])
        c0 = np.sqrt(modulus / mats.density)
        state.energy_floor = 1e-12 * float(np.sum(mass * c0[particles.mat] ** 2))
        speed = c0[particles.mat] + np.sqrt(np.sum(particles.v**2, axis=1))
        state.wave_max = float(speed.max())
        return state
