"""docs/tutorial.md, run as written from an empty folder: its files (```yaml file=NAME,
```python file=NAME) are written, and every `$ ` command of its ```console blocks is run in
order, each required to exit 0. `mpmsim` is this checkout's; `python` is this interpreter;
`xvfb-run -a pvbatch` runs pvbatch on a virtual screen the test starts itself
(tests/ecosystem/pvbatch.py) when ParaView is installed (MPMSIM_REQUIRE_PARAVIEW=1, set in CI,
makes a missing ParaView a failure). The checks after the run hold the tutorial's claims."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys

import pandas as pd
import pytest

from ..conftest import ROOT
from .pvbatch import failure, pvbatch, run_pvbatch

pytestmark = pytest.mark.ecosystem
TUTORIAL = ROOT / "docs" / "tutorial.md"
BLOCK = re.compile(r"^```(\w+)([^\n]*)\n(.*?)^```", re.S | re.M)


def steps(text: str) -> list[tuple[str, str, str]]:
    """(kind, file name or '', content) in document order; kind 'file' or 'command'."""
    out = []
    for lang, info, body in BLOCK.findall(text):
        name = re.search(r"file=(\S+)", info)
        if name:
            out.append(("file", name.group(1), body))
        elif lang == "console":
            out += [("command", "", line[2:]) for line in body.splitlines() if line.startswith("$ ")]
    return out


def test_the_tutorial_runs_from_an_empty_folder(tmp_path):
    todo = steps(TUTORIAL.read_text())
    commands = [c for k, _, c in todo if k == "command"]
    assert any(c.startswith("mpmsim run") for c in commands) and any("pandas" in b for _, _, b in todo)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    pv = pvbatch() is not None
    for kind, name, body in todo:
        if kind == "file":
            (tmp_path / name).write_text(body)
            continue
        words = shlex.split(body)
        if words[0] == "mpmsim":
            words = [sys.executable, "-m", "mpmsim"] + words[1:]
        elif words[0] == "python":
            words[0] = sys.executable
        elif words[:3] == ["xvfb-run", "-a", "pvbatch"]:
            if not pv:
                assert not os.environ.get("MPMSIM_REQUIRE_PARAVIEW"), "pvbatch not found"
                continue
            run = run_pvbatch(words[3:], cwd=tmp_path, env=env)
            assert run.returncode == 0, f"$ {body}\n{failure(run)}"
            continue
        run = subprocess.run(words, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900)
        assert run.returncode == 0, f"$ {body}\n{run.stdout[-3000:]}\n{run.stderr[-3000:]}"
    # what the tutorial says the reader gets
    res = tmp_path / "results" / "disk_on_block"
    assert (res / "disk_on_block.pvd").exists() and (res / "disk_on_block_paraview.py").exists()
    history = pd.read_csv(res / "disk_on_block_history.csv")
    assert {"time", "kinetic_energy", "py_disk", "py_block"} <= set(history.columns)
    assert (tmp_path / "energy.png").stat().st_size > 10_000
    if pv:
        assert (tmp_path / "disk_on_block.png").stat().st_size > 10_000
