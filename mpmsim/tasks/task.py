"""A named task of the time step: what it runs and why the scene needs it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable


@dataclass(frozen=True)
class Task:
    name: str
    run: Callable
    why: str
