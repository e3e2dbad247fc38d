"""The seams new methods plug into: an integrator of a test's own runs through the normal run
loop with its output; history sums come from the body sets; the state is data and the
deck is not read while a run steps."""

from __future__ import annotations

import ast
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import yaml

from mpmsim.bodies import KINETIC, MASS, MOMENTUM, NSUMS, BodyInfo, BodySet, Sums
from mpmsim.deck.overrides import with_overrides
from mpmsim.integrators import Integrator
from mpmsim.output.history import History, read_history
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation

from ..conftest import ROOT, deck_from

pytestmark = pytest.mark.architecture

PACKAGE = ROOT / "mpmsim"

BLOCKS = {
    "title": "two blocks and a platen", "units": "mm-g-ms",
    "grid": {"cell_size": 1.0, "boundaries": {"ymin": "fixed"}},
    "materials": {"soft": {"type": "neo_hookean", "K": 100.0, "G": 30.0, "density": 0.001},
                  "hard": {"type": "linear_elastic", "E": 500.0, "nu": 0.3, "density": 0.002},
                  "platen": {"type": "rigid", "velocity": [0.0, -1.0]}},
    "bodies": [{"shape": "rectangle", "min": [0, 0], "max": [4, 3], "material": "soft", "name": "base",
                "velocity": [0.5, 0.0]},
               {"shape": "rectangle", "min": [0, 3], "max": [4, 5], "material": "hard", "velocity": [0.0, 0.25]},
               {"shape": "rectangle", "min": [0, 5], "max": [4, 6], "material": "platen"}],
    "time": {"end": 0.05},
    "output": {"vtu_interval": 0.01, "history_interval": 0.005},
}


class RigidOnly(Integrator):
    """A method of the test's own: rigid bodies follow their prescribed motion, nothing else
    moves. Fixed step 0.004 (the loop cuts the last one at time.end)."""

    name = "rigid only"

    def __init__(self, materials):
        super().__init__()
        self.motions = materials.motions
        self.timers = {"move rigid bodies": 0.0}
        self.plan = [("move rigid bodies", "x += dt v(t + dt/2)")]
        self.calls = 0

    def stable_dt(self, state) -> float:
        return 0.004

    def advance(self, state, dt: float) -> float:
        R = state.rigid
        R.v_start[:] = [m.velocity(state.t) for m in self.motions]
        R.v_end[:] = [m.velocity(state.t + dt) for m in self.motions]
        mean = 0.5 * (R.v_start + R.v_end)
        R.x += dt * mean[R.mat]
        R.v[:] = R.v_end[R.mat]
        R.disp += dt * mean
        self.calls += 1
        self.timers["move rigid bodies"] += 1e-6
        return dt


def test_an_integrator_of_ones_own_runs_through_the_normal_loop_with_output(tmp_path):
    scene = build_scene(deck_from(BLOCKS))
    integ = RigidOnly(scene.materials)
    sim = Simulation(scene, out_dir=tmp_path, integrator=integ)
    x0 = sim.state.particles.x.copy()
    result = sim.run()
    # 0.05 / 0.004 = 12.5: thirteen equal steps, no longer than the integrator's 0.004
    assert result.steps == integ.calls == 13
    assert sim.state.t == pytest.approx(0.05, rel=1e-12)
    assert sim.state.dt == pytest.approx(0.05 / 13, rel=1e-12)
    # the loop wrote the VTU series, the .pvd and the history on its own schedule
    sets = ET.parse(result.pvd_path).getroot().find("Collection").findall("DataSet")
    rigid = ET.parse(tmp_path / "deck_rigid.pvd").getroot().find("Collection").findall("DataSet")
    assert len(sets) == len(rigid) == 6 and len(result.files) == 12
    hist = read_history(result.history_path)
    assert np.allclose(hist["u_platen_y"], -hist["time"], rtol=1e-12, atol=1e-15)
    # nothing but the rigid body moved; the loop's checks ran and passed
    np.testing.assert_array_equal(sim.state.particles.x, x0)
    assert hist["kinetic_energy"][0] == hist["kinetic_energy"][-1] > 0.0
    # the timing table lists the integrator's own parts, then the loop's
    assert list(result.timers) == ["move rigid bodies", "check stability", "output"]


def test_an_integrator_that_breaks_the_state_is_stopped_by_the_loop(tmp_path):
    """The loop's stability check sees what any integrator leaves: a NaN velocity stops the
    run with the particle named, and the failing state is written."""
    from mpmsim.errors import InstabilityError

    class Breaks(RigidOnly):
        def advance(self, state, dt):
            super().advance(state, dt)
            if self.calls == 3:
                state.particles.v[7, 1] = np.nan
                state.flags.set(7, 1, 0.0)
            return dt

    scene = build_scene(deck_from(BLOCKS))
    sim = Simulation(scene, out_dir=tmp_path, integrator=Breaks(scene.materials))
    with pytest.raises(InstabilityError, match=r"unstable at step 3, .*particle 7 \(material 'soft'"):
        sim.run()
    assert read_history(sim.recorder.path)["step"][-1] == 3


class Probe(BodySet):
    """A body kind of the test's own with fixed sums: one body, mass 2, momentum (3, -1),
    kinetic energy 5."""

    kind = "probe"
    has_mass = True

    def __init__(self):
        self.infos = [BodyInfo(99, "probe", self.kind)]

    def sums(self, state, detail=True):
        row = np.zeros(NSUMS)
        row[MASS], row[KINETIC] = 2.0, 5.0
        row[MOMENTUM][:2] = (3.0, -1.0)
        return Sums(row.copy(), row[None, :].copy())


def test_history_sums_come_from_the_body_kinds():
    sim = Simulation(build_scene(deck_from(BLOCKS)))
    st = sim.state
    sim.recorder.record(st)
    plain = dict(zip(sim.recorder.names, sim.recorder.rows[-1]))
    st.bodies.append(Probe())
    history = History(sim.scene, st)
    history.record(st)
    row = dict(zip(history.names, history.rows[-1]))
    assert row["kinetic_energy"] == pytest.approx(plain["kinetic_energy"] + 5.0, rel=1e-14)
    assert row["px"] == pytest.approx(plain["px"] + 3.0, rel=1e-14)
    assert row["py"] == pytest.approx(plain["py"] - 1.0, rel=1e-14)
    assert row["ke_probe"] == 5.0 and row["px_probe"] == 3.0
    # the particle bodies' own columns are theirs: named bodies, default names
    P = st.particles
    for name, body in (("base", 0), ("body1", 1)):
        on = P.body == body
        assert row[f"ke_{name}"] == pytest.approx(0.5 * np.sum(P.mass[on, None] * P.v[on] ** 2), rel=1e-14)
        assert row[f"px_{name}"] == pytest.approx(np.sum(P.mass[on] * P.v[on, 0]), rel=1e-14)
    assert "ke_body2" not in row  # the platen is rigid: no mass, no sums


def test_per_body_and_angular_momentum_columns_add_up_over_a_run():
    """Two blocks colliding in contact: the per-body momenta sum to the total at every row,
    and the total angular momentum column is sum m x cross v."""
    data = yaml.safe_load((ROOT / "inputs" / "two_blocks.yaml").read_text())
    data = with_overrides(data, {"time.end": 0.5, "output.history_interval": 0.05})
    sim = Simulation(build_scene(deck_from(data, ROOT / "inputs", "two_blocks")))
    sim.run()
    h = sim.recorder
    for axis in "xy":
        np.testing.assert_allclose(h.column(f"p{axis}_body0") + h.column(f"p{axis}_body1"), h.column(f"p{axis}"),
                                   rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(h.column("ke_body0") + h.column("ke_body1"), h.column("kinetic_energy"), rtol=1e-12)
    P = sim.state.particles
    L = float(np.sum(P.mass * (P.x[:, 0] * P.v[:, 1] - P.x[:, 1] * P.v[:, 0])))
    assert h.column("L")[-1] == pytest.approx(L, rel=1e-12)


def _imports(path: Path) -> set[str]:
    """Modules a file imports, resolved to absolute dotted names within mpmsim."""
    tree = ast.parse(path.read_text())
    pkg = ".".join(path.relative_to(ROOT).with_suffix("").parts[:-1])
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            base = pkg.split(".")
            if node.level:
                base = base[: len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module
            out.add(mod)
            out.update(f"{mod}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


@pytest.mark.parametrize("module", ["state.py", "bodies/__init__.py", "bodies/particles.py", "bodies/rigid.py",
                                    "contact/grid/workspace.py", "scene/build.py", "views.py"])
def test_data_modules_import_nothing_from_the_step(module):
    """State, bodies, workspace and scene are data: they import neither tasks nor integrators,
    nor the run loop or output."""
    bad = {m for m in _imports(PACKAGE / module)
           if m.startswith(("mpmsim.tasks", "mpmsim.integrators", "mpmsim.solver", "mpmsim.output"))}
    assert not bad, f"{module} imports {sorted(bad)}"


class Sealed:
    """Stands in for the deck once the scene is built: any read fails the test."""

    def __getattr__(self, name):
        raise AssertionError(f"the deck was read after the scene was built (deck.{name})")


ALL_DECKS = sorted(p.stem for p in (ROOT / "inputs").glob("*.yaml"))


@pytest.mark.parametrize("deck", ALL_DECKS)
def test_nothing_reads_the_deck_after_the_scene_is_built(deck, tmp_path):
    """Every deck in inputs/ (particle, FEM and implicit ones): the state, the integrator, the
    stability check and the output are built from the scene, and three steps with their
    history rows, a VTU frame and a checkpoint run with the deck sealed."""
    data = yaml.safe_load((ROOT / "inputs" / f"{deck}.yaml").read_text())
    scene = build_scene(deck_from(data, ROOT / "inputs", deck))
    scene.loaded.deck = Sealed()
    sim = Simulation(scene, out_dir=tmp_path, threads=1)
    for _ in range(3):
        sim.step()
        sim.recorder.record(sim.state)
    sim._write_frame()
    sim.write_checkpoint()
    assert sim.state.step == 3


def test_the_sealed_deck_fails_a_read():
    """The test above can fail: a read of the sealed deck raises."""
    data = yaml.safe_load((ROOT / "inputs" / "two_blocks.yaml").read_text())
    scene = build_scene(deck_from(data, ROOT / "inputs", "two_blocks"))
    scene.loaded.deck = Sealed()
    with pytest.raises(AssertionError, match="deck.time"):
        scene.loaded.deck.time


BELOW_THE_SCENE = ["state.py", "loads.py", "tasks", "integrators", "contact", "augury.py", "barrier", "fem",
                   "materials", "bodies"]


def test_no_module_below_the_scene_names_the_deck():
    """grep: the modules below the scene take the resolved scene (settings, contact model,
    materials), never `deck.`; the deck's contact block is resolved in one place."""
    import re

    found = []
    for part in BELOW_THE_SCENE:
        path = PACKAGE / part
        for f in ([path] if path.is_file() else sorted(path.rglob("*.py"))):
            for k, line in enumerate(f.read_text().splitlines(), 1):
                if re.search(r"(?<![.\w])deck\.\w", line.split("#")[0]):
                    found.append(f"{f.relative_to(PACKAGE)}:{k}: {line.strip()}")
    assert not found, "\n".join(found)
    readers = sorted(str(f.relative_to(PACKAGE)) for f in PACKAGE.rglob("*.py")
                     if re.search(r"deck\.contact\b", f.read_text()) and f.parent.name != "deck")
    assert readers == ["scene/contact.py"], readers


def test_friction_and_node_materials_are_built_once():
    """The Coulomb friction table comes from the contact model and the FEM node materials
    from the scene's FEM seed: no module builds either again."""
    import re

    builders = {"friction": r"np\.full\(\(len\([\w.]*deformable\),\) \* 2",
                "node material": r"\[\w+\.cells\.ravel\(\)\] = np\.repeat"}
    for what, pattern in builders.items():
        where = sorted(str(f.relative_to(PACKAGE)) for f in PACKAGE.rglob("*.py") if re.search(pattern, f.read_text()))
        assert len(where) == 1, f"{what} table built in {where}"
