"""Converged finite-element reference for a cohesive double cantilever beam (DCB).

No particles: a plain small-strain FE model of the scene the MPM benchmarks use, so
MPM load-opening curves can be judged against a converged solution of the *same*
model (elastic arms + bilinear cohesive interface) and not only against LEFM.

Model (units mm, N, MPa; unit thickness; plane strain)
  * Arms 0 <= x <= 26, h = 2 each, E = 3000, nu = 0.3.  Pre-crack 0 <= x <= a_tip = 12.25
    (traction free), bilinear cohesive interface on y = 0 for x >= a_tip.
  * Symmetric half model: only the upper arm (0 <= y <= 2) is meshed.  Mode I symmetry
    makes the interface slip zero, so u_x on y = 0 is free (one node, x = 26, y = 0, has
    u_x = 0 to remove the translation); the cohesive traction acts on y = 0 against the
    symmetry plane with total opening w = 2 u_y(x, 0).
  * Bulk: 9-node Lagrange quadrilaterals (Q9), 3x3 Gauss, uniform hx x (2/ny) mesh.
  * Interface: the quadratic edges on y = 0 are integrated with the 3-point Gauss-Lobatto
    (Simpson, i.e. nodal/lumped) rule: nodal springs with weights hx/6, 4hx/6, hx/6.
  * Load: pin load - u_y = Delta/2 prescribed at the single top-surface node (0.25, 2);
    u_x and rotation there free.  P = reaction at that node (per unit thickness).
    Reported opening delta = 2 x (mean u_y along the line x = 0.25, 0 <= y <= 2,
    line-integral mean with the element shape functions), as the MPM code measures it.
  * Cohesive law (normal): t = D w for w <= w0 = sig_c/D, linear softening to 0 at
    w_f = 2 G_c/sig_c; damage d = max_hist w_f (w - w0) / (w (w_f - w0)) in [0, 1];
    unloading to the origin with (1-d) D; compression: penalty D, no damage.
  * Solve: the bulk is linear, so it is condensed exactly (sparse LU, Schur complement)
    onto the interface u_y DOFs and the load DOF; quasi-static load-point displacement
    control with full Newton (consistent tangent) on the condensed dense system.

LEFM reference: corrected beam theory with the Williams (1989) root-rotation correction
chi (Compos. Sci. Technol. 34, 1989, doi:10.1016/0266-3538(89)90058-4).

ENF mode (mode II, full model, no symmetry): arms 0..54 x 2 mm each, u_y = 0 at the single
bottom nodes x = 2, 52 (u_x = 0 at x = 2), u_y = -Delta at the top node x = 27; pre-crack
x <= 21 is frictionless contact (normal penalty 2000 in compression only); beyond it a
bilinear shear law (K_s = 2000, tau_c = 15, G_IIc = 0.6) with linear-elastic normal springs
(D = 2000, tension and compression).  Bonded pairs beyond --x-cut (40) stay linear and are
folded into the bulk before condensation.  Deflection = mean u_y of the x = 27 section
minus the mean of the two support sections.

  python bench/cohesive_fem.py dcb --h-elem 0.125 [--json out.json]
  python bench/cohesive_fem.py enf --h-elem 0.25
"""
import argparse
import json
import time

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

E, NU = 3000.0, 0.3
H, LENGTH, A_TIP, X_LOAD = 2.0, 26.0, 12.25, 0.25


# ----------------------------------------------------------------------------- bulk
def q9_stiffness(hx, hy, e=E, nu=NU):
    """Element stiffness of a hx x hy Q9 rectangle (plane strain, 3x3 Gauss).
    Local node k = 3*b + a  (a: x index 0..2, b: y index 0..2); dofs (ux, uy) per node."""
    c = e / ((1 + nu) * (1 - 2 * nu))
    dm = c * np.array([[1 - nu, nu, 0], [nu, 1 - nu, 0], [0, 0, (1 - 2 * nu) / 2]])
    gp, gw = np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)]), np.array([5, 8, 5]) / 9.0
    n1 = lambda s: np.array([s * (s - 1) / 2, 1 - s * s, s * (s + 1) / 2])
    d1 = lambda s: np.array([s - 0.5, -2 * s, s + 0.5])
    ke = np.zeros((18, 18))
    for xi, wx in zip(gp, gw):
        for eta, wy in zip(gp, gw):
            dndx = np.outer(n1(eta), d1(xi)).ravel() * 2 / hx
            dndy = np.outer(d1(eta), n1(xi)).ravel() * 2 / hy
            b = np.zeros((3, 18))
            b[0, 0::2], b[1, 1::2] = dndx, dndy
            b[2, 0::2], b[2, 1::2] = dndy, dndx
            ke += b.T @ dm @ b * wx * wy * hx * hy / 4
    return ke


def mesh(x0, x1, y0, y1, nx, ny):
    """Uniform Q9 grid. Node id = j*NX + i on a (2nx+1) x (2ny+1) lattice."""
    NX, NY = 2 * nx + 1, 2 * ny + 1
    xs, ys = np.linspace(x0, x1, NX), np.linspace(y0, y1, NY)
    ex, ey = np.meshgrid(np.arange(nx), np.arange(ny), indexing="xy")
    ex, ey = ex.ravel(), ey.ravel()
    conn = np.stack([(2 * ey + b) * NX + 2 * ex + a for b in range(3) for a in range(3)], 1)
    return xs, ys, conn


def assemble(conn, ke, nnode):
    dofs = np.empty((conn.shape[0], 18), dtype=np.int64)
    dofs[:, 0::2], dofs[:, 1::2] = 2 * conn, 2 * conn + 1
    rows = np.repeat(dofs, 18, axis=1).ravel()
    cols = np.tile(dofs, (1, 18)).ravel()
    vals = np.tile(ke.ravel(), conn.shape[0])
    return sp.coo_matrix((vals, (rows, cols)), shape=(2 * nnode, 2 * nnode)).tocsr()


def condense(k, bdofs, fixed, vecs, block=128):
    """Exact static condensation onto bdofs (no load on the other free dofs).
    Returns S = Kbb - Kbf Kff^-1 Kfb and, for each vector v, v_b - Kbf Kff^-1 v_f
    (so that v . u = v_cond . u_b for any equilibrium state)."""
    mask = np.ones(k.shape[0], bool)
    mask[bdofs] = False
    mask[fixed] = False
    f = np.flatnonzero(mask)
    kf = k[f]
    lu = spla.splu(kf[:, f].tocsc(), permc_spec="COLAMD")
    kfb = kf[:, bdofs].tocsc()
    s = k[bdofs][:, bdofs].toarray()
    for i in range(0, len(bdofs), block):
        x = lu.solve(kfb[:, i:i + block].toarray())
        s[:, i:i + block] -= kfb.T @ x
    out = [v[bdofs] - kfb.T @ lu.solve(v[f]) for v in vecs]
    return 0.5 * (s + s.T), out


# ------------------------------------------------------------------------ cohesive
class Bilinear:
    """Triangular traction-separation law with damage, unloading to the origin."""

    def __init__(self, d=2000.0, sig=8.0, gc=0.3):
        self.d, self.sig, self.gc = d, sig, gc
        self.w0, self.wf = sig / d, 2 * gc / sig

    def damage(self, wm):
        wm = np.maximum(wm, 1e-300)
        d = self.wf * (wm - self.w0) / (wm * (self.wf - self.w0))
        return np.clip(np.where(wm > self.w0, d, 0.0), 0.0, 1.0)

    def __call__(self, w, wm_hist):
        """Traction, consistent tangent dt/dw and trial history for opening w."""
        dmg = self.damage(np.maximum(wm_hist, w))
        t = np.where(w < 0, self.d * w, (1 - dmg) * self.d * w)
        kt = np.where(w < 0, self.d, (1 - dmg) * self.d)
        load = (w >= wm_hist) & (w > self.w0)
        kt = np.where(load, np.where(w < self.wf, -self.sig / (self.wf - self.w0), 0.0), kt)
        return t, kt

    def dissipated(self, wm):
        """Energy dissipated per unit area once the maximum opening wm was reached."""
        tm = (1 - self.damage(wm)) * self.d * wm
        wc = np.minimum(wm, self.wf)
        g = 0.5 * self.sig * self.w0 + (wc - self.w0) * (self.sig + tm) / 2 - 0.5 * tm * wm
        return np.where(wm > self.w0, g, 0.0)

    def stored(self, w, wm):
        return 0.5 * np.where(w < 0, self.d, (1 - self.damage(wm)) * self.d) * w * w


# ----------------------------------------------------------------------------- DCB
def build_dcb(hx, ny):
    nx = int(round(LENGTH / hx))
    xs, ys, conn = mesh(0.0, LENGTH, 0.0, H, nx, ny)
    NX = len(xs)
    k = assemble(conn, q9_stiffness(hx, H / ny), NX * len(ys))
    ic = np.flatnonzero(xs >= A_TIP - 1e-9)               # interface nodes (j = 0)
    assert abs(xs[ic[0]] - A_TIP) < 1e-9, "a_tip must be a corner node"
    wl = np.zeros(NX)                                      # Simpson (Lobatto) weights
    for e in range(ic[0], NX - 1, 2):
        wl[e:e + 3] += hx * np.array([1, 4, 1]) / 6
    iload = int(np.argmin(abs(xs - X_LOAD)))
    assert abs(xs[iload] - X_LOAD) < 1e-9
    top = (len(ys) - 1) * NX + iload
    bdofs = np.r_[2 * ic + 1, 2 * top + 1]                 # interface u_y, load u_y
    fixed = np.array([2 * (NX - 1)])                       # u_x at (26, 0)
    m = np.zeros(k.shape[0])                               # mean u_y on x = 0.25
    wy = np.zeros(len(ys))
    for e in range(0, len(ys) - 1, 2):
        wy[e:e + 3] += np.array([1, 4, 1]) / 6 / ny
    m[2 * (np.arange(len(ys)) * NX + iload) + 1] = wy
    s, (mc,) = condense(k, bdofs, fixed, [m])
    return dict(s=s, mc=mc, x=xs[ic], wl=wl[ic], nc=len(ic))


def solve_dcb(model, law, dstep=0.005, delta_max=4.0, tol=1e-10, verbose=False):
    s, mc, x, wl, nc = (model[k] for k in ("s", "mc", "x", "wl", "nc"))
    scc, scp, spp = s[:nc, :nc], s[:nc, nc], s[nc, nc]
    uc, wm, up = np.zeros(nc), np.zeros(nc), 0.0
    rec = {k: [0.0] for k in ("delta", "P", "delta_lp", "dissipated", "failed_length",
                              "energy_error")}
    wext, dup, nfail = 0.0, dstep / 2, 0
    while rec["delta"][-1] < delta_max:
        upn = up + dup
        u = uc.copy()
        for it in range(40):
            t, kt = law(2 * u, wm)
            r = scc @ u + scp * upn + wl * t
            if np.max(abs(r)) < tol and it > 0:
                break
            u -= sla.solve(scc + np.diag(2 * wl * kt), r, assume_a="sym")
        else:
            nfail += 1
            dup /= 2
            if dup < 1e-7:
                raise RuntimeError("Newton failed at delta_lp=%g" % (2 * up))
            continue
        p = s[nc, :nc] @ u + spp * upn
        wext += 0.5 * (p + rec["P"][-1]) * 2 * (upn - up)   # both arms
        uc, up = u, upn
        w = 2 * uc
        wm = np.maximum(wm, w)
        diss = np.sum(wl * law.dissipated(wm))
        ub = np.r_[uc, up]
        energy = ub @ s @ ub + np.sum(wl * law.stored(w, wm)) + diss  # 2 x half strain
        failed = wm >= law.wf
        if failed[0]:
            k = np.argmin(failed) if not failed.all() else len(x) - 1
            xt = x[k - 1] + (x[k] - x[k - 1]) * (law.wf - wm[k - 1]) / (wm[k] - wm[k - 1])
            fl = min(xt, x[k]) - A_TIP
        else:
            fl = 0.0
        for key, v in zip(rec, (2 * mc @ ub, p, 2 * up, diss, fl,
                                (wext - energy) / max(wext, 1e-30))):
            rec[key].append(float(v))
        dup = min(dstep / 2, 1.5 * dup)
        if verbose and len(rec["P"]) % 100 == 0:
            print("  delta %.3f P %.4f" % (rec["delta"][-1], p), flush=True)
    rec["newton_cutbacks"] = nfail
    return rec


# ----------------------------------------------------------------------------- ENF
def build_enf(hx, ny, span=54.0, a=21.0, sup=(2.0, 52.0), xl=27.0, kn=2000.0, x_cut=40.0):
    """Full ENF model: two arms with coincident interface node pairs on y = 0.
    Bonded pairs with x > x_cut are linear springs folded into K before condensation
    (checked after the run to stay below the shear peak)."""
    nx = int(round(span / hx))
    xs, yb, cb = mesh(0.0, span, -H, 0.0, nx, ny)
    _, yt, ct = mesh(0.0, span, 0.0, H, nx, ny)
    NX, NY = len(xs), len(yb)
    nn = NX * NY
    k = assemble(np.vstack([cb, ct + nn]), q9_stiffness(hx, H / ny), 2 * nn)
    bot, top = (NY - 1) * NX + np.arange(NX), nn + np.arange(NX)
    wpre, wcoh = np.zeros(NX), np.zeros(NX)
    for e in range(0, NX - 1, 2):
        (wpre if xs[e + 2] <= a + 1e-9 else wcoh)[e:e + 3] += hx * np.array([1, 4, 1]) / 6
    far = xs > x_cut + 1e-9
    rows, cols, vals = [], [], []
    for comp, kk in ((0, 2000.0), (1, kn)):            # shear / normal springs
        it, ib, c = 2 * top[far] + comp, 2 * bot[far] + comp, kk * wcoh[far]
        rows += [it, ib, it, ib]; cols += [it, ib, ib, it]; vals += [c, c, -c, -c]
    k = k + sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                          shape=k.shape).tocsr()
    near = ~far
    sh = near & (wcoh > 0)
    ix = lambda v: int(np.argmin(abs(xs - v)))
    load = nn + (NY - 1) * NX + ix(xl)
    bdofs = np.r_[2 * top[near] + 1, 2 * bot[near] + 1, 2 * top[sh], 2 * bot[sh], 2 * load + 1]
    fixed = np.array([2 * ix(sup[0]) + 1, 2 * ix(sup[1]) + 1, 2 * ix(sup[0])])
    wy = np.zeros(NY)
    for e in range(0, NY - 1, 2):
        wy[e:e + 3] += np.array([1, 4, 1]) / 6 / ny / 2
    sect = []
    for xv in (xl, sup[0], sup[1]):                       # mean u_y of a full section
        v = np.zeros(k.shape[0])
        v[2 * (np.arange(NY) * NX + ix(xv)) + 1] = wy
        v[2 * (nn + np.arange(NY) * NX + ix(xv)) + 1] += wy
        sect.append(v)
    s, (m0, m1, m2) = condense(k, bdofs, fixed, sect)
    n1, n2 = near.sum(), sh.sum()
    return dict(s=s, mdefl=m0 - 0.5 * (m1 + m2), n1=n1, n2=n2, x=xs[sh], wn=wcoh[near],
                wp=wpre[near], ws=wcoh[sh], kn=kn, a=a, xcut=x_cut)


def solve_enf(m, law, dstep=0.01, dmax=5.0, tol=1e-9, verbose=False):
    s, n1, n2, wn, wp, ws, kn = (m[k] for k in ("s", "n1", "n2", "wn", "wp", "ws", "kn"))
    nb = s.shape[0] - 1
    it_, ib_ = np.r_[np.arange(n1), 2 * n1 + np.arange(n2)], np.r_[n1 + np.arange(n1),
                                                                   2 * n1 + n2 + np.arange(n2)]
    u, sm, dl = np.zeros(nb), np.zeros(n2), 0.0
    rec = {k: [0.0] for k in ("deflection", "P", "delta_lp", "dissipated", "failed_length")}
    dd, status, pk = dstep, "reached delta max", 0.0
    while dl < dmax:
        dn, v = dl + dd, u.copy()
        for itr in range(40):
            w, sl = v[:n1] - v[n1:2 * n1], v[2 * n1:2 * n1 + n2] - v[2 * n1 + n2:]
            t, kt = law(abs(sl), sm)
            fn = (wp * kn * np.minimum(w, 0) + wn * kn * w)
            kn_ = wp * kn * (w < 0) + wn * kn
            f = np.r_[fn, ws * np.sign(sl) * t]
            c = np.r_[kn_, ws * kt]
            r = s[:nb, :nb] @ v - s[:nb, nb] * dn
            r[it_] += f
            r[ib_] -= f
            if np.max(abs(r)) < tol and itr > 0:
                break
            j = s[:nb, :nb].copy()
            j[it_, it_] += c; j[ib_, ib_] += c; j[it_, ib_] -= c; j[ib_, it_] -= c
            v -= sla.solve(j, r, assume_a="sym")
        else:
            dd /= 2
            if dd < 1e-6:
                status = "Newton failed (snap-back?) at delta_lp=%.4f" % dl
                break
            continue
        u, dl = v, dn
        sm = np.maximum(sm, abs(v[2 * n1:2 * n1 + n2] - v[2 * n1 + n2:]))
        p = -(s[nb, :nb] @ u - s[nb, nb] * dl)
        failed = sm >= law.wf
        fl = m["x"][np.argmin(failed)] - m["a"] if failed[0] else 0.0
        for key, val in zip(rec, (-m["mdefl"] @ np.r_[u, -dl], p, dl,
                                  np.sum(ws * law.dissipated(sm)), fl)):
            rec[key].append(float(val))
        pk = max(pk, p)
        if p < 0.7 * pk:
            status = "P dropped below 0.7 peak"
            break
        dd = min(dstep, 1.5 * dd)
        if verbose and len(rec["P"]) % 20 == 0:
            print("  delta %.3f P %.4f" % (dl, p), flush=True)
    rec["status"], rec["max_slip_at_xcut"] = status, float(sm[-1])
    return rec


def beam_theory(gc=0.3, h=H, a0=A_TIP - X_LOAD):
    ep = E / (1 - NU ** 2)
    g_mod = E / (2 * (1 + NU))
    g = 1.18 * ep / g_mod
    chi = np.sqrt(ep / (11 * g_mod)) * (3 - 2 * (g / (1 + g)) ** 2)
    m = np.sqrt(gc * ep * h ** 3 / 12)
    return dict(chi=chi, p_peak=m / (a0 + chi * h),
                delta_peak=8 * (a0 + chi * h) ** 3 / (ep * h ** 3) * m / (a0 + chi * h),
                c0=8 * (a0 + chi * h) ** 3 / (ep * h ** 3),
                p_prop=lambda d: np.sqrt(8 * m ** 3 / (ep * h ** 3 * d)))


def summarize(rec, targets=(1.5, 2.0, 2.5, 3.0, 3.5)):
    d, p = np.array(rec["delta"]), np.array(rec["P"])
    ipk = int(np.argmax(p))
    up = np.flatnonzero(p >= 1.0)[0]
    d1 = d[up - 1] + (d[up] - d[up - 1]) * (1.0 - p[up - 1]) / (p[up] - p[up - 1])
    fl = np.array(rec["failed_length"])
    ratio = rec["dissipated"][-1] / (0.3 * fl[-1]) if fl[-1] > 0 else np.nan
    return dict(p_peak=float(p[ipk]), delta_peak=float(d[ipk]), compliance_p1=float(d1),
                p_at={t: float(np.interp(t, d, p)) for t in targets},
                diss_ratio=float(ratio), failed_length=float(fl[-1]),
                max_energy_error=float(np.max(np.abs(rec["energy_error"][10:]))))


def run_enf(a):
    ny = a.ny or int(round(H / a.h_elem))
    t0 = time.time()
    m = build_enf(a.h_elem, ny, x_cut=a.x_cut)
    t1 = time.time()
    rec = solve_enf(m, Bilinear(2000.0, 15.0, 0.6), a.dstep or 0.01, a.delta_max or 3.0,
                    verbose=a.verbose)
    t2 = time.time()
    p, dfl, dlp = (np.array(rec[k]) for k in ("P", "deflection", "delta_lp"))
    dec = np.flatnonzero(np.diff(p) < 0)          # first local maximum (the crack
    i = int(dec[0]) if len(dec) else len(p) - 1   # re-stabilises past the load point)
    ep, chi = E / (1 - NU ** 2), beam_theory()["chi"]
    ae, L = 19.0 + 0.42 * chi * H, 25.0          # crack from support; Wang-Williams 0.42 chi
    pc = 4 / (3 * ae) * np.sqrt(0.6 * ep * H ** 3)
    c = (2 * L ** 3 + 3 * ae ** 3) / (8 * ep * H ** 3)
    print("ENF full model, Q9 hx=%g ny=%d, %d+%d interface pairs, x_cut=%g; condense %.1fs,"
          " solve %.1fs, %d steps; %s" % (a.h_elem, ny, m["n1"], m["n2"], a.x_cut, t1 - t0,
                                          t2 - t1, len(p) - 1, rec["status"]))
    print("peak P %.4f N/mm at section deflection %.4f mm (load-node disp %.4f);"
          " LEFM(CBT, a+0.42chi h) P_c %.4f at %.4f (FE/LEFM %.4f)"
          % (p[i], dfl[i], dlp[i], pc, c * pc, p[i] / pc))
    pi1 = np.flatnonzero(p >= 2.0)[0]
    print("compliance (section defl/P at P~2) %.5f, LEFM %.5f; max slip at x_cut %.2e"
          " (s0 = 0.0075); failed length at end %.3f"
          % (dfl[pi1] / p[pi1], c, rec["max_slip_at_xcut"], rec["failed_length"][-1]))
    return rec, t2 - t0, ny


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("mode", choices=["dcb", "enf"])
    ap.add_argument("--h-elem", type=float, default=0.125)
    ap.add_argument("--ny", type=int, default=None, help="elements through h (default h/h_elem)")
    ap.add_argument("--dstep", type=float, default=None, help="opening/deflection increment")
    ap.add_argument("--delta-max", type=float, default=None)
    ap.add_argument("--x-cut", type=float, default=40.0, help="ENF: linear interface beyond")
    ap.add_argument("--json", default=None)
    ap.add_argument("-v", "--verbose", action="store_true")
    a = ap.parse_args()
    if a.mode == "enf":
        rec, tt, ny = run_enf(a)
        if a.json:
            with open(a.json, "w") as f:
                json.dump(dict(rec, h_elem=a.h_elem, ny=ny, time_s=tt), f)
        return
    ny = a.ny or int(round(H / a.h_elem))
    t0 = time.time()
    model = build_dcb(a.h_elem, ny)
    t1 = time.time()
    rec = solve_dcb(model, Bilinear(), a.dstep or 0.005, a.delta_max or 4.0, verbose=a.verbose)
    t2 = time.time()
    sm, bt = summarize(rec), beam_theory()
    print("DCB half model, Q9 hx=%g ny=%d, %d interface nodes; condense %.1fs, solve %.1fs,"
          " %d steps, %d cutbacks" % (a.h_elem, ny, model["nc"], t1 - t0, t2 - t1,
                                      len(rec["P"]) - 1, rec["newton_cutbacks"]))
    print("beam theory: chi=%.4f P_peak=%.4f delta_peak=%.4f C0=%.4f"
          % (bt["chi"], bt["p_peak"], bt["delta_peak"], bt["c0"]))
    print("%-26s %10s %10s %8s" % ("quantity", "FE", "beam", "FE/beam"))
    row = lambda n, f, b: print("%-26s %10.4f %10.4f %8.4f" % (n, f, b, f / b))
    row("peak P [N/mm]", sm["p_peak"], bt["p_peak"])
    row("delta at peak [mm]", sm["delta_peak"], bt["delta_peak"])
    row("compliance at P=1 [mm2/N]", sm["compliance_p1"], bt["c0"])
    for t, v in sm["p_at"].items():
        row("P at delta=%.1f" % t, v, bt["p_prop"](t))
    print("failed length %.4f mm, dissipated/(Gc*failed) %.4f, max |energy balance err| %.2e"
          % (sm["failed_length"], sm["diss_ratio"], sm["max_energy_error"]))
    if a.json:
        out = dict(rec, summary=dict(sm, p_at={str(k): v for k, v in sm["p_at"].items()}),
                   h_elem=a.h_elem, ny=ny, time_s=t2 - t0)
        with open(a.json, "w") as f:
            json.dump(out, f)


if __name__ == "__main__":
    main()
