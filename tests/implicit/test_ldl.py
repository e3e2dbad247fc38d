"""mpmsim's sparse LDL^T (mpmsim/integrators/ldl.py): solutions against scipy's spsolve on grid
(2D-FEM-like) and random SPD matrices, the analysis reused over matrices of one pattern, a
matrix that is not positive definite found (and solved by SuperLU in the Newton solver), the
Newton step of the rings deck equal to SuperLU's, and the same bits between calls, thread
counts and CPU targets (the kernels compiled for baseline x86-64, without FMA, give the host's
bits; the host's machine code has no fused multiply-add)."""

from __future__ import annotations

import os
import re
import subprocess
import sys

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from mpmsim.integrators import ldl as ldl_module
from mpmsim.integrators import solvers
from mpmsim.integrators.assembly import Assembler
from mpmsim.integrators.ldl import LDL, NotPositiveDefiniteError, adjacency, rcm
from mpmsim.integrators.solvers import NewtonSolver

from ..conftest import ROOT
from .test_solvers import RINGS, run

pytestmark = pytest.mark.implicit


def grid_matrix(nx: int, ny: int, seed: int = 0, shuffle: bool = False) -> sp.csc_matrix:
    """A 2D-FEM-like SPD matrix: 2 unknowns per node of an nx x ny grid, every pair of nodes
    of a 9-point stencil coupled by a random positive weight times a 2x2 SPD block (a weighted
    graph Laplacian (x) block, PSD), plus a random positive mass diagonal. Full, CSC."""
    rng = np.random.default_rng(seed)
    nodes = np.arange(nx * ny).reshape(ny, nx)
    pairs = [(nodes[:, :-1], nodes[:, 1:]), (nodes[:-1, :], nodes[1:, :]),
             (nodes[:-1, :-1], nodes[1:, 1:]), (nodes[:-1, 1:], nodes[1:, :-1])]
    a = np.concatenate([p[0].ravel() for p in pairs])
    b = np.concatenate([p[1].ravel() for p in pairs])
    w = rng.uniform(0.5, 2.0, len(a))
    m = nx * ny
    W = sp.coo_matrix((w, (a, b)), shape=(m, m))
    W = W + W.T
    lap = sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W
    block = np.array([[2.0, 0.7], [0.7, 1.0]])
    A = sp.kron(lap, block) + sp.diags(rng.uniform(0.1, 1.0, 2 * m))
    if shuffle:  # number the nodes at random: the ordering has to find the band again
        p = np.repeat(2 * rng.permutation(m), 2) + np.tile([0, 1], m)
        A = A.tocsr()[p][:, p]
    A = sp.csc_matrix(A)
    A.sort_indices()
    return A


def random_spd(n: int, per_row: int = 2, seed: int = 0) -> sp.csc_matrix:
    """B^T B + diag, B sparse random (per_row entries in each of its n rows)."""
    rng = np.random.default_rng(seed)
    rows = np.repeat(np.arange(n), per_row)
    cols = rng.integers(0, n, n * per_row)
    B = sp.csc_matrix((rng.standard_normal(n * per_row), (rows, cols)), shape=(n, n))
    A = sp.csc_matrix(B.T @ B + sp.diags(rng.uniform(0.01, 1.0, n)))
    A.sort_indices()
    return A


def lower(A: sp.csc_matrix) -> sp.csc_matrix:
    L = sp.tril(A).tocsc()
    L.sort_indices()
    return L


def factor_and_solve(A: sp.csc_matrix, b: np.ndarray) -> tuple[LDL, np.ndarray]:
    f = LDL()
    f.analyse(lower(A))
    assert f.factor(lower(A))
    return f, f.solve(b)


def check_solution(A, b, x):
    ref = spsolve(A, b)
    assert np.linalg.norm(x - ref) <= 1e-10 * np.linalg.norm(ref)
    assert np.linalg.norm(A @ x - b) < 1e-12 * np.linalg.norm(b)


@pytest.mark.parametrize("nx, ny", [(1, 1), (2, 3), (9, 7), (20, 20), (32, 32)])
def test_grid_matrices_are_solved_as_spsolve_solves_them(nx, ny):
    """2D 9-point grids with 2 unknowns per node, numbered at random, 2 to 2048 unknowns."""
    A = grid_matrix(nx, ny, seed=nx * ny, shuffle=True)
    b = np.random.default_rng(1).standard_normal(A.shape[0])
    f, x = factor_and_solve(A, b)
    check_solution(A, b, x)
    assert f.D.min() > 0 and f.pivot == -1


@pytest.mark.parametrize("n", [1, 5, 60, 400, 800])
def test_random_spd_matrices_are_solved_as_spsolve_solves_them(n):
    A = random_spd(n, seed=n)
    b = np.random.default_rng(2).standard_normal(n)
    _, x = factor_and_solve(A, b)
    check_solution(A, b, x)


def test_the_factors_are_those_of_the_permuted_matrix():
    """L D L^T = P A P^T entry by entry (L unit lower, D diagonal, P from the RCM permutation),
    on a small random matrix whose factors are dense enough to check them all."""
    A = random_spd(40, per_row=3, seed=3)
    f, _ = factor_and_solve(A, np.ones(40))
    n = f.n
    L = sp.csc_matrix((f.Lx, f.Li, f.Lp), shape=(n, n)) + sp.identity(n)
    C = A.toarray()[np.ix_(f.perm, f.perm)]
    assert np.abs((L @ sp.diags(f.D) @ L.T).toarray() - C).max() <= 1e-13 * np.abs(C).max()
    assert np.array_equal(np.sort(f.perm), np.arange(n))


def test_rcm_finds_the_band_of_a_grid_numbered_at_random():
    """The fill of a 20 x 20 grid numbered at random, ordered by RCM, is within 25% of its
    natural (row by row, banded) numbering's and no more than with scipy's RCM; the components
    of a block-diagonal matrix are numbered apart."""
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    natural = LDL()
    natural.analyse(lower(grid_matrix(20, 20)), perm=np.arange(800))
    shuffled = grid_matrix(20, 20, shuffle=True)
    ours, theirs, none = LDL(), LDL(), LDL()
    ours.analyse(lower(shuffled))
    theirs.analyse(lower(shuffled), perm=reverse_cuthill_mckee(shuffled, symmetric_mode=True))
    none.analyse(lower(shuffled), perm=np.arange(800))
    assert ours.nnz <= 1.25 * natural.nnz  # 39,388 against 32,320: RCM's fronts are the stencil's squares
    assert ours.nnz <= theirs.nnz  # equal here
    assert none.nnz > 2.5 * ours.nnz  # 114,768 in the random numbering
    # a permutation of the nodes in each component, components kept apart
    two = sp.block_diag([grid_matrix(3, 3), grid_matrix(4, 2)]).tocsc()
    perm = rcm(two.shape[0], *adjacency(two.shape[0], lower(two).indptr.astype(np.int64),
                                        lower(two).indices.astype(np.int64)))
    assert np.array_equal(np.sort(perm), np.arange(two.shape[0]))
    first = perm < 18
    assert first[:first.sum()].all() or first[-first.sum():].all()


def test_the_analysis_is_reused_over_matrices_of_one_pattern():
    """Three matrices of one pattern, new values each (the grid's weights and masses drawn
    again): one analysis, three factorisations, each solution right; another pattern must be
    analysed again."""
    f = LDL()
    b = np.random.default_rng(4).standard_normal(2 * 12 * 10)
    for seed in range(3):
        A = grid_matrix(12, 10, seed=seed)
        if seed == 0:
            f.analyse(lower(A))
        assert f.factor(lower(A))
        check_solution(A, b, f.solve(b))
    assert (f.analyses, f.factorisations) == (1, 3)
    with pytest.raises(ValueError, match="not the analysed one"):
        f.factor(lower(grid_matrix(10, 12)))
    with pytest.raises(ValueError, match="lower triangle only"):
        LDL().analyse(grid_matrix(3, 3))  # the full matrix

    solver = NewtonSolver("ldl")
    assert solver.lower
    for seed, version in ((0, 1), (1, 1), (2, 1), (0, 2)):
        A = grid_matrix(12, 10, seed=seed)
        check_solution(A, b, solver.solve(lower(A), b, version))
    assert solver.counts == {"ldl": 4, "splu": 0, "analyses": 2, "fallbacks": 0}
    assert solver.report() == ("linear solver: mpmsim LDL^T (simplicial, RCM ordering, no BLAS), 4 factorisations "
                               "on 2 analyses")


def test_a_matrix_that_is_not_positive_definite_is_found():
    """An indefinite 3 x 3 matrix and a grid matrix shifted below its smallest eigenvalues (the
    LDL^T's D has the matrix's inertia, so some D < 0): factor says False and names the unknown,
    solve raises. NewtonSolver's ldl hands such a matrix to SuperLU and counts it."""
    A = sp.csc_matrix(np.array([[1.0, 3.0, 0.0], [3.0, 1.0, 1.0], [0.0, 1.0, 2.0]]))
    f = LDL()
    f.analyse(lower(A))
    assert not f.factor(lower(A))
    assert 0 <= f.pivot < 3
    with pytest.raises(NotPositiveDefiniteError, match="not positive definite"):
        f.solve(np.ones(3))

    G = grid_matrix(10, 10)
    shift = np.linalg.eigvalsh(G.toarray())[5]  # 5 eigenvalues below the shift
    S = sp.csc_matrix(G - shift * sp.identity(G.shape[0]))
    f = LDL()
    f.analyse(lower(S))
    assert not f.factor(lower(S))
    assert f.factor(lower(G))  # the same pattern, positive definite again

    b = np.array([1.0, 2.0, 3.0])
    solver = NewtonSolver("ldl")
    x = solver.solve(lower(A), b, version=1)
    assert np.allclose(A @ x, b, rtol=0, atol=1e-14)
    assert solver.counts == {"ldl": 0, "splu": 1, "analyses": 1, "fallbacks": 1}
    assert "1 not positive definite, solved by SuperLU" in solver.report()
    assert solver.solve(sp.csc_matrix((0, 0)), np.zeros(0), version=2).shape == (0,)


def test_auto_is_cholmod_when_installed_else_ldl(monkeypatch):
    assert NewtonSolver("auto").method == ("cholmod" if solvers.CHOLMOD_AVAILABLE else "ldl")
    monkeypatch.setattr(solvers, "CHOLMOD_AVAILABLE", False)
    auto = NewtonSolver("auto")
    assert auto.method == "ldl" and auto.lower
    assert "CHOLMOD not installed" in auto.report()
    assert NewtonSolver("lu").lower is False
    assert NewtonSolver(cholesky=False).method == "lu"  # the former flag
    with pytest.raises(ValueError, match="linear solver"):
        NewtonSolver("cholmod")


def test_ldl_gives_superlus_newton_step_and_run():
    """Newton matrices of the rings in contact (an MPM ring, an FEM ring, the barrier between;
    two matrices of one pattern): the step from LDL^T (lower triangle, the analysis reused)
    against SuperLU's (full matrix); then 12 steps with linear_solver ldl: SuperLU's Newton
    iterations, positions within the Newton tolerance x dt."""
    sim = run("lu")
    it = sim.integrator
    assert it.barrier_term.in_contact
    y = np.concatenate([it.fem.x, it.grid.X])
    index = np.arange(y.size)
    ldl, lu = NewtonSolver("ldl"), NewtonSolver("lu")
    lower_assembler, full = Assembler(2, lower=True), Assembler(2)
    for shift in (0.0, 1e-6):
        yk = y + shift * np.sin(np.arange(y.size)).reshape(y.shape)
        it._sweep(yk)
        it.yn = y  # the energy of the displacement yk - y from y, inertia about y
        E, g, (hessians, diag) = it._energy(yk - y, np.zeros_like(y), True)
        p_ldl = ldl.solve(lower_assembler.matrix(hessians, diag, it.c, index), -g, lower_assembler.version)
        p_lu = lu.solve(full.matrix(hessians, diag, it.c, index), -g, full.version)
        assert np.abs(p_ldl - p_lu).max() <= 1e-10 * np.abs(p_lu).max()
    assert ldl.counts == {"ldl": 2, "splu": 0, "analyses": 1, "fallbacks": 0}

    with_ldl = run("ldl")
    assert with_ldl.integrator.report()[1].startswith("linear solver: mpmsim LDL^T")
    assert "mpmsim LDL^T" in with_ldl.integrator.solver.name
    assert [s[0] for s in with_ldl.integrator.stats] == [s[0] for s in it.stats]
    dt, tol = RINGS["time"]["dt"], RINGS["implicit"]["newton_tolerance"]
    for name in ("particles", "fem"):
        assert np.abs(getattr(with_ldl.state, name).x - getattr(sim.state, name).x).max() < tol * dt


SUBPROCESS = """
import sys, numpy as np, scipy.sparse as sp
from mpmsim.integrators.ldl import LDL
z = np.load(sys.argv[1])
A = sp.csc_matrix((z["data"], z["indices"], z["indptr"]), shape=tuple(z["shape"]))
f = LDL(); f.analyse(A); assert f.factor(A)
np.savez(sys.argv[2], x=f.solve(z["b"]), Lx=f.Lx, D=f.D)
"""


def test_the_same_bits_between_calls_thread_counts_and_cpu_targets(tmp_path):
    """The factors and the solution, to the bit: between two factorisations in this process
    (one LDL refactorising, another analysing afresh), in a process with NUMBA_NUM_THREADS=1,
    and in one whose kernels are compiled for baseline x86-64 (NUMBA_CPU_NAME=generic: SSE2,
    no AVX, no FMA). The host's machine code of the numeric kernels has no fused multiply-add
    (that would round differently from a CPU without one)."""
    A = lower(grid_matrix(15, 13, seed=7, shuffle=True))
    b = np.random.default_rng(5).standard_normal(A.shape[0])
    first = LDL()
    first.analyse(A)
    first.factor(A)
    bits = (first.solve(b).tobytes(), first.Lx.tobytes(), first.D.tobytes())
    first.factor(A)
    assert (first.solve(b).tobytes(), first.Lx.tobytes(), first.D.tobytes()) == bits
    second, x = factor_and_solve(grid_matrix(15, 13, seed=7, shuffle=True), b)
    assert (x.tobytes(), second.Lx.tobytes(), second.D.tobytes()) == bits

    np.savez(tmp_path / "in.npz", data=A.data, indices=A.indices, indptr=A.indptr, shape=A.shape, b=b)
    for name, env in (("one_thread", {"NUMBA_NUM_THREADS": "1"}),
                      ("generic", {"NUMBA_CPU_NAME": "generic", "NUMBA_CACHE_DIR": str(tmp_path / "cache")})):
        out = tmp_path / f"{name}.npz"
        done = subprocess.run([sys.executable, "-c", SUBPROCESS, str(tmp_path / "in.npz"), str(out)],
                              env={**os.environ, **env}, cwd=ROOT, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        z = np.load(out)
        assert (z["x"].tobytes(), z["Lx"].tobytes(), z["D"].tobytes()) == bits, name

    from numba import njit

    for kernel in (ldl_module.numeric, ldl_module.ldl_solve):
        fresh = njit(error_model="numpy")(kernel.py_func)  # cached code cannot be inspected
        sig = kernel.signatures[0]
        fresh.compile(sig)
        asm = fresh.inspect_asm(sig)
        assert "mulsd" in asm  # the multiplications are there, unfused
        assert not re.findall(r"\bvfn?m(?:add|sub)\w*", asm), kernel.__name__
