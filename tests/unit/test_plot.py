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
        paths.append(sim.recorder.path)
    assert history_title(paths[1]) == "bar, pic"
    assert len(read_history(paths[0])["time"]) > 10  # the title comes from the sidecar
    png = tmp_path / "px.png"
    assert plot_histories(paths, "time", ["px"], png) == ["bar, flip", "bar, pic"]
    png.unlink()
    res = CliRunner().invoke(app, ["plot", *map(str, paths), "--x", "-time * 1000", "--y", "px", "--out", str(png)])
    assert res.exit_code == 0, res.output
    assert png.stat().st_size > 1000
    res = CliRunner().invoke(app, ["plot", str(paths[0]), "--y", "nonsense", "--out", str(png)])
    assert res.exit_code == 2 and "nonsense" in res.output


def test_plot_axis_labels_can_be_named(tmp_path, monkeypatch):
    """An expression on an axis is labelled as written unless --xlabel/--ylabel name it."""
    import matplotlib.axes

    deck = example("bar_vibration")
    deck["time"]["end"] = 0.01
    path = simulate(deck, ROOT / "inputs", out_dir=tmp_path / "run").recorder.path
    seen = []
    for what in ("set_xlabel", "set_ylabel"):
        original = getattr(matplotlib.axes.Axes, what)
        monkeypatch.setattr(matplotlib.axes.Axes, what,
                            lambda self, text, *a, _o=original, **k: (seen.append(text), _o(self, text, *a, **k))[1])
    png = tmp_path / "p.png"
    res = CliRunner().invoke(app, ["plot", str(path), "--x", "time * 1000", "--y", "px", "--out", str(png)])
    assert res.exit_code == 0 and seen[:2] == ["time * 1000", "px [g m/s]"], (res.output, seen)
    res = CliRunner().invoke(app, ["plot", str(path), "--x", "time * 1000", "--xlabel", "time (µs)", "--y", "px",
                                   "--ylabel", "momentum", "--out", str(png)])
    assert res.exit_code == 0 and seen[2:] == ["time (µs)", "momentum"], (res.output, seen)
