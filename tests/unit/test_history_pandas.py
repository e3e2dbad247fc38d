"""The history as pandas reads it: plain column names, a units sidecar, rows in the file as
they are recorded, per-material sums, the contact force between materials against the
momentum it moves, and a restart that brings the file back to the checkpoint's rows."""

from __future__ import annotations

import copy
import json

import numba
import numpy as np
import pandas as pd
import pytest

import mpmsim
from mpmsim.errors import DeckError
from mpmsim.output.history import history_title, history_units, read_history, sidecar_path
from mpmsim.scene import build_scene
from mpmsim.solver import Simulation

from ..conftest import deck_from

pytestmark = pytest.mark.ecosystem

# A (soft) runs into B (hard) and bounces off with Coulomb friction; C (soft too) drifts far
# from both: no gravity, no wall touches a body, so contact is the only force between bodies
COLLISION = {
    "title": "two soft blocks, one hard", "units": "SI", "analysis": "plane_strain",
    "grid": {"cell_size": 0.01, "domain": {"min": [0.0, 0.0], "max": [0.5, 0.2]}},
    "shape_function": "gimp", "particles_per_direction": 2,
    "materials": {"soft": {"type": "linear_elastic", "E": 1.0e6, "nu": 0.3, "density": 1000.0},
                  "hard": {"type": "linear_elastic", "E": 4.0e6, "nu": 0.3, "density": 2000.0}},
    "bodies": [
        {"shape": "rectangle", "min": [0.05, 0.05], "max": [0.15, 0.15], "material": "soft", "velocity": [2.0, 0.5],
         "name": "A"},
        {"shape": "rectangle", "min": [0.17, 0.07], "max": [0.27, 0.13], "material": "hard", "velocity": [-1.0, 0.0],
         "name": "B"},
        {"shape": "rectangle", "min": [0.36, 0.05], "max": [0.44, 0.1], "material": "soft", "velocity": [0.0, 0.3],
         "name": "C"},
    ],
    "contact": {"normal": "logistic_regression", "default": {"law": "coulomb", "friction": 0.3}},
    "time": {"end": 0.02, "cfl": 0.4},
    "update": {"scheme": "flip", "stress": "usavg"},
    "output": {"history_interval": 1e-9, "vtu_interval": 1.0},  # a row every step
}


def _deck(**changes) -> dict:
    data = copy.deepcopy(COLLISION)
    for key, value in changes.items():
        data[key] = value
    return data


def _sim(data: dict, out=None, **kw) -> Simulation:
    return Simulation(build_scene(deck_from(data, name="collision")), out_dir=out, threads=1, **kw)


@pytest.fixture(scope="module")
def collision(tmp_path_factory):
    out = tmp_path_factory.mktemp("collision")
    sim = _sim(COLLISION, out)
    seen = []  # (rows recorded, rows in the file) after each step, read while the run goes on

    def progress(state):
        if state.step % 40 == 0:
            seen.append((len(sim.recorder.rows), len(pd.read_csv(sim.recorder.path))))

    sim.run(progress=progress)
    return sim, out, seen


def test_pandas_reads_the_csv_as_it_is(collision):
    sim, out, _ = collision
    df = pd.read_csv(out / "collision_history.csv")
    assert list(df.columns) == sim.recorder.names
    assert all(n.isidentifier() for n in df.columns)
    for name in ("time", "step", "dt", "wall_s", "sxx", "kinetic_energy", "px", "ke_A", "px_mat_soft",
                 "contact_fx_soft_hard", "contact_impulse_y_hard_soft"):
        assert name in df.columns, name
    rows = np.array(sim.recorder.rows, dtype=float)
    assert df.shape == rows.shape and df["step"].dtype == np.int64
    np.testing.assert_allclose(df.to_numpy(), rows, rtol=1e-9, atol=0)  # 10 significant digits
    assert np.all(np.diff(df["wall_s"]) >= 0) and df["wall_s"].iloc[0] >= 0


def test_the_sidecar_holds_units_title_deck_and_versions(collision, tmp_path):
    sim, out, _ = collision
    path = out / "collision_history.csv"
    meta = json.loads(sidecar_path(path).read_text())
    assert sidecar_path(path).name == "collision_history.json"
    assert list(meta["columns"]) == sim.recorder.names
    units = meta["columns"]
    assert (units["time"], units["wall_s"], units["sxx"], units["kinetic_energy"]) == ("s", "s", "Pa", "J")
    assert units["contact_fx_soft_hard"] == "N" and units["contact_impulse_x_soft_hard"] == units["px"] == "kg m/s"
    assert meta["title"] == "two soft blocks, one hard" == history_title(path)
    assert meta["deck"] == sim.scene.deck.model_dump(mode="json")
    assert meta["deck"]["contact"]["default"]["friction"] == 0.3 and meta["deck"]["update"]["scheme"] == "flip"
    assert (meta["mpmsim"], meta["numba"], meta["numpy"]) == (mpmsim.__version__, numba.__version__, np.__version__)
    assert history_units(path) == units
    # without its sidecar a history still reads: no title, no units
    alone = tmp_path / "alone_history.csv"
    alone.write_bytes(path.read_bytes())
    assert history_title(alone) == "" and history_units(alone) == {}
    assert list(read_history(alone)) == sim.recorder.names


def test_rows_are_in_the_file_as_they_are_recorded(collision):
    sim, out, seen = collision
    assert len(seen) >= 5
    assert all(in_file == recorded for recorded, in_file in seen), seen
    assert [r for r, _ in seen] == sorted(r for r, _ in seen) and seen[0][0] < len(sim.recorder.rows)
    text = (out / "collision_history.csv").read_text()
    assert text.endswith("\n") and len(text.splitlines()) == 1 + len(sim.recorder.rows)


def test_per_material_columns_are_sums_of_their_bodies_and_add_up_to_the_totals(collision):
    h = collision[0].recorder
    assert h.column("ke_A").max() > 0 and h.column("ke_C").max() > 0
    for axis in "xy":
        soft = h.column(f"p{axis}_mat_soft")
        np.testing.assert_allclose(soft, h.column(f"p{axis}_A") + h.column(f"p{axis}_C"), rtol=1e-12, atol=0)
        total = h.column(f"p{axis}")
        scale = np.abs(h.column(f"p{axis}_A")).max()
        np.testing.assert_allclose(soft + h.column(f"p{axis}_mat_hard"), total, rtol=1e-12, atol=1e-12 * scale)
    np.testing.assert_allclose(h.column("ke_mat_soft") + h.column("ke_mat_hard"), h.column("kinetic_energy"),
                               rtol=1e-12)
    np.testing.assert_allclose(h.column("se_mat_soft"), h.column("se_A") + h.column("se_C"), rtol=1e-12, atol=0)


def _contact_balance(h) -> None:
    """The impulse hard gave soft equals soft's momentum change, the force summed over the
    rows (one every step) equals the impulse, and soft gave hard the opposite."""
    dt = h.column("dt")
    for axis in "xy":
        p = h.column(f"p{axis}_mat_soft")
        impulse = h.column(f"contact_impulse_{axis}_soft_hard")
        change = p - p[0]
        assert abs(change[-1]) > 0.02 * abs(h.column("px_A")[0])  # the blocks did collide
        np.testing.assert_allclose(impulse - impulse[0], change, rtol=0, atol=1e-9 * np.abs(change).max())
        np.testing.assert_allclose(np.cumsum(h.column(f"contact_f{axis}_soft_hard")[1:] * dt[1:]), impulse[1:],
                                   rtol=0, atol=1e-12 * np.abs(impulse).max())
        np.testing.assert_allclose(h.column(f"contact_impulse_{axis}_hard_soft"), -impulse, rtol=0,
                                   atol=1e-12 * np.abs(impulse).max())
    assert h.column("contact_impulse_x_soft_hard")[-1] < 0  # B pushed A back


def test_contact_force_integrates_to_the_momentum_change_flip(collision):
    """FLIP: pass 2's force only (pass 1's change of the extrapolated momenta never reaches
    FLIP's particles)."""
    _contact_balance(collision[0].recorder)


@pytest.mark.parametrize("scheme", ["pic", "xpic"])
def test_contact_force_integrates_to_the_momentum_change(scheme):
    """PIC: pass 1 counts too; XPIC: and the contact re-imposed on the filter's increments.
    Leaving either out misses the balance by percents."""
    sim = _sim(_deck(update={"scheme": scheme, "stress": "usavg"}))
    sim.run()
    _contact_balance(sim.recorder)


def test_a_restart_leaves_exactly_the_checkpoint_rows_then_the_new_ones(tmp_path):
    data = _deck(time={"end": 0.004, "cfl": 0.4},
                 output={"history_interval": 1e-9, "vtu_interval": 1.0, "checkpoint_interval": 0.0015})
    whole = _sim(data, tmp_path / "whole")
    whole.run()
    part = _sim(data, tmp_path / "part")
    kill_at = whole.state.step - 5

    def kill():
        if part.state.step == kill_at:
            raise KeyboardInterrupt  # killed between checkpoints: the file has rows past the checkpoint

    with pytest.raises(KeyboardInterrupt):
        part.run(between_steps=kill)
    path = tmp_path / "part" / "collision_history.csv"
    left = path.read_text().splitlines()
    assert len(left) == 1 + kill_at + 1
    again = _sim(data, tmp_path / "part", resume=True)
    saved = again.resume()["step"]
    assert 0 < saved < kill_at
    assert path.read_text().splitlines() == left[: 1 + saved + 1]  # header, rows of steps 0 .. saved
    again.run()
    got, want = pd.read_csv(path), pd.read_csv(tmp_path / "whole" / "collision_history.csv")
    assert list(got.columns) == list(want.columns) and len(got) == len(want) == whole.state.step + 1
    pd.testing.assert_frame_equal(got.drop(columns="wall_s"), want.drop(columns="wall_s"), check_exact=True)


def test_names_that_would_give_one_column_twice_are_refused():
    data = _deck()
    data["bodies"][1]["material"] = "soft"
    data["bodies"][2]["material"] = "hard"
    data["bodies"][2]["name"] = "mat_soft"  # ke_mat_soft: the material's and this body's
    with pytest.raises(DeckError, match=r"bodies\.2\.name: gives history columns .*ke_mat_soft"):
        _sim(data)
