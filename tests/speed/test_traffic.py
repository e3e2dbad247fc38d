"""The byte accounting of bench/traffic.py against the arrays of a real State, so that it
cannot silently go stale: every task of the step has an entry; every array it names exists
with the declared dtype size and row length; two tasks' totals equal sums computed directly
from the state's arrays; the in-cache replays leave the particles as they were."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from ..conftest import ROOT

pytestmark = pytest.mark.speed

spec = importlib.util.spec_from_file_location("traffic", ROOT / "bench" / "traffic.py")
traffic = importlib.util.module_from_spec(spec)
spec.loader.exec_module(traffic)


def tiny(name: str):
    """The benchmark deck shrunk to 64 particles (the two-block one with warm-started fits, so
    every term of the accounting applies in one of the two), stepped twice."""

    def edit(data):
        traffic.shrink(data)
        if "contact" in data:
            data["contact"]["warm_start"] = True

    sim = traffic.simulation(traffic.DECKS[name], edit=edit)
    for _ in range(2):
        sim.step()
    return sim


@pytest.fixture(scope="module")
def sims():
    return {name: tiny(name) for name in traffic.DECKS}


def row_elements(arr: np.ndarray) -> int:
    return int(np.prod(arr.shape[1:]))


def test_every_task_and_term_is_accounted(sims):
    used = set()
    for name, sim in sims.items():
        numbers = traffic.scene_numbers(sim)
        tasks = [t for t in sim.timers if t != "output"]  # the integrator's tasks and the stability check
        missing = [t for t in tasks if t not in traffic.TRAFFIC]
        assert missing == [], f"{name}: tasks without an accounting: {missing}"
        for task in tasks:
            for term in traffic.used_terms(sim, task):
                used.add((task, term))
                if term.path.startswith("tmp:"):
                    continue
                arr = traffic.resolve(sim.state, term.path)
                assert arr.itemsize == term.itemsize, (name, task, term.path, arr.dtype)
                assert row_elements(arr) == eval(term.elems, {}, numbers), (name, task, term.path, arr.shape)
    unused = [(task, t.path) for task, terms in traffic.TRAFFIC.items() for t in terms if (task, t) not in used]
    assert unused == []  # each term was checked against a state in one of the two scenes


def test_shape_function_bytes_equal_the_state_arrays(sims):
    sim = sims["column"]
    st = sim.state
    P, R, sd, rsd = st.particles, st.rigid, st.sd, st.rigid_sd
    n = P.n
    per_particle = P.x[0].nbytes + sum(a[0].nbytes for a in (sd.nodes, sd.S, sd.G, sd.lowest))
    per_rigid = R.x[0].nbytes + sum(a[0].nbytes for a in (rsd.nodes, rsd.S, rsd.G, rsd.lowest))
    expected = per_particle + per_rigid * R.n / n + st.box.fields.nbytes / n  # (one thread: the order stays)
    streamed, gathered = traffic.task_bytes(sim, "shape functions")
    assert streamed == pytest.approx(expected, rel=1e-12)
    assert gathered == 0.0
    assert per_particle == 16 + 9 * (8 + 8 + 16) + 24  # gimp in 2D: K = 9 entries


def test_stress_update_bytes_equal_the_state_arrays(sims):
    sim = sims["column"]
    st = sim.state
    P, f, box = st.particles, st.fields, st.box
    n = P.n
    nodes, G = st.entries.nodes, st.sd.G
    particle = (P.mat[0].nbytes + nodes[0].nbytes + G[0].nbytes + 2 * P.F[0].nbytes + 2 * P.vol[0].nbytes
                + P.vol0[0].nbytes + P.stress[0].nbytes + P.v[0].nbytes)
    field = (box.fields[0].nbytes + box.fnodes[0].nbytes + f.mass[0].nbytes + f.mom[0].nbytes + f.rigid_vol[0].nbytes
             + f.vel[0].nbytes + box.fields[0].nbytes + f.ghost_src[0].nbytes)  # walls: the ghost mirror
    streamed, gathered = traffic.task_bytes(sim, "update stress first")
    assert streamed == pytest.approx(particle + field * box.fields.size / n, rel=1e-12)
    assert gathered == nodes.shape[1] * f.vel[0].nbytes
    assert traffic.task_bytes(sim, "update stress last") == (streamed, gathered)


def test_replays_leave_the_particles_as_they_were(sims):
    for sim in sims.values():
        P = sim.state.particles
        before = [a.copy() for a in (P.x, P.v, P.F, P.stress, P.vol)]
        runs = traffic.replays(sim)
        for task in ("update stress first", "particle update", "shape functions"):
            runs[task](16)
        for old, new in zip(before, (P.x, P.v, P.F, P.stress, P.vol)):
            np.testing.assert_array_equal(old, new)
