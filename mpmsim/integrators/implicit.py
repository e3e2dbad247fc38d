"""Implicit integration of FEM bodies and MPM particle bodies with barrier contact: one step
minimises the incremental potential of the BFEMP paper (Li, Fang, Li, Jiang, arXiv:2108.03349;
the formulas and what is measured in docs/bfemp.md):

    E(y) = 1/2 (y - y~)^T M (y - y~) + c sum_terms Phi_term(y),   c = 2 zeta beta dt^2,
    y~ = y^n + dt v^n + zeta (1 - 2 beta) dt^2 a^n,

then a^{n+1} = (y - y~) / c and v^{n+1} = v^n + dt [(1 - gamma) a^n + gamma a^{n+1}]. Presets
(zeta, beta, gamma): backward Euler (1, 1/2, 1) and midpoint Newmark (1/2, 1/4, 1/2).

Newton's unknowns are the displacements u = y - y^n over the step (y = y^n + u for the terms):
the inertia term M (u - u~) and a^{n+1} = (u - u~) / c with u~ = y~ - y^n = dt v^n + ... are then
free of the positions' rounding, which at small dt would set the velocities' last bits (a
position's ulp / dt) and with them the momentum's. The positions y are the FEM vertices followed
by the active grid nodes of the particle bodies
(implicit_mpm.GridUnknowns: the particles' weights frozen at the step's start, their masses,
velocities and accelerations transferred to the grid, and back after the solve). The step
composes energy terms (mpmsim/energy.py: value, gradient, PSD Hessian, step bound), in this
order: the FEM strain energy and the particles' (terms.py: a particle is an element over its
grid nodes), the log barrier between contact points and FEM boundary edges (2D,
contact/barrier/energy.py) or triangles (3D, contact/barrier/surface.py) and its lagged
friction, and gravity. Without a deck kappa the barrier's stiffness adapts
(contact/barrier/stiffness.py: its bounds at the first step, the gradient balance at the first
step in contact, raised after Newton iterations where contacts keep closing or a solve stalls). A new physics term is a Potential added to
`terms`; the Newton loop below does not change.

Projected Newton: the terms' Hessians (PSD) and M make H = M + c sum_terms H_term on the free
degrees of freedom (held components move to their target and are eliminated; the local
Hessians are scattered by compiled kernels straight into the CSC values over the free unknowns,
on a pattern kept while the bundles' node lists stay the same: assembly.py), solved by CHOLMOD's
Cholesky factorisation or mpmsim's LDL^T (no BLAS: the same bits on every CPU), the analysis
reused while the pattern holds, or by SuperLU (solvers.py; implicit.linear_solver). After a
full step, the terms' exact (unprojected) Hessians while their matrix stays positive definite:
the last iterations converge quadratically (_newton). Line search:
alpha = the smallest of the terms' step bounds (additive CCD
keeps every contact point at least 10% of its distance from every edge; the inversion bounds
keep det F > 0 for triangles and particles), then halved until E decreases. Stop when the
largest move of an FEM node or a particle, max |p| / dt, is below newton_tolerance; that last
step is taken when it is feasible whole (it squares the residual, so momentum is conserved to
round-off, not to the tolerance). Because every accepted position lies on the feasible side of
the CCD bound, no point ever crosses an edge, whatever the time step. Lagged terms (friction)
are re-lagged in an outer loop until Newton converges at once under them (friction_lags).
Components moving at a prescribed velocity, or nodes following a prescribed rigid motion
(fem.motion: their targets are the motion's positions at t^{n+1}), are pulled to their target by
a stiffening spring inside the solve. The grid nodes on and beyond a constrained face of
grid.boundaries are held (implicit_mpm.walls). 2D (plane strain) and 3D.
"""

from __future__ import annotations

import inspect
import time as wallclock
from types import SimpleNamespace

import numpy as np

from .. import linalg
from ..contact.barrier.energy import BarrierContact, LaggedFriction, interpolate
from ..contact.barrier.start import check_initial_gaps
from ..contact.barrier.stiffness import STALL, initial_stiffness, raised_stiffness, stiffness_bounds
from ..contact.barrier.surface import SurfaceBarrier, SurfaceFriction
from ..energy import StepStart
from ..errors import InstabilityError
from ..loads import ramped_gravity
from .base import Integrator
from .assembly import Assembler
from .implicit_mpm import GridUnknowns
from .solvers import CHOLMOD_AVAILABLE, NewtonSolver
from .terms import FemStrain, Gravity, ParticleStrain

SCHEMES = {"backward_euler": (1.0, 0.5, 1.0), "newmark": (0.5, 0.25, 0.5)}
PARTS = ("derivatives", "assemble", "solve", "ccd", "line search")  # derivatives: sweep, values, gradients, local Hessians
SPRING_START, SPRING_MAX = 1e2, 1e12  # prescribed-motion spring stiffness relative to the inertia term


def empty_fem(dim: int) -> SimpleNamespace:
    """A scene without FEM bodies, as the implicit step reads one."""
    z = np.zeros((0, dim))
    return SimpleNamespace(X=z, x=z.copy(), v=z.copy(), a=z.copy(), mass=np.zeros(0), held=np.zeros((0, dim), bool),
                           held_velocity=z.copy(), cells=np.zeros((0, dim + 1), np.int64),
                           Dm_inv=np.zeros((0, dim, dim)), vol0=np.zeros(0), cell_mat=np.zeros(0, np.int64),
                           facets=np.zeros((0, dim), np.int64), boundary=np.zeros(0, np.int64),
                           node_body=np.zeros(0, np.int64), node_mat=np.zeros(0, np.int64), infos=[], n=0)


ROUNDING = 1e-10  # a change of the incremental potential below this fraction of it is rounding


class ImplicitStep(Integrator):
    """`integrator: implicit`: the incremental-potential step above, for FEM bodies and MPM
    particle bodies (implicit_mpm.GridUnknowns)."""

    name = "implicit"

    def __init__(self, scene):
        super().__init__()
        run = scene.settings
        imp = run.implicit
        barrier = scene.contact.barrier
        self.zeta, self.beta, self.gamma = SCHEMES[imp.scheme]
        self.tolerance = imp.newton_tolerance
        self.max_iterations = imp.max_newton_iterations
        self.barrier = barrier
        self.friction_lags = barrier.friction_lags
        self.mu = scene.contact.friction  # Coulomb friction between materials
        self.dt = run.time.dt
        self.thickness = float(scene.thickness) if scene.dim == 2 else 1.0
        self.full_gravity, self.gravity_ramp = run.gravity.copy(), run.gravity_ramp
        # the gravity of the step (the Gravity term holds this array): under a ramp, its value at
        # the step's end, where the incremental potential takes the forces (at t = 0 for a^0)
        self.gravity = ramped_gravity(self.full_gravity, self.gravity_ramp, 0.0) if self.gravity_ramp > 0.0 \
            else self.full_gravity.copy()
        self.timers = {p: 0.0 for p in PARTS}
        self.stats: list[tuple[int, int, int, int]] = []  # per step: Newton iterations, halvings, CCD-limited, lags
        n_fem = len(scene.fem.infos) if scene.fem is not None else 0
        self.grid = GridUnknowns(run.update.scheme, imp.particle_quadrature) if scene.has_particles else None
        bodies = n_fem + (1 if self.grid is not None else 0)
        dhat = barrier.dhat
        self.contact = dhat is not None and n_fem >= 1 and bodies > 1
        if dhat is not None:
            check_initial_gaps(scene, dhat, barrier.particle_contact == "corners")
        what = "FEM bodies" if self.grid is None else ("particle bodies" if not n_fem else "FEM and particle bodies")
        choice = imp.linear_solver
        if choice == "cholmod" and not CHOLMOD_AVAILABLE:
            from ..deck.loader import raise_at

            raise_at([(("implicit", "linear_solver"), "cholmod needs scikit-sparse on SuiteSparse's CHOLMOD "
                       "(apt install libsuitesparse-dev, then pip install -e '.[cholmod]'); or use ldl, lu or auto")],
                     scene.loaded)
        self.solver = NewtonSolver(choice)  # auto: cholmod when installed, else ldl
        self.plan = [("newton", f"{imp.scheme} incremental potential of the {what}, projected Newton, "
                                f"{self.solver.name}"),
                     ("barrier contact", f"log barrier on FEM boundary {'edges' if scene.dim == 2 else 'triangles'}, "
                      f"dhat {dhat:g}, kappa {'adaptive' if barrier.kappa is None else f'{barrier.kappa:g}'}"
                      + (f", particles at their {barrier.particle_contact}" if self.grid is not None else "")
                      if self.contact else "no contact")]
        if self.grid is not None:
            self.plan.insert(0, ("grid unknowns", f"particles -> active grid nodes ({run.update.scheme} transfers), "
                                                  "weights frozen over the step"))
        self.started = False
        self.terms = []
        self.added: list = []  # terms given by add_term, after the built-in ones
        self.spring = None  # (moving components, their targets, stiffness) during a step
        self.yn = None  # the positions at the step's start (the unknowns are displacements from them)
        self.assembler = None  # the Newton matrix's assembly (its pattern kept), once the dimension is known
        self.barrier_term = None
        self.adaptive = self.contact and barrier.kappa is None
        self.kappa_bounds = None  # adaptive kappa: (kappa_min, kappa_max, bounding-box diagonal)
        self.kappa_set = False  # the initial balance taken (at the first step that starts in contact)
        self.closest = np.inf  # smallest pair distance after the last Newton iteration
        self.exact_steps = 0  # Newton steps on the exact Hessian (_newton)
        self.exact_refused = 0  # exact Hessians not positive definite (or not descending): projected instead
        self.exact_terms: list = []
        self.newton_sizes: list[float] = []  # max |p| / dt per iteration of the last Newton solve
        self.motions = scene.fem.motions if scene.fem is not None else []  # (nodes, RigidMotion)

    def add_term(self, term) -> None:
        """Add an energy term (mpmsim.energy.Potential) to the incremental potential, after the
        built-in ones; before the first step."""
        if self.started:
            raise RuntimeError("energy terms are added before the first step")
        self.added.append(term)

    # ----------------------------------------------------------------------------- pieces
    def stable_dt(self, state) -> float:
        return self.dt

    def dry_parts(self, state) -> list:
        """Each energy term's calls apart (value, derivatives, sweep, step bound; the FEM
        forces of a^0), for the helper that compiles a first step's kernels
        (mpmsim/compile_ahead.py). Before the first step the terms are made here, in this
        process (their construction compiles little); a^0 and the step stay in advance()."""
        if self.started:
            return [lambda: self.advance(state, state.dt)]
        if not self.terms:
            self._make_terms(state)
        fem, grid = self.fem, self.grid

        def y():
            return np.concatenate([fem.x, grid.X]) if grid is not None else fem.x.copy()

        parts = [lambda: grid.begin(state)] if grid is not None else []
        parts.append(lambda: self.terms[0].forces(fem.x))
        for term in self.terms:
            parts += [lambda t=term: t.value(y()), lambda t=term: t.derivatives(y(), np.zeros_like(y())),
                      lambda t=term: t.sweep(y(), np.zeros_like(y())),
                      lambda t=term: t.step_bound(y(), np.zeros_like(y()))]
            if term in self.exact_terms:
                parts.append(lambda t=term: t.derivatives(y(), np.zeros_like(y()), exact=True))
        return parts

    def _setup(self, state) -> None:
        """The energy terms of the scene's bodies (unless dry_parts made them), and a^0 (the
        mechanical acceleration at the initial state)."""
        if not self.terms:
            self._make_terms(state)
        self._initial_acceleration(state)

    def _make_terms(self, state) -> None:
        """The energy terms of the scene's bodies."""
        dim = state.dim
        self.dim = dim
        self.assembler = Assembler(dim, lower=self.solver.lower)
        fem = state.fem if state.fem is not None else empty_fem(dim)
        self.fem = fem
        m = state.materials
        terms = [FemStrain(fem, m)]
        if self.grid is not None:
            terms.append(ParticleStrain(self.grid, m, fem.n))
        if self.contact:
            b = self.barrier
            kappa = b.kappa if b.kappa is not None else 0.0  # adaptive: set at the first step
            if dim == 2:
                barrier = BarrierContact(fem, self.grid, b.dhat, kappa, self.thickness, b.particle_contact)
                friction = LaggedFriction
            else:
                barrier = SurfaceBarrier(fem, self.grid, b.dhat, kappa, b.particle_contact)
                friction = SurfaceFriction
            self.barrier_term = barrier
            terms.append(barrier)
            if self.mu.any():
                terms.append(friction(barrier, self.mu, b.friction_velocity))
        terms.append(Gravity(self.gravity))
        self.terms = terms + self.added
        # the terms whose derivatives can give their exact Hessian (an added term may not take `exact`)
        self.exact_terms = [t for t in self.terms if "exact" in inspect.signature(t.derivatives).parameters]

    def _initial_acceleration(self, state) -> None:
        """a^0, the mechanical acceleration at the initial state; the integrator has started."""
        fem, m = self.fem, state.materials
        f = self.terms[0].forces(fem.x)
        fem.a[:] = f / fem.mass[:, None] + self.gravity if fem.n else 0.0
        fem.a[fem.held] = 0.0
        if self.grid is not None:
            grid = self.grid
            grid.begin(state)
            fg = grid.forces(np.zeros_like(grid.X), m)
            a_grid = np.where(grid.mass[:, None] > 0.0, fg / np.maximum(grid.mass, 1e-300)[:, None], 0.0) + self.gravity
            grid.a = np.einsum("pk,pkc->pc", grid.S, a_grid[grid.nodes])
            grid.begin(state)  # the grid's a^n from these
        self.started = True

    def _sweep(self, y: np.ndarray, p: np.ndarray | None = None) -> None:
        """The terms' active sets for positions y + alpha p, alpha in [0, 1] (p None: at y)."""
        p = np.zeros_like(y) if p is None else p
        for term in self.terms:
            term.sweep(y, p)

    def _energy(self, u, ut, want_derivatives, exact=False):
        """E at the displacement u from the step's start (inf if an element or particle
        inverted or a pair touched; the terms see the positions y^n + u, the inertia u - u~),
        and when asked its gradient (n*d,) and PSD-projected Hessian (with `exact`: the terms'
        own, unprojected, where a term has both): the terms' Hessian bundles (Blocks, Triplets;
        to be scaled by c) and the diagonal (n*d,) added unscaled (assembly.Assembler). The
        terms' sum is taken in their order."""
        c, d = self.c, self.dim
        y = self.yn + u
        dx = (u - ut).ravel()
        total = 0.0
        for term in self.terms:
            total += term.value(y)
        E = 0.5 * float(linalg.dot(dx, self.M * dx)) + c * total
        spring = self.spring
        if spring is not None:
            moving, target, ks = spring
            off = np.where(moving, y - target, 0.0).ravel()
            E += 0.5 * ks * float(linalg.dot(off, self.M * off))
        if not want_derivatives or not np.isfinite(E):
            return E, None, None
        force = np.zeros_like(y)
        scatters, hessians = [], []
        for term in self.terms:
            parts = term.derivatives(y, force, exact=True) if exact and term in self.exact_terms else \
                term.derivatives(y, force)
            scatters.extend(parts.local)
            hessians.extend(parts.hessian)
        g = self.M * dx + c * (-force).ravel()
        for s in scatters:
            np.add.at(g.reshape(-1, d), s.nodes, c * s.G)
        diag = self.M + (ks * self.M * moving.ravel() if spring is not None else 0.0)
        if spring is not None:
            g += ks * self.M * off
        return E, g, (hessians, diag)

    def _step_bound(self, y, p) -> tuple[float, bool]:
        """Largest alpha in (0, 1] the terms allow (CCD, det F > 0) and whether a collision
        bound limited it."""
        alpha, limited = 1.0, False
        for term in self.terms:
            a = term.step_bound(y, p)
            if a < alpha:
                alpha, limited = a, term.ccd
        return alpha, limited

    def _step_size(self, p: np.ndarray) -> float:
        """max |p| over the FEM nodes and over the particles (a particle moves by sum_i w_ip p_i;
        a grid node's own move means nothing where it weighs little)."""
        nf, grid = self.fem.n, self.grid
        size = float(np.abs(p[:nf]).max()) if nf else 0.0
        if grid is not None:
            size = max(size, float(np.abs(interpolate(grid.S, grid.nodes, p[nf:])).max()))
        return size

    # ----------------------------------------------------------------------------- the step
    def _direction(self, u, ut, free, index, exact):
        """The Newton step at displacement u: (E, g, p, exact). With `exact`, from the terms' own Hessians
        when their matrix is positive definite and the step descends; otherwise (and then
        returned exact = False) from the PSD-projected ones."""
        while True:
            t0 = wallclock.perf_counter()
            E, g, (hessians, diag) = self._energy(u, ut, True, exact)
            t1 = wallclock.perf_counter()
            self.timers["derivatives"] += t1 - t0
            Hf = self.assembler.matrix(hessians, diag, self.c, index)
            self.timers["assemble"] += wallclock.perf_counter() - t1
            t0 = wallclock.perf_counter()
            rhs = -g[free]
            step = self.solver.solve(Hf, rhs, self.assembler.version, definite=exact)
            self.timers["solve"] += wallclock.perf_counter() - t0
            if not exact or (step is not None and float(linalg.dot(rhs, step)) > 0.0):
                break
            exact = False  # not positive definite (or no descent): projected from here on
            self.exact_refused += 1
        p = np.zeros(u.size)
        p[free] = step
        return E, g, p.reshape(u.shape), exact

    def _newton(self, state, u, ut, free, dt):
        """Projected Newton from the displacement u on the free DOFs, its last iterations on the
        exact Hessian (below); returns (u, iterations, halvings, CCD-limited).

        The PSD projection of the local Hessians (elements, particles, barrier pairs) keeps
        every step a descent direction, but where a projection acts it leaves Newton linear:
        near the solution the projected matrix is not the energy's second derivative. So once a
        full step (alpha = 1, not limited by a collision bound) has been taken, the iterations
        use the terms' own Hessians while their matrix stays positive definite, which makes
        the last iterations quadratic; the first one that is not goes back to the projection
        for the rest of the solve. So does a step that fails to halve after one whose energy
        change was below E's rounding: there the gradient's rounding sets the steps, and a
        near-singular exact matrix (a quasi-static column) would only amplify it."""
        halvings = 0
        ccd_limited = False
        exact = False
        index = np.full(free.size, -1, np.int64)  # DOF -> free unknown (-1: eliminated)
        index[free] = np.arange(int(free.sum()))
        refused = self.exact_refused
        settled = False  # the last step's predicted decrease was below what E resolves
        self.newton_sizes = sizes = []  # max |p| / dt of each iteration of this solve
        for it in range(1, self.max_iterations + 1):
            y = self.yn + u
            self._sweep(y)
            if self.adaptive and it > 1:  # after the previous iteration, on this sweep's pairs
                self._raise_kappa(y, it - 1)
            E, g, p, exact = self._direction(u, ut, free, index, exact)
            size = self._step_size(p) / dt
            if exact and settled and size > 0.5 * sizes[-1]:
                # after a step at the energy's rounding, one that does not shrink: the
                # gradient's rounding rules here, not its curvature; the projection from here on
                self.exact_refused += 1
                E, g, p, exact = self._direction(u, ut, free, index, False)
                size = self._step_size(p) / dt
            self.exact_steps += exact
            sizes.append(size)
            if size < self.tolerance:
                # converged: the last Newton step is below the tolerance; take it when it is
                # feasible as a whole (it squares the residual: momentum to round-off)
                self._sweep(y, p)
                if self._step_bound(y, p)[0] >= 1.0:
                    u = u + p
                return u, it, halvings, ccd_limited
            t0 = wallclock.perf_counter()
            self._sweep(y, p)
            alpha, limited = self._step_bound(y, p)
            ccd_limited |= limited
            self.timers["ccd"] += wallclock.perf_counter() - t0
            t0 = wallclock.perf_counter()
            # an exact Newton step whose predicted decrease, g.p / 2, is below what E resolves
            # (1e-10 of it) is taken without the test: E's rounding would refuse it
            settled = exact and -float(linalg.dot(g, p.ravel())) <= ROUNDING * abs(E)
            while True:
                trial = u + alpha * p
                if settled:
                    break
                E_trial, _, _ = self._energy(trial, ut, False)
                if E_trial <= E or alpha < 1e-12:
                    break
                alpha *= 0.5
                halvings += 1
            self.timers["line search"] += wallclock.perf_counter() - t0
            u = trial
            if alpha == 1.0 and not limited and self.exact_refused == refused:
                exact = True
        names = self._body_names(state)
        raise InstabilityError(
            f"stopped at step {state.step + 1}, t = {state.t + dt:.6g}: Newton did not converge in "
            f"{self.max_iterations} iterations (bodies {names}; last max|p|/dt = {self._step_size(p) / dt:.3g}); "
            "try a smaller time.dt or a larger implicit.newton_tolerance", state.t, state.step)

    def _initial_kappa(self, ut, free, mass, lagged) -> None:
        """Adaptive kappa (contact/barrier/stiffness.py): its bounds at the first step, the
        gradient balance at the first step that starts with pairs within dhat (at the step's
        start: u = 0)."""
        barrier = self.barrier_term
        y, u = self.yn, np.zeros_like(ut)
        if self.kappa_bounds is None:
            diagonal = linalg.norm(y.max(axis=0) - y.min(axis=0))
            kmin, kmax = stiffness_bounds(float(mass[mass > 0].mean()), diagonal, self.c,
                                          float(barrier.points.weight.mean()), barrier.dhat)
            self.kappa_bounds = (kmin, kmax, diagonal)
            barrier.kappa = kmin
        self.spring = None
        self._sweep(y)
        if not barrier.in_contact:
            return
        kmin, kmax, _ = self.kappa_bounds
        barrier.kappa = 0.0
        g_rest = self._energy(u, ut, True)[1]
        barrier.kappa = 1.0
        g_barrier = (self._energy(u, ut, True)[1] - g_rest)[free]
        if not g_barrier.any():  # candidates, but none within dhat yet
            barrier.kappa = kmin
            return
        barrier.kappa = initial_stiffness(g_barrier, g_rest[free], kmin, kmax)
        self.kappa_set = True
        for term in lagged:  # their normal forces with this kappa
            term.relag(y)

    def _raise_kappa(self, y, iteration: int) -> None:
        """After a Newton iteration (y its result, swept): IPC's raise (a closest distance below
        1e-9 of the scene that keeps shrinking), and ours: every STALL iterations of one solve in
        contact."""
        barrier = self.barrier_term
        d = barrier.min_distance(y)
        _, kmax, diagonal = self.kappa_bounds
        kappa = raised_stiffness(self.closest, d, barrier.kappa, kmax, diagonal)
        if iteration % STALL == 0 and d < barrier.dhat:
            kappa = min(kmax, 2.0 * kappa)
        barrier.kappa = kappa
        self.closest = d

    def _body_names(self, state) -> str:
        infos = list(self.fem.infos) + (list(state.particles.infos) if self.grid is not None else [])
        return " and ".join(f"'{b.name}'" for b in infos)

    def advance(self, state, dt: float) -> float:
        """One step. Fixed components stay put (eliminated). Components moving at a prescribed
        velocity are not moved to their target by fiat (that could push them through another
        body): a spring 1/2 k m |x - target|^2 pulls them there inside the Newton solve, with the
        CCD line search watching, and k grows tenfold until they are within 1e-6 of their move
        (or of newton_tolerance x dt, what Newton resolves)."""
        if not self.started:
            self._setup(state)
        elif self.grid is not None:
            self.grid.begin(state)
        fem, grid, d = self.fem, self.grid, self.dim
        nf = fem.n
        t_next = state.t + dt
        for nodes, motion in self.motions:  # the rigid motion's velocity at t^{n+1} (its target below)
            fem.held_velocity[nodes] = motion.velocities(fem.X[nodes], t_next)
        if self.gravity_ramp > 0.0:
            self.gravity[:] = ramped_gravity(self.full_gravity, self.gravity_ramp, t_next)
        self.c = 2.0 * self.zeta * self.beta * dt * dt
        h2 = self.zeta * (1.0 - 2.0 * self.beta) * dt * dt
        # the unknowns: FEM nodes, then the particles' active grid nodes
        if grid is not None:
            yn = np.concatenate([fem.x, grid.X])
            vn = np.concatenate([fem.v, grid.v])
            an = np.concatenate([fem.a, grid.a_grid])
            mass = np.concatenate([fem.mass, grid.mass])
            held = np.concatenate([fem.held, grid.held])
            held_velocity = np.concatenate([fem.held_velocity, np.zeros((grid.n, d))])
        else:
            yn, vn, an = fem.x.copy(), fem.v.copy(), fem.a.copy()
            mass, held, held_velocity = fem.mass, fem.held, fem.held_velocity
        self.M = np.repeat(mass, d)
        self.yn = yn
        ut = dt * vn + h2 * an  # y~ - y^n
        moving = held & (held_velocity != 0.0)
        target = yn + dt * held_velocity
        for nodes, motion in self.motions:
            target[nodes] = motion.positions(fem.X[nodes], t_next)
            moving[nodes] = True
        fixed = held & ~moving
        free = ~fixed.ravel()
        start = StepStart(state, yn, mass, dt)
        for term in self.terms:
            term.begin(start)
        lagged = [term for term in self.terms if term.lagged]
        if self.adaptive and not self.kappa_set:
            self._initial_kappa(ut, free, mass, lagged)
        u = np.zeros_like(yn)
        its = halvings = 0
        ccd_limited = False
        k = SPRING_START
        reach = max(1e-6 * (float(np.abs(target - yn)[moving].max()) if moving.any() else 0.0),
                    self.tolerance * dt)
        lags = 0
        while True:
            self.spring = (moving, target, k) if moving.any() else None
            u, n_it, n_half, limited = self._newton(state, u, ut, free, dt)
            y = yn + u
            its, halvings, ccd_limited = its + n_it, halvings + n_half, ccd_limited or limited
            if any(t.active for t in lagged) and lags + 1 < self.friction_lags and not (lags and n_it == 1):
                # the outer loop of the lagged terms: their lagged quantities again at the new
                # positions, until Newton converges at once under them
                lags += 1
                if any([t.relag(y) for t in lagged]):
                    continue
            if self.spring is None or np.abs(y - target)[moving].max() <= reach:
                break
            if k >= SPRING_MAX:
                names = ", ".join(f"'{fem.infos[b].name}'" for b in np.unique(fem.node_body[moving[:nf].any(axis=1)]))
                raise InstabilityError(
                    f"stopped at step {state.step + 1}, t = {state.t + dt:.6g}: the prescribed motion of {names} "
                    f"could not be reached (off by {np.abs(y - target)[moving].max():.3g}; something blocks it)",
                    state.t, state.step)
            k *= 10.0
        self.spring = None
        if moving.any():  # work of the prescribed motion: the constraint force (gradient / c) times the move
            self._sweep(y)
            _, g, _ = self._energy(u, ut, True)
            force = g.reshape(y.shape) / self.c
            state.work_in += float(np.sum(np.where(moving, force * u, 0.0)))
        if self.contact:
            self._contact_work(y, u)
        a_new = (u - ut) / self.c
        a_new[held] = 0.0
        v_new = vn + dt * ((1.0 - self.gamma) * an + self.gamma * a_new)
        v_new[held] = held_velocity[held]
        # gravity's work on the FEM nodes and the particles
        state.work_in += float(np.sum(fem.mass[:, None] * self.gravity[None, :] * u[:nf]))
        fem.v[:], fem.a[:], fem.x[:] = v_new[:nf], a_new[:nf], y[:nf]
        if grid is not None:
            P = state.particles
            x_before = P.x.copy()
            grid.finish(state, u[nf:], v_new[nf:], a_new[nf:])
            state.work_in += float(np.sum(P.mass[:, None] * self.gravity[None, :] * (P.x - x_before)))
        self.stats.append((its, halvings, int(ccd_limited), lags + 1))
        return dt

    def _contact_work(self, y, u) -> None:
        """The contact terms' work over the step (their forces at the step's end, as the
        implicit step applies them, times the move): per FEM body into fem.contact_work, on
        the particles' grid unknowns into fem.particle_contact_work (the history's
        contact_work_<body> and contact_dissipated, minus their sum: friction's dissipation
        and the barrier's stored energy)."""
        force = np.zeros_like(y)
        still = np.zeros_like(y)
        for term in self.terms:
            if not term.contact:
                continue
            term.sweep(y, still)
            term.value(y)
            parts = term.derivatives(y, force)
            for s in parts.local:  # gradients of the pair stencils: minus their force
                np.add.at(force, s.nodes, -s.G)
        work = np.einsum("nc,nc->n", force, u)
        fem, nf = self.fem, self.fem.n
        fem.contact_work += np.bincount(fem.node_body, work[:nf], minlength=len(fem.contact_work))
        fem.particle_contact_work += float(work[nf:].sum())

    def report(self) -> list[str]:
        """The Newton table: steps, iterations per step (mean, max), line-search halvings and
        CCD-limited steps."""
        if not self.stats:
            return []
        its = np.array([s[0] for s in self.stats])
        halv = sum(s[1] for s in self.stats)
        ccd = sum(s[2] for s in self.stats)
        line = (f"Newton: {len(its)} steps, {its.mean():.2f} iterations per step (max {its.max()}), "
                f"{halv} line-search halvings, {ccd} CCD-limited steps, {self.exact_steps} iterations on the exact "
                f"Hessian ({self.exact_refused} not positive definite)")
        lags = np.array([s[3] for s in self.stats])
        if self.friction_lags > 1:
            line += f", {lags.mean():.2f} friction lags per step (max {lags.max()})"
        if self.adaptive and self.kappa_bounds is not None:
            kmin, kmax, _ = self.kappa_bounds
            line += (f"; adaptive kappa {self.barrier_term.kappa:.4g} (range {kmin:.3g} to {kmax:.3g}"
                     + ("" if self.kappa_set else ", no contact yet") + ")")
        return [line, self.solver.report()]
