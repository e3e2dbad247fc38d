"""Every energy term of the implicit step against central differences, at states Newton meets.

Each scene runs to the first Newton solve whose terms are all in play (contact pairs within
dhat, friction lagged, in 3D edge-edge pairs too), and stops there with the terms set up for that
step. Around that state, 20 random states per scene: for each term (FEM strain, particle strain,
barrier, lagged friction, gravity) and a random direction v, the gradient's g.v within 1e-6
(relative) of the central difference of the term's energy, and its exact Hessian's H v within
1e-5 (relative, 2-norm) of the central difference of its gradient. A sign flipped in one block
of a term's Hessian fails the same check (the test tries it on every term that has a Hessian).

Differences: the step is 1e-5 of the closest contact distance for the contact terms, 1e-4 of
it for the others, 1e-4 of the smoothing length for the friction: the truncation error
(measured: it falls as the step squared) stays near 1e-8 relative, the rounding error below
that. A directional derivative is compared relative to itself, or to 1% of |g| |v| where the
direction happens to be nearly across the gradient.

And with those Hessians, Newton's last iterations converge quadratically (the rings in contact)."""

from __future__ import annotations

import numpy as np
import pytest

from mpmsim.integrators.assembly import Assembler
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation
from tests.conftest import ROOT, deck_from
from tests.validation.helpers import example
from tests.implicit.test_fem_fem_3d import deck as deck_3d
from tests.implicit.test_fem_fem_3d import fem_box

pytestmark = pytest.mark.implicit

GRADIENT_TOL, HESSIAN_TOL = 1e-6, 1e-5
STATES = 20


class Caught(Exception):
    """Stops the run at the Newton solve the test wants."""


def newton_start(deck: dict, ready=None, step: int | None = None) -> tuple:
    """(integrator, y, y at the step's start) at the start of the first Newton solve where
    ready(integrator, y) holds (after a sweep at y), or of the step numbered `step` (from 1);
    the terms are set up for that step."""
    sim = Simulation(build_scene(deck_from(deck, ROOT / "inputs")), out_dir=None, threads=1)
    integ = sim.integrator
    solve = integ._newton

    def watch(state, u, ut, free, dt):
        if step is None or state.step + 1 == step:  # (a sweep only where it is looked at)
            y = integ.yn + u  # Newton's unknowns are the displacements from the step's start
            integ._sweep(y)
            if step is not None or ready(integ, y):
                raise Caught(y.copy())
        return solve(state, u, ut, free, dt)

    integ._newton = watch
    while sim.state.t < sim.end * (1 - 1e-12):
        try:
            sim.step()
        except Caught as caught:
            fem, grid = integ.fem, integ.grid
            yn = np.concatenate([fem.x, grid.X]) if grid is not None else fem.x.copy()  # the step's start
            return integ, caught.args[0], yn
    raise AssertionError("the terms never all came into play")


def gradient(term, y, exact=True):
    """The term's gradient (n, d) and Hessian bundles at y (its active set as swept)."""
    term.value(y)
    force = np.zeros_like(y)
    parts = term.derivatives(y, force, exact=exact)
    g = -force
    for s in parts.local:
        np.add.at(g, s.nodes, s.G)
    return g, parts.hessian


def hessian_times(hessians, v: np.ndarray) -> np.ndarray:
    """H v for the Hessian bundles (Blocks, weighted Blocks, Triplets), assembled as Newton's
    matrix is (integrators/assembly.Assembler, every unknown free)."""
    n = v.size
    H = Assembler(v.shape[1]).matrix(list(hessians), np.zeros(n), 1.0, np.arange(n))
    return (H @ v.ravel()).reshape(v.shape)


def flip_one_block(hessians, d: int):
    """The bundles with the sign of one d x d block flipped: the largest block of the first
    bundle that has local matrices (None if the term has none)."""
    for i, h in enumerate(hessians):
        if hasattr(h, "rows") or not len(h.local):
            continue
        local = h.local.copy()
        q, n = local.shape[0], local.shape[1] // d
        blocks = np.abs(local).reshape(q, n, d, n, d).max(axis=(2, 4))
        e, a, b = np.unravel_index(np.argmax(blocks), blocks.shape)
        local[e, a * d:(a + 1) * d, b * d:(b + 1) * d] *= -1.0
        return hessians[:i] + (h._replace(local=local),) + hessians[i + 1:]
    return None


def check_terms(integ, y0: np.ndarray, yn: np.ndarray, seed: int) -> dict:
    """The largest relative errors per term over STATES random states, and the smallest error
    a flipped Hessian block gives. The states: y0 moved by up to a tenth of its closest contact
    distance in each coordinate; for the lagged friction, the step's start yn moved by up to a
    fifth of its smoothing length eps_v dt (slips below it, where its Hessian is not zero)."""
    rng = np.random.default_rng(seed)
    worst: dict = {}
    delta = 0.1 * integ.barrier_term.min_distance(y0)
    for _ in range(STATES):
        ys = y0 + delta * rng.uniform(-1.0, 1.0, y0.shape)
        integ._sweep(ys)  # the active sets at this state, kept for its differences
        for term in integ.terms:
            y, eps = ys, (1e-4 if term.contact else 1e-3) * delta
            if term.lagged:
                y = yn + 0.2 * term.eps * rng.uniform(-1.0, 1.0, yn.shape)
                eps = 1e-4 * term.eps
            v = rng.uniform(-1.0, 1.0, y.shape)
            g, H = gradient(term, y)
            fd = (term.value(y + eps * v) - term.value(y - eps * v)) / (2 * eps)
            an = float(np.sum(g * v))
            gp, _ = gradient(term, y + eps * v)
            gm, _ = gradient(term, y - eps * v)
            fd_hv = (gp - gm) / (2 * eps)
            g, H = gradient(term, y)  # (the active term's local data back at y)
            hv = hessian_times(H, v)
            scale = np.linalg.norm(fd_hv)
            e = worst.setdefault(term.name, {"gradient": 0.0, "hessian": 0.0, "flipped": np.inf, "scale": 0.0})
            e["scale"] = max(e["scale"], abs(fd))
            if fd != 0.0 or an != 0.0:  # (a direction nearly across the gradient: to its size)
                size = max(abs(fd), 1e-2 * float(np.linalg.norm(g) * np.linalg.norm(v)))
                e["gradient"] = max(e["gradient"], abs(an - fd) / size)
            if scale > 0.0:
                e["hessian"] = max(e["hessian"], float(np.linalg.norm(hv - fd_hv) / scale))
                flipped = flip_one_block(H, y.shape[1])
                if flipped is not None:
                    err = float(np.linalg.norm(hessian_times(flipped, v) - fd_hv) / scale)
                    e["flipped"] = min(e["flipped"], err)
    return worst


def assert_exact(worst: dict, names: set):
    print({k: {q: f"{x:.2e}" for q, x in e.items()} for k, e in worst.items()})
    assert names <= set(worst), (names, set(worst))
    for name, e in worst.items():
        assert e["gradient"] < GRADIENT_TOL, (name, e)
        assert e["hessian"] < HESSIAN_TOL, (name, e)
        if np.isfinite(e["flipped"]):  # the check sees a sign flipped in one Hessian block
            assert e["flipped"] > 10.0 * HESSIAN_TOL, (name, e)


def contact_ready(integ, y, friction=True, edges=False) -> bool:
    """The barrier acts at y (pairs within dhat; edge-edge ones too in 3D when asked), and the
    friction term (if any) has lagged normal forces above 0.01 N."""
    b = integ.barrier_term
    if b is None or not b.in_contact or b.value(y) <= 0.0:
        return False
    if edges and not len(b.edge_current.edge):
        return False
    if friction:
        lagged = [t for t in integ.terms if t.lagged]
        return bool(lagged) and all(t.active and t.lag.mu_lambda.max() > 1e-2 for t in lagged)
    return True


def test_2d_terms_match_central_differences_particles_on_a_bent_fem_wall():
    """inputs/implicit_sine_wall_2d.yaml (MPM block, FEM sine wall and floor, friction 0.3,
    gravity): FEM strain, particle strain, barrier with the boundary-node correction at the
    wall's bends, lagged friction, gravity."""
    integ, y, yn = newton_start(example("implicit_sine_wall_2d"),
                            lambda it, y: contact_ready(it, y) and len(it.barrier_term.current.node) > 0)
    worst = check_terms(integ, y, yn, seed=1)
    assert_exact(worst, {"FEM strain energy", "particle strain energy", "barrier contact", "gravity",
                         "lagged friction"})


def test_2d_terms_match_central_differences_rings_as_they_meet():
    """inputs/implicit_rings_2d.yaml (an MPM ring on an FEM ring, midpoint Newmark): the state
    Newton solves while the rings are pressed together."""
    integ, y, yn = newton_start(example("implicit_rings_2d"), lambda it, y: contact_ready(it, y, friction=False))
    worst = check_terms(integ, y, yn, seed=2)
    assert_exact(worst, {"FEM strain energy", "particle strain energy", "barrier contact"})


@pytest.mark.validation
def test_2d_terms_match_central_differences_paper_size_rings_at_step_41():
    """The rings at the BFEMP paper's size (bench/implicit.py --paper-rings: h = 8.66 mm, FEM
    elements 15.3 mm, 20,109 particles; newton_tolerance 1e-6), at the start of step 41's Newton
    solve, where projected Newton once stalled: made here by running the deck to it (about a
    minute on one quiet thread) rather than stored. Measured: gradients within 4.3e-9, Hessians
    within 3.4e-10, a flipped block 6.7e-4 or more."""
    d = example("implicit_rings_2d")
    d["grid"]["cell_size"], d["bodies"][1]["element_size"] = 0.00866, 0.0153
    integ, y, yn = newton_start(d, step=41)
    assert integ.barrier_term.in_contact
    worst = check_terms(integ, y, yn, seed=4)
    assert_exact(worst, {"FEM strain energy", "particle strain energy", "barrier contact"})


def test_3d_terms_match_central_differences_two_fem_cubes_and_an_mpm_cube():
    """Two FEM cubes side by side and an MPM cube falling on both (tests/implicit/
    test_fem_fem_3d.py's scene, friction 0.3): point-triangle groups, edge-edge terms between
    the FEM cubes, friction on both, strain of tetrahedra and particles."""
    A = fem_box("A", (-0.1, -0.1, -0.05), (0.0, 0.0, 0.05))
    B = fem_box("B", (0.004, -0.1, -0.05), (0.104, 0.0, 0.05), (-1.0, 0.0, 0.0))
    mpm = {"name": "cube", "shape": "box", "min": [-0.05, 0.004, -0.05], "max": [0.05, 0.104, 0.05],
           "material": "m", "velocity": [0.0, -2.0, 0.0]}
    d = deck_3d([A, B, mpm], 1e-3, 0.015, friction=0.3, cell=0.05)
    d["gravity"] = [0.0, -9.81, 0.0]
    integ, y, yn = newton_start(d, lambda it, y: contact_ready(it, y, edges=True) and any(
        getattr(t, "edge_lag", None) is not None for t in it.terms))  # edge-edge friction lagged too
    worst = check_terms(integ, y, yn, seed=3)
    assert_exact(worst, {"FEM strain energy", "particle strain energy", "barrier contact", "gravity",
                         "lagged friction"})


def test_newton_converges_quadratically_in_contact():
    """inputs/implicit_rings_2d.yaml, every step while the rings press and part (steps 20-45):
    each of the last three step sizes (max |p|/dt, m/s) of every solve that took four or more
    iterations is at most 20 s/m times the previous one squared (measured: at most 4.8, e.g.
    4.8e-3, 5.6e-5, 6.9e-9). A linear rate of 0.1 per iteration fails it once the sizes are
    below 5e-3; projected Newton alone (4.8e-3, 1.9e-4, 1.0e-5, 5.3e-7) reaches 5e4."""
    sim = Simulation(build_scene(deck_from(example("implicit_rings_2d"), ROOT / "inputs")), out_dir=None,
                     threads=1)
    integ = sim.integrator
    checked = 0
    while sim.state.step < 45:
        sim.step()
        sizes = integ.newton_sizes
        if sim.state.step >= 20 and len(sizes) >= 4:
            a, b, c = sizes[-3:]
            assert b <= 20.0 * a * a and c <= 20.0 * b * b, (sim.state.step, sizes)
            checked += 1
    assert checked >= 10 and integ.exact_steps > 0
