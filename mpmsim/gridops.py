"""Numba helpers shared by the grid tasks: the active fields, node numbering, particle
chunks, and the slab ordering that lets particle-to-grid scatters run on several threads.

Grid quantities live on *fields*. A field is a node (index < number of nodes) or, where two
or more materials meet, one material's slot at that node (index >= number of nodes; see
mpmsim/contact). Every grid kernel loops over the step's list of active fields, so material
slots need no code of their own.

Scatter kernels (particle -> grid) must not let two threads add into one node at once.
Particles are binned into slabs along one axis by their lowest node index; a slab is at
least as wide as any particle's node span, so slabs two apart never share a node. All
even slabs run in parallel, then all odd slabs. With one thread there is a single slab
and no binning cost. Every scatter kernel walks the slabs the same way:

    for color in range(2):
        for s in prange((ptr.size - color) // 2):
            for q in slab(ptr, color, s):
                p = order[q]  # (order, ptr: the views.Scatter's, bound before the loops)
                ...
"""

from __future__ import annotations

import numba
import numpy as np
from numba import njit, prange

from .parallel import chunk_kernel, chunks_for
from .views import ActiveFields, Scatter


def n_threads() -> int:
    return numba.get_num_threads()


@njit(cache=True, inline="always")
def chunk_range(c, nchunk, n):
    size = (n + nchunk - 1) // nchunk
    start = c * size
    stop = min(n, start + size)
    return start, stop


@njit(cache=True, inline="always")
def node_ijk(node, shape):
    """(i, j, k) of a flat node index."""
    return node % shape[0], (node // shape[0]) % shape[1], node // (shape[0] * shape[1])


@njit(cache=True, inline="always")
def slab(ptr, color, s):
    """The positions in the particle order of slab color + 2 s (ptr: a views.Scatter's)."""
    k = color + 2 * s
    return range(ptr[k], ptr[k + 1])


@njit(cache=True)
def slab_subset(order, ptr, keep, sub_order, sub_ptr):
    """The particles p of `order` (slabs `ptr`: a views.Scatter's) with keep[p], slab by slab in
    their order there, into sub_order and sub_ptr (sizes order.size and ptr.size); returns
    their number. A scatter over them adds the terms a scatter over all would add, in the same
    order, where the others add none."""
    n = 0
    for s in range(ptr.size - 1):
        sub_ptr[s] = n
        for q in range(ptr[s], ptr[s + 1]):
            p = order[q]
            if keep[p]:
                sub_order[n] = p
                n += 1
    sub_ptr[ptr.size - 1] = n
    return n


@njit(cache=True)
def box_nodes(lo, hi, shape, out):
    """Flat indices of the nodes in the box [lo, hi] (inclusive), in memory order."""
    q = 0
    for k in range(lo[2], hi[2] + 1):
        for j in range(lo[1], hi[1] + 1):
            for i in range(lo[0], hi[0] + 1):
                out[q] = i + shape[0] * (j + shape[1] * k)
                q += 1


@chunk_kernel
def zero_fields(fields, arr):
    """Zero the rows of a (n_fields, ncomp) array for the active fields."""
    for q in prange(fields.size):
        f = fields[q]
        for c in range(arr.shape[1]):
            arr[f, c] = 0.0


@njit(cache=True, inline="always")
def slab_of(lowest, p, axis, lo_axis, width, nslab):
    s = (lowest[p, axis] - lo_axis) // width
    return min(max(s, 0), nslab - 1)


@chunk_kernel
def bin_slabs(lowest, axis, lo_axis, width, nslab, nchunk, order, ptr):
    """Stable counting sort of particles into slabs by their lowest node index along `axis`,
    in chunks of particles: each chunk counts its particles per slab, a slab's particles are
    placed chunk after chunk, so `order` lists each slab's particles in index order, as a
    serial sort would (the scatters' sums then do not depend on the thread count's chunks)."""
    n = lowest.shape[0]
    start_of = np.zeros((nchunk, nslab), dtype=np.int64)  # counts, then each chunk's first place
    for c in prange(nchunk):
        start, stop = chunk_range(c, nchunk, n)
        for p in range(start, stop):
            start_of[c, slab_of(lowest, p, axis, lo_axis, width, nslab)] += 1
    ptr[0] = 0
    for s in range(nslab):
        place = ptr[s]
        for c in range(nchunk):
            count = start_of[c, s]
            start_of[c, s] = place
            place += count
        ptr[s + 1] = place
    for c in prange(nchunk):
        start, stop = chunk_range(c, nchunk, n)
        for p in range(start, stop):
            s = slab_of(lowest, p, axis, lo_axis, width, nslab)
            order[start_of[c, s]] = p
            start_of[c, s] += 1


class ActiveBox:
    """Node box touched by particles this step, its active fields, and the slab ordering for
    scatters. `fields` are field indices, `fnodes` their nodes, `skip` marks fields without
    dynamics of their own (rigid materials' slots)."""

    def __init__(self, shape: np.ndarray):
        self.shape = np.asarray(shape, dtype=np.int64)
        self.lo = np.zeros(3, dtype=np.int64)
        self.hi = np.zeros(3, dtype=np.int64)
        self.order = np.zeros(0, dtype=np.int64)
        self.ptr = np.zeros(2, dtype=np.int64)
        self.fields = np.zeros(0, dtype=np.int64)
        self.fnodes = self.fields
        self.skip = np.zeros(0, dtype=np.bool_)
        self.n_box = 0  # the first n_box fields are the box's nodes
        self.storage_axis = -1  # the axis the particles' storage order varies slowest along
        self.in_storage_order = False  # order is 0, 1, ..., n - 1 (one thread's single slab)

    def active(self) -> ActiveFields:
        return ActiveFields(self.fields, self.fnodes, self.skip)

    def scatter(self, fidx: np.ndarray, S: np.ndarray) -> Scatter:
        """Particle entries (fields fidx, weights S) in this step's slab order."""
        return Scatter(self.order, self.ptr, fidx, S)

    def update(self, boxes, lowest: np.ndarray, span: int, threads: int) -> None:
        """Set the box to the union of (lo, hi) node boxes; bin particles with `lowest` into slabs."""
        lo = np.min([b[0] for b in boxes], axis=0)
        hi = np.max([b[1] for b in boxes], axis=0)
        self.lo[:] = np.maximum(lo, 0)
        self.hi[:] = np.minimum(hi, self.shape - 1)
        self.n_box = int(np.prod(self.hi - self.lo + 1))
        if self.fields.size != self.n_box:
            self.fields = np.empty(self.n_box, dtype=np.int64)
            self.skip = np.zeros(self.n_box, dtype=np.bool_)
        box_nodes(self.lo, self.hi, self.shape, self.fields)
        self.fnodes = self.fields
        n = len(lowest)
        if self.order.shape[0] != n:
            self.order = np.arange(n, dtype=np.int64)
            self.in_storage_order = True
        if threads <= 1:
            if not self.in_storage_order:  # (rewritten only after a threaded step binned it)
                self.order[:] = np.arange(n)
                self.in_storage_order = True
            self.ptr = np.array([0, n], dtype=np.int64)
            return
        self.in_storage_order = False
        extent = self.hi - self.lo + 1
        width = max(span, 1)
        if self.storage_axis < 0:  # once: particles keep their storage order through a run
            axes = [d for d in range(lowest.shape[1]) if extent[d] > 1]  # (2D: not z)
            changes = [np.count_nonzero(np.diff(lowest[:, d])) for d in axes]
            self.storage_axis = axes[int(np.argmin(changes))] if axes else 0
        # Slabs across the axis the storage order varies slowest along hold runs of consecutive
        # particles, so a scatter reads particle rows nearly in order (slabs across the other
        # axis made the 256 000-particle column's scatters 4x slower once its particles no
        # longer fit in cache); the longest axis when that gives too few slabs to share.
        axis = self.storage_axis
        if extent[axis] / width < 4 * threads:
            axis = int(np.argmax(extent))
        nslab = max(1, int(np.ceil(extent[axis] / width)))
        self.ptr = np.zeros(nslab + 1, dtype=np.int64)
        bin_slabs(lowest, axis, self.lo[axis], width, nslab, chunks_for(threads), self.order, self.ptr)
