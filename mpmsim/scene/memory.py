"""The memory a scene will take, estimated before anything is allocated, so a deck that asks
for more than the machine has is refused with the estimate (not a MemoryError traceback, not
a machine swapping for an hour).

The per-item sizes are rough upper figures of what a run holds (arrays of the state, the
contact workspace, the shape data: K = 4^dim nodes per particle, the widest B-spline; output
copies), not measurements to the byte."""

from __future__ import annotations

import os

PARTICLE_BYTES = {2: 8 * (16 * 4 + 80), 3: 8 * (64 * 5 + 120)}
NODE_BYTES = {2: 8 * 40, 3: 8 * 60}  # per grid node and velocity field
FEM_NODE_BYTES = {2: 8 * 60, 3: 8 * 150}  # a node and its share of elements, sparse matrices included
CANDIDATE_BYTES = 8 * 8  # a lattice site tested while filling a body (index and position)


def available_bytes() -> int:
    """Memory available to a new allocation: MemAvailable of /proc/meminfo (Linux), else the
    free physical pages."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, AttributeError):
        return 1 << 62


def too_big(need: float, what: str, remedy: str) -> str | None:
    """The problem of a scene estimated to need more memory than is available, or None."""
    have = available_bytes()
    if need > have:
        return f"{what} need about {need / 1e9:.3g} GB; {have / 1e9:.3g} GB are available: {remedy}"
    return None
