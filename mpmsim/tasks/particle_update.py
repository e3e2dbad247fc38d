"""Task: update particle velocities and positions from the grid (notes §1.4).

With a = f/m and v+ = p+/m per node, v the start-of-step lumped velocity (velocity
conditions imposed, `vstart`), v* the XPIC/FMPM-filtered velocity, and S q = sum_i S_ip q_i:

  FLIP:  V += dt S a
  PIC:   V  = S v+
  XPIC:  V  = S (v* + a dt)     (published form; the xpic task leaves v* + a dt, with the BC
         refinement documented there, in vstar)
  FMPM:  V  = S v*  (v* from v+)
  APIC:  V  = S v+, B = sum_i S_ip v+_i (x) (x_i - x_p)

Positions (`update.position`):

  midpoint (default):  FLIP  x += dt S (v + v+)/2      (second order)
                       PIC, XPIC  x += dt [S v + (V_new - V_old)/2]
                       FMPM  x += dt (V_new + V_old)/2
                       APIC  x += dt V_new  (= dt S v+)
  updated, every scheme:  x += dt S v+

The updated form moves a particle with the grid velocity that the stress update integrates
into F (exactly so with `reextrapolate: false`), after the velocity: a symplectic-Euler pair.
The midpoint forms, with the velocity updated by the start-of-step force, amplify every
oscillation by a factor (1 + (w dt)^2 / 2)^(1/2) per step where the positions carry the
stiffness, as they do under a stress large against the moduli (docs/stability.md, "High-rate
compaction"). Away from velocity conditions v = v+ - a dt, so FLIP's midpoint form is the
notes' §1.4 x += dt S(v+ - a dt/2), exact for constant acceleration. Rigid particles move
with their prescribed velocity (trapezoidal in time).
"""

from __future__ import annotations

from functools import cache
from typing import NamedTuple

import math

import numpy as np
from numba import njit, prange

from ..gridops import chunk_range
from ..faults import BAD_LEFT_GRID, BAD_NAN
from ..parallel import chunk_kernel
from ..views import Faults
from .boundary import has_walls, mirror_ghosts

FLIP, PIC, XPIC, FMPM, APIC = 0, 1, 2, 3, 4
SCHEMES = {"flip": FLIP, "pic": PIC, "xpic": XPIC, "fmpm": FMPM, "apic": APIC}
UPDATED, MIDPOINT = 0, 1
POSITIONS = {"updated": UPDATED, "midpoint": MIDPOINT}


class GridVelocities(NamedTuple):
    vnew: np.ndarray  # v+
    acc: np.ndarray  # a = f/m
    vstart: np.ndarray  # v (start, velocity conditions imposed)
    vstar: np.ndarray  # XPIC/FMPM filtered


@cache
def particle_update_kernel(scheme: int, position: int, dim: int):
    """The particle update of one scheme and position form (codes) in `dim` dimensions,
    compiled for them alone: all three are constants of the kernel, so numba drops the other
    branches."""

    @chunk_kernel
    def kernel(entries, offs, grid, gv, dt, P, gravity, lo, hi, nchunk, chunk_gwork, faults):
        """Velocities and positions (`position`: UPDATED or MIDPOINT) of particles P from the grid
        velocities gv (entries: shapes.ShapeData whose nodes are the particles' fields); per chunk
        the work of gravity and the first particle that went non-finite or left [lo, hi]."""
        nodes, S, lowest = entries.nodes, entries.S, entries.lowest
        origin, h = grid.origin, grid.h
        vnew, acc, vstart, vstar = gv.vnew, gv.acc, gv.vstart, gv.vstar
        x, v, B, pmass = P.x, P.v, P.B, P.mass
        chunk_bad, chunk_code = faults.bad, faults.code
        n, K = S.shape
        # the grid fields this scheme and position form read
        use_a = scheme == FLIP
        use_v = scheme == FLIP or scheme == PIC or scheme == APIC or position == UPDATED
        use_0 = scheme == FLIP or scheme == PIC or (scheme == XPIC and position != UPDATED)
        use_s = scheme == XPIC or scheme == FMPM
        for c in prange(nchunk):
            start, stop = chunk_range(c, nchunk, n)
            sa = np.zeros(3)
            sv = np.zeros(3)
            s0 = np.zeros(3)
            ss = np.zeros(3)
            gwork = 0.0
            bad = -1
            code = 0
            for p in range(start, stop):
                if scheme == APIC:
                    for a in range(dim):
                        for b in range(dim):
                            B[p, a, b] = 0.0
                # the sums S q run in scalar locals (a compiled plain loop must assume scratch
                # rows may overlap the grid arrays it reads, and would reload them: 1.7x slower;
                # an inlined helper returning the three sums was 4.6x slower than these lines)
                ax = ay = az = 0.0  # S a
                vx = vy = vz = 0.0  # S v+
                zx = zy = zz = 0.0  # S v (start)
                sx = sy = sz = 0.0  # S v*
                for k in range(K):  # gather only the fields this scheme uses
                    w = S[p, k]
                    i = np.uint64(nodes[p, k])  # (unsigned: no negative-index wrap per access)
                    if use_a:
                        ax += w * acc[i, 0]
                        ay += w * acc[i, 1]
                        if dim == 3:
                            az += w * acc[i, 2]
                    if use_v:
                        vx += w * vnew[i, 0]
                        vy += w * vnew[i, 1]
                        if dim == 3:
                            vz += w * vnew[i, 2]
                    if use_0:
                        zx += w * vstart[i, 0]
                        zy += w * vstart[i, 1]
                        if dim == 3:
                            zz += w * vstart[i, 2]
                    if use_s:
                        sx += w * vstar[i, 0]
                        sy += w * vstar[i, 1]
                        if dim == 3:
                            sz += w * vstar[i, 2]
                    if scheme == APIC:
                        for b in range(dim):
                            rb = origin[b] + (lowest[p, b] + offs[k, b]) * h[b] - x[p, b]
                            for a in range(dim):
                                B[p, a, b] += w * vnew[i, a] * rb
                sa[0], sa[1], sa[2] = ax, ay, az
                sv[0], sv[1], sv[2] = vx, vy, vz
                s0[0], s0[1], s0[2] = zx, zy, zz
                ss[0], ss[1], ss[2] = sx, sy, sz
                worst = MOVED
                for d in range(dim):
                    v[p, d], x[p, d], gw, status = advance(scheme, position, v[p, d], x[p, d], dt, sa[d], sv[d], s0[d],
                                                           ss[d], pmass[p], gravity[d], lo[d], hi[d])
                    gwork += gw
                    worst = max(worst, status)
                if bad < 0 and worst != MOVED:
                    bad, code = p, (BAD_NAN if worst == NOT_FINITE else BAD_LEFT_GRID)
            chunk_gwork[c] = gwork
            chunk_bad[c] = bad
            chunk_code[c] = code

    return kernel


MOVED, LEFT, NOT_FINITE = 0, 1, 2  # advance's status, worst last


@njit(cache=True, inline="always")
def advance(scheme, position, vold, xold, dt, a, vplus, vbegin, vstar, mass, g, lo, hi):
    """One component of a particle's velocity and position: (new velocity, new position, work
    of gravity g on mass m, status) from the gathered a, v+, start v and filtered v* of the
    scheme; status NOT_FINITE where either is not finite, else LEFT where the position left
    [lo, hi], else MOVED. Also the GPU step's. (The status is set, not returned early: with a
    return per case the inlined helper made the FLIP kernel 8% slower.)"""
    if scheme == FLIP:
        vn = vold + dt * a
        dx = 0.5 * dt * (vbegin + vplus)
    elif scheme == PIC:
        vn = vplus
        dx = dt * (vbegin + 0.5 * (vn - vold))
    elif scheme == XPIC:
        vn = vstar
        dx = dt * (vbegin + 0.5 * (vn - vold))
    elif scheme == FMPM:
        vn = vstar
        dx = 0.5 * dt * (vn + vold)
    else:  # APIC
        vn = vplus
        dx = dt * vn
    if position == UPDATED:
        dx = dt * vplus
        # the work that changes 1/2 m V^2 by exactly m g (V_new^2 - V_old^2)/2g in free fall
        gw = mass * g * 0.5 * dt * (vold + vn)
    else:
        gw = mass * g * dx  # exact work of a constant body force
    x = xold + dx
    status = MOVED
    if x < lo or x > hi:
        status = LEFT
    if not (math.isfinite(vn) and math.isfinite(x)):
        status = NOT_FINITE
    return vn, x, gw, status


def particle_update(scheme: str, position: str, dim: int):
    """The particle update of one scheme (flip, pic, xpic, fmpm, apic) with positions moved by
    the updated grid velocity or by the scheme's midpoint form."""
    code_of_position = POSITIONS[position]
    kernel = particle_update_kernel(SCHEMES[scheme], code_of_position, dim)

    def run(state) -> None:
        P, f = state.particles, state.fields
        nc = state.nchunk
        if code_of_position == UPDATED and state.contact is not None and has_walls(state):
            # contact pass 2 changed v+ after the grid update mirrored it: the ghosts follow again
            mirror_ghosts(state.box.fields, f.ghost_src, f.vnew)
        gwork = np.zeros(nc)
        faults = Faults.empty(nc)
        kernel(state.entries, state.entry_offsets, state.grid.view, GridVelocities(f.vnew, f.acc, f.vstart, f.vstar),
               state.dt, P.view(), state.gravity, *state.particle_bounds, nc, gwork, faults)
        state.work_in += float(gwork.sum())
        if state.loads is not None:
            state.work_in += state.loads.work_of_step(P.x)
        first = faults.first()
        if first is not None:
            state.flags.set(*first)

    return run


def move_rigid(state) -> None:
    """Rigid particles: x += dt (v(t) + v(t+dt))/2, V = v(t+dt)."""
    R = state.rigid
    mean = 0.5 * (R.v_start + R.v_end)
    R.x += state.dt * mean[R.mat]
    R.v[:] = R.v_end[R.mat]
    R.disp += state.dt * mean
