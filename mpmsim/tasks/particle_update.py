"""Task: update particle velocities and positions from the grid (notes §1.4).

With a = f/m and v+ = p+/m per node, and S q = sum_i S_ip q_i:
  FLIP: V += dt S a;            x += dt S(v+ - a dt/2)   (= dt S (v + v+)/2, second order)
  PIC:  V_new = S v+;           x += dt [S(v+ - a dt) + (V_new - V_old)/2]
Rigid particles move with their prescribed velocity (trapezoidal in time).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..gridops import chunk_range
from .stress import BAD_LEFT_GRID, BAD_NAN

FLIP = 0
PIC = 1
SCHEMES = {"flip": FLIP, "pic": PIC}


@njit(parallel=True, cache=True)
def particle_update_kernel(nodes, S, vnew, acc, dt, scheme, x, v, pmass, gravity, lo, hi, nchunk,
                           chunk_gwork, chunk_bad, chunk_code):
    n, K = S.shape
    dim = x.shape[1]
    for c in prange(nchunk):
        start, stop = chunk_range(c, nchunk, n)
        sa = np.zeros(3)
        sv = np.zeros(3)
        gwork = 0.0
        bad = -1
        code = 0
        for p in range(start, stop):
            for d in range(dim):
                sa[d] = 0.0
                sv[d] = 0.0
            for k in range(K):
                w = S[p, k]
                i = nodes[p, k]
                for d in range(dim):
                    sa[d] += w * acc[i, d]
                    sv[d] += w * vnew[i, d]
            outside = False
            finite = True
            for d in range(dim):
                vold = v[p, d]
                if scheme == FLIP:
                    vn = vold + dt * sa[d]
                    dx = dt * (sv[d] - 0.5 * dt * sa[d])
                else:
                    vn = sv[d]
                    dx = dt * ((sv[d] - dt * sa[d]) + 0.5 * (vn - vold))
                x[p, d] += dx
                v[p, d] = vn
                gwork += pmass[p] * gravity[d] * dx  # exact work of a constant body force
                if x[p, d] < lo[d] or x[p, d] > hi[d]:
                    outside = True
                if not (np.isfinite(vn) and np.isfinite(x[p, d])):
                    finite = False
            if bad < 0 and not finite:
                bad, code = p, BAD_NAN
            elif bad < 0 and outside:
                bad, code = p, BAD_LEFT_GRID
        chunk_gwork[c] = gwork
        chunk_bad[c] = bad
        chunk_code[c] = code


def particle_update(state) -> None:
    P, f, sd, g = state.particles, state.fields, state.sd, state.grid
    nc = state.nchunk
    gwork = np.zeros(nc)
    bad = np.full(nc, -1, dtype=np.int64)
    code = np.zeros(nc, dtype=np.int64)
    scheme = SCHEMES[state.scene.deck.update.scheme]
    particle_update_kernel(sd.nodes, sd.S, f.vnew, f.acc, state.dt, scheme, P.x, P.v, P.mass, state.gravity,
                           g.domain_lo, g.domain_hi, nc, gwork, bad, code)
    state.work_in += float(gwork.sum())
    hits = np.nonzero(bad >= 0)[0]
    if len(hits):
        state.flags.set(int(bad[hits[0]]), int(code[hits[0]]), 0.0)


def move_rigid(state) -> None:
    """Rigid particles: x += dt (v(t) + v(t+dt))/2, V = v(t+dt)."""
    R = state.rigid
    mean = 0.5 * (state.rigid_v_start + state.rigid_v_end)
    R.x += state.dt * mean[R.mat]
    R.v[:] = state.rigid_v_end[R.mat]
    state.rigid_disp += state.dt * mean
