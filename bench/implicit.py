"""The implicit step with barrier contact: cost per step (`make bench`).

    python bench/implicit.py [--h 0.025] [--rings-end 0.1] [--threads 1 2] [--cpu] [--tree OLD_CHECKOUT]
    python bench/implicit.py --paper-rings  # the rings at the BFEMP paper's size, whole run (make bench-rings-paper)
    python bench/implicit.py --column       # MPM column settling on an FEM floor: refinement
    python bench/implicit.py --boxes        # BFEMP §6.5: MPM box on an FEM box, refinement at 4/9/16 per cell
    python bench/implicit.py --buckling     # stacked semicircular rings, three ring-ring mu
    python bench/implicit.py --solvers      # Newton's matrices: splu against CHOLMOD (cholespy, extra `bench`)
    python bench/implicit.py --supernodal   # CHOLMOD simplicial against supernodal as the rings are refined
    python bench/implicit.py --quadrature   # 1D model: particle quadrature against B-spline knots
    python bench/implicit.py --contact3d    # 3D: an MPM cube dropped on an FEM slab, contact cost per iteration
    python bench/implicit.py --impact3d 1e-1 1e-2 1e-3   # 3D: a 20 m/s cube on a held slab at dt = f x T
    python bench/implicit.py --impact3d 1e-4  # the same at T/10^4, 30,000 steps (make bench-impact3d-fine)
    python bench/implicit.py --impact3d-window 400  # T/10^4 through the first contact, held and free: momentum
    python bench/implicit.py --impact2d 1e-4  # 2D: the tests' 20 m/s block on a held wall, whole impact

inputs/implicit_blocks_2d.yaml (FEM on FEM) at element size h, and inputs/implicit_rings_2d.yaml
(an MPM ring against an FEM ring), on 1 and 2 threads: DOFs, Newton iterations per step and the time per
step split into assembly, sparse solve, CCD and line search, after a first (compiling) step.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numba
import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
if "--tree" in sys.argv:  # time another checkout's mpmsim (old and new alternated in one sitting)
    sys.path.insert(0, str(Path(sys.argv[sys.argv.index("--tree") + 1]).resolve()))
else:
    sys.path.insert(0, str(ROOT))

from mpmsim.deck import load_deck_text  # noqa: E402
from mpmsim.contact.barrier.start import particles_inside  # noqa: E402
from mpmsim.scene import build_scene  # noqa: E402
from mpmsim.solver import Simulation  # noqa: E402


CLOCK = time.perf_counter  # --cpu: time.process_time
PAPER_RINGS = (0.00866, 0.0153)  # grid cell and FEM element size of the paper-size rings (--paper-rings)


def timed_run(sim) -> tuple[float, list]:
    """Step `sim` to its end after its first (compiling) step: (seconds, the timed steps' Newton stats)."""
    sim.reset_timers()
    first = len(sim.integrator.stats)
    t0 = CLOCK()
    while sim.state.t < sim.end * (1 - 1e-9):
        sim.step()
    return CLOCK() - t0, sim.integrator.stats[first:]


def measure(name: str, d: dict, threads: int = 1) -> None:
    numba.set_num_threads(threads)
    sim = Simulation(build_scene(load_deck_text(yaml.safe_dump(d), ROOT / "inputs" / "bench.yaml")), threads=threads)
    t0 = CLOCK()
    sim.step()
    first = CLOCK() - t0
    wall, stats = timed_run(sim)
    steps = len(stats)
    st = sim.state
    its = sum(s[0] for s in stats)
    parts = []
    dofs = 0
    if st.fem is not None:
        parts.append(f"{len(st.fem.cells)} triangles")
        dofs += st.fem.x.size - int(st.fem.held.sum())
    if sim.integrator.grid is not None:
        grid = sim.integrator.grid
        parts.append(f"{st.particles.n} particles on {grid.n} active grid nodes")
        dofs += grid.X.size
    print(f"{name}: {', '.join(parts)}, {dofs} free DOFs (last step), {steps} steps, {its / steps:.2f} Newton "
          f"iterations per step, {wall / steps * 1e3:.1f} ms per step ({wall / its * 1e3:.1f} ms per Newton "
          f"iteration), {threads} thread(s); whole run {first + wall:.1f} s ({first:.1f} s the first step, "
          f"compiling included)")
    for part, sec in sim.integrator.timers.items():
        print(f"  {part:12s} {sec / steps * 1e3:8.2f} ms/step  {100 * sec / wall:5.1f}%")
    print("  " + "\n  ".join(sim.integrator.report()))


def column_deck(h: float, per_direction: int, steps: int = 12, E: float = 1e7, contact: str = "corners",
                shift: float = 0.0, tolerance: float = 1e-7, gap: float = 1.05e-3, quadrature: str = "domain") -> dict:
    """A 0.2 x 1 MPM column (nu = 0, E, rho 1000, g 10) `gap` above a stiff FEM floor, backward
    Euler with dt = 1 s: a few steps reach the static state. `contact`: implicit.particle_contact;
    `shift`: the grid moved up by this fraction of a cell (0: the column's ends on grid lines).
    The default gap is just above dhat = 1 mm, where the column rests (0.99 mm): it barely drops
    onto the barrier, so its particles stay where they sat against the grid's knots.
    `quadrature`: implicit.particle_quadrature (domain: full order at every count)."""
    return {
        "title": "column", "units": "SI", "analysis": "plane_strain",
        "grid": {"cell_size": h, "domain": {"min": [-0.4, -0.2 + shift * h], "max": [0.4, 1.4 + shift * h]}},
        "shape_function": "bspline2", "update": {"scheme": "apic"}, "particles_per_direction": per_direction,
        "materials": {"column": {"type": "compressible_neo_hookean", "E": E, "nu": 0.0, "density": 1000.0},
                      "floor": {"type": "compressible_neo_hookean", "E": 1e10, "nu": 0.3, "density": 1000.0}},
        "bodies": [{"name": "floor", "shape": "rectangle", "min": [-0.3, -0.1], "max": [0.3, -gap],
                    "material": "floor", "discretization": "fem", "element_size": 0.05,
                    "constraints": [{"region": {"min": [-1.0, -0.2], "max": [1.0, -0.09]}}]},
                   {"name": "column", "shape": "rectangle", "min": [-0.1, 0.0], "max": [0.1, 1.0],
                    "material": "column"}],
        "gravity": [0.0, -10.0], "integrator": "implicit",
        "implicit": {"scheme": "backward_euler", "dhat": 1e-3, "kappa": 1e8, "newton_tolerance": tolerance,
                     "particle_contact": contact, "particle_quadrature": quadrature},
        "time": {"end": float(steps), "dt": 1.0},
    }


def column_exact(Y, H=1.0, rho=1000.0, g=10.0, E=1e6):
    """Static height of the material point at reference height Y in the nu = 0 neo-Hookean
    column (Y = 0 at the bottom): lambda = 0, so P_yy = mu (F - 1/F) = -rho g (H - Y), F_xx = 1."""
    mu = 0.5 * E
    Ys = np.linspace(0.0, H, 20001)
    s = -rho * g * (H - Ys) / mu
    F = 0.5 * (s + np.sqrt(s * s + 4.0))
    y = np.concatenate([[0.0], np.cumsum(0.5 * (F[1:] + F[:-1]) * np.diff(Ys))])
    return np.interp(Y, Ys, y)


def column_errors(h: float, per_direction: int, **options) -> dict:
    """Settlement of the top particle row and centre of mass, both relative to the bottom row
    (the barrier's gap drops out), and the top row's height over the row nearest Y = 0.5 (the
    upper half, away from the contact), against column_exact; `options` go to column_deck."""
    d = column_deck(h, per_direction, **options)
    E = d["materials"]["column"]["E"]
    sim = Simulation(build_scene(load_deck_text(yaml.safe_dump(d), ROOT / "inputs" / "column.yaml")), threads=1)
    P = sim.state.particles
    Y = P.x[:, 1].copy()
    sim.run()
    bottom, top = np.isclose(Y, Y.min()), np.isclose(Y, Y.max())
    y_bottom = P.x[bottom, 1].mean()
    exact_top = column_exact(Y.max(), E=E) - column_exact(Y.min(), E=E)
    exact_com = (column_exact(Y, E=E) - column_exact(Y.min(), E=E)).mean()
    settlement = (Y.max() - Y.min()) - (P.x[top, 1].mean() - y_bottom)
    exact_settlement = (Y.max() - Y.min()) - exact_top
    middle = np.unique(Y)[np.argmin(np.abs(np.unique(Y) - 0.5))]  # a row away from the contact
    upper = (P.x[top, 1].mean() - P.x[Y == middle, 1].mean()) - (column_exact(Y.max(), E=E) - column_exact(middle, E=E))
    return {"h": h, "per_direction": per_direction, "particles": P.n, "settlement": settlement,
            "exact_settlement": exact_settlement, "settlement_error": settlement - exact_settlement,
            "com_error": (P.x[:, 1] - y_bottom).mean() - exact_com, "upper_half_error": upper}


def boxes_deck(h: float, per_direction: int, steps: int = 12, E: float = 1e6, width: float = 0.2,
               dhat0: float = 1e-3, tolerance: float = 1e-8, quadrature: str = "domain") -> dict:
    """BFEMP §6.5 in 2D: a soft MPM box (`width` x 0.2, E, nu 0.3, rho 1000) stacked on a soft
    FEM box (0.4 x 0.2, the same material, its bottom held vertically and its bottom centre
    horizontally), gravity 10; grid cell = FEM element size = h, and dhat = dhat0 (h / 0.1)^2
    refined with it (a barrier gap of order h^2); the MPM box starts 1.05 dhat above the FEM box
    with contact at the particles' corners, backward Euler with dt = 1 s, PIC (the paper's)."""
    dhat = dhat0 * (h / 0.1) ** 2
    gap = 1.05 * dhat
    return {
        "title": "boxes", "units": "SI", "analysis": "plane_strain",
        "grid": {"cell_size": h, "domain": {"min": [-0.6, -0.2], "max": [0.6, 0.8]}},
        "shape_function": "bspline2", "update": {"scheme": "pic"}, "particles_per_direction": per_direction,
        "materials": {"soft": {"type": "compressible_neo_hookean", "E": E, "nu": 0.3, "density": 1000.0}},
        "bodies": [{"name": "fem_box", "shape": "rectangle", "min": [-0.2, -0.2], "max": [0.2, -gap],
                    "material": "soft", "discretization": "fem", "element_size": h,
                    "constraints": [{"region": {"min": [-1.0, -0.21], "max": [1.0, -0.19]}, "axes": ["y"]},
                                    {"region": {"min": [-1e-3, -0.21], "max": [1e-3, -0.19]}, "axes": ["x"]}]},
                   {"name": "mpm_box", "shape": "rectangle", "min": [-0.5 * width, 0.0], "max": [0.5 * width, 0.2],
                    "material": "soft"}],
        "gravity": [0.0, -10.0], "integrator": "implicit",
        "implicit": {"scheme": "backward_euler", "dhat": dhat, "kappa": 1e8, "newton_tolerance": tolerance,
                     "particle_contact": "corners", "particle_quadrature": quadrature},
        "time": {"end": float(steps), "dt": 1.0},
    }


def boxes_com(h: float, per_direction: int, **options) -> dict:
    """Height of the centre of mass of both boxes (FEM lumped masses and particles) at rest
    (the paper's measure), the drop of the MPM box's own centre of mass, and the run's Newton
    iterations; `options` go to boxes_deck."""
    d = boxes_deck(h, per_direction, **options)
    sim = Simulation(build_scene(load_deck_text(yaml.safe_dump(d), ROOT / "inputs" / "boxes.yaml")), threads=1)
    Y = sim.state.particles.x[:, 1].copy()
    t0 = time.perf_counter()
    sim.run()
    P, f = sim.state.particles, sim.state.fem
    com = (P.mass @ P.x[:, 1] + f.mass @ f.x[:, 1]) / (P.mass.sum() + f.mass.sum())
    return {"h": h, "per_direction": per_direction, "com": float(com), "particles": P.n, "triangles": len(f.cells),
            "mpm_drop": float(P.mass @ (Y - P.x[:, 1]) / P.mass.sum()),
            "speed": float(max(np.abs(P.v).max(), np.abs(f.v).max())),
            "newton": int(sum(s[0] for s in sim.integrator.stats)), "seconds": time.perf_counter() - t0}


def boxes_study(hs=(0.1, 0.05, 0.025), reference: float = 0.0125) -> None:
    """§6.5's refinement (boxes_deck): errors in the height of the centre of mass of both boxes
    against the run at h = `reference` with the same count (the paper's measure), their orders,
    and the orders from successive differences over hs and the reference."""
    for per_direction in (2, 3, 4):
        rows = [boxes_com(h, per_direction) for h in hs + (reference,)]
        c = np.array([r["com"] for r in rows])
        e = c[:-1] - c[-1]
        orders = np.log2(np.abs(e[:-1] / e[1:]))
        diffs = np.diff(c)
        successive = np.log2(np.abs(diffs[:-1] / diffs[1:]))
        print(f"  {per_direction ** 2:2d} per cell: centre of mass {c[-1]:.12f} m at h = {reference:g}; errors "
              + ", ".join(f"{x * 1e6:+.3f}" for x in e) + " um at h = " + ", ".join(f"{h:g}" for h in hs)
              + "; orders " + ", ".join(f"{o:.2f}" for o in orders) + "; from successive differences "
              + ", ".join(f"{o:.2f}" for o in successive) + f"; {sum(r['seconds'] for r in rows):.1f} s", flush=True)


def _bspline(degree: int):
    """(N, dN/dr) of the centred B-spline of degree 2 (knots at r = +-1/2, +-3/2) or 3 (at the
    integers), r = (x - node) / h."""
    if degree == 2:
        def N(r):
            a = abs(r)
            return np.where(a < 0.5, 0.75 - r * r, np.where(a < 1.5, 0.5 * (1.5 - a) ** 2, 0.0))

        def dN(r):
            a = abs(r)
            return np.where(a < 0.5, -2 * r, np.where(a < 1.5, -np.sign(r) * (1.5 - a), 0.0))
    else:
        def N(r):
            a = abs(r)
            return np.where(a < 1, 2 / 3 - r * r + 0.5 * a ** 3, np.where(a < 2, (2 - a) ** 3 / 6, 0.0))

        def dN(r):
            a = abs(r)
            return np.where(a < 1, -2 * r + 1.5 * a * r, np.where(a < 2, -np.sign(r) * 0.5 * (2 - a) ** 2, 0.0))
    return N, dN


def _bspline2_domain(R, l):
    """Averages of the quadratic B-spline N and of dN/dr over [R - l, R + l] (cell units):
    (M(R + l) - M(R - l)) / 2l and (N(R + l) - N(R - l)) / 2l, M the integral of N."""
    N, _ = _bspline(2)

    def M(r):
        return np.where(r <= -1.5, 0.0, np.where(r < -0.5, (r + 1.5) ** 3 / 6, np.where(
            r < 0.5, 0.5 + 0.75 * r - r ** 3 / 3, np.where(r < 1.5, 1 - (1.5 - r) ** 3 / 6, 1.0))))
    return (M(R + l) - M(R - l)) / (2 * l), (N(R + l) - N(R - l)) / (2 * l)


def bar_quadrature(h: float, per_cell: int, knot_offset: float = 0.0, degree: int = 2, rule: str = "points"):
    """A 1D bar [0, 1] with `per_cell` particles per cell (the lattice aligned with its ends) on
    B-spline nodes x_i = knot_offset h + i h: (nodes, particle volumes, weights S (n, nodes),
    gradients G). rule: points (N_i and N_i' at the particles, MPM's quadrature) or domain
    (their averages over the particles' domains, quadratic only: implicit_mpm.domain_weights)."""
    N, dN = _bspline(degree)
    n = int(round(1.0 / h))
    xp = (np.arange(n * per_cell) + 0.5) * (h / per_cell)
    vp = np.full_like(xp, h / per_cell)
    nodes = knot_offset * h + np.arange(-3, n + 4) * h
    R = (xp[:, None] - nodes[None, :]) / h
    if rule == "domain":
        S, G = _bspline2_domain(R, 0.5 / per_cell)
        return nodes, vp, S, G / h
    return nodes, vp, N(R), dN(R) / h


def bar_row_errors(h: float, per_cell: int, rule: str = "points", knot_offset: float = 0.0):
    """Per node of the bar: (node / h, error of sum_p v_p N_i(x_p) / h, error of sum_p v_p N_i'(x_p))
    against the exact integrals over the bar (quadratic B-splines)."""
    N, _ = _bspline(2)
    nodes, vp, S, G = bar_quadrature(h, per_cell, knot_offset, 2, rule)
    exact_S, _ = _bspline2_domain((0.5 - nodes) / h, 0.5 / h)  # the average over [0, 1] times its length 1
    exact_G = N((1.0 - nodes) / h) - N(-nodes / h)
    return nodes / h, (vp @ S - exact_S) / h, vp @ G - exact_G


def bar_model_com(h: float, per_cell: int, knot_offset: float, degree: int = 2, rule: str = "points") -> float:
    """Centre-of-mass displacement of a 1D bar [0, 1] (E = rho = g = 1) under its weight, held
    at x = 0 by a stiff point support at its end (the corner contact point), in the Galerkin
    space of B-splines on nodes x_i = knot_offset h + i h with `per_cell` particles per cell of
    [0, 1] as the quadrature (bar_quadrature's rule). Exact: -1/3."""
    N, _ = _bspline(degree)
    nodes, vp, S, G = bar_quadrature(h, per_cell, knot_offset, degree, rule)
    S, G = np.where(S > 1e-10, S, 0.0), np.where(S > 1e-10, G, 0.0)  # implicit_mpm.WEIGHT_FLOOR
    K = (G * vp[:, None]).T @ G + 1e10 * np.outer(N(-nodes / h), N(-nodes / h))
    f = -(S * vp[:, None]).sum(axis=0)
    act = np.abs(K).sum(axis=1) > 0
    u = np.zeros(len(nodes))
    u[act] = np.linalg.solve(K[np.ix_(act, act)], f[act])
    return float((S @ u * vp).sum() / vp.sum())


def quadrature_study() -> None:
    """Why 9 particles per cell (3 per direction) converge at first order with the particles'
    own weights where 4 and 16 converge at second, and how the domain averages fix it: the rows
    of the basis functions cut off by the bar's end, and a 1D bar held at its end, as the MPM
    column on the barrier with corner contact points."""
    print("Quadrature errors per row, h = 0.1, the bar's end at x = 0 on a node: node / h: "
          "error of int N_i / h, error of int N_i'")
    for rule in ("points", "domain"):
        for per in (2, 3, 4):
            at, eS, eG = bar_row_errors(0.1, per, rule)
            rows = ", ".join(f"{a:+.0f}: {s:+.2e}, {g:+.2e}" for a, s, g in zip(at, eS, eG) if -2 <= a <= 2)
            inside = (at > 1.5) & (at < round(1 / 0.1) - 1.5)
            print(f"  {rule:6s} {per} per cell: {rows}; rows whose support lies inside the bar: at most "
                  f"{np.abs(eS[inside]).max():.1e}, {np.abs(eG[inside]).max():.1e}")
    hs = [0.1, 0.05, 0.025, 0.0125]
    print("| rule | basis | nodes offset from the body's end | per cell | COM errors at h = " + ", ".join(map(str, hs))
          + " | orders |\n|---|---|---|---|---|---|")
    cases = [("points", 2, offset) for offset in (0.0, 0.25, 0.5)] + [("points", 3, 0.0), ("points", 3, 0.5)] \
        + [("domain", 2, offset) for offset in (0.0, 0.25, 0.5)]
    for (rule, degree, offset), per in ((case, per) for case in cases for per in (2, 3, 4, 40)):
        err = [abs(bar_model_com(h, per, offset, degree, rule) + 1.0 / 3.0) for h in hs]
        orders = [np.log2(err[i] / err[i + 1]) for i in range(len(err) - 1)]
        print(f"| {rule} | {'quadratic' if degree == 2 else 'cubic'} | {offset:g} h | {per} | "
              + ", ".join(f"{e:.2e}" for e in err) + " | " + ", ".join(f"{o:.2f}" for o in orders) + " |")


def column_study() -> None:
    """Errors and orders for 4/9/16 particles per cell at h = 0.1, 0.05, 0.025: particle
    contact at the centres and at the corners, E = 1e7 and 1e6 (settlement 0.5 and 5 mm), the
    column's ends on grid lines and half a cell off them, the column starting just above the
    barrier (1.05 mm) or 3 mm above the floor (it drops 2 mm onto the barrier)."""
    cases = [(1e7, "centres", 0.0, 1.05e-3), (1e7, "corners", 0.0, 1.05e-3), (1e7, "corners", 0.5, 1.05e-3),
             (1e6, "corners", 0.0, 1.05e-3), (1e7, "corners", 0.0, 3e-3)]
    for E, contact, shift, gap in cases:
        print(f"MPM column on an FEM floor, E = {E:g} (rho g H^2 / 2E = {5e3 / E * 1e3:g} mm), particle contact at "
              f"the {contact}, grid shifted by {shift:g} h, starting {gap * 1e3:g} mm above the floor: errors "
              "against the exact static column")
        for per_direction in (2, 3, 4):
            rows = [column_errors(h, per_direction, E=E, contact=contact, shift=shift, gap=gap)
                    for h in (0.1, 0.05, 0.025)]
            for a, b in zip(rows, rows[1:] + [None]):
                order = "" if b is None else \
                    f"  order to next: settlement {np.log2(abs(a['settlement_error'] / b['settlement_error'])):.2f}, " \
                    f"com {np.log2(abs(a['com_error'] / b['com_error'])):.2f}, " \
                    f"upper half {np.log2(abs(a['upper_half_error'] / b['upper_half_error'])):.2f}"
                print(f"  {per_direction ** 2:2d} per cell, h = {a['h']:<6g}: settlement {a['settlement'] * 1e3:.4f} mm "
                      f"(exact {a['exact_settlement'] * 1e3:.4f}), error {a['settlement_error'] * 1e6:+.3f} um, "
                      f"centre of mass {a['com_error'] * 1e6:+.3f} um, upper half {a['upper_half_error'] * 1e6:+.4f} um{order}")


def buckling_run(mu: float) -> dict:
    """inputs/implicit_buckling_2d.yaml with Coulomb mu between the rings: the inner ring's
    crown dip (its top face at 90 +- 35 degrees minus at 90 degrees, > 0 once the crown is
    pushed below its shoulders) every 5 steps, frames every 20, Newton statistics."""
    deck = ROOT / "inputs" / "implicit_buckling_2d.yaml"
    d = yaml.safe_load(deck.read_text())
    d["contact"]["pairs"][0] = {"between": ["outer", "inner"], "law": "coulomb" if mu > 0 else "frictionless",
                                "friction": mu}
    sim = Simulation(build_scene(load_deck_text(yaml.safe_dump(d), deck)), threads=1)
    st = sim.state
    P, f = st.particles, st.fem
    r0 = np.hypot(P.x[:, 0], P.x[:, 1])
    angle = np.degrees(np.arctan2(P.x[:, 1], P.x[:, 0]))
    face = r0 > 0.39
    crown, shoulders = face & (np.abs(angle - 90) < 3), face & (np.abs(np.abs(angle - 90) - 35) < 3)
    times, dips, frames = [], [], []
    inside, sideways = 0, 0.0
    wall = time.perf_counter()
    while st.t < sim.end * (1 - 1e-12):
        sim.step()
        inside = max(inside, int(particles_inside(P.x, f.x, f.cells).sum()))
        sideways = max(sideways, abs(P.x[crown, 0].mean()))
        if st.step % 5 == 0:
            times.append(st.t)
            dips.append(P.x[shoulders, 1].mean() - P.x[crown, 1].mean())
        if st.step % 20 == 0:
            frames.append((st.t, P.x.copy(), f.x.copy()))
    it = np.array([s[0] for s in sim.integrator.stats])
    return {"mu": mu, "t": np.array(times), "dip": np.array(dips), "frames": frames, "cells": f.cells,
            "wall": time.perf_counter() - wall, "iterations": it.mean(), "max_iterations": it.max(),
            "inside": inside, "sideways": sideways}


def buckling_study(figure: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs = [buckling_run(mu) for mu in (0.0, 0.2, 1.0)]
    print("Stacked semicircular rings (inputs/implicit_buckling_2d.yaml): inner crown dip (mm) under the plate")
    for r in runs:
        at = {round(t, 3): v for t, v in zip(r["t"], r["dip"])}
        onset = r["t"][np.argmax(r["dip"] > 5e-3)] if (r["dip"] > 5e-3).any() else float("nan")
        print(f"  mu = {r['mu']:<4g}: dip at 0.3/0.4/0.5 s {at[0.3] * 1e3:+.1f} / {at[0.4] * 1e3:+.1f} / "
              f"{at[0.5] * 1e3:+.1f} mm, past 5 mm at {onset:.3f} s; Newton {r['iterations']:.1f} iterations "
              f"per step (max {r['max_iterations']}), {r['wall']:.0f} s on 1 thread; particles inside FEM "
              f"triangles after a step: at most {r['inside']}; crown's mean x at most {r['sideways']:.1e} m")
    n = len(runs[0]["frames"])
    fig, axs = plt.subplots(len(runs), n, figsize=(2.4 * n, 1.6 * len(runs)), squeeze=False)
    for i, r in enumerate(runs):
        for j, (t, px, fx) in enumerate(r["frames"]):
            ax = axs[i, j]
            ax.triplot(fx[:, 0], fx[:, 1], r["cells"], lw=0.15, color="0.55")
            ax.scatter(px[:, 0], px[:, 1], s=0.2, c="tab:red", linewidths=0)
            ax.set_aspect("equal")
            ax.set_xlim(-0.62, 0.62)
            ax.set_ylim(-0.06, 0.56)
            ax.axis("off")
            ax.set_title(f"mu = {r['mu']:g}, t = {t:.1f} s", fontsize=7)
    fig.savefig(figure, dpi=130, bbox_inches="tight")
    print(f"figure: {figure}")


def newton_matrices(name: str, end: float, keep: int = 6, changes: dict | None = None) -> list:
    """Up to `keep` of Newton's matrices (free unknowns, full) from the deck's run to `end` with
    SuperLU, every third from the first: the step's solve is wrapped to copy them."""
    from mpmsim.integrators.solvers import NewtonSolver

    seen, kept = [], []
    original = NewtonSolver.solve

    def grab(self, A, *args, **kwargs):
        seen.append(1)
        if len(seen) % 3 == 1 and len(kept) < keep:
            kept.append(A.copy())
        return original(self, A, *args, **kwargs)

    deck = ROOT / "inputs" / name
    d = yaml.safe_load(deck.read_text())
    d["time"]["end"] = end
    d["implicit"]["linear_solver"] = "lu"
    for key, value in (changes or {}).items():  # "a.b.c": value, list items by index
        *path, last = key.split(".")
        node = d
        for k in path:
            node = node[int(k)] if isinstance(node, list) else node[k]
        node[last] = value
    NewtonSolver.solve = grab
    try:
        Simulation(build_scene(load_deck_text(yaml.safe_dump(d), deck)), threads=1).run()
    finally:
        NewtonSolver.solve = original
    return kept


def solver_study() -> None:
    import scipy.sparse as sp
    from scipy.sparse.linalg import splu

    from mpmsim.integrators.solvers import analyze

    try:
        from cholespy import CholeskySolverD, MatrixType
    except ImportError:
        print("cholespy is missing: pip install -e '.[bench]'")
        return

    def best(solve, reps=3):
        times = []
        for _ in range(reps):
            t0 = time.perf_counter()
            x = solve()
            times.append(time.perf_counter() - t0)
        return min(times), x

    print("Newton's matrices, best of 3 per solve (analysis + factorisation + solve)")
    rng = np.random.default_rng(0)
    for name, end in [("implicit_blocks_2d.yaml", 0.05), ("implicit_rings_2d.yaml", 0.03),
                      ("implicit_buckling_2d.yaml", 0.03)]:
        for A in newton_matrices(name, end):
            A = A.tocsc()
            n = A.shape[0]
            b = rng.random(n)
            C = A.tocoo()

            def cholmod():
                x = np.zeros(n)
                CholeskySolverD(n, C.row.astype(np.int32), C.col.astype(np.int32), C.data, MatrixType.COO).solve(b, x)
                return x

            runs = [best(lambda: splu(A).solve(b)), best(lambda: splu(A, permc_spec="MMD_AT_PLUS_A").solve(b)),
                    best(cholmod)]
            refactor = ""
            if analyze is not None:  # what the step does: analysis once per pattern, then refactorise
                L = sp.tril(A).tocsc()
                factor = analyze(L, mode="simplicial")

                def again():
                    factor.cholesky_inplace(L)
                    return factor(b)

                runs.append(best(again))
                refactor = f", CHOLMOD refactorisation (scikit-sparse, simplicial) {runs[3][0] * 1e3:6.2f} ms"
            res = [np.linalg.norm(A @ x - b) / np.linalg.norm(b) for _, x in runs]
            print(f"  {name:28s} n {n:5d} nnz {A.nnz:6d}: splu (COLAMD) {runs[0][0] * 1e3:6.2f} ms, splu (MMD A'+A) "
                  f"{runs[1][0] * 1e3:6.2f} ms, CHOLMOD {runs[2][0] * 1e3:6.2f} ms{refactor}; residuals "
                  + " ".join(f"{r:.1e}" for r in res))


def supernodal_study() -> None:
    """CHOLMOD's simplicial LDL^T against its supernodal LL^T (BLAS on 1 and 2 threads) on the
    rings' Newton matrices as the grid and mesh are refined: where solvers.SUPERNODAL_MIN
    comes from."""
    import scipy.sparse as sp
    from threadpoolctl import threadpool_limits

    from mpmsim.integrators.solvers import analyze

    def best(f, reps):
        f()
        times = []
        for _ in range(reps):
            t0 = time.perf_counter()
            f()
            times.append(time.perf_counter() - t0)
        return min(times) * 1e3

    print("the rings' Newton matrix after 2 steps, CHOLMOD refactorisation (analysis reused), best of 3-9")
    for h, e in [(0.04, 0.04), (0.02, 0.025), (0.0141, 0.02), (0.01, 0.0175), PAPER_RINGS]:
        A = newton_matrices("implicit_rings_2d.yaml", 0.004, 1, {"grid.cell_size": h, "bodies.1.element_size": e})[0]
        L = sp.tril(A.tocsc()).tocsc()
        n = A.shape[0]
        reps = 9 if n < 5000 else 3
        row = []
        for mode, threads in (("simplicial", 1), ("supernodal", 1), ("supernodal", 2)):
            factor = analyze(L, mode=mode)
            with threadpool_limits(limits=threads, user_api="blas"):
                row.append(best(lambda: factor.cholesky_inplace(L), reps))
        print(f"  h {h * 1e3:5.2f} mm: n {n:6d}, nnz(lower) {L.nnz:7d}: simplicial {row[0]:8.2f} ms, supernodal "
              f"{row[1]:8.2f} ms (1 thread), {row[2]:8.2f} ms (2 threads)", flush=True)


def cube_drop_deck(speed: float = 2.0, dt: float = 2e-3, end: float = 0.03) -> dict:
    """An MPM cube (0.1 m, 512 particles) dropped at `speed` onto a held FEM slab (216
    tetrahedra), backward Euler, adaptive kappa (tests/implicit/test_implicit_3d.py's scene)."""
    return {
        "title": "3D cube drop", "units": "SI", "analysis": "3d",
        "grid": {"cell_size": 0.025, "domain": {"min": [-0.2, -0.15, -0.2], "max": [0.2, 0.2, 0.2]}},
        "shape_function": "bspline2", "update": {"scheme": "apic"},
        "materials": {"m": {"type": "compressible_neo_hookean", "E": 1e6, "nu": 0.3, "density": 1000.0}},
        "bodies": [
            {"name": "slab", "shape": "box", "min": [-0.15, -0.05, -0.15], "max": [0.15, 0.0, 0.15], "material": "m",
             "discretization": "fem", "element_size": 0.05,
             "constraints": [{"region": {"min": [-1.0, -0.06, -1.0], "max": [1.0, -0.045, 1.0]}}]},
            {"name": "cube", "shape": "box", "min": [-0.04, 0.004, -0.06], "max": [0.06, 0.104, 0.04],
             "material": "m", "velocity": [0.5, -speed, 0.0]}],
        "contact": {"default": {"law": "coulomb", "friction": 0.3}},
        "integrator": "implicit",
        "implicit": {"scheme": "backward_euler", "dhat": 1e-3, "newton_tolerance": 1e-6},
        "time": {"end": end, "dt": dt},
        "output": {"history_interval": end},
    }


def contact3d_study(threads: int) -> None:
    """Per Newton iteration: the 3D barrier's broad phase and grouping (sweep), its energy with
    gradient and projected Hessian (value + derivatives), its CCD (step_bound), and the friction
    term; after a first, compiling step."""
    numba.set_num_threads(threads)
    d = cube_drop_deck()
    sim = Simulation(build_scene(load_deck_text(yaml.safe_dump(d), ROOT / "inputs" / "bench.yaml")), threads=threads)
    sim.step()
    timers: dict[str, float] = {}

    def timed(obj, name, label):
        f = getattr(obj, name)

        def wrapper(*a, **k):
            t0 = time.perf_counter()
            r = f(*a, **k)
            timers[label] = timers.get(label, 0.0) + time.perf_counter() - t0
            return r
        setattr(obj, name, wrapper)

    terms = {t.name: t for t in sim.integrator.terms}
    barrier, friction = terms["barrier contact"], terms.get("lagged friction")
    timed(barrier, "sweep", "broad phase + grouping (sweep)")
    timed(barrier, "value", "barrier energy, gradient, projected Hessian (value)")
    timed(barrier, "derivatives", "barrier scatter to the unknowns (derivatives)")
    timed(barrier, "step_bound", "CCD (step_bound)")
    if friction is not None:
        timed(friction, "value", "friction (value)")
        timed(friction, "derivatives", "friction (derivatives)")
    wall, stats = timed_run(sim)
    its = sum(s[0] for s in stats)
    groups = len(barrier.current.point)
    print(f"3D cube drop: {sim.state.particles.n} particles, {len(sim.state.fem.cells)} tetrahedra, {len(stats)} steps, "
          f"{its / len(stats):.2f} Newton iterations per step, {wall / its * 1e3:.1f} ms per iteration, "
          f"{groups} contact groups at the end, {threads} thread(s); {sim.integrator.report()[0]}")
    for label, sec in timers.items():
        print(f"  {label:55s} {sec / its * 1e3:8.2f} ms per iteration")
    for part, sec in sim.integrator.timers.items():
        print(f"  step timer: {part:42s} {sec / its * 1e3:8.2f} ms per iteration")


FAST_BLOCK_T = (0.002 + 0.05) / 20.0  # the time the fast block needs to cross its gap and the wall


def fast_block_deck(fraction: float, crossings: float = 3.0) -> dict:
    """An MPM block at 20 m/s at a thin held FEM wall (2D, adaptive kappa), dt = fraction x
    FAST_BLOCK_T, over `crossings` x FAST_BLOCK_T (3: the whole impact, the block turned back)."""
    T = FAST_BLOCK_T
    return {
        "title": "fast block", "units": "SI", "analysis": "plane_strain",
        "grid": {"cell_size": 0.02, "domain": {"min": [-0.3, -0.2], "max": [0.3, 0.2]}},
        "shape_function": "bspline2", "update": {"scheme": "apic"},
        "materials": {"m": {"type": "compressible_neo_hookean", "E": 1e6, "nu": 0.3, "density": 1000.0}},
        "bodies": [
            {"name": "wall", "shape": "rectangle", "min": [-0.003, -0.15], "max": [0.047, 0.15], "material": "m",
             "discretization": "fem", "element_size": 0.025,
             "constraints": [{"region": {"min": [0.04, -1.0], "max": [1.0, 1.0]}}]},
            {"name": "block", "shape": "rectangle", "min": [-0.1, -0.05], "max": [-0.004, 0.05],
             "material": "m", "velocity": [20.0, 0.0]},
        ],
        "integrator": "implicit",
        "implicit": {"scheme": "backward_euler", "dhat": 1e-3, "newton_tolerance": 1e-6},
        "time": {"end": crossings * T, "dt": fraction * T},
        "output": {"history_interval": crossings * T},
    }


def impact2d_study(fractions: list[float]) -> None:
    """fast_block_deck over the whole impact: every step no particle inside the wall or through it;
    Newton iterations per step, kappa, the block's velocity at the end."""
    for f in fractions:
        sim = Simulation(build_scene(load_deck_text(yaml.safe_dump(fast_block_deck(f)), ROOT / "inputs" / "bench.yaml")),
                         threads=1)
        st = sim.state
        P, fem = st.particles, st.fem
        bad = 0
        t0 = time.perf_counter()
        while st.t < sim.end * (1 - 1e-9):
            sim.step()
            bad += int(len(particles_inside(P.x, fem.x, fem.cells)) > 0 or P.x[:, 0].max() >= 0.047)
        stats = np.array(sim.integrator.stats)
        print(f"dt = {f:g} T: {len(stats)} steps, {time.perf_counter() - t0:.1f} s, Newton {stats[:, 0].mean():.2f} per "
              f"step ({stats[:, 0].max()} at most), steps with a particle inside or through: {bad}, block velocity "
              f"{P.v[:, 0].mean():+.2f} m/s at the end; {sim.integrator.report()[0].split('; ')[-1]}", flush=True)


def inside_tetrahedra(points: np.ndarray, x: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Which points lie strictly inside some tetrahedron (signed volumes of the point with each
    face all of the tetrahedron's sign)."""
    def vol(a, b, c, d):
        return np.einsum("...i,...i->...", np.cross(b - a, c - a), d - a)

    inside = np.zeros(len(points), bool)
    for e in cells:
        a, b, c, d = x[e]
        s = np.sign(vol(a, b, c, d))
        inside |= ((s * vol(points, b, c, d) > 0) & (s * vol(a, points, c, d) > 0)
                   & (s * vol(a, b, points, d) > 0) & (s * vol(a, b, c, points) > 0))
    return inside


IMPACT3D_SPEED, IMPACT3D_GAP, IMPACT3D_THICK = 20.0, 1e-3, 0.01
IMPACT3D_T = (IMPACT3D_THICK + IMPACT3D_GAP) / IMPACT3D_SPEED  # the time to cross the slab and the gap


def impact3d_deck(f: float, end: float, held: bool = True, lowered: float = 0.0) -> dict:
    """A 2 cm MPM cube (512 particles, the grid's lattice sites, the lowest 3.75 mm above the
    slab) at 20 m/s onto a 1 cm FEM slab (150 tetrahedra) held at its bottom (or free), backward
    Euler, adaptive kappa, dhat = 0.25 mm, dt = f x T, until `end`. `lowered`: the cube and the
    grid's lattice lowered by that much (the grid's origin moves, its nodes stay 5 mm apart)."""
    speed, gap, thick, T = IMPACT3D_SPEED, IMPACT3D_GAP, IMPACT3D_THICK, IMPACT3D_T
    slab = {"name": "slab", "shape": "box", "min": [-0.025, -thick, -0.025], "max": [0.025, 0.0, 0.025],
            "material": "m", "discretization": "fem", "element_size": 0.01}
    if held:
        slab["constraints"] = [{"region": {"min": [-1.0, -thick - 0.001, -1.0], "max": [1.0, -thick + 0.001, 1.0]}}]
    return {
        "title": "3D impact", "units": "SI", "analysis": "3d",
        "grid": {"cell_size": 0.005, "domain": {"min": [-0.03, -0.02 - lowered, -0.03], "max": [0.03, 0.04, 0.03]}},
        "shape_function": "bspline2", "update": {"scheme": "apic"},
        "materials": {"m": {"type": "compressible_neo_hookean", "E": 1e6, "nu": 0.3, "density": 1000.0}},
        "bodies": [slab,
                   {"name": "cube", "shape": "box", "min": [-0.01, gap + 0.00125 - lowered, -0.01],
                    "max": [0.01, gap + 0.02125 - lowered, 0.01], "material": "m", "velocity": [0.0, -speed, 0.0]}],
        "integrator": "implicit",
        "implicit": {"scheme": "backward_euler", "dhat": 2.5e-4, "newton_tolerance": 1e-6},
        "time": {"end": end, "dt": f * T},
        "output": {"history_interval": end},
    }


def impact3d_study(fractions: list[float]) -> None:
    """impact3d_deck over 3 T: the whole impact. Every step: no particle inside a tetrahedron or
    below the slab, no FEM node inside another tetrahedron, the momentum change equal to the held
    nodes' reaction impulse; the run: Newton iterations per step, kappa, the rebound speed."""
    speed, thick, T = IMPACT3D_SPEED, IMPACT3D_THICK, IMPACT3D_T
    for f in fractions:
        d = impact3d_deck(f, 3.0 * T)
        sim = Simulation(build_scene(load_deck_text(yaml.safe_dump(d), ROOT / "inputs" / "bench.yaml")), threads=1)
        st = sim.state
        P, fem = st.particles, st.fem
        reaction = held_reaction(sim.integrator)
        bad = 0
        low = np.inf
        off = 0.0  # largest |momentum change - reaction impulse| over the steps
        t0 = time.perf_counter()
        while st.t < sim.end * (1 - 1e-9):
            before = momentum(st)
            sim.step()
            off = max(off, float(np.abs(momentum(st) - before - st.dt * reaction[0]).max()))
            bad += int(inside_tetrahedra(P.x, fem.x, fem.cells).any()
                       or inside_tetrahedra(fem.x, fem.x, fem.cells).any() or P.x[:, 1].min() < -thick)
            low = min(low, float(P.x[:, 1].min()))
        stats = np.array(sim.integrator.stats)
        scale = float(np.sum(P.mass) * speed)
        print(f"dt = {f:g} T: {len(stats)} steps, {time.perf_counter() - t0:.1f} s, Newton {stats[:, 0].mean():.2f} per "
              f"step ({stats[:, 0].max()} at most), steps with a particle or node inside or through: {bad}, lowest "
              f"particle {low * 1e3:.3f} mm, cube velocity {P.v[:, 1].mean():+.2f} m/s at 3T; momentum balance "
              f"(change - held nodes' reaction impulse) worst step {off / scale:.1e} of the cube's m v0; "
              f"{sim.integrator.report()[0].split('; ')[-1]}", flush=True)


def impact3d_window(steps: int) -> None:
    """impact3d_deck at T/10^4 for `steps` steps from 91 steps before the first contact (the cube
    and the lattice lowered 3.4 mm), held and free slab: the worst step's momentum balance (held:
    change minus the reaction impulse; free: the change) and the free run's drift, in units of
    the cube's m v0, and the cube's velocity after them."""
    speed, T = IMPACT3D_SPEED, IMPACT3D_T
    for held in (True, False):
        d = impact3d_deck(1e-4, steps * 1e-4 * T, held=held, lowered=0.0034)
        sim = Simulation(build_scene(load_deck_text(yaml.safe_dump(d), ROOT / "inputs" / "bench.yaml")), threads=1)
        st = sim.state
        P = st.particles
        reaction = held_reaction(sim.integrator)
        scale = float(np.sum(P.mass) * speed)
        p0 = momentum(st)
        worst = drift = 0.0
        first = None
        t0 = time.perf_counter()
        while st.t < sim.end * (1 - 1e-9):
            before = momentum(st)
            sim.step()
            change = momentum(st) - before - (st.dt * reaction[0] if held else 0.0)
            worst = max(worst, float(np.abs(change).max()) / scale)
            drift = max(drift, float(np.abs(momentum(st) - p0).max()) / scale)
            if first is None and sim.integrator.barrier_term.in_contact:
                first = st.step
        print(f"T/10^4, slab {'held' if held else 'free'}: {st.step} steps ({time.perf_counter() - t0:.1f} s), "
              f"first contact at step {first}; worst step's momentum balance {worst:.2e} of the cube's m v0"
              + ("" if held else f", drift {drift:.2e}") + f"; cube velocity {P.v[:, 1].mean():+.4f} m/s", flush=True)


def momentum(state) -> np.ndarray:
    """Total momentum of the particles and the FEM nodes."""
    P, fem = state.particles, state.fem
    return (P.mass[:, None] * P.v).sum(0) + (fem.mass[:, None] * fem.v).sum(0)


def held_reaction(integrator) -> list:
    """The held nodes' reaction force at the end of each backward Euler step, summed: after
    Newton, the energy's gradient at the fixed unknowns over c (there the inertia term vanishes
    and the gradient is c times minus the elastic and contact force the reaction balances), so
    that a step's momentum change must equal dt times it (the free unknowns' residual is
    Newton's). Read by wrapping the integrator's solve; one list element, overwritten."""
    out = [None]
    solve = integrator._newton

    def wrapped(state, u, ut, free, dt):
        result = solve(state, u, ut, free, dt)
        integrator._sweep(integrator.yn + result[0])
        _, g, _ = integrator._energy(result[0], ut, True)
        fixed = ~free.reshape(u.shape)
        out[0] = np.where(fixed, g.reshape(u.shape), 0.0).sum(0) / integrator.c
        return result

    integrator._newton = wrapped
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--h", type=float, default=0.025, help="element size of the blocks (default 0.025)")
    ap.add_argument("--rings-end", type=float, help="end time of the rings run (default 0.1 s; 0.2 s, the deck's, "
                                                      "with --paper-rings)")
    ap.add_argument("--paper-rings", action="store_true",
                    help="the rings at the BFEMP paper's size (section 6.1: 20,098 particles, 1830 vertices, 3310 "
                         f"triangles; here h = {PAPER_RINGS[0] * 1e3:g} mm, FEM element size {PAPER_RINGS[1] * 1e3:g} mm: "
                         "20,109 particles, 1855 vertices, 3462 triangles), the whole run")
    ap.add_argument("--column", action="store_true", help="the column refinement study instead")
    ap.add_argument("--boxes", action="store_true",
                    help="BFEMP §6.5: a soft MPM box on a soft FEM box, refined with dhat, against a fine reference")
    ap.add_argument("--buckling", action="store_true",
                    help="the buckling rings for three friction coefficients instead (docs/figures/bfemp_buckling.png)")
    ap.add_argument("--solvers", action="store_true", help="splu against CHOLMOD on Newton's matrices instead")
    ap.add_argument("--supernodal", action="store_true",
                    help="CHOLMOD simplicial against supernodal (1 and 2 BLAS threads) as the rings are refined")
    ap.add_argument("--quadrature", action="store_true",
                    help="the 1D model of particle quadrature against B-spline knots instead (column orders)")
    ap.add_argument("--contact3d", action="store_true",
                    help="the 3D barrier's cost per Newton iteration instead (broad phase, assembly, CCD)")
    ap.add_argument("--impact2d", type=float, nargs="+", metavar="F",
                    help="the tests' 20 m/s block on a held wall in 2D at dt = F x the crossing time, whole impact")
    ap.add_argument("--impact3d", type=float, nargs="+", metavar="F",
                    help="a 20 m/s cube on a held slab in 3D at dt = F x the crossing time, over the whole impact")
    ap.add_argument("--impact3d-window", type=int, metavar="STEPS",
                    help="the 3D impact at T/10^4 over STEPS steps from 91 before the first contact, slab held "
                         "and free: the momentum balance per step")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2], help="thread counts (default 1 2)")
    ap.add_argument("--cpu", action="store_true",
                    help="time by this process's CPU time, not the wall clock (a shared, busy machine)")
    ap.add_argument("--tree", metavar="PATH", help="time the mpmsim of another checkout (e.g. the old commit's)")
    ap.add_argument("--no-blocks", action="store_true", help="the rings only")
    args = ap.parse_args()
    numba.set_num_threads(1)
    if args.cpu:
        import types

        import mpmsim.integrators.implicit as implicit

        global CLOCK
        CLOCK = time.process_time
        implicit.wallclock = types.SimpleNamespace(perf_counter=time.process_time)  # the step's part timers
    if args.column:
        column_study()
        return
    if args.boxes:
        boxes_study()
        return
    if args.solvers:
        solver_study()
        return
    if args.supernodal:
        supernodal_study()
        return
    if args.quadrature:
        quadrature_study()
        return
    if args.impact2d:
        impact2d_study(args.impact2d)
        return
    if args.impact3d:
        impact3d_study(args.impact3d)
        return
    if args.impact3d_window:
        impact3d_window(args.impact3d_window)
        return
    if args.contact3d:
        for threads in args.threads:
            contact3d_study(threads)
        return
    if args.buckling:
        buckling_study(ROOT / "docs" / "figures" / "bfemp_buckling.png")
        return
    d = yaml.safe_load((ROOT / "inputs" / "implicit_blocks_2d.yaml").read_text())
    for b in d["bodies"]:
        b["element_size"] = args.h
    d["output"] = {"history_interval": d["time"]["end"]}
    rings = yaml.safe_load((ROOT / "inputs" / "implicit_rings_2d.yaml").read_text())
    end = args.rings_end if args.rings_end is not None else (rings["time"]["end"] if args.paper_rings else 0.1)
    rings["time"]["end"] = end
    rings["output"] = {"history_interval": end}
    name = "implicit rings (MPM ring against FEM ring)"
    if args.paper_rings:
        rings["grid"]["cell_size"], rings["bodies"][1]["element_size"] = PAPER_RINGS
        name = f"implicit rings at the paper's size (newton_tolerance {rings['implicit']['newton_tolerance']:g})"
        args.no_blocks = True
    print(f"mpmsim from {sys.path[0]}")
    for threads in args.threads:
        if not args.no_blocks:
            measure(f"implicit blocks, h = {args.h:g}", d, threads)
        measure(name, rings, threads)


if __name__ == "__main__":
    main()
