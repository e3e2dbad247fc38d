"""Newton's matrix on a kept pattern: the energy terms' local Hessians (mpmsim/energy.py: Blocks,
Triplets) scattered by compiled kernels straight into the CSC values over the free unknowns.

The pattern is built at node level (which unknowns couple: every node pair of an element, of a
particle's grid stencil, of a contact pair's stencil) by `csc_slots` and expanded to the free
degrees of freedom (`dof_pattern`; every column of a node has the same rows). Each bundle of
local Hessians gets a slot map, one CSC slot per local entry (-1: an eliminated component, or
the upper triangle when only the lower one is kept), computed when the pattern is built; each
Newton iteration then only scatters values (`scatter`), in the bundles' order and each bundle's
(group, row, column) order, so every sum is the one the triplets gave, to the bit.

The pattern is exact: it is rebuilt when a bundle's node lists change (contact pairs appearing
or leaving, the particles' stencils at a new step) and kept, with its slot maps, otherwise. A
rebuild costs a node-level bucketing of the node pairs of each bundle's distinct node lists
(the particles of one cell share a stencil) and a slot pass over them (0.8 ms on the rings
deck), and a new symbolic analysis of the Cholesky factorisation (solvers.py) only when the
rebuilt pattern differs from the last. A superset over the step (all contact pairs a
step might meet) would save the rebuilds but adds fill to every factorisation and leaves the
matrix different from the triplets' (explicit zeros change SuperLU's column ordering).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from numba import njit

from ..energy import Blocks, Triplets


@njit(cache=True)
def csc_slots(rows, cols, index, n):
    """The pattern of the pairs (rows, cols) restricted to the unknowns k with index[k] >= 0
    and renumbered by index, n of them: canonical CSC arrays (indptr, indices) (rows sorted
    within each column, no duplicates) and each pair's slot in them (-1: eliminated). Two
    stable counting sorts, by row then by column, leave each column's entries in row order,
    duplicates next to each other: no comparison sort."""
    m = len(rows)
    rstart = np.zeros(n + 1, np.int64)
    cstart = np.zeros(n + 1, np.int64)
    for k in range(m):
        i, j = index[rows[k]], index[cols[k]]
        if i >= 0 and j >= 0:
            rstart[i + 1] += 1
            cstart[j + 1] += 1
    for j in range(n):
        rstart[j + 1] += rstart[j]
        cstart[j + 1] += cstart[j]
    kept = rstart[n]
    fill = rstart[:n].copy()
    by_row = np.empty(kept, np.int64)
    for k in range(m):
        i, j = index[rows[k]], index[cols[k]]
        if i >= 0 and j >= 0:
            by_row[fill[i]] = k
            fill[i] += 1
    fill = cstart[:n].copy()
    by_col = np.empty(kept, np.int64)
    for q in range(kept):
        k = by_row[q]
        j = index[cols[k]]
        by_col[fill[j]] = k
        fill[j] += 1
    slot = np.full(m, -1, np.int64)
    indptr = np.zeros(n + 1, np.int32)
    indices = np.empty(kept, np.int32)
    nnz = 0
    for j in range(n):
        last = -1
        for q in range(cstart[j], cstart[j + 1]):
            k = by_col[q]
            i = index[rows[k]]
            if i != last:
                indices[nnz] = i
                nnz += 1
                last = i
            slot[k] = nnz - 1
        indptr[j + 1] = nnz
    return indptr, indices[:nnz].copy(), slot


@njit(cache=True)
def csc_values(slot, vals, nnz):
    """The CSC values of triplet values vals on the pattern `slot` (csc_slots): duplicates
    summed in triplet order."""
    data = np.zeros(nnz)
    for k in range(len(slot)):
        if slot[k] >= 0:
            data[slot[k]] += vals[k]
    return data


def free_csc(rows, cols, vals, index, n):
    """The sparse matrix of the triplets (rows, cols, vals) (duplicates summed) restricted to
    the unknowns k with index[k] >= 0 and renumbered by index, n of them, as canonical CSC
    arrays (indptr, indices, data)."""
    indptr, indices, slot = csc_slots(rows, cols, index, n)
    return indptr, indices, csc_values(slot, vals, len(indices))


@njit(cache=True)
def distinct_groups(nodes):
    """The distinct rows of nodes (g, k): (reps, inverse), reps the first group of each
    distinct node list (in the order of a hash sort), inverse[q] the position in reps of
    group q's list. MPM particles in one cell share a grid stencil: the rings deck's 948
    particles have 267 distinct ones, and the pattern and slot maps are built for those."""
    g, k = nodes.shape
    key = np.empty(g, np.int64)
    for q in range(g):
        h = 1469598103934665603
        for a in range(k):
            h = (h ^ nodes[q, a]) * 1099511628211  # FNV-1a over the node numbers (wraps)
        key[q] = h
    order = np.argsort(key, kind="mergesort")
    reps = np.empty(g, np.int64)
    inverse = np.empty(g, np.int64)
    m = 0
    for t in range(g):
        q = order[t]
        found = -1
        u = m - 1
        while u >= 0 and key[reps[u]] == key[q]:  # equal hashes are next to each other
            same = True
            for a in range(k):
                if nodes[reps[u], a] != nodes[q, a]:
                    same = False
                    break
            if same:
                found = u
                break
            u -= 1
        if found < 0:
            reps[m] = q
            found = m
            m += 1
        inverse[q] = found
    return reps[:m].copy(), inverse


@njit(cache=True)
def block_pairs(nodes):
    """The node pairs (rows, cols) of groups over node lists nodes (g, k), in (group, row node,
    column node) order."""
    g, k = nodes.shape
    rows = np.empty(g * k * k, np.int64)
    cols = np.empty(g * k * k, np.int64)
    t = 0
    for q in range(g):
        for a in range(k):
            for b in range(k):
                rows[t] = nodes[q, a]
                cols[t] = nodes[q, b]
                t += 1
    return rows, cols


@njit(cache=True)
def dof_pattern(nptr, nidx, index, d, lower):
    """The free unknowns' CSC pattern of a node-level pattern (nptr, nidx) (every node's
    column lists its neighbours, sorted), with index (n_nodes d,) each DOF's free number (-1:
    eliminated), only rows >= column if `lower`. Returns (indptr, indices, offset, before):
    offset[e] the number of free DOFs of the nodes ahead of entry e's row node in its column;
    before[i, c] the free components of node i ahead of c (-1: c eliminated)."""
    n_nodes = len(nptr) - 1
    before = np.full((n_nodes, d), -1, np.int64)
    nfree = np.zeros(n_nodes, np.int64)
    for i in range(n_nodes):
        for c in range(d):
            if index[i * d + c] >= 0:
                before[i, c] = nfree[i]
                nfree[i] += 1
    offset = np.zeros(len(nidx), np.int64)
    m = 0
    nnz = 0
    for j in range(n_nodes):
        s = 0
        for e in range(nptr[j], nptr[j + 1]):
            offset[e] = s
            s += nfree[nidx[e]]
        m += nfree[j]
        nnz += nfree[j] * s
    indptr = np.zeros(m + 1, np.int32)
    indices = np.empty(nnz, np.int32)
    col = 0
    t = 0
    for j in range(n_nodes):
        for c in range(d):
            J = index[j * d + c]
            if J < 0:
                continue
            for e in range(nptr[j], nptr[j + 1]):
                i = nidx[e]
                for a in range(d):
                    I = index[i * d + a]
                    if I >= 0 and (I >= J or not lower):
                        indices[t] = I
                        t += 1
            col += 1
            indptr[col] = t
    return indptr, indices[:t].copy(), offset, before


class DofPattern(NamedTuple):
    """What a slot lookup reads: the free unknowns' CSC pattern (dof_pattern) over its node
    pattern."""

    index: np.ndarray  # (n_nodes d,) each DOF's free number (-1: eliminated)
    indptr: np.ndarray  # (m + 1,) CSC column starts
    offset: np.ndarray  # (node entries,) free DOFs ahead of the entry's row node in its column
    before: np.ndarray  # (n_nodes, d) free components of node i ahead of c (-1: c eliminated)
    diag_entry: np.ndarray  # (n_nodes,) each node's own entry (its diagonal block)


@njit(cache=True, inline="always")
def _slot(i, c, j, e, entry, diag_entry, d, index, indptr, offset, before, lower):
    """CSC slot of (row DOF i d + c, column DOF j d + e), node pair entry `entry` (-1: not
    kept)."""
    I = index[i * d + c]
    J = index[j * d + e]
    if I < 0 or J < 0 or (lower and I < J):
        return -1
    p = offset[entry] + before[i, c]
    if lower:  # the column's rows start at its diagonal
        p -= offset[diag_entry[j]] + before[j, e]
    return indptr[J] + p


@njit(cache=True)
def block_slots(nodes, entries, pattern, lower):
    """Slot map (g, k d, k d) of groups over node lists nodes (g, k), node pair entries
    `entries` (g k k,) in block_pairs order, on `pattern` (DofPattern)."""
    index, indptr, offset, before, diag_entry = pattern
    d = before.shape[1]
    g, k = nodes.shape
    out = np.empty((g, k * d, k * d), np.int32)  # CSC slots (indptr is int32 too)
    t = 0
    for q in range(g):
        for a in range(k):
            for b in range(k):
                i, j, ent = nodes[q, a], nodes[q, b], entries[t]
                t += 1
                for c in range(d):
                    for e in range(d):
                        out[q, a * d + c, b * d + e] = _slot(i, c, j, e, ent, diag_entry, d, index, indptr, offset,
                                                             before, lower)
    return out


@njit(cache=True)
def triplet_slots(rows, cols, entries, pattern, lower):
    """Slot map (k, 1, 1) of DOF triplets (rows, cols), node pair entries `entries`, on
    `pattern` (DofPattern)."""
    index, indptr, offset, before, diag_entry = pattern
    d = before.shape[1]
    out = np.empty((len(rows), 1, 1), np.int32)
    for t in range(len(rows)):
        out[t, 0, 0] = _slot(rows[t] // d, rows[t] % d, cols[t] // d, cols[t] % d, entries[t], diag_entry, d, index,
                             indptr, offset, before, lower)
    return out


@njit(cache=True)
def scatter(slots, local, weights, block, d, scale, data):
    """data[slots[q, r, s]] += scale * local value of (q, r, s), in (q, r, s) order. Unweighted
    (weights of shape (0, 0)): the value is local[q, r, s]. Weighted: r = a d + c over the
    group's nodes a, whose local block is block[a] and weight weights[q, a]: the value is
    local[q, block[a] d + c, block[b] d + e] * (weights[q, a] weights[q, b]); zero weights are
    skipped (their terms are +-0)."""
    g = slots.shape[0]
    n = slots.shape[1]
    if weights.shape[0] == 0:
        for q in range(g):
            for r in range(n):
                for s in range(n):
                    k = slots[q, r, s]
                    if k >= 0:
                        data[k] += scale * local[q, r, s]
        return
    k_nodes = weights.shape[1]
    for q in range(g):
        for a in range(k_nodes):
            wa = weights[q, a]
            if wa == 0.0:
                continue
            for c in range(d):
                r = a * d + c
                lr = block[a] * d + c
                for b in range(k_nodes):
                    w = wa * weights[q, b]
                    if w == 0.0:
                        continue
                    for e in range(d):
                        k = slots[q, r, b * d + e]
                        if k >= 0:
                            data[k] += scale * (local[q, lr, block[b] * d + e] * w)


@njit(cache=True)
def scatter_diagonal(slots, diag, data):
    """data[slots[k]] += diag[k] (the DOFs' own diagonal entries; -1: eliminated)."""
    for k in range(len(slots)):
        if slots[k] >= 0:
            data[slots[k]] += diag[k]


NO_WEIGHTS = np.zeros((0, 0))
NO_BLOCK = np.zeros(0, np.int64)


def _distinct(h: Blocks | Triplets):
    """(distinct node lists, inverse) of a Blocks bundle (distinct_groups); None for triplets."""
    if isinstance(h, Triplets):
        return None
    nodes = np.asarray(h.nodes, np.int64)
    reps, inverse = distinct_groups(nodes)
    return nodes[reps], inverse


def _pairs_of(h: Blocks | Triplets, distinct, d: int) -> tuple[np.ndarray, np.ndarray]:
    if isinstance(h, Triplets):
        return np.asarray(h.rows, np.int64) // d, np.asarray(h.cols, np.int64) // d
    return block_pairs(distinct[0])


def _key(h: Blocks | Triplets) -> tuple:
    return (h.rows, h.cols) if isinstance(h, Triplets) else (h.nodes,)


def _same(a: tuple, b: tuple) -> bool:
    return len(a) == len(b) and all(x is y or (x.shape == y.shape and np.array_equal(x, y)) for x, y in zip(a, b))


class Assembler:
    """The Newton matrix M_diag + scale sum H over the free unknowns, on a pattern kept while the
    bundles' node lists and the free set stay the same. `lower`: only the lower triangle (what
    CHOLMOD reads). `version` counts the distinct patterns (a solver reuses its analysis while
    it holds)."""

    def __init__(self, d: int, lower: bool = False):
        self.d, self.lower = d, lower
        self.keys: list = []
        self.index = None
        self.pattern = None  # (indptr, indices)
        self.slots: list = []
        self.diag_slots = None
        self.version = 0
        self.rebuilds = 0

    def _build(self, hessians, index) -> None:
        d = self.d
        n_nodes = len(index) // d
        distinct = [_distinct(h) for h in hessians]
        pairs = [_pairs_of(h, u, d) for h, u in zip(hessians, distinct)]
        every = np.arange(n_nodes, dtype=np.int64)
        rows = np.concatenate([p[0] for p in pairs] + [every])
        cols = np.concatenate([p[1] for p in pairs] + [every])
        nptr, nidx, entry = csc_slots(rows, cols, every, n_nodes)
        diag_entry = entry[len(rows) - n_nodes:]
        indptr, indices, offset, before = dof_pattern(nptr, nidx, index, d, self.lower)
        args = (DofPattern(index, indptr, offset, before, diag_entry), self.lower)
        self.slots, start = [], 0
        for h, u, (r, _) in zip(hessians, distinct, pairs):
            ent = entry[start:start + len(r)]
            start += len(r)
            if isinstance(h, Triplets):
                self.slots.append(triplet_slots(np.asarray(h.rows, np.int64), np.asarray(h.cols, np.int64), ent, *args))
            else:  # the distinct lists' slot maps, one per group
                self.slots.append(block_slots(u[0], ent, *args)[u[1]])
        dofs = np.arange(len(index), dtype=np.int64)
        self.diag_slots = triplet_slots(dofs, dofs, np.repeat(diag_entry, d), *args).ravel()
        if self.pattern is None or not (np.array_equal(self.pattern[0], indptr)
                                        and np.array_equal(self.pattern[1], indices)):
            self.version += 1
        self.pattern = (indptr, indices)
        self.rebuilds += 1

    def matrix(self, hessians, diag: np.ndarray, scale: float, index: np.ndarray) -> sp.csc_matrix:
        """diag (the unknowns' own diagonal, unscaled) + scale x the bundles' sum, restricted to
        the unknowns k with index[k] >= 0, renumbered by index."""
        keys = [_key(h) for h in hessians]
        if (self.index is None or len(keys) != len(self.keys) or not np.array_equal(self.index, index)
                or not all(_same(a, b) for a, b in zip(keys, self.keys))):
            self._build(hessians, index)
            self.index = index
        self.keys = keys
        indptr, indices = self.pattern
        n = len(indptr) - 1
        data = np.zeros(len(indices))
        d = self.d
        for h, slots in zip(hessians, self.slots):
            if isinstance(h, Triplets):
                scatter(slots, np.asarray(h.vals, np.float64).reshape(-1, 1, 1), NO_WEIGHTS, NO_BLOCK, d, scale, data)
            elif h.weights is None:
                scatter(slots, h.local, NO_WEIGHTS, NO_BLOCK, d, scale, data)
            else:
                scatter(slots, h.local, h.weights, h.block, d, scale, data)
        scatter_diagonal(self.diag_slots, diag, data)
        return sp.csc_matrix((data, indices, indptr), shape=(n, n))
