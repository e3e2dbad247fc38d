"""CUDA kernels of the explicit MPM step (numba-cuda): one thread per particle or per grid node.

Imported only when a run asks for `device: cuda` (mpmsim/gpu/step.py), never on the CPU path.
The per-particle and per-node work is the CPU path's own compiled code, which numba-cuda
compiles again as device functions: the inlined helpers the CPU kernels call per item (the
shape-function weights per axis and node entries, shapes/tensor.py; the APIC affine matrix,
tasks/extrapolate.py; a node's force, tasks/forces.py; the
2D velocity gradient and F update, tasks/stress.py; a held component's force and a node's
velocity, tasks/grid_update.py and tasks/boundary.py; the particle advance,
tasks/particle_update.py), the velocity conditions and ghost mirrors (bc.py), the 3x3
determinant and each material model's stress update (materials/<model>.py). What differs
from the CPU kernels is how the work is spread: a thread per particle or node instead of a
chunk per CPU thread, float64 atomic adds where particles scatter to the grid (the CPU path
colours slabs instead), and scratch in per-thread local arrays. Each kernel is built once per
set of constants (dimension, shape function, scheme, material model) so the compiler drops
the branches a scene does not use.

Fault slots (`faults`, int64, lowest particle index wins, `n` when none): SHAPE, RIGID_SHAPE,
STRESS, UPDATE; the stress and particle-update codes and values sit in `fcode`/`fvalue` at
the flagged particle's index.
"""

from __future__ import annotations

import math
from functools import cache
from typing import NamedTuple

import numpy as np
from numba import cuda, float64, int64

from numba.cuda.core import config as cuda_config

from .. import bc
from ..bc import NO_BC, RIGID_OWNER
from ..faults import BAD_INVERTED, BAD_LEFT_GRID, BAD_NAN
from .. import gridops
from ..materials import kernels as mk
from ..bodies import KINETIC, STRAIN
from ..materials.dispatch import energy_dispatch
from ..materials.kernels import EOS_N
from ..materials.model import model_of
from ..shapes import tensor
from ..tasks.boundary import mirror_field as _mirror_field, velocity_of as _velocity_of
from ..tasks.extrapolate import RIGID_MIN_WEIGHT, affine_of as _affine_of
from ..tasks.forces import node_force as _node_force
from ..tasks.grid_update import held_force as _held_force
from ..tasks.particle_update import APIC, FLIP, MOVED, NOT_FINITE, PIC, UPDATED, advance as _advance
from ..tasks.stress import deform_2d as _deform_2d, velocity_gradient_2d as _velocity_gradient_2d

SIMULATOR = bool(cuda_config.ENABLE_CUDASIM)


def _add_ufunc_loops() -> None:
    """numba-cuda 0.30 has no float64 loops for the NumPy functions the shared CPU code calls
    on scalars (np.floor and np.cbrt in the shape functions and the neo-Hookean stress;
    np.sqrt, np.exp and np.isfinite in the contact geometry and laws): add them to its ufunc
    table (LLVM's floor, libdevice's cbrt, sqrt, exp and isfinite), so the CPU path's
    functions compile for the device unchanged."""
    import math

    from llvmlite import ir
    from numba.core import types, typing
    from numba.cuda import cgutils, libdevice, ufuncs
    from numba.cuda.cudaimpl import ptx_cbrt
    from numba.cuda.mathimpl import get_unary_impl_for_fn_and_ty

    def floor(context, builder, sig, args):
        fnty = ir.FunctionType(ir.DoubleType(), [ir.DoubleType()])
        return builder.call(cgutils.get_or_insert_function(builder.module, fnty, "llvm.floor.f64"), args)

    def isfinite(context, builder, sig, args):
        impl = context.get_function(libdevice.isfinited, typing.signature(types.int32, types.float64))
        return context.cast(builder, impl(builder, args), types.int32, types.boolean)

    db = ufuncs.ufunc_db()
    db.setdefault(np.floor, {}).setdefault("d->d", floor)
    db.setdefault(np.cbrt, {}).setdefault("d->d", ptx_cbrt)
    db.setdefault(np.sqrt, {}).setdefault("d->d", get_unary_impl_for_fn_and_ty(math.sqrt, types.float64))
    db.setdefault(np.exp, {}).setdefault("d->d", get_unary_impl_for_fn_and_ty(math.exp, types.float64))
    db.setdefault(np.isfinite, {}).setdefault("d->?", isfinite)


if not SIMULATOR:
    _add_ufunc_loops()


def device_function(f):
    """The CPU path's compiled function `f` for use in a kernel: as it is on a GPU (numba-cuda
    compiles a numba.njit function called from a kernel again for the device); under the
    simulator (kernels run as Python), called on the numpy arrays its device arrays wrap."""
    if not SIMULATOR:
        return f

    def call(*args):
        return f(*[_host_view(a) for a in args])

    return call


def _host_view(a):
    """The numpy array a simulated device array wraps (inside bundles too)."""
    if isinstance(a, tuple):
        items = [_host_view(x) for x in a]
        return type(a)(*items) if hasattr(a, "_fields") else tuple(items)
    return getattr(a, "_ary", a)


ghost_mirror, node_bc, rigid_holds = (device_function(f) for f in (bc.ghost_mirror, bc.node_bc, bc.rigid_holds))
det3 = device_function(mk.det3)
node_ijk = device_function(gridops.node_ijk)
# the per-particle and per-node bodies the CPU kernels share with these
axis_weights, fill_entries = device_function(tensor.axis_weights), device_function(tensor.fill_entries)
affine_of = device_function(_affine_of)
velocity_of, held_force, held_volume = (device_function(f) for f in (_velocity_of, _held_force, bc.held_volume))
mirror_field = device_function(_mirror_field)
node_force, deform_2d = device_function(_node_force), device_function(_deform_2d)
velocity_gradient_2d = device_function(_velocity_gradient_2d)
advance = device_function(_advance)
TPB = 1 if SIMULATOR else 128  # threads per block (the simulator runs a block's threads as Python threads, their
# atomic adds in no fixed order: one thread per block runs the threads one after another)
SHAPE, RIGID_SHAPE, STRESS, UPDATE = 0, 1, 2, 3
N_SLOTS = 4
WAVE, GRID_WORK, GRAVITY_WORK = 0, 1, 2  # entries of the step's scalars


def blocks(n: int) -> tuple[int, int]:
    return (max(1, (n + TPB - 1) // TPB), TPB)


@cuda.jit
def zero(a):
    """a[:] = 0 for a flat array."""
    i = cuda.grid(1)
    if i < a.size:
        a[i] = 0.0


@cuda.jit
def zero_int(a):
    """a[:] = 0 for a flat integer array."""
    i = cuda.grid(1)
    if i < a.size:
        a[i] = 0


@cuda.jit
def damp(mom, alpha, force):
    """Grid damping (loads.damp_grid): f -= alpha p on every node (p = 0 where no mass is)."""
    node = cuda.grid(1)
    if node < force.shape[0]:
        for d in range(force.shape[1]):
            force[node, d] -= alpha * mom[node, d]


@cache
def shape_kernel(dim: int, kind: int, per_axis: int):
    """Node lists, S_ip and G_ip of tensor-product shape functions (tensor.py's kernel, one
    particle per thread); a particle whose support leaves the grid weighs nothing and is flagged."""

    @cuda.jit
    def kernel(x, origin, h, shape, semi, nodes, S, G, lowest, faults, slot):
        p = cuda.grid(1)
        if p >= x.shape[0]:
            return
        w = cuda.local.array((3, 4), float64)
        dw = cuda.local.array((3, 4), float64)
        base = cuda.local.array(3, int64)
        for d in range(3):
            base[d] = 0
            for a in range(4):
                w[d, a] = 1.0
                dw[d, a] = 0.0
        inside = True
        for d in range(dim):
            base[d], ok = axis_weights(kind, x[p, d], origin[d], h[d], semi[d], per_axis, shape[d], w[d], dw[d])
            inside = inside and ok
        if not inside:
            for k in range(S.shape[1]):
                nodes[p, k] = 0
                S[p, k] = 0.0
                for d in range(dim):
                    G[p, k, d] = 0.0
            cuda.atomic.min(faults, slot, p)
            return
        for d in range(dim):
            lowest[p, d] = base[d]
        fill_entries(p, base, w, dw, per_axis, dim, shape, nodes, S, G)

    return kernel


@cache
def affine_kernel(dim: int):
    """APIC: C_p = B_p D_p^-1, D_p = sum_i S_ip (x_i - x_p)(x_i - x_p)^T (extrapolate.py)."""

    @cuda.jit
    def kernel(S, lowest, offs, origin, h, x, B, C):
        p = cuda.grid(1)
        if p >= S.shape[0]:
            return
        D = cuda.local.array((3, 3), float64)
        Di = cuda.local.array((3, 3), float64)
        r = cuda.local.array(3, float64)
        affine_of(p, S, lowest, offs, origin, h, x, B, dim, D, Di, r, C)

    return kernel


@cache
def p2g_kernel(dim: int, affine: bool, ordered: bool = False):
    """Scatter m_p and m_p (v_p + C_p (x_i - x_p)) with float64 atomic adds (the masses only
    with `with_mass`); `ordered`: thread t takes particle order[t] (particles sorted by cell,
    so a warp's atomic adds fall on a few nodes)."""

    @cuda.jit
    def kernel(pmass, pvel, nodes, S, with_mass, gmass, gmom, C, lowest, offs, origin, h, xref, order):
        p = cuda.grid(1)
        if p >= S.shape[0]:
            return
        if ordered:
            p = order[p]
        mp = pmass[p]
        r = cuda.local.array(3, float64)
        for k in range(S.shape[1]):
            w = S[p, k]
            if w == 0.0:
                continue
            i = nodes[p, k]
            wm = w * mp
            if with_mass:
                cuda.atomic.add(gmass, i, wm)
            if affine:  # (written out in both: as inlined helpers, node offset and affine velocity made
                # the CPU scatter 2-3% slower, NRT decref calls 57 -> 61)
                for b in range(dim):
                    r[b] = origin[b] + (lowest[p, b] + offs[k, b]) * h[b] - xref[p, b]
                for d in range(dim):
                    vd = pvel[p, d]
                    for b in range(dim):
                        vd += C[p, d, b] * r[b]
                    cuda.atomic.add(gmom, (i, d), wm * vd)
            else:
                for d in range(dim):
                    cuda.atomic.add(gmom, (i, d), wm * pvel[p, d])

    return kernel


@cuda.jit
def rigid_volume(nodes, S, vol, mat, rigid_vol):
    p = cuda.grid(1)
    if p >= S.shape[0]:
        return
    r = mat[p]
    for k in range(S.shape[1]):
        w = S[p, k]
        if w > RIGID_MIN_WEIGHT:
            cuda.atomic.add(rigid_vol, (nodes[p, k], r), w * vol[p])


class FieldMap(NamedTuple):
    """The grid fields of this step: the nodes, then the material slots of the contact nodes
    (slot s is field nn + s at node slot_node[s]; mpmsim/contact/grid/fields.py)."""

    n_fields: int  # nn + this step's slots
    nn: int
    slot_node: object  # device array (>= 1 entry)


@cuda.jit(device=True)
def node_of(f, fm):
    return f if f < fm.nn else fm.slot_node[f - fm.nn]


@cache
def node_kernels(dim: int):
    """The per-field passes (a thread per node or material slot): ghost table, grid velocity,
    mirrors, the momentum update."""

    @cuda.jit
    def ghosts(fm, shape, face_type, wall_index, rigid_vol, constrain, slots, src, face):
        """boundary.ghost_table: a ghost slot mirrors its material's field at the mirror node."""
        f = cuda.grid(1)
        if f >= fm.n_fields:
            return
        node = node_of(f, fm)
        i, j, k = node_ijk(node, shape)
        for d in range(dim):
            mirror, fc = ghost_mirror(i, j, k, d, dim, face_type, wall_index, shape)
            face[f, d] = fc
            if mirror == -1 or rigid_holds(node, d, rigid_vol, constrain):
                src[f, d] = -1
            else:
                src[f, d] = mirror_field(f, mirror, fm.nn, slots.node_cn, slots.cn_ptr, slots.slot_group, slots.mask,
                                         slots.n_def)

    @cuda.jit
    def velocity(fm, shape, face_type, wall_index, rigid_vol, constrain, rig_vel, mass, mom, vel):
        """boundary.grid_velocity: vel = p/m with velocity conditions imposed."""
        f = cuda.grid(1)
        if f >= fm.n_fields:
            return
        node = node_of(f, fm)
        i, j, k = node_ijk(node, shape)
        m = mass[f]
        for d in range(dim):
            owner, vbc = node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain, rig_vel)
            vel[f, d] = velocity_of(owner != NO_BC, vbc, m, mom[f, d])

    @cuda.jit
    def mirror(fm, src, field):
        """boundary.mirror_ghosts."""
        f = cuda.grid(1)
        if f >= fm.n_fields:
            return
        for d in range(dim):
            mf = src[f, d]
            if mf != -1:
                field[f, d] = -field[mf, d] if mf >= 0 else 0.0

    @cuda.jit
    def fold(fm, src, face, force):
        """boundary.fold_ghost_forces (B-splines)."""
        f = cuda.grid(1)
        if f >= fm.n_fields:
            return
        for d in range(dim):
            mf = src[f, d]
            if mf >= 0 and face[f, d] // 2 == d:
                cuda.atomic.add(force, (mf, d), -force[f, d])

    @cuda.jit
    def update(fm, shape, face_type, wall_index, rigid_vol, constrain, v_start, v_end, mass, mom, force, vnew, acc,
               vstart, dt, reaction, scalars):
        """grid_update.grid_update_kernel, reactions and work added atomically. (The calls to
        node_bc and held_force stay written out here and there: one helper taking the condition
        and field arrays and calling node_bc made the CPU kernel 4.2x slower.)"""
        f = cuda.grid(1)
        if f >= fm.n_fields:
            return
        node = node_of(f, fm)
        i, j, k = node_ijk(node, shape)
        m = mass[f]
        if m <= 0.0:
            for d in range(dim):
                vnew[f, d] = 0.0
                acc[f, d] = 0.0
                vstart[f, d] = 0.0
            return
        work = 0.0
        for d in range(dim):
            owner, vbc = node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain, v_end)
            v0 = node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain, v_start)[1] \
                if owner != NO_BC else 0.0
            pd = mom[f, d]
            vstart[f, d], fd, dfc = held_force(owner != NO_BC, vbc, v0, m, pd, force[f, d], dt)
            acc[f, d] = fd / m
            vnew[f, d] = (pd + fd * dt) / m
            if owner != NO_BC:
                work += dfc * vbc * dt
                if owner != RIGID_OWNER:
                    cuda.atomic.add(reaction, (owner, d), dfc)
                else:  # shared by the rigid materials holding the node, by their volumes (bc.add_reaction)
                    wsum = held_volume(node, d, rigid_vol, constrain)
                    for r in range(constrain.shape[0]):
                        if constrain[r, d] and rigid_vol[node, r] > 0.0:
                            cuda.atomic.add(reaction, (RIGID_OWNER + r, d), dfc * rigid_vol[node, r] / wsum)
        if work != 0.0:
            cuda.atomic.add(scalars, GRID_WORK, work)

    @cuda.jit
    def mirror_update(fm, src, face, mass, mom, vnew, acc, vstart, dt, reaction):
        """grid_update.mirror_update."""
        f = cuda.grid(1)
        if f >= fm.n_fields:
            return
        m = mass[f]
        if m <= 0.0:
            return
        for d in range(dim):
            mf = src[f, d]
            if mf == -1:
                continue
            v = -vnew[mf, d] if mf >= 0 else 0.0
            cuda.atomic.add(reaction, (face[f, d], d), m * (v - vnew[f, d]) / dt)
            vnew[f, d] = v
            acc[f, d] = (v - mom[f, d] / m) / dt
            vstart[f, d] = -vstart[mf, d] if mf >= 0 else 0.0

    return ghosts, velocity, mirror, fold, update, mirror_update


@cache
def forces_kernel(dim: int, has_gravity: bool, ordered: bool = False):
    """f_i = -sum_p V_p sigma_p . G_ip + sum_p S_ip m_p g (forces.py), atomic adds (`ordered`:
    as p2g_kernel's)."""

    @cuda.jit
    def kernel(nodes, S, G, vol, stress, pmass, gravity, gforce, order):
        p = cuda.grid(1)
        if p >= S.shape[0]:
            return
        if ordered:
            p = order[p]
        vp = vol[p]
        wm = pmass[p]
        sxx, syy, szz, sxy, syz, sxz = (stress[p, 0], stress[p, 1], stress[p, 2], stress[p, 3], stress[p, 4],
                                        stress[p, 5])
        g0, g1, g2 = gravity[0], gravity[1], gravity[dim - 1]
        for k in range(S.shape[1]):
            w = S[p, k]
            i = nodes[p, k]
            gz = G[p, k, 2] if dim == 3 else 0.0
            fx, fy, fz = node_force(G[p, k, 0], G[p, k, 1], gz, w, vp, wm, sxx, syy, szz, sxy, syz, sxz, g0, g1, g2,
                                    has_gravity, dim)
            cuda.atomic.add(gforce, (i, 0), fx)
            cuda.atomic.add(gforce, (i, 1), fy)
            if dim == 3:
                cuda.atomic.add(gforce, (i, 2), fz)

    return kernel


@cache
def stress_kernel(model: int, dim: int):
    """tasks/stress.py's update for the particles of one material model (no internal energy):
    F <- (I + dt L) F, V = J V0, the model's stress, the largest wave speed + |v|."""
    m = model_of(model)
    STRESS = device_function(m.stress(dim))
    CODE = m.code
    READS_L_2D, READS_F3_2D = m.reads_L_2d, m.reads_F3_2d

    @cuda.jit
    def kernel(nodes, G, gvel, dt, v, F, stress, vol, vol0, mat, code, props, density, scalars, faults, slot, fcode,
               fvalue):
        p = cuda.grid(1)
        if p >= nodes.shape[0]:
            return
        mt = mat[p]
        if code[mt] != CODE:
            return
        K = nodes.shape[1]
        L = cuda.local.array((3, 3), float64)
        F3 = cuda.local.array((3, 3), float64)
        W = cuda.local.array((3, 3), float64)
        A = cuda.local.array((3, 3), float64)
        Ai = cuda.local.array((3, 3), float64)
        Q = cuda.local.array((3, 3), float64)
        eos = cuda.local.array(EOS_N, float64)
        for a in range(3):
            for b in range(3):
                L[a, b] = 0.0
                F3[a, b] = 0.0
        n00 = n01 = n10 = n11 = 0.0
        if dim == 2:
            l00, l01, l10, l11 = velocity_gradient_2d(p, nodes, G, gvel)
            if READS_L_2D:
                L[0, 0], L[0, 1], L[1, 0], L[1, 1] = l00, l01, l10, l11
            n00, n01, n10, n11 = deform_2d(dt, l00, l01, l10, l11, F[p, 0, 0], F[p, 0, 1], F[p, 1, 0], F[p, 1, 1])
            if READS_F3_2D:
                F3[0, 0], F3[0, 1], F3[1, 0], F3[1, 1] = n00, n01, n10, n11
                F3[2, 2] = 1.0
            J = n00 * n11 - n01 * n10
        else:
            for k in range(K):
                i = nodes[p, k]
                for a in range(3):
                    va = gvel[i, a]
                    for b in range(3):
                        L[a, b] += va * G[p, k, b]
            for a in range(3):
                for b in range(3):
                    s = F[p, a, b]
                    for mm in range(3):
                        s += dt * L[a, mm] * F[p, mm, b]
                    F3[a, b] = s
            J = det3(F3)
        if not (J > 0.0):
            fcode[p] = BAD_INVERTED
            fvalue[p] = J
            cuda.atomic.min(faults, slot, p)
            return
        if dim == 2:
            F[p, 0, 0], F[p, 0, 1], F[p, 1, 0], F[p, 1, 1] = n00, n01, n10, n11
        else:
            for a in range(3):
                for b in range(3):
                    F[p, a, b] = F3[a, b]
        vol[p] = vol0[p] * J
        # (no material state on the GPU: its models keep none, and get an empty row)
        modulus = STRESS(props[mt], L, dt, F3, J, n00, n01, n10, n11, stress[p], W, A, Ai, Q, eos, eos[:0])
        speed2 = 0.0
        for a in range(dim):
            speed2 += v[p, a] * v[p, a]
        cp = math.sqrt(modulus * J / density[mt]) + math.sqrt(speed2)
        cuda.atomic.max(scalars, WAVE, cp)
        finite = True
        for a in range(6):
            s = stress[p, a]
            if not math.isfinite(s):
                finite = False
        if not finite:
            fcode[p] = BAD_NAN
            fvalue[p] = 0.0
            cuda.atomic.min(faults, slot, p)

    return kernel


@cache
def particle_kernel(scheme: int, position: int, dim: int):
    """particle_update.py's FLIP, PIC and APIC updates, one particle per thread."""
    use_a = scheme == FLIP
    use_v = scheme == FLIP or scheme == PIC or scheme == APIC or position == UPDATED
    use_0 = scheme == FLIP or scheme == PIC

    @cuda.jit
    def kernel(nodes, S, lowest, offs, origin, h, vnew, acc, vstart, dt, x, v, B, pmass, gravity, lo, hi, scalars,
               faults, slot, fcode):
        p = cuda.grid(1)
        if p >= S.shape[0]:
            return
        K = S.shape[1]
        sa = cuda.local.array(3, float64)
        sv = cuda.local.array(3, float64)
        s0 = cuda.local.array(3, float64)
        for d in range(3):
            sa[d] = 0.0
            sv[d] = 0.0
            s0[d] = 0.0
        if scheme == APIC:
            for a in range(dim):
                for b in range(dim):
                    B[p, a, b] = 0.0
        for k in range(K):
            w = S[p, k]
            i = nodes[p, k]
            for d in range(dim):
                if use_a:
                    sa[d] += w * acc[i, d]
                if use_v:
                    sv[d] += w * vnew[i, d]
                if use_0:
                    s0[d] += w * vstart[i, d]
            if scheme == APIC:
                for b in range(dim):
                    rb = origin[b] + (lowest[p, b] + offs[k, b]) * h[b] - x[p, b]
                    for a in range(dim):
                        B[p, a, b] += w * vnew[i, a] * rb
        gwork = 0.0
        worst = MOVED
        for d in range(dim):
            v[p, d], x[p, d], gw, status = advance(scheme, position, v[p, d], x[p, d], dt, sa[d], sv[d], s0[d], 0.0,
                                                   pmass[p], gravity[d], lo[d], hi[d])
            gwork += gw
            worst = max(worst, status)
        if gwork != 0.0:
            cuda.atomic.add(scalars, GRAVITY_WORK, gwork)
        if worst != MOVED:
            fcode[p] = BAD_NAN if worst == NOT_FINITE else BAD_LEFT_GRID
            cuda.atomic.min(faults, slot, p)

    return kernel


@cuda.jit
def inside_rigid(x, origin, spacing, lo, span, owner, first, found):
    """bodies/rigid.py's penetration watch: the lowest particle inside a rigid body's lattice."""
    p = cuda.grid(1)
    if p >= x.shape[0]:
        return
    dim = x.shape[1]
    k = cuda.local.array(3, int64)
    for a in range(dim):
        k[a] = int(math.floor((x[p, a] - origin[a]) / spacing[a] - 0.5)) - lo[a]
        if k[a] < 0 or k[a] + 1 >= span[a]:
            return
    corner = 0
    for c in range(2 ** dim):
        flat = 0
        for a in range(dim):
            flat = flat * span[a] + k[a] + ((c >> a) & 1)
        if owner[flat] < 0:
            return
        if c == 0:
            corner = owner[flat]
    found[p] = corner
    cuda.atomic.min(first, 0, p)


@cache
def energy_kernel(codes: tuple):
    """The kinetic and strain energy of the particles (bodies/particles.py's sums, the two the
    energy check reads), atomic adds into out[KINETIC], out[STRAIN]."""
    ENERGY = device_function(energy_dispatch(codes)[1])

    @cuda.jit
    def kernel(v, mass, vol, F, stress, mat, code, props, out):
        p = cuda.grid(1)
        if p >= v.shape[0]:
            return
        dim = v.shape[1]
        F3 = cuda.local.array((3, 3), float64)
        v2 = 0.0
        for d in range(dim):
            v2 += v[p, d] * v[p, d]
        for a in range(3):
            for b in range(3):
                F3[a, b] = F[p, a, b] if (a < dim and b < dim) else (1.0 if a == b else 0.0)
        mt = mat[p]
        cuda.atomic.add(out, KINETIC, 0.5 * mass[p] * v2)
        cuda.atomic.add(out, STRAIN, vol[p] * ENERGY(code[mt], props[mt], F3, stress[p], det3(F3)))

    return kernel


@cuda.jit
def count_cells(nodes, count):
    """Particles per cell (a particle's cell: its lowest node), for the sorted scatter."""
    p = cuda.grid(1)
    if p < nodes.shape[0]:
        cuda.atomic.add(count, nodes[p, 0], 1)


@cuda.jit
def place_by_cell(nodes, cursor, order):
    """order[cursor[cell]++] = p: the particles grouped by cell (counting sort; within a cell
    in no particular order)."""
    p = cuda.grid(1)
    if p < nodes.shape[0]:
        order[cuda.atomic.add(cursor, nodes[p, 0], 1)] = p


@cuda.jit
def move_rigid(x, v, mat, v_start, v_end, dt):
    """Rigid particles: x += dt (v(t) + v(t+dt))/2, V = v(t+dt)."""
    p = cuda.grid(1)
    if p >= x.shape[0]:
        return
    r = mat[p]
    for d in range(x.shape[1]):
        x[p, d] += dt * (0.5 * (v_start[r, d] + v_end[r, d]))
        v[p, d] = v_end[r, d]

