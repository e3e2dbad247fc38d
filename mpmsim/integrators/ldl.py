"""mpmsim's own sparse LDL^T of a symmetric positive definite matrix: the same bits on every CPU.

SuperLU (scipy's splu) calls OpenBLAS, whose kernels are chosen per CPU (AVX-512, AVX2, ...),
so its rounding, and with it a run's last bits, differ between machines; CHOLMOD's supernodal
factorisation does too. This one calls no BLAS or LAPACK: compiled serial kernels over plain
arrays, every sum taken in an order fixed by the matrix's pattern alone. Numba compiles without
fast-math, so LLVM neither reassociates a sum nor contracts a*b+c into a fused multiply-add
(tests/implicit/test_ldl.py looks for FMA instructions in the kernels' machine code): each
operation is one IEEE-754 rounding, the same on any x86-64 CPU.

The algorithm is the simplicial up-looking LDL^T of T. A. Davis, "Algorithm 849: A concise
sparse Cholesky factorization package", ACM TOMS 31(4), 587-591, 2005
(doi:10.1145/1114268.1114277); the code is written here. With C = P A P^T:
  - symbolic (`LDL.analyse`, once per pattern): the fill-reducing permutation P, the upper
    triangle of C by columns (= row k of C's lower triangle, for k = 0..n-1) with a map from
    each of its entries to A's values, the elimination tree and the column counts of L;
  - numeric (`LDL.factor`, every matrix): row k of L is the solution of a sparse triangular
    system L[:k,:k] D y = C[:k,k], whose pattern is the etree reach of C[:k,k]'s rows; then
    D[k] = C[k,k] - sum_j L[k,j] y[j]. A D[k] that is not > 0 means C is not positive definite;
    the factorisation stops there and `factor` returns False;
  - solve (`LDL.solve`): L z = P b, D w = z, L^T v = w, x = P^T v.

The permutation is reverse Cuthill-McKee (`rcm`), computed here rather than by scipy's
`reverse_cuthill_mckee`: scipy picks each component's start node through np.argsort, an
unstable sort whose order among nodes of equal degree depends on the CPU (numpy dispatches it
to AVX-512, AVX2 or baseline code: on one machine, the permutation of three uncoupled 2D grids
changed with numpy's AVX2 switched off), and a different permutation gives different bits.
Here every tie goes to the lowest index, and each component starts at a pseudo-peripheral node
(George and Liu 1979), found from its lowest-degree node.

RCM makes the profile small, not the fill: on 2D meshes L holds O(n^1.5) entries against
O(n log n) for a minimum-degree or nested-dissection ordering, so on large problems this is
slower than CHOLMOD (AMD ordering) and SuperLU (COLAMD).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit


class NotPositiveDefiniteError(ArithmeticError):
    """A pivot D[k] <= 0 (or NaN) in the LDL^T factorisation."""


@njit(cache=True)
def adjacency(n, Ap, Ai):
    """The off-diagonal graph of the symmetric matrix whose lower triangle is the CSC pattern
    (Ap, Ai): (adjp, adji), each node's neighbours (ascending when Ai is sorted by column).
    An entry above the diagonal raises ValueError."""
    degree = np.zeros(n, np.int64)
    for j in range(n):
        for p in range(Ap[j], Ap[j + 1]):
            i = Ai[p]
            if i < j or i >= n:
                raise ValueError("LDL reads the lower triangle only: an entry above the diagonal")
            if i != j:
                degree[i] += 1
                degree[j] += 1
    adjp = np.zeros(n + 1, np.int64)
    for j in range(n):
        adjp[j + 1] = adjp[j] + degree[j]
    adji = np.empty(adjp[n], np.int64)
    nxt = adjp[:n].copy()
    for j in range(n):  # node i's neighbours j < i, j ascending
        for p in range(Ap[j], Ap[j + 1]):
            i = Ai[p]
            if i != j:
                adji[nxt[i]] = j
                nxt[i] += 1
    for j in range(n):  # then its neighbours i > j, in column order
        for p in range(Ap[j], Ap[j + 1]):
            i = Ai[p]
            if i != j:
                adji[nxt[j]] = i
                nxt[j] += 1
    return adjp, adji


@njit(cache=True)
def _levels(start, adjp, adji, mark, stamp, queue):
    """Breadth-first search of start's component over the nodes whose mark is not stamp (they
    get it): queue[:count] in visiting order. Returns (count, depth, first of the last level)."""
    queue[0] = start
    mark[start] = stamp
    tail = 1
    level = 0
    depth = 0
    while True:
        end = tail
        for q in range(level, end):
            v = queue[q]
            for p in range(adjp[v], adjp[v + 1]):
                w = adji[p]
                if mark[w] != stamp:
                    mark[w] = stamp
                    queue[tail] = w
                    tail += 1
        if tail == end:
            return tail, depth, level
        level = end
        depth += 1


@njit(cache=True)
def _lowest_degree(nodes, degree):
    """The node of least degree in nodes, the lowest index among equals."""
    best = nodes[0]
    for v in nodes[1:]:
        if degree[v] < degree[best] or (degree[v] == degree[best] and v < best):
            best = v
    return best


@njit(cache=True)
def rcm(n, adjp, adji):
    """Reverse Cuthill-McKee permutation of the graph (adjp, adji): perm[k] is the node put
    k-th. Components in the order of their lowest node; each is numbered breadth-first from a
    pseudo-peripheral node, each node's unnumbered neighbours by increasing degree (lowest
    index first among equals), and the whole order is reversed. Ties never depend on a sort's
    implementation."""
    degree = adjp[1:] - adjp[:n]
    mark = np.zeros(n, np.int64)  # stamps of the searches
    stamp = 0
    queue = np.empty(n, np.int64)
    order = np.empty(n, np.int64)
    numbered = np.zeros(n, np.bool_)
    pos = 0
    for root in range(n):
        if numbered[root]:
            continue
        stamp += 1
        count, depth, last = _levels(root, adjp, adji, mark, stamp, queue)
        start = _lowest_degree(queue[:count], degree)
        stamp += 1
        count, depth, last = _levels(start, adjp, adji, mark, stamp, queue)
        while True:  # George-Liu: move to the far end while the eccentricity grows
            candidate = _lowest_degree(queue[last:count], degree)
            stamp += 1
            count, d, last = _levels(candidate, adjp, adji, mark, stamp, queue)
            if d <= depth:
                break
            start, depth = candidate, d
        order[pos] = start
        numbered[start] = True
        head = pos
        pos += 1
        while head < pos:
            v = order[head]
            head += 1
            first = pos
            for p in range(adjp[v], adjp[v + 1]):
                w = adji[p]
                if not numbered[w]:
                    numbered[w] = True
                    order[pos] = w
                    pos += 1
            for q in range(first + 1, pos):  # stable insertion sort by degree
                w = order[q]
                r = q - 1
                while r >= first and degree[order[r]] > degree[w]:
                    order[r + 1] = order[r]
                    r -= 1
                order[r + 1] = w
    return order[::-1].copy()


@njit(cache=True)
def permuted_upper(n, Ap, Ai, pinv):
    """C = P A P^T's upper triangle by columns from A's lower triangle (Ap, Ai), pinv[i] the new
    index of unknown i: (Cp, Ci, src), rows ascending within each column, src[q] the position
    in A's values of C's entry q. Two stable counting sorts (by row, then by column)."""
    nnz = Ap[n]
    rows = np.empty(nnz, np.int64)
    cols = np.empty(nnz, np.int64)
    for j in range(n):
        for p in range(Ap[j], Ap[j + 1]):
            a, b = pinv[Ai[p]], pinv[j]
            rows[p] = min(a, b)
            cols[p] = max(a, b)
    rstart = np.zeros(n + 1, np.int64)
    Cp = np.zeros(n + 1, np.int64)
    for p in range(nnz):
        rstart[rows[p] + 1] += 1
        Cp[cols[p] + 1] += 1
    for k in range(n):
        rstart[k + 1] += rstart[k]
        Cp[k + 1] += Cp[k]
    by_row = np.empty(nnz, np.int64)
    for p in range(nnz):
        by_row[rstart[rows[p]]] = p
        rstart[rows[p]] += 1
    nxt = Cp[:n].copy()
    Ci = np.empty(nnz, np.int64)
    src = np.empty(nnz, np.int64)
    for q in range(nnz):
        p = by_row[q]
        c = cols[p]
        Ci[nxt[c]] = rows[p]
        src[nxt[c]] = p
        nxt[c] += 1
    return Cp, Ci, src


@njit(cache=True)
def symbolic(n, Cp, Ci):
    """Elimination tree and column pointers of L from C's upper triangle by columns (Davis 2005,
    ldl_symbolic): row k of L is the set of nodes met walking up the tree from each i < k of
    column k until a node already flagged for k; each such node i gains an entry L[k, i], and
    a node without a parent yet gets k. Returns (parent, Lp); parent -1 at a root."""
    parent = np.full(n, -1, np.int64)
    flag = np.empty(n, np.int64)
    counts = np.zeros(n, np.int64)
    for k in range(n):
        flag[k] = k
        for p in range(Cp[k], Cp[k + 1]):
            i = Ci[p]
            while i < k and flag[i] != k:
                if parent[i] == -1:
                    parent[i] = k
                counts[i] += 1
                flag[i] = k
                i = parent[i]
    Lp = np.zeros(n + 1, np.int64)
    for k in range(n):
        Lp[k + 1] = Lp[k] + counts[k]
    return parent, Lp


@njit(cache=True, error_model="numpy")
def numeric(n, Cp, Ci, src, Ax, parent, Lp, Li, Lx, D):
    """The numeric LDL^T (Davis 2005, ldl_numeric), up-looking: row k of L by a sparse
    triangular solve over the etree reach of C[:, k] (topological order), then D[k]. C's
    values are Ax[src]. Fills Li, Lx (columns by Lp, rows ascending) and D; returns n, or the
    first k whose D[k] is not > 0 (not positive definite; the rest of L, D is left unset)."""
    y = np.zeros(n)
    flag = np.empty(n, np.int64)
    stack = np.empty(n, np.int64)
    filled = np.zeros(n, np.int64)  # entries so far in each column of L
    for k in range(n):
        flag[k] = k
        top = n
        for p in range(Cp[k], Cp[k + 1]):
            i = Ci[p]
            y[i] += Ax[src[p]]
            length = 0
            while flag[i] != k:  # the path from i up to the reach found so far
                stack[length] = i
                length += 1
                flag[i] = k
                i = parent[i]
            while length > 0:  # pushed so that stack[top:] stays in topological order
                top -= 1
                length -= 1
                stack[top] = stack[length]
        d = y[k]
        y[k] = 0.0
        for t in range(top, n):
            i = stack[t]
            yi = y[i]
            y[i] = 0.0
            end = Lp[i] + filled[i]
            for p in range(Lp[i], end):
                y[Li[p]] -= Lx[p] * yi
            lki = yi / D[i]
            d -= lki * yi
            Li[end] = k
            Lx[end] = lki
            filled[i] += 1
        D[k] = d
        if not d > 0.0:
            return k
    return n


@njit(cache=True, error_model="numpy")
def ldl_solve(n, perm, Lp, Li, Lx, D, b):
    """x = A^-1 b from C = P A P^T = L D L^T: L z = P b, D w = z, L^T v = w, x = P^T v."""
    x = np.empty(n)
    for k in range(n):
        x[k] = b[perm[k]]
    for j in range(n):
        xj = x[j]
        for p in range(Lp[j], Lp[j + 1]):
            x[Li[p]] -= Lx[p] * xj
    for j in range(n):
        x[j] /= D[j]
    for j in range(n - 1, -1, -1):
        s = x[j]
        for p in range(Lp[j], Lp[j + 1]):
            s -= Lx[p] * x[Li[p]]
        x[j] = s
    out = np.empty(n)
    for k in range(n):
        out[perm[k]] = x[k]
    return out


class LDL:
    """Sparse LDL^T of symmetric positive definite matrices given by their lower triangle (CSC).
    `analyse(A)` once per pattern (the permutation, the permuted upper triangle, the
    elimination tree, L's column pointers), `factor(A)` for each matrix of that pattern (False
    when not positive definite), `solve(b)`. Counts its analyses and factorisations."""

    # not in checkpoints (L can hold millions of entries): a restart analyses the pattern again,
    # and the analysis, a function of the pattern alone, gives the same bits
    checkpoint_skip = True

    def __init__(self):
        self.n = 0
        self.pattern = None  # A's (indptr, indices) as analysed
        self.perm = None
        self.analyses = 0
        self.factorisations = 0
        self.definite = False  # the last factorisation's outcome
        self.pivot = -1  # the unknown (A's numbering) whose D entry was not > 0; -1 if none

    @staticmethod
    def _lower(A) -> sp.csc_matrix:
        if not (sp.issparse(A) and A.format == "csc"):
            raise TypeError("LDL needs a scipy CSC matrix (its lower triangle)")
        if A.shape[0] != A.shape[1]:
            raise ValueError(f"LDL needs a square matrix, not {A.shape}")
        return A

    def analyse(self, A, perm: np.ndarray | None = None) -> None:
        """The symbolic analysis of A's pattern (lower triangle, CSC). perm: the ordering
        (perm[k] the unknown put k-th); default reverse Cuthill-McKee."""
        A = self._lower(A)
        n = A.shape[0]
        Ap = np.asarray(A.indptr, np.int64)
        Ai = np.asarray(A.indices, np.int64)
        adjp, adji = adjacency(n, Ap, Ai)  # checks that A is lower triangular
        if perm is None:
            perm = rcm(n, adjp, adji)
        else:
            perm = np.asarray(perm, np.int64)
            if not np.array_equal(np.sort(perm), np.arange(n)):
                raise ValueError("LDL.analyse: perm is not a permutation of the unknowns")
        pinv = np.empty(n, np.int64)
        pinv[perm] = np.arange(n, dtype=np.int64)
        self.Cp, self.Ci, self.src = permuted_upper(n, Ap, Ai, pinv)
        self.parent, self.Lp = symbolic(n, self.Cp, self.Ci)
        self.n, self.perm, self.pinv = n, perm, pinv
        self.pattern = (A.indptr.copy(), A.indices.copy())
        self.Li = np.empty(self.Lp[n], np.int64)
        self.Lx = np.empty(self.Lp[n])
        self.D = np.empty(n)
        self.definite = False
        self.analyses += 1

    @property
    def nnz(self) -> int:
        """Entries of L below its unit diagonal (the fill included)."""
        return int(self.Lp[self.n]) if self.pattern is not None else 0

    def factor(self, A) -> bool:
        """The numeric factorisation of A (lower triangle, the analysed pattern): True, or False
        when A is not positive definite (a D entry <= 0; `pivot` names the unknown)."""
        A = self._lower(A)
        if self.pattern is None:
            raise RuntimeError("LDL.factor before LDL.analyse")
        if not (A.shape[0] == self.n and np.array_equal(A.indptr, self.pattern[0])
                and np.array_equal(A.indices, self.pattern[1])):
            raise ValueError("LDL.factor: the matrix's pattern is not the analysed one (analyse it again)")
        data = np.ascontiguousarray(A.data, dtype=np.float64)
        k = numeric(self.n, self.Cp, self.Ci, self.src, data, self.parent, self.Lp, self.Li, self.Lx, self.D)
        self.factorisations += 1
        self.definite = k == self.n
        self.pivot = -1 if self.definite else int(self.perm[k])
        return self.definite

    def solve(self, b: np.ndarray) -> np.ndarray:
        """x with A x = b for the last factorised A."""
        if not self.definite:
            if self.pivot >= 0:
                raise NotPositiveDefiniteError(f"the matrix is not positive definite (D <= 0 at unknown {self.pivot})")
            raise RuntimeError("LDL.solve before a factorisation")
        b = np.ascontiguousarray(b, dtype=np.float64)
        if b.shape != (self.n,):
            raise ValueError(f"LDL.solve: b of shape {b.shape}, the matrix has {self.n} unknowns")
        return ldl_solve(self.n, self.perm, self.Lp, self.Li, self.Lx, self.D, b)
