"""The command line as a newcomer meets it (issue 76): every command's help shows its source
text whole (no bracketed word eaten as markup, such as mpmsim[cuda]), the command list gives
each command's one-line summary, --max-steps is an integer, and the errors a user makes are
answered in one line that names the file, option or deck key, without a traceback."""

from __future__ import annotations

import inspect
import re
import subprocess
import sys
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from mpmsim.cli import app

pytestmark = pytest.mark.newcomer

ROOT_COMMAND = typer.main.get_command(app)
COMMANDS = sorted(ROOT_COMMAND.commands)
BRACKETED = re.compile(r"\[[^\[\]]+\]")


def flat(text: str) -> str:
    return " ".join(text.split())


def invoke(*args: str):
    return CliRunner().invoke(app, list(args), terminal_width=100)


def source_texts(name: str | None) -> list[str]:
    """The help texts as written in mpmsim/cli.py: the docstring and every parameter's help."""
    command = ROOT_COMMAND if name is None else ROOT_COMMAND.commands[name]
    texts = [inspect.getdoc(command.callback) or ""] if command.callback is not None else []
    texts += [command.help or ""]
    texts += [getattr(p, "help", None) or "" for p in command.params]
    return [t for t in texts if t]


def test_every_command_is_covered():
    assert set(COMMANDS) >= {"run", "compile", "check", "sweep", "plot", "paraview"}


@pytest.mark.parametrize("name", [None, *COMMANDS])
def test_help_shows_every_bracketed_word_of_its_source(name):
    result = invoke(*([] if name is None else [name]), "--help")
    assert result.exit_code == 0, result.output
    shown = flat(result.output)
    words = [w for text in source_texts(name) for w in BRACKETED.findall(flat(text))]
    if name == "run":
        assert "[cuda]" in " ".join(words)  # the case that was lost
    missing = [w for w in words if w not in shown]
    assert not missing, f"{name}: lost from the rendered help: {missing}"


def test_bracket_check_can_fail():
    """Rendered with rich markup (the old setting) the run help loses [cuda]: the test above
    would see it."""
    from rich.console import Console
    from rich.text import Text

    console = Console(width=200, record=True)
    console.print(Text.from_markup("pip install 'mpmsim[cuda]'"))
    assert "[cuda]" not in console.export_text()


def test_command_list_gives_each_summary_whole():
    shown = flat(invoke("--help").output)
    for name in COMMANDS:
        summary = inspect.getdoc(ROOT_COMMAND.commands[name].callback).splitlines()[0]
        assert f"{name} {summary}" in shown, (name, summary)


def test_max_steps_and_max_frames_are_integers():
    params = {p.name: p for p in ROOT_COMMAND.commands["run"].params}
    for name, default in (("max_steps", 100_000_000), ("max_frames", 100_000)):
        assert params[name].type_descriptor.annotation is int, params[name].type_descriptor
        assert params[name].default == default and isinstance(params[name].default, int)
    shown = flat(invoke("run", "--help").output)
    assert "100000000" in shown and "100000000.0" not in shown and "100000.0" not in shown


def one_line_error(result, *names: str) -> str:
    """The message of a refused command: exit 2, no traceback, no errno, every name in it; its
    lines (the deck errors' header `mpmsim: bad deck` aside) one."""
    assert result.exit_code == 2, result.output
    text = result.output
    assert "Traceback" not in text and "[Errno" not in text, text
    lines = [ln for ln in text.strip().splitlines() if ln.strip() and ln.strip() != "mpmsim: bad deck"]
    assert len(lines) == 1, text
    for name in names:
        assert name in lines[0], (name, text)
    return lines[0]


def history(tmp_path):
    path = tmp_path / "h_history.csv"
    path.write_text("time,syy\n0,1\n1,2\n")
    return path


def test_plot_of_a_missing_file(tmp_path):
    line = one_line_error(invoke("plot", str(tmp_path / "missing.csv"), "--y", "syy"), "missing.csv")
    assert "no such file" in line


def test_plot_of_a_folder(tmp_path):
    one_line_error(invoke("plot", str(tmp_path), "--y", "syy"), str(tmp_path), "folder")


def test_plot_of_a_file_that_is_not_a_history(tmp_path):
    path = tmp_path / "text.csv"
    path.write_text("a,b\n1,x\n")
    one_line_error(invoke("plot", str(path), "--y", "b"), "text.csv", "not a history CSV")


def test_plot_of_a_missing_column(tmp_path):
    one_line_error(invoke("plot", str(history(tmp_path)), "--y", "sxx"), "--y sxx", "syy")


def test_plot_of_an_expression_that_does_not_parse(tmp_path):
    one_line_error(invoke("plot", str(history(tmp_path)), "--y", "syy +"), "--y syy +", "expression")


def test_plot_to_a_path_it_cannot_write(tmp_path):
    (tmp_path / "plain").write_text("x")
    out = tmp_path / "plain" / "p.png"  # below a regular file
    one_line_error(invoke("plot", str(history(tmp_path)), "--y", "syy", "--out", str(out)), "--out", str(out))


DECK = """title: t
units: mm-g-ms
analysis: plane_strain
grid: {{cell_size: {cell_size}}}
materials:
  a: {{type: neo_hookean, K: 1000.0, G: 500.0, density: 0.001}}
  p: {{type: rigid, velocity: {velocity}}}
bodies:
  - {{shape: rectangle, min: [0.0, 0.0], max: [1.0, 1.0], material: a}}
  - {{shape: rectangle, min: [0.0, 1.0], max: [1.0, 1.25], material: p}}
time: {{end: 0.001}}
"""


def deck(tmp_path, cell_size="0.25", velocity="[0.0, -1.0]"):
    path = tmp_path / "d.yaml"
    path.write_text(DECK.format(cell_size=cell_size, velocity=velocity))
    return str(path)


def test_the_deck_itself_is_good(tmp_path):
    assert invoke("check", deck(tmp_path)).exit_code == 0


def test_a_unit_string_for_cell_size(tmp_path):
    line = one_line_error(invoke("check", deck(tmp_path, cell_size="0.025mm")), "d.yaml, line 4", "grid.cell_size:")
    assert "'0.025mm' is not a number or a list of numbers" in line and "write 0.025" in line
    assert ".float" not in line and ".list" not in line


def test_a_value_no_form_of_a_union_accepts(tmp_path):
    """The rule is general: a rigid velocity is a list of numbers or a table {times, values}."""
    line = one_line_error(invoke("check", deck(tmp_path, velocity="fast")), "materials.p.velocity:")
    assert "'fast' is not a list of numbers (one per axis) or a mapping with keys times, values" in line
    assert "VelocityTable" not in line


def test_a_fault_inside_one_form_of_a_union_is_named_there(tmp_path):
    line = one_line_error(invoke("check", deck(tmp_path, cell_size="[0.25, abc]")), "grid.cell_size.1:")
    assert "number" in line


def test_a_bracketed_word_in_a_deck_error_is_shown(tmp_path):
    """Deck errors go through rich: a value such as '[bold]' is text, not a style tag."""
    line = one_line_error(invoke("check", deck(tmp_path, cell_size="'[bold]'")), "grid.cell_size:")
    assert "'[bold]' is not a number" in line


def console(*args: str) -> subprocess.CompletedProcess:
    """`mpmsim ARGS` as a shell runs it: the installed console script (pyproject's
    [project.scripts], mpmsim.cli.main) beside this Python."""
    script = Path(sys.executable).with_name("mpmsim")
    assert script.exists(), f"{script}: the package is not installed (make test installs it)"
    return subprocess.run([str(script), *args], capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("args, names", [
    (("run",), ("mpmsim run", "deck")),
    (("run", "--threads", "abc", "d.yaml"), ("mpmsim run", "--threads")),
    (("frobnicate",), ("mpmsim", "frobnicate")),
], ids=["missing-argument", "bad-option-value", "unknown-command"])
def test_a_usage_error_is_one_line(args, names):
    """Click's usage errors (a missing argument, a value an option does not take, a command
    that does not exist) end in one line on stderr naming the command and what is wrong, exit
    2, as the deck errors do; without the entry point's handling they are click's three lines
    (Usage, Try, Error)."""
    done = console(*args)
    assert done.returncode == 2, done
    assert done.stdout == "", done.stdout
    lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, done.stderr
    assert "Usage:" not in lines[0] and "Traceback" not in lines[0]
    for name in names:
        assert name in lines[0], (name, lines[0])


def test_help_version_and_no_command_as_before():
    """The entry point's own handling leaves --help and --version as they were (exit 0), and
    `mpmsim` alone prints its help whole (exit 2)."""
    done = console("run", "--help")
    assert done.returncode == 0 and "Usage: mpmsim run" in done.stdout, done
    done = console("--version")
    assert done.returncode == 0 and done.stdout.strip(), done
    done = console()
    assert done.returncode == 2 and done.stderr.startswith("Usage: mpmsim") and "Commands" in done.stderr, done
