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

SuperLU (scipy's splu, COLAMD ordering; Li 2005, doi:10.1145/1089014.1089017) otherwise: it
needs the full matrix and analyses every time.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

try:  # the extra `cholmod`: scikit-sparse on SuiteSparse's CHOLMOD
    from sksparse.cholmod import CholmodError, analyze
except ImportError:  # pragma: no cover - depends on the installation
    analyze = None

CHOLMOD_AVAILABLE = analyze is not None
SUPERNODAL_MIN = 5000  # unknowns from which CHOLMOD factorises supernodally (bench/implicit.py --supernodal)


def full_from_lower(L: sp.csc_matrix) -> sp.csc_matrix:
    """The symmetric matrix whose lower triangle is L."""
    return (L + sp.tril(L, -1).T).tocsc()


class NewtonSolver:
    """Solves with CHOLMOD (the lower triangle) when `cholesky`, else SuperLU (the full matrix).
    Counts the solves of each, the analyses and the fallbacks."""

    def __init__(self, cholesky: bool):
        self.cholesky = cholesky and CHOLMOD_AVAILABLE
        self.factor = None
        self.version = None
        self.counts = {"cholmod": 0, "supernodal": 0, "splu": 0, "analyses": 0, "fallbacks": 0}

    @property
    def lower(self) -> bool:
        """Whether the solver reads only the lower triangle."""
        return self.cholesky

    @property
    def name(self) -> str:
        return ("CHOLMOD (scikit-sparse): simplicial LDL^T, supernodal from "
                f"{SUPERNODAL_MIN} unknowns" if self.cholesky else "SuperLU (scipy splu)")

    def solve(self, A: sp.csc_matrix, b: np.ndarray, version: int) -> np.ndarray:
        """x with A x = b; A's pattern is the same while `version` is."""
        if not len(b):  # every unknown held
            return np.zeros(0)
        if self.cholesky:
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
            self.counts["fallbacks"] += 1
            A = full_from_lower(A)
        self.counts["splu"] += 1
        return splu(A).solve(b)

    def report(self) -> str:
        c = self.counts
        if self.cholesky:
            line = (f"linear solver: CHOLMOD (scikit-sparse), {c['cholmod']} factorisations "
                    f"({c['supernodal']} supernodal, the rest simplicial LDL^T) on {c['analyses']} analyses")
            if c["fallbacks"]:
                line += f"; {c['fallbacks']} not positive definite, solved by SuperLU"
            return line
        why = "" if CHOLMOD_AVAILABLE else " (CHOLMOD not installed: pip install -e '.[cholmod]')"
        return f"linear solver: {self.name}, {c['splu']} factorisations{why}"
