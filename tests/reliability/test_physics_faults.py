"""Runs that must stop: a platen driven through the block (inputs/faults/fast_platen.yaml) and
a strip inverted by a too-large fixed step (inputs/faults/inverting_bar.yaml). Each stops with
exit 3 and one message naming the step, the time, the particle's material and body (and the
rigid body it entered); the output up to and including the failing state is kept whole."""

from __future__ import annotations

import re

import pytest
from typer.testing import CliRunner

from mpmsim.cli import EXIT_UNSTABLE, app
from mpmsim.output.history import read_history
from tests.conftest import ROOT

pytestmark = pytest.mark.reliability

CASES = [
    ("fast_platen", r"stopped at step (\d+), t = ([\d.e+-]+) ms: particle \d+ \(material 'block', body 'body1'\) "
                    r"at \(.*\) mm is inside rigid material 'bottom' \(body 'body0'\)"),
    ("inverting_bar", r"unstable at step (\d+), t = ([\d.e+-]+) ms: particle \d+ \(material 'strip', body 'strip'\) "
                      r"at \(.*\) mm: J = -[\d.e+-]+ <= 0: the particle inverted"),
]


@pytest.mark.parametrize("deck,pattern", CASES, ids=[c[0] for c in CASES])
def test_a_run_that_goes_wrong_stops_with_exit_3_naming_when_and_what(tmp_path, deck, pattern):
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["run", str(ROOT / "inputs" / "faults" / f"{deck}.yaml"), "--out", str(out),
                                      "--quiet", "--threads", "1"])
    assert result.exit_code == EXIT_UNSTABLE, result.output
    text = " ".join(result.output.split())
    found = re.search(pattern, text)
    assert found, text
    step, t = int(found.group(1)), float(found.group(2))
    assert "Traceback" not in result.output and not list(out.glob(".*.tmp"))
    history = read_history(out / f"{deck}_history.csv")
    assert history["step"][-1] == step and history["time"][-1] == pytest.approx(t, rel=1e-5)  # the failing state
    frames = []
    for pvd in out.glob("*.pvd"):  # the deformable collection, and the rigid one if any
        frames += re.findall(r'timestep="([^"]+)" group="" part="0" file="([^"]+)"', pvd.read_text())
    assert float(frames[-1][0]) == pytest.approx(t, rel=1e-5)
    assert {f for _, f in frames} == {p.name for p in out.glob("*.vtu")}


def test_the_platen_deck_at_the_paper_speed_is_not_stopped():
    """The check does not fire where contact holds: the same scene at 0.9622 m/s (compression.yaml)
    for 0.5 ms is run to the end by the validation tests; here its first 0.5 ms."""
    import yaml

    from tests.conftest import simulate

    d = yaml.safe_load((ROOT / "inputs" / "compression.yaml").read_text())
    d["time"]["end"] = 0.5
    sim = simulate(d, ROOT / "inputs", threads=1)
    assert sim.state.t == pytest.approx(0.5)


@pytest.mark.parametrize("dim", [2, 3])
def test_inside_a_rigid_body_means_more_than_half_a_spacing_past_its_surface(dim):
    """A rigid block of 4^dim particles (spacing 1, its surface at 0 and 4 along each axis),
    moved by its displacement: a centre 0.4 spacing past the surface is not inside, 0.6 is; the
    lattice follows the displacement."""
    from types import SimpleNamespace

    import numpy as np

    from mpmsim.bodies.rigid import inside_rigid

    k = np.stack(np.meshgrid(*[np.arange(4)] * dim, indexing="ij"), axis=-1).reshape(-1, dim)
    disp = np.full((1, dim), 2.25)
    rigid = SimpleNamespace(names=["platen"], mat=np.zeros(len(k), int), x0=k + 0.5, disp=disp)
    spacing, origin = np.ones(dim), np.zeros(dim)
    middle = np.full(dim, 2.0) + disp[0]
    for depth, inside in ((0.4, False), (0.6, True)):
        x = np.array([middle, middle])
        x[1, 0] = disp[0, 0] + depth  # past the surface x = 0 (moved by disp) by `depth`
        x[0, 0] = disp[0, 0] - 3.0  # well outside
        p, q = inside_rigid(x, rigid, origin, spacing)
        assert (p == 1) == inside and (q >= 0) == inside
    p, _ = inside_rigid(np.array([middle - disp[0]]), rigid, origin, spacing)  # where the block was
    assert p == -1


def test_a_stop_can_be_reported_from_a_worker_process():
    """InstabilityError survives pickling (process pools of sweeps and benchmarks)."""
    import pickle

    from mpmsim.errors import InstabilityError

    e = pickle.loads(pickle.dumps(InstabilityError("stopped at step 3", 0.5, 2)))
    assert str(e) == "stopped at step 3" and (e.time, e.step) == (0.5, 2)


@pytest.mark.parametrize("deck,key,small", [("two_blocks", "grid.cell_size", 1_000_000),
                                            ("fem_blocks_2d", "bodies.0.element_size", 10_000)])
def test_a_scene_larger_than_the_memory_is_refused_before_it_is_built(monkeypatch, deck, key, small):
    """The estimate is compared with the memory available: with less than the decks need
    (two_blocks: 390 grid nodes and up to 864 lattice sites, 1.4 MB by the per-item sizes;
    fem_blocks_2d: about 196 nodes a body, 94 kB) they are refused (exit 2, the key and the estimate named);
    with 24 GB they are not."""
    import mpmsim.scene.memory as memory

    monkeypatch.setattr(memory, "available_bytes", lambda: small)
    result = CliRunner().invoke(app, ["check", str(ROOT / "inputs" / f"{deck}.yaml")])
    assert result.exit_code == 2, result.output
    text = " ".join(result.output.split())
    assert f": {key}: " in text and "GB are available" in text and "Traceback" not in text
    monkeypatch.setattr(memory, "available_bytes", lambda: 24 << 30)
    assert CliRunner().invoke(app, ["check", str(ROOT / "inputs" / f"{deck}.yaml")]).exit_code == 0


@pytest.mark.speed
@pytest.mark.parametrize("dim", [2, 3])
def test_the_inside_rigid_search_finds_what_a_plain_search_of_every_cell_finds(dim):
    """bodies.rigid._first_inside skips the particles outside the lattice's box before its
    exact cell test; the first particle found (and its cell's owner) must be the one an exact
    test of every particle finds, here with particles scattered in and around an L-shaped
    lattice with a hole, at positions within rounding of the cell edges too."""
    import numpy as np

    from mpmsim.bodies.rigid import _first_inside

    rng = np.random.default_rng(dim)
    origin, spacing = np.array([0.3, -1.1, 0.2])[:dim], np.array([0.5, 0.25, 0.4])[:dim]
    lo, span = np.array([3, 7, 2])[:dim], np.array([6, 5, 4])[:dim]
    owner = np.arange(int(np.prod(span)), dtype=np.int64).reshape(tuple(span))
    owner[3:, 3:] = -1  # the L
    owner[1, 1] = -1  # a hole
    owner = owner.ravel()

    def plain(x):
        for p in range(len(x)):
            k = np.floor((x[p] - origin) / spacing - 0.5).astype(np.int64) - lo
            if np.any(k < 0) or np.any(k + 1 >= span):
                continue
            corners = [np.ravel_multi_index(tuple(k + np.array([(c >> a) & 1 for a in range(dim)])), tuple(span))
                       for c in range(2 ** dim)]
            if all(owner[f] >= 0 for f in corners):
                return p, int(owner[np.ravel_multi_index(tuple(k), tuple(span))])
        return -1, -1

    box_lo, box_hi = origin + (lo - 1.0) * spacing, origin + (lo + span + 1.0) * spacing
    found = 0
    for trial in range(200):
        x = rng.uniform(box_lo, box_hi, (int(rng.integers(1, 40)), dim))
        edges = origin + (lo + rng.integers(0, span, x.shape) + 0.5) * spacing  # on cell edges, +- an ulp
        pick = rng.random(x.shape) < 0.3
        x[pick] = np.nextafter(edges[pick], edges[pick] + rng.choice([-1.0, 1.0], pick.sum()))
        got = _first_inside(x, origin, spacing, lo, span, owner)
        assert got == plain(x), trial
        found += got[0] >= 0
    assert 20 < found < 190  # both outcomes seen
