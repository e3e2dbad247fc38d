"""Simulation state: plain data, struct-of-arrays numpy arrays.

- `bodies`: one set per body kind present (mpmsim/bodies): deformable particles, rigid
  particles; `particles` and `rigid` name the two particle sets.
- the background grid's workspace: field arrays (`fields`), the active node box (`box`) and
  each particle set's shape data (`sd`, `rigid_sd`);
- the contact workspace (`contact`, mpmsim/contact/grid/workspace.py) where materials meet;
- the clock (t, dt, step) and the run's energy accounts (work put in, reactions, the energy
  stored in interfaces), and the flags kernels raise when something goes bad.

The state holds no methods of the step; integrators (mpmsim/integrators) change it, the run
loop (mpmsim/solver.py) reads it for history, output and stability checks.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import linalg
from .bodies.fem import FemBodies
from .bodies.particles import Particles
from .bodies.rigid import RigidParticles
from .contact.grid.workspace import ContactWorkspace
from .gridops import ActiveBox, n_threads
from .loads import build_loads
from .materials import MaterialTable
from .parallel import auto_threads, chunks_for, use_threads
from .scene import Scene
from .scene.grid import GridSpec
from .shapes import ShapeData, ShapeFunction, shape_function

N_LOSSES = 6  # the energy ledger's totals (state.ledger), named by mpmsim/tasks/ledger.py LOSSES


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
    ghost_src: np.ndarray = None  # (>= active fields, dim) the field each ghost component mirrors (tasks/boundary.py)
    ghost_face: np.ndarray = None  # (>= active fields, dim) its face

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
                   z(nn, max(n_rigid, 1)), z(nf, dim), z(nf, dim), z(nf, dim), np.zeros((0, dim), dtype=np.int64),
                   np.zeros((0, dim), dtype=np.int64))


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
    dim: int
    grid: GridSpec
    materials: MaterialTable
    shape: ShapeFunction
    particles: Particles
    rigid: RigidParticles
    bodies: list  # the body sets, in kind order (deformable particles, rigid particles, ...)
    sd: ShapeData  # shape data of deformable particles
    rigid_sd: ShapeData
    fields: GridFields
    box: ActiveBox
    gravity: np.ndarray  # (dim,)
    threads: int
    nchunk: int
    entry_offsets: np.ndarray  # (K, 3) node offset of shape entry k from the particle's lowest node
    contact: ContactWorkspace | None  # where materials meet (None: a single velocity field)
    loads: object  # mpmsim.loads.Loads when the deck has traction loads, else None
    damping: float  # grid damping alpha (1/time)
    t: float = 0.0
    dt: float = 0.0
    dt_rule: float = 0.0  # the step the integrator allows, before the cut at the end time
    step: int = 0
    wave_max: float = 0.0  # max(c + |v|) over particles from the last stress update
    reaction: np.ndarray = None  # (6 + n_rigid, dim) force walls/rigid bodies exert on material
    impulse: np.ndarray = None  # (6 + n_rigid, dim) the same, integrated over the steps since t = 0
    energy0: float = 0.0  # mechanical energy at the start of the run
    interface_energy: float = 0.0  # imperfect interfaces, end of the last step
    fracture_energy: float = 0.0  # cohesive interfaces: energy their damage dissipated, so far
    debonded_area: float = 0.0  # cohesive interfaces: the interface area failed so far
    work_in: float = 0.0  # signed work done on the material by walls, rigid materials, gravity
    ledger: np.ndarray | None = None  # the energy ledger's losses (tasks/ledger.py LOSSES), when the deck asks
    energy_floor: float = 0.0  # round-off scale of energy (sum m c^2 x 1e-12)
    flags: StepFlags = field(default_factory=StepFlags)
    particle_bounds: tuple = ()  # (lo, hi): where particle centres may go (GridSpec.particle_bounds)
    noise_scratch: tuple | None = None  # shape data and grid arrays for the noise metric
    fem: FemBodies | None = None  # the FEM bodies (mpmsim/bodies/fem.py), if any

    @property
    def field_index(self) -> np.ndarray:
        """(n, K) field each particle-node entry reads and writes: its node, or its material's
        slot at nodes where materials meet (mpmsim/contact)."""
        return self.sd.nodes if self.contact is None else self.contact.fidx

    @property
    def entries(self) -> ShapeData:
        """The deformable particles' shape data with fields in place of nodes (field_index)."""
        return self.sd if self.contact is None else self.sd._replace(nodes=self.contact.fidx)

    @property
    def n_rigid_materials(self) -> int:
        return len(self.materials.rigid)

    @classmethod
    def from_scene(cls, scene: Scene, threads: int | None = None) -> "State":
        state = cls.particle_state(scene, threads) if scene.has_particles else cls.without_particles(scene, threads)
        if scene.fem is not None:
            state.fem = FemBodies.from_seed(scene.fem, scene.materials, scene.thickness, scene.dim)
            state.fem.check_every = scene.settings.stability.check_every
            if scene.contact.augury is not None:
                state.fem.crossing_depth = scene.contact.augury.overlap_tolerance
            state.bodies.append(state.fem)
            state.energy0 += 0.5 * float(linalg.dot(state.fem.mass, np.sum(state.fem.v**2, axis=1)))
            c0 = np.sqrt(scene.materials.wave_moduli() / scene.materials.density)
            state.energy_floor += 1e-12 * float(np.sum(state.fem.mass * c0[state.fem.node_mat] ** 2))
        return state

    @classmethod
    def without_particles(cls, scene: Scene, threads: int | None) -> "State":
        """A scene of FEM bodies only: no background grid, no particle workspace."""
        dim, mats = scene.dim, scene.materials
        g = scene.settings.gravity.copy()
        threads = threads or n_threads()
        particles = Particles.from_seed(scene.deformable, mats.density, np.full(dim, 0.5), [], affine=False,
                                        energy=False)
        rigid = RigidParticles.from_seed(scene.rigid, mats, [], dim)
        state = cls(dim=dim, grid=None, materials=mats, shape=None, particles=particles, rigid=rigid,
                    bodies=[particles, rigid], sd=None, rigid_sd=None, fields=None, box=None, gravity=g,
                    threads=threads, nchunk=chunks_for(threads), entry_offsets=None, contact=None, loads=None,
                    damping=0.0)
        state.reaction = np.zeros((6 + len(mats.rigid), dim))
        state.impulse = np.zeros_like(state.reaction)
        return state

    @classmethod
    def particle_state(cls, scene: Scene, threads: int | None) -> "State":
        dim = scene.dim
        run = scene.settings
        mats = scene.materials
        scheme = run.update.scheme
        particles = Particles.from_seed(scene.deformable, mats.density, scene.semi_size, scene.deformable_bodies,
                                        affine=scheme == "apic", energy=mats.tracks_energy, state0=mats.state0,
                                        hoop=run.axisymmetric)
        rigid = RigidParticles.from_seed(scene.rigid, mats, scene.rigid_bodies, dim, run.stability.rigid_penetration)
        sf = shape_function(run.shape_function)
        axisymmetric = run.axisymmetric
        if axisymmetric:
            sf = sf.for_axisymmetric()
        K = sf.nodes_per_particle(dim)
        if not threads:  # no count asked for: one thread for a small scene
            threads, _ = auto_threads(n_threads(), particles.n)
        use_threads(threads)  # kernels run from here on (shape functions below) in this form
        nr = len(mats.rigid)
        g = run.gravity.copy()
        per = sf.per_axis
        offsets = np.array([(k % per, (k // per) % per, k // (per * per)) for k in range(K)], dtype=np.int64)
        nn = scene.grid.n_nodes
        contact = None
        if scene.contact.grid is not None:
            contact = ContactWorkspace.create(scene.contact.grid, particles.mat, rigid.mat, nn, K, dim)
        state = cls(
            dim=dim, grid=scene.grid, materials=mats, shape=sf, particles=particles, rigid=rigid,
            bodies=[particles, rigid], sd=ShapeData.empty(particles.n, K, dim, axisymmetric),
            rigid_sd=ShapeData.empty(rigid.n, K, dim, axisymmetric),
            fields=GridFields.allocate(nn, dim, nr, scheme in ("xpic", "fmpm")),
            box=ActiveBox(scene.grid.shape), gravity=g, threads=threads, nchunk=chunks_for(threads),
            entry_offsets=offsets, contact=contact, loads=build_loads(scene, particles.x, particles.vol),
            damping=run.damping,
        )
        state.reaction = np.zeros((6 + nr, dim))
        state.impulse = np.zeros_like(state.reaction)
        if run.output.energy_ledger:
            state.ledger = np.zeros(N_LOSSES)  # tasks/ledger.py LOSSES
        state.particle_bounds = scene.grid.particle_bounds
        mass = particles.mass
        state.energy0 = 0.5 * float(np.sum(mass[:, None] * particles.v**2))
        c0 = np.sqrt(mats.wave_moduli() / mats.density)
        state.energy_floor = 1e-12 * float(np.sum(mass * c0[particles.mat] ** 2))
        speed = c0[particles.mat] + np.sqrt(np.sum(particles.v**2, axis=1))
        state.wave_max = float(speed.max())
        return state
