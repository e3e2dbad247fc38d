"""Task: XPIC(m) / FMPM(k) null-space filtering of the grid velocity (notes §1.4, §5).

The filtered grid velocity is the series

    v* = sum_{j=0}^{m-1} (I - S+S)^j v,     (S+S q)_i = (1/m_i) sum_p m_p S_ip sum_j S_jp q_j

built incrementally, dv(1) = v, dv(l) = dv(l-1) - S+S dv(l-1), v* = sum dv(l). Components
held by velocity conditions are zeroed in every increment, so constrained nodes keep their
imposed velocity. The whole series is one numba call: m - 1 fused gather/scatter passes
over the active nodes. The result left in `vstar` is the grid velocity the particles take,
V = S vstar:

- XPIC filters the start-of-step velocity and adds the step's change: vstar = v* + (v+ - v_e).
  v_e is the start velocity with velocity conditions imposed (p/m elsewhere), so inside the
  material v+ - v_e = a dt (the published V = S(v* + a dt)), and on a constrained node v*
  starts from the imposed velocity rather than the unconstrained p/m. Seeding with p/m there
  (as the reference code does) lets a fixed wall's spurious p/m leak into every filtered
  velocity near it: a fixed-free bar then loses 4.3% of its energy in 10 periods with
  XPIC(5), against 0.002% with this seed (docs/shape-functions.md).
- FMPM filters v+ itself (already on the imposed values): vstar = v*(v+).
"""

from __future__ import annotations

from numba import njit, prange

from ..gridops import node_ijk
from .boundary import NO_BC, has_walls, mirror_ghosts, node_bc


@njit(parallel=True, cache=True)
def xpic_series(order_, ptr, nodes, S, pmass, fields, fnodes, n_box, shape, mass, vnew, vstart, filter_updated,
                m_order, face_type, wall_index, rigid_vol, constrain, rig_vel, walls, dv, tmp, vstar):
    """`nodes` are the particles' field indices (material slots at contact nodes)."""
    dim = vnew.shape[1]
    nq = fields.size
    K = S.shape[1]
    n_slab = ptr.size - 1
    for q in prange(nq):
        f = fields[q]
        for d in range(dim):
            dv[f, d] = vnew[f, d] if filter_updated else vstart[f, d]
            vstar[f, d] = dv[f, d] if filter_updated else vnew[f, d]  # v0 + (v+ - v0)
    for ell in range(2, m_order + 1):
        for q in prange(nq):
            f = fields[q]
            for d in range(dim):
                tmp[f, d] = 0.0
        # tmp = sum_p m_p S_ip (S dv)_p: gather then scatter, slab by slab
        for color in range(2):
            for s in prange((n_slab - color + 1) // 2):
                slab = color + 2 * s
                for qq in range(ptr[slab], ptr[slab + 1]):
                    p = order_[qq]
                    g0 = 0.0
                    g1 = 0.0
                    g2 = 0.0
                    for kk in range(K):
                        w = S[p, kk]
                        node = nodes[p, kk]
                        g0 += w * dv[node, 0]
                        g1 += w * dv[node, 1]
                        if dim == 3:
                            g2 += w * dv[node, 2]
                    mp = pmass[p]
                    for kk in range(K):
                        wm = S[p, kk] * mp
                        if wm == 0.0:
                            continue
                        node = nodes[p, kk]
                        tmp[node, 0] += wm * g0
                        tmp[node, 1] += wm * g1
                        if dim == 3:
                            tmp[node, 2] += wm * g2
        for q in prange(nq):
            f = fields[q]
            node = fnodes[q]
            i, j, k = node_ijk(node, shape)
            m = mass[f]
            for d in range(dim):
                if m > 0.0:
                    owner, vbc = node_bc(node, i, j, k, d, dim, face_type, wall_index, rigid_vol, constrain,
                                         rig_vel)
                    inc = 0.0 if owner != NO_BC else dv[f, d] - tmp[f, d] / m
                else:
                    inc = 0.0
                dv[f, d] = inc
        if walls:  # ghost components of the increment mirror their interior node
            mirror_ghosts(fields[:n_box], shape, face_type, wall_index, rigid_vol, constrain, dv)
        for q in prange(nq):
            f = fields[q]
            for d in range(dim):
                vstar[f, d] += dv[f, d]


def xpic(state) -> None:
    f, g, box, sd = state.fields, state.grid, state.box, state.sd
    upd = state.scene.deck.update
    xpic_series(box.order, box.ptr, state.field_index, sd.S, state.particles.mass, box.fields, box.fnodes, box.n_box,
                box.shape, f.mass, f.vnew, f.vstart, upd.scheme == "fmpm", upd.order, g.face_type, g.wall_index,
                f.rigid_vol, state.materials.constrain, state.rigid_v_end, has_walls(state), f.dv, f.tmp, f.vstar)
