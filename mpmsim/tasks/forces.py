"""Task: grid forces. f_i = -sum_p V_p sigma_p . G_ip + sum_p S_ip m_p g, plus traction loads
 and grid damping -alpha p when the deck has them. Axisymmetric (x = r): V_p per radian and the
 hoop stress's radial force -V_p sigma_tt T_ip (T: the hoop function, shapes/axisymmetric.py)."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..gridops import slab, zero_fields
from ..loads import damp_grid, p2g_loads
from ..parallel import chunk_kernel
from .boundary import fold_ghost_forces, has_walls


@chunk_kernel
def p2g_forces(sc, G, T, P, gravity, has_gravity, gforce):
    """Internal forces (and gravity) of particles P scattered to their fields (sc: views.Scatter;
    T: the hoop functions of an axisymmetric scene, else (0, K))."""
    nodes, S, vol, stress, pmass = sc.fidx, sc.S, P.vol, P.stress, P.mass
    K = S.shape[1]
    hoop = T.shape[0] > 0
    dim = G.shape[2]
    order, ptr = sc.order, sc.ptr
    g0, g1, g2 = gravity[0], gravity[1], gravity[dim - 1]  # (g2 read only in 3D)
    for color in range(2):
        for s in prange((ptr.size - color) // 2):
            for q in slab(ptr, color, s):
                p = order[q]
                vp = vol[p]
                wm = pmass[p]
                # the particle's stress in locals: the stores into gforce below cannot then
                # force its reloads (a compiled plain loop must assume the arrays may overlap)
                sxx, syy, szz, sxy, syz, sxz = (stress[p, 0], stress[p, 1], stress[p, 2], stress[p, 3],
                                                stress[p, 4], stress[p, 5])
                for k in range(K):
                    w = S[p, k]
                    i = np.uint64(nodes[p, k])  # (unsigned: no negative-index wrap per access)
                    gz = G[p, k, 2] if dim == 3 else 0.0
                    fx, fy, fz = node_force(G[p, k, 0], G[p, k, 1], gz, w, vp, wm, sxx, syy, szz, sxy, syz, sxz, g0, g1,
                                            g2, has_gravity, dim)
                    if hoop:
                        fx -= szz * T[p, k] * vp
                    gforce[i, 0] += fx
                    gforce[i, 1] += fy
                    if dim == 3:
                        gforce[i, 2] += fz


@njit(cache=True, inline="always")
def node_force(gx, gy, gz, w, vp, wm, sxx, syy, szz, sxy, syz, sxz, g0, g1, g2, has_gravity, dim):
    """The force (fx, fy, fz) of a particle (volume vp, mass wm, stress components) on one of
    its nodes (weight w, gradient gx, gy, gz): -V sigma . G + w m g. Also the GPU step's.
    Scalars in and out: taking the arrays G and gravity instead, the inlined helper left NRT
    incref/decref calls in the kernel (3% slower)."""
    if dim == 3:
        fx = (0.0 - sxx * gx - sxy * gy - sxz * gz) * vp
        fy = (0.0 - sxy * gx - syy * gy - syz * gz) * vp
        fz = (0.0 - sxz * gx - syz * gy - szz * gz) * vp
    else:
        fx = (0.0 - sxx * gx - sxy * gy) * vp
        fy = (0.0 - sxy * gx - syy * gy) * vp
        fz = 0.0
    if has_gravity:
        fx += w * wm * g0
        fy += w * wm * g1
        if dim == 3:
            fz += w * wm * g2
    return fx, fy, fz


def forces(state) -> None:
    f, box, P, sd = state.fields, state.box, state.particles, state.sd
    zero_fields(box.fields, f.force)
    has_g = bool(state.gravity.any())
    p2g_forces(box.scatter(state.field_index, sd.S), sd.G, sd.T, P.view(), state.gravity, has_g, f.force)
    loads = state.loads
    if loads is not None:  # their work is booked by the particle update, over the step's displacement
        p2g_loads(loads.particle, loads.start_step(P.x, state.t + 0.5 * state.dt), loads.at_surface, loads.offset, P.x,
                  state.field_index, sd.S, sd.lowest, state.entry_offsets, state.grid.view, f.force)
    # only B-splines: with linear hats the ghosts carry only the force of a CPDI corner pushed
    # past the wall, and folding that back flings the particle out (Fig. 6 ellipses, 75% strain)
    if state.shape.reaches_ghosts and has_walls(state):
        fold_ghost_forces(box.fields, f.ghost_src, f.ghost_face, f.force)
    if state.damping > 0.0:
        damp_grid(box.fields, f.mom, state.damping, f.force)
