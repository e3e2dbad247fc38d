"""Exceptions that the command line turns into clean messages and exit codes."""

from __future__ import annotations


class DeckError(Exception):
    """A problem with the input deck: the key path, the YAML line and what is wrong.

    `problems` is a list of (path, message) pairs; `path` is a tuple of keys and list
    indices into the deck. The loader fills in file name and line numbers.
    """

    def __init__(self, problems, source: str | None = None, lines: list[int | None] | None = None):
        if isinstance(problems, tuple) and len(problems) == 2 and isinstance(problems[1], str):
            problems = [problems]
        self.problems = [(tuple(p), m) for p, m in problems]
        self.source = source
        self.lines = lines if lines is not None else [None] * len(self.problems)
        super().__init__(self.format())

    def format(self) -> str:
        out = []
        for (path, msg), line in zip(self.problems, self.lines):
            where = self.source or "deck"
            if line is not None:
                where += f", line {line}"
            key = ".".join(str(k) for k in path) if path else "(top level)"
            out.append(f"{where}: {key}: {msg}")
        return "\n".join(out)


class InstabilityError(Exception):
    """The run went unstable; the message says when, where, which material and what."""

    def __init__(self, message: str, time: float, step: int):
        self.time = time
        self.step = step
        super().__init__(message)

    def __reduce__(self):  # picklable, so a worker process can report it (sweeps, benchmarks)
        return type(self), (str(self), self.time, self.step)
