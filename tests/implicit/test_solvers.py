"""The Newton step's sparse solve (mpmsim/integrators/solvers.py): CHOLMOD (the extra `cholmod`,
its analysis reused while the pattern holds) gives SuperLU's step, and a run with it SuperLU's
run within the Newton tolerance, momentum kept to round-off. CI installs CHOLMOD and sets
MPMSIM_REQUIRE_CHOLMOD=1, so there these cases run; elsewhere they skip only where scikit-sparse
is missing."""

from __future__ import annotations

import os

import numpy as np
import pytest
import yaml

from mpmsim.deck.overrides import with_overrides
from mpmsim.integrators import solvers
from mpmsim.integrators.assembly import Assembler
from mpmsim.integrators.solvers import CHOLMOD_AVAILABLE, NewtonSolver
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation

from ..conftest import ROOT, deck_from

pytestmark = pytest.mark.implicit

RINGS = yaml.safe_load((ROOT / "inputs" / "implicit_rings_2d.yaml").read_text())
STEPS = 12  # the rings meet at about step 8 (the barrier's pairs enter the pattern)


def need_cholmod():
    if not CHOLMOD_AVAILABLE:
        assert not os.environ.get("MPMSIM_REQUIRE_CHOLMOD"), "scikit-sparse (CHOLMOD) is not installed"
        pytest.skip("scikit-sparse (CHOLMOD) is not installed: pip install -e '.[cholmod]'")


def run(solver: str, steps: int = STEPS) -> Simulation:
    sim = Simulation(build_scene(deck_from(with_overrides(RINGS, {"implicit.linear_solver": solver}),
                                           ROOT / "inputs")), out_dir=None, threads=1)
    for _ in range(steps):
        sim.step()
    return sim


@pytest.mark.parametrize("supernodal", [False, True])
def test_cholmod_gives_superlus_newton_step(supernodal, monkeypatch):
    """Newton matrices of the rings in contact (an MPM ring, an FEM ring, the barrier between):
    the step p = -H^-1 g from CHOLMOD (lower triangle, analysis reused over two matrices of one
    pattern; simplicial, and supernodal as from solvers.SUPERNODAL_MIN unknowns) against
    SuperLU (full matrix)."""
    need_cholmod()
    if supernodal:
        monkeypatch.setattr(solvers, "SUPERNODAL_MIN", 0)
    sim = run("lu")
    it = sim.integrator
    assert it.barrier_term.in_contact
    y = np.concatenate([it.fem.x, it.grid.X])
    free = np.ones(y.size, bool)
    index = np.arange(y.size)
    chol, lu = NewtonSolver(cholesky=True), NewtonSolver(cholesky=False)
    lower, full = Assembler(2, lower=True), Assembler(2)
    for shift in (0.0, 1e-6):  # two matrices on one pattern: the second reuses the analysis
        yk = y + shift * np.sin(np.arange(y.size)).reshape(y.shape)
        it._sweep(yk)
        it.yn = y  # the energy of the displacement yk - y from y, inertia about y
        E, g, (hessians, diag) = it._energy(yk - y, np.zeros_like(y), True)
        assert np.isfinite(E)
        p_chol = chol.solve(lower.matrix(hessians, diag, it.c, index), -g[free], lower.version)
        p_lu = lu.solve(full.matrix(hessians, diag, it.c, index), -g[free], full.version)
        assert np.abs(p_chol - p_lu).max() <= 1e-10 * np.abs(p_lu).max()
    assert chol.counts == {"cholmod": 2, "supernodal": 2 * supernodal, "splu": 0, "analyses": 1, "fallbacks": 0}


def test_a_run_with_cholmod_is_superlus_run_within_the_newton_tolerance():
    """The rings over 12 steps (contact from step 8): the same Newton iterations, positions
    within the Newton tolerance x dt of SuperLU's, momentum conserved to round-off either way."""
    need_cholmod()
    runs = {s: run(s) for s in ("cholmod", "lu")}
    chol, lu = runs["cholmod"], runs["lu"]
    assert chol.integrator.report()[1].startswith("linear solver: CHOLMOD")
    assert lu.integrator.report()[1].startswith("linear solver: SuperLU")
    assert [s[0] for s in chol.integrator.stats] == [s[0] for s in lu.integrator.stats]
    dt, tol = RINGS["time"]["dt"], RINGS["implicit"]["newton_tolerance"]
    for name in ("particles", "fem"):
        a, b = getattr(chol.state, name), getattr(lu.state, name)
        assert np.abs(a.x - b.x).max() < tol * dt
    p0 = None
    for sim in (chol, lu):
        P, f = sim.state.particles, sim.state.fem
        momentum = (P.mass[:, None] * P.v).sum(0) + (f.mass[:, None] * f.v).sum(0)
        scale = (P.mass[:, None] * np.abs(P.v)).sum() + (f.mass[:, None] * np.abs(f.v)).sum()
        p0 = momentum if p0 is None else p0
        assert abs(momentum[1]) < 1e-13 * scale  # head-on along x: no y momentum
    assert np.abs(p0 - momentum).max() < 1e-12 * scale


def test_linear_solver_cholmod_without_scikit_sparse_is_a_deck_error(monkeypatch):
    import mpmsim.integrators.implicit as implicit
    from mpmsim.errors import DeckError

    monkeypatch.setattr(implicit, "CHOLMOD_AVAILABLE", False)
    with pytest.raises(DeckError, match="implicit.linear_solver"):
        Simulation(build_scene(deck_from(with_overrides(RINGS, {"implicit.linear_solver": "cholmod"}),
                                         ROOT / "inputs")), out_dir=None, threads=1)


@pytest.mark.parametrize("supernodal", [False, True])
def test_a_factorisation_that_is_not_positive_definite_is_solved_by_superlu(supernodal, monkeypatch):
    """CHOLMOD's LDL^T of an indefinite matrix meets a D entry <= 0, its supernodal LL^T stops
    with an error: SuperLU solves it."""
    import scipy.sparse as sp

    need_cholmod()
    if supernodal:
        monkeypatch.setattr(solvers, "SUPERNODAL_MIN", 0)
    A = sp.csc_matrix(np.array([[1.0, 3.0, 0.0], [3.0, 1.0, 1.0], [0.0, 1.0, 2.0]]))
    b = np.array([1.0, 2.0, 3.0])
    solver = NewtonSolver(cholesky=True)
    x = solver.solve(sp.tril(A).tocsc(), b, version=1)
    assert np.allclose(A @ x, b, rtol=0, atol=1e-14)
    assert solver.counts == {"cholmod": 0, "supernodal": 0, "splu": 1, "analyses": 1, "fallbacks": 1}
    assert "1 not positive definite, solved by SuperLU" in solver.report()
    empty = sp.csc_matrix((0, 0))  # every unknown held: nothing to solve
    assert solver.solve(empty, np.zeros(0), version=2).shape == (0,)
