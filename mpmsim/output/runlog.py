"""`<stem>_run.log`: what a run was and how it ended, beside its results.

Written whole when the run starts (command line, versions, machine, threads, the deck as
resolved: every default filled in) and rewritten whole when it ends, adding the warnings
and messages it gave, the timing table and the exit reason. A run killed outright leaves the
first version ("exit: still running (or killed)").
"""

from __future__ import annotations

import datetime
import os
import platform
import shlex
from pathlib import Path

import yaml

from .atomic import write_text


def versions() -> dict[str, str]:
    import numba
    import numpy

    from .._version import __version__

    return {"mpmsim": __version__, "numba": numba.__version__, "numpy": numpy.__version__,
            "python": platform.python_version()}


class RunLog:
    def __init__(self, path: Path, argv: list[str], loaded, threads: int):
        self.path = Path(path)
        self.messages: list[str] = []
        started = datetime.datetime.now().astimezone().isoformat(timespec="seconds")
        head = [f"command: {shlex.join(argv)}", f"started: {started}", f"folder: {os.getcwd()}",
                f"deck: {loaded.path}", f"machine: {platform.node()} ({platform.machine()}, "
                f"{os.cpu_count()} cores), {platform.platform()}", f"threads: {threads}"]
        head += [f"{k}: {v}" for k, v in versions().items()]
        deck = yaml.safe_dump(loaded.deck.model_dump(mode="json"), sort_keys=False, allow_unicode=True)
        self.head = "\n".join(head) + "\n\n# deck, as resolved (defaults filled in)\n" + deck
        self._write("exit: still running (or killed)")

    def note(self, message: str) -> None:
        """A warning or message of the run (kept for the final log)."""
        self.messages.append(" ".join(message.split()))

    def finish(self, reason: str, table: str = "") -> None:
        ended = datetime.datetime.now().astimezone().isoformat(timespec="seconds")
        self._write(f"ended: {ended}\nexit: {reason}", table)

    def _write(self, tail: str, table: str = "") -> None:
        parts = [self.head]
        if self.messages:
            parts.append("# warnings and messages\n" + "\n".join(self.messages) + "\n")
        if table:
            parts.append("# time per task\n" + table.rstrip() + "\n")
        parts.append(tail + "\n")
        write_text(self.path, "\n".join(parts))
