"""Tasks: update particle deformation and stress from grid velocities.

grad V_p = sum_i v_i (x) G_ip;  F <- (I + dt grad V) F;  stress from the material.
USF runs it once before the forces (velocities from the initial extrapolation), USL once
after the particle update (from re-extrapolated momenta), USAVG half a step at each.

Particles of materials with internal energy (Mie–Grüneisen, or under artificial viscosity)
also update U and the pressure, and carry the viscous pressure q of Eq. (52) in their stress
(docs/shock.md); the per-material flag keeps every other particle on the plain path.
"""

from __future__ import annotations

from functools import cache

import numpy as np
from numba import njit, prange

from ..faults import BAD_EOS, BAD_INVERTED, BAD_NAN
from ..gridops import chunk_range
from ..materials.kernels import EOS_DEN, EOS_J0, EOS_N, EOS_P, EOS_Q, EOS_RHO0, EOS_U, det3
from ..materials.model import model_of
from ..parallel import chunk_kernel, specialize
from ..views import Faults
from .boundary import set_grid_velocity


# the constants of one compiled stress kernel, bound per model by `update_stress_kernel`
MODEL_CODE, DIM, TRACKED, READS_L_2D, READS_F3_2D, OWN_EOS, AXISYMMETRIC = -1, 2, False, True, True, False, False
STRESS = BULK = None


def stress_kernel(entries, gvel, dt, P, M, dx, nchunk, chunk_wave, faults):
    """Velocity gradient from the grid velocity gvel (entries: shapes.ShapeData whose nodes
    are the particles' fields), F and volume, then the stress of each particle whose material
    (M: views.MaterialView) is of this model; per chunk the largest wave speed + |v| and the
    first bad particle."""
    nodes, G, T = entries.nodes, entries.G, entries.T
    pvel, F, stress, vol, vol0, mat, U, pressure, qv = P.v, P.F, P.stress, P.vol, P.vol0, P.mat, P.U, P.pressure, P.q
    mstate = P.mstate
    code, props, density, energy, av = M.code, M.props, M.density, M.energy, M.av
    chunk_bad, chunk_code, chunk_value = faults.bad, faults.code, faults.value
    n, K = nodes.shape
    dim = DIM
    for c in prange(nchunk):
        start, stop = chunk_range(c, nchunk, n)
        work = np.zeros((6, 3, 3))  # velocity gradient, F, and the constitutive update's scratch
        L, F3, W, A, Ai, Q = work[0], work[1], work[2], work[3], work[4], work[5]
        eos = np.zeros(EOS_N)
        wave = 0.0
        bad = -1
        bad_code = 0
        bad_value = 0.0
        for p in range(start, stop):
            mt = mat[p]
            if code[mt] != MODEL_CODE:
                continue
            # F <- (I + dt L) F, padded to 3x3 (plane strain: F33 = 1, no z gradient)
            n00 = n01 = n10 = n11 = 0.0  # 2D: the new F's in-plane entries
            n22 = 1.0  # axisymmetric: the new hoop stretch
            if DIM == 2 and AXISYMMETRIC:
                # r-z: the in-plane gradient plus the hoop rate L_tt = sum_i v_r,i T_ip; the
                # material sees the 3D tensors (L, F block-diagonal: r-z block and theta)
                l00, l01, l10, l11 = velocity_gradient_2d(p, nodes, G, gvel)
                l22 = hoop_rate(p, nodes, T, gvel)
                L[0, 0], L[0, 1], L[1, 0], L[1, 1], L[2, 2] = l00, l01, l10, l11, l22
                n00, n01, n10, n11 = deform_2d(dt, l00, l01, l10, l11, F[p, 0, 0], F[p, 0, 1], F[p, 1, 0], F[p, 1, 1])
                n22 = F[p, 2, 2] * (1.0 + dt * l22)
                F3[0, 0], F3[0, 1], F3[1, 0], F3[1, 1], F3[2, 2] = n00, n01, n10, n11, n22
            elif DIM == 2:
                # in 2D the sums run in scalar locals: a compiled plain loop must assume the
                # scratch rows may overlap the arrays it reads, and reloads them (1.5x slower)
                l00, l01, l10, l11 = velocity_gradient_2d(p, nodes, G, gvel)
                if READS_L_2D or TRACKED:  # (the 2D neo-Hookean path reads neither)
                    L[0, 0], L[0, 1], L[1, 0], L[1, 1] = l00, l01, l10, l11
                n00, n01, n10, n11 = deform_2d(dt, l00, l01, l10, l11, F[p, 0, 0], F[p, 0, 1], F[p, 1, 0], F[p, 1, 1])
                if READS_F3_2D:
                    F3[0, 0], F3[0, 1], F3[1, 0], F3[1, 1] = n00, n01, n10, n11
                    F3[0, 2] = 0.0
                    F3[1, 2] = 0.0
                    F3[2, 0] = 0.0
                    F3[2, 1] = 0.0
                    F3[2, 2] = 1.0
            else:
                for a in range(dim):
                    for b in range(dim):
                        L[a, b] = 0.0
                for k in range(K):
                    i = np.uint64(nodes[p, k])  # (unsigned: no negative-index wrap per access)
                    for a in range(dim):
                        va = gvel[i, a]
                        for b in range(dim):
                            L[a, b] += va * G[p, k, b]
                for a in range(3):
                    for b in range(3):
                        s = F[p, a, b]
                        for m in range(dim):
                            s += dt * L[a, m] * F[p, m, b]
                        F3[a, b] = s
            # det3 of the padded F; in 2D its out-of-plane terms are exact zeros, which change
            # nothing where J > 0 (elsewhere the particle is reported inverted either way)
            J = (n00 * n11 - n01 * n10) * n22 if DIM == 2 else det3(F3)
            if not (J > 0.0):
                if bad < 0:
                    bad, bad_code, bad_value = p, BAD_INVERTED, J
                continue
            if DIM == 2:
                F[p, 0, 0], F[p, 0, 1], F[p, 1, 0], F[p, 1, 1] = n00, n01, n10, n11
                if AXISYMMETRIC:
                    F[p, 2, 2] = n22
            else:
                for a in range(dim):
                    for b in range(dim):
                        F[p, a, b] = F3[a, b]
            track = TRACKED and energy[mt]
            J0 = vol[p] / vol0[p] if track else 1.0  # (read only with internal energy)
            vol[p] = vol0[p] * J
            q = 0.0
            if track:
                # Eq. (52): q only in compression, C the current bulk wave speed
                trD = 0.0
                for a in range(3 if AXISYMMETRIC else dim):
                    trD += L[a, a]
                if trD < 0.0 and av[mt, 0] + av[mt, 1] > 0.0:
                    C = np.sqrt(max(BULK(props[mt], J, pressure[p]), 0.0) * J / density[mt])
                    dxd = -dx * trD
                    q = density[mt] / J * dxd * (av[mt, 0] * C + av[mt, 1] * dxd)
                for a in range(3):  # take out the last q: a hypoelastic stress is incremental
                    stress[p, a] += qv[p]
                eos[EOS_U] = U[p]
                eos[EOS_P] = pressure[p]
                eos[EOS_Q] = q
                eos[EOS_J0] = J0
                eos[EOS_RHO0] = density[mt]
                eos[EOS_DEN] = 1.0
            # the stress of this model (STRESS, bound per model: mpmsim/materials/model.py)
            pr, sp = props[mt], stress[p]
            modulus = STRESS(pr, L, dt, F3, J, n00, n01, n10, n11, sp, W, A, Ai, Q, eos, mstate[p])
            if track:
                q = eos[EOS_Q]
                if OWN_EOS:
                    U[p] = eos[EOS_U]
                    pressure[p] = eos[EOS_P]
                    if not (eos[EOS_DEN] > 0.0) and bad < 0:
                        bad, bad_code, bad_value = p, BAD_EOS, eos[EOS_DEN]
                else:  # elastic energy is strain energy; U holds only the viscous dissipation
                    U[p] += q * (J0 - J) / density[mt]
                    pressure[p] = -(stress[p, 0] + stress[p, 1] + stress[p, 2]) / 3.0
                for a in range(3):
                    stress[p, a] -= q
                qv[p] = q
            speed2 = 0.0
            for a in range(dim):
                speed2 += pvel[p, a] * pvel[p, a]
            cp = np.sqrt(modulus * J / density[mt]) + np.sqrt(speed2)
            if cp > wave:
                wave = cp
            finite = True
            for a in range(6):
                if not np.isfinite(stress[p, a]):
                    finite = False
            if not finite and bad < 0:
                bad, bad_code, bad_value = p, BAD_NAN, 0.0
        chunk_wave[c] = wave
        chunk_bad[c] = bad
        chunk_code[c] = bad_code
        chunk_value[c] = bad_value


@njit(cache=True, inline="always")
def velocity_gradient_2d(p, nodes, G, gvel):
    """The 2D velocity gradient (l00, l01, l10, l11) of particle p, sum_k v_i (x) G_pk, summed
    in scalar locals. Also the GPU step's."""
    l00 = 0.0
    l01 = 0.0
    l10 = 0.0
    l11 = 0.0
    for k in range(nodes.shape[1]):
        i = np.uint64(nodes[p, k])  # unsigned: numba then adds no negative-index wrap per access
        v0, v1 = gvel[i, 0], gvel[i, 1]
        g0, g1 = G[p, k, 0], G[p, k, 1]
        l00 += v0 * g0
        l01 += v0 * g1
        l10 += v1 * g0
        l11 += v1 * g1
    return l00, l01, l10, l11


@njit(cache=True, inline="always")
def hoop_rate(p, nodes, T, gvel):
    """The axisymmetric hoop strain rate of particle p, L_tt = sum_k v_r,i T_pk."""
    l22 = 0.0
    for k in range(nodes.shape[1]):
        l22 += gvel[np.uint64(nodes[p, k]), 0] * T[p, k]
    return l22


@njit(cache=True, inline="always")
def deform_2d(dt, l00, l01, l10, l11, f00, f01, f10, f11):
    """The in-plane entries of (I + dt L) F. Also the GPU step's."""
    n00 = f00 + dt * l00 * f00 + dt * l01 * f10
    n01 = f01 + dt * l00 * f01 + dt * l01 * f11
    n10 = f10 + dt * l10 * f00 + dt * l11 * f10
    n11 = f11 + dt * l10 * f01 + dt * l11 * f11
    return n00, n01, n10, n11


@cache
def update_stress_kernel(model: int, tracked: bool, dim: int, axisymmetric: bool = False):
    """The stress update of the particles of one material model (type code `model`), compiled
    for that model alone: its stress and bulk-modulus functions and flags
    (mpmsim/materials/model.py), `tracked` (some material of the model carries internal energy)
    and `dim` are bound as constants of the kernel, so a scene compiles only the models it
    uses. (Plain ints and bools: they key numba's cache; the model's tag names the copy.)
    `axisymmetric`: the r-z form, the model's 3D update on block-diagonal L and F (x = r,
    y = z, the third axis the hoop direction)."""
    m = model_of(model)
    law = m.stress(3 if axisymmetric else dim)
    if law is None:
        raise ValueError(f"material model {m.name} has no explicit MPM stress update")
    tag = f"{m.tag}_{int(tracked)}_{'rz' if axisymmetric else f'{dim}d'}"
    return chunk_kernel(specialize(stress_kernel, tag, MODEL_CODE=m.code, DIM=dim, TRACKED=tracked,
                                   READS_L_2D=m.reads_L_2d, READS_F3_2D=m.reads_F3_2d, OWN_EOS=m.internal_energy,
                                   STRESS=law, BULK=m.bulk_modulus, AXISYMMETRIC=axisymmetric))


def stress_kernels(materials, dim: int, axisymmetric: bool = False) -> list:
    """The stress kernels of a material table: one per material model its deformable
    materials use (models without an explicit update are those of FEM bodies only: the
    deck's checks keep them off explicit particles)."""
    codes = np.asarray(materials.type_code)
    return [update_stress_kernel(int(m), bool(materials.energy[codes == m].any()), int(dim), bool(axisymmetric))
            for m in np.unique(codes) if model_of(int(m)).stress(dim) is not None]


def _update_stress(state, dt, gvel, kernels) -> None:
    nc = state.nchunk
    wave = np.zeros(nc)
    faults = Faults.empty(nc)
    P, M, dx = state.particles.view(), state.materials.view(), float(state.grid.h.min())
    state.wave_max = 0.0
    for kernel in kernels:
        kernel(state.entries, gvel, dt, P, M, dx, nc, wave, faults)
        state.wave_max = max(state.wave_max, float(wave.max()))
        first = faults.first()
        if first is not None:
            state.flags.set(*first)
            break


def update_stress_first(fraction: float, kernels: list):
    """USF/USAVG (fraction 1 or 1/2 of the step): velocities from the initial extrapolation,
    BCs at the step's start. kernels: the scene's stress_kernels."""

    def run(state) -> None:
        set_grid_velocity(state, state.rigid.v_start)
        _update_stress(state, fraction * state.dt, state.fields.vel, kernels)

    return run


def update_stress_last(fraction: float, reextrapolate: bool, kernels: list):
    """USL/USAVG (fraction 1 or 1/2 of the step). Default ("+", reextrapolate): from the
    momenta the re-extrapolate task rebuilt (and contact pass 3 corrected), with velocity
    conditions at the step's end. With `update.reextrapolate: false` ("-"): from the updated
    grid velocity v+ directly, so the stress and the FLIP position update integrate the same
    grid field (much less FLIP ringing in long compressions; docs/stability.md)."""

    def run(state) -> None:
        if reextrapolate:
            set_grid_velocity(state, state.rigid.v_end)
            gvel = state.fields.vel
        else:
            gvel = state.fields.vnew
        _update_stress(state, fraction * state.dt, gvel, kernels)

    return run
