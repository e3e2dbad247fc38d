"""The sparse solve of a Newton step: H p = -g with H symmetric positive definite (the mass
plus c times PSD-projected Hessians, on the free unknowns).

CHOLMOD (Chen, Davis, Hager, Rajamanickam 2008, doi:10.1145/1391989.1391995) through
scikit-sparse, when installed (the extra `cholmod`): the symbolic analysis (fill-reducing
ordering, elimination tree) is done once per matrix pattern and reused while the pattern holds
(assembly.Assembler.version); each iteration refactorises numerically in place. Below
SUPERNODAL_MIN unknowns the factorisation is simplicial LDL^T: on the 2D decks it factorises
in 1.2-1.3 ms against 1.7-7.8 ms for the supernodal one (1342 and 3390 unknowns), and it
calls no BLAS, so its results are the same on every machine. From SUPERNODAL_MIN up it is
supernodal (dense BLAS blocks): the two take the same time at 3870 unknowns (the rings at
h = 20 mm), supernodal 0.80x at 6742, 0.56x at 11,592 and 0.49x (64 against 130 ms) at the
paper's size, 15,164 unknowns (`python bench/implicit.py --supernodal`). Its BLAS stays on
one thread, as mpmsim keeps BLAS: on the 2-core VM a second BLAS thread gained nothing, and
beside numba's two OpenMP threads (which spin-wait between parallel regions) it made 2-thread
runs of the paper-size rings up to 1.7x slower than 1-thread ones. A matrix
that is not positive definite (it cannot be for an exact PSD sum, but round-off may make it
so: a D entry <= 0 of the simplicial LDL^T, an error of the supernodal LL^T) is solved by
SuperLU instead.

mpmsim's own simplicial LDL^T (ldl.py; Davis 2005, doi:10.1145/1114268.1114277) with a
reverse Cuthill-McKee ordering: no BLAS, every sum in an order fixed by the pattern, so the same
bits on every x86-64 CPU; the analysis is reused like CHOLMOD's, a matrix that is not positive
definite (a D entry <= 0) is solved by SuperLU. RCM leaves more fill than CHOLMOD's AMD, so on
large problems it is slower. `auto` takes CHOLMOD when installed, else this.

SuperLU (scipy's splu, COLAMD ordering; Li 2005, doi:10.1145/1089014.1089017) for `lu`: it
needs the full matrix and analyses every time; it calls OpenBLAS, whose kernels are chosen per
CPU, so its last bits differ between machines.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from .ldl import LDL

try:  # the extra `cholmod`: scikit-sparse on SuiteSparse's CHOLMOD
    from sksparse.cholmod import CholmodError, analyze
except ImportError:  # pragma: no cover - depends on the installation
    analyze = None

CHOLMOD_AVAILABLE = analyze is not None
SUPERNODAL_MIN = 5000  # unknowns from which CHOLMOD factorises supernodally (bench/implicit.py --supernodal)


def full_from_lower(L: sp.csc_matrix) -> sp.csc_matrix:
    """The symmetric matrix whose lower triangle is L."""
    return (L + sp.tril(L, -1).T).tocsc()


METHODS = ("cholmod", "ldl", "lu")  # implicit.linear_solver, auto resolved by NewtonSolver


class NewtonSolver:
    """Solves with CHOLMOD (`cholmod`, the lower triangle), mpmsim's LDL^T (`ldl`, the lower
    triangle) or SuperLU (`lu`, the full matrix); `auto`: CHOLMOD when installed, else ldl.
    Counts the solves of each, the analyses and the fallbacks to SuperLU. `cholesky` is the
    former flag: True for CHOLMOD where installed, else SuperLU; False for SuperLU."""

    def __init__(self, method: str = "auto", *, cholesky: bool | None = None):
        if cholesky is not None:
            method = "cholmod" if cholesky and CHOLMOD_AVAILABLE else "lu"
        self.auto = method == "auto"
        if self.auto:
            method = "cholmod" if CHOLMOD_AVAILABLE else "ldl"
        if method not in METHODS:
            raise ValueError(f"linear solver {method!r}: one of auto, {', '.join(METHODS)}")
        if method == "cholmod" and not CHOLMOD_AVAILABLE:
            raise ValueError("linear solver cholmod: scikit-sparse (CHOLMOD) is not installed")
        self.method = method
        self.factor = None
        self.version = None
        if method == "ldl":
            self.counts = {"ldl": 0, "splu": 0, "analyses": 0, "fallbacks": 0}
        else:
            self.counts = {"cholmod": 0, "supernodal": 0, "splu": 0, "analyses": 0, "fallbacks": 0}

    @property
    def cholesky(self) -> bool:
        """Whether CHOLMOD solves."""
        return self.method == "cholmod"

    @property
    def lower(self) -> bool:
        """Whether the solver reads only the lower triangle."""
        return self.method != "lu"

    @property
    def name(self) -> str:
        if self.method == "cholmod":
            return f"CHOLMOD (scikit-sparse): simplicial LDL^T, supernodal from {SUPERNODAL_MIN} unknowns"
        if self.method == "ldl":
            return "mpmsim LDL^T (simplicial, RCM ordering, no BLAS: the same bits on every CPU)"
        return "SuperLU (scipy splu)"

    def solve(self, A: sp.csc_matrix, b: np.ndarray, version: int, definite: bool = False) -> np.ndarray | None:
        """x with A x = b; A's pattern is the same while `version` is. With `definite`, None
        where the Cholesky solvers find A not positive definite (instead of SuperLU's answer);
        SuperLU (`lu`) cannot tell and solves."""
        if not len(b):  # every unknown held
            return np.zeros(0)
        if self.method == "ldl":
            if self.factor is None or version != self.version:
                self.factor = LDL()
                self.factor.analyse(A)
                self.version = version
                self.counts["analyses"] += 1
            if self.factor.factor(A):
                self.counts["ldl"] += 1
                return self.factor.solve(b)
            if definite:
                return None
            self.counts["fallbacks"] += 1
            A = full_from_lower(A)
        elif self.method == "cholmod":
            supernodal = len(b) >= SUPERNODAL_MIN
            try:
                if self.factor is None or version != self.version:
                    self.factor = analyze(A, mode="supernodal" if supernodal else "simplicial")
                    self.version = version
                    self.counts["analyses"] += 1
                if supernodal:  # LL^T: a matrix not positive definite raises
                    self.factor.cholesky_inplace(A)
                    definite = True
                else:  # LDL^T goes through a D entry <= 0
                    self.factor.cholesky_inplace(A)
                    definite = self.factor.D().min() > 0.0
                if definite:
                    self.counts["cholmod"] += 1
                    self.counts["supernodal"] += supernodal
                    return self.factor(b)
            except CholmodError:
                self.factor = None
            if definite:
                return None
            self.counts["fallbacks"] += 1
            A = full_from_lower(A)
        self.counts["splu"] += 1
        return splu(A).solve(b)

    def report(self) -> str:
        c = self.counts
        fallbacks = f"; {c['fallbacks']} not positive definite, solved by SuperLU" if c["fallbacks"] else ""
        if self.method == "cholmod":
            return (f"linear solver: CHOLMOD (scikit-sparse), {c['cholmod']} factorisations "
                    f"({c['supernodal']} supernodal, the rest simplicial LDL^T) on {c['analyses']} analyses"
                    + fallbacks)
        if self.method == "ldl":
            why = " (auto: CHOLMOD not installed, pip install -e '.[cholmod]')" if self.auto else ""
            return (f"linear solver: mpmsim LDL^T (simplicial, RCM ordering, no BLAS), {c['ldl']} factorisations "
                    f"on {c['analyses']} analyses{fallbacks}{why}")
        return f"linear solver: {self.name}, {c['splu']} factorisations"
