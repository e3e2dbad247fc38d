"""`mpmsim plot`: history columns of several runs overlaid in a PNG, labelled by deck title."""

from __future__ import annotations

from typer.testing import CliRunner

from mpmsim.cli import app
from mpmsim.output.history import history_title, read_history
from mpmsim.plotting import plot_histories

from ..conftest import ROOT, simulate
from ..validation.helpers import example


def test_plot_overlays_histories_labelled_by_title(tmp_path):
    paths = []
    for scheme in ("flip", "pic"):
        deck = example("bar_vibration")
        deck.update(title=f"bar, {scheme}", update={"scheme": scheme})
        deck["time"]["end"] = 0.05
        sim = simulate(deck, ROOT / "inputs", out_dir=tmp_path / scheme)
        paths.append(sim.history.path)
    assert history_title(paths[1]) == "bar, pic"
    assert len(read_history(paths[0])["time"]) > 10  # the title line does not upset the reader
    png = tmp_path / "px.png"
    assert plot_histories(paths, "time", ["px"], png) == ["bar, flip", "bar, pic"]
    png.unlink()
    res = CliRunner().invoke(app, ["plot", *map(str, paths), "--x", "-time * 1000", "--y", "px", "--out", str(png)])
    assert res.exit_code == 0, res.output
    assert png.stat().st_size > 1000
    res = CliRunner().invoke(app, ["plot", str(paths[0]), "--y", "nonsense", "--out", str(png)])
    assert res.exit_code == 2 and "nonsense" in res.output
