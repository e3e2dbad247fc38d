"""The tutorial's pictures, made by the tutorial's own files and commands (`make figure-tutorial`).

docs/tutorial.md is run as written in a temporary folder: its files (```yaml file=NAME,
```python file=NAME) are written, and every `$ ` command of its ```console blocks is run in
order (`mpmsim` as this checkout's, `python` as this interpreter; the ParaView step needs
pvbatch and, without a screen, xvfb-run). Then the two pictures it makes are copied to
docs/figures/: disk_on_block.png (the ParaView screenshot) as tutorial_paraview.png and
energy.png (the pandas plot) as tutorial_energy.png. tests/ecosystem/test_tutorial.py runs the
same commands and checks the numbers the tutorial quotes.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TUTORIAL = ROOT / "docs" / "tutorial.md"
FIGURES = ROOT / "docs" / "figures"
PICTURES = {"disk_on_block.png": "tutorial_paraview.png", "energy.png": "tutorial_energy.png"}
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


def main() -> int:
    if shutil.which("pvbatch") is None:
        print("pvbatch (ParaView) is not installed: the tutorial's ParaView picture cannot be made", file=sys.stderr)
        return 1
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    with tempfile.TemporaryDirectory(prefix="mpmsim-tutorial-") as tmp:
        work = Path(tmp)
        for kind, name, body in steps(TUTORIAL.read_text()):
            if kind == "file":
                (work / name).write_text(body)
                continue
            words = shlex.split(body)
            if words[0] == "mpmsim":
                words = [sys.executable, "-m", "mpmsim"] + words[1:]
            elif words[0] == "python":
                words[0] = sys.executable
            print(f"$ {body}", flush=True)
            run = subprocess.run(words, cwd=work, env=env)
            if run.returncode != 0:
                print(f"failed (exit {run.returncode}): {body}", file=sys.stderr)
                return 1
        for made, kept in PICTURES.items():
            shutil.copyfile(work / made, FIGURES / kept)
            print(f"wrote docs/figures/{kept}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
