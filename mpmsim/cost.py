"""Run-time estimates for `mpmsim check`: a time per step from per-task costs.

Each task of an explicit step costs a + b · n · K microseconds on one thread: a fixed part
(calling the kernel, the grid box, Python around it) and a part per particle-node pair (n
particles, K grid nodes in each particle's support: 9 for uGIMP in 2D, 27 in 3D, 16 for
CPDI, 25 for B2CPDI), which is what the transfers and the stress update loop over. The
coefficients are fitted, per task, by `python bench/calibrate.py` (in `make bench`) to the
warm task timers of every explicit deck in inputs/ on one thread, and stored in
task_costs.json with the date and machine they were measured on (docs/performance.md says
how close the estimates come).
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

from .solver import CHECK  # the run loop's own task, after every step

COSTS = Path(__file__).with_name("task_costs.json")


@lru_cache(maxsize=1)
def task_costs() -> dict:
    """{"tasks": {name: [a_us, b_us]}, "measured": "..."} (empty tasks if the file is missing)."""
    try:
        return json.loads(COSTS.read_text())
    except (OSError, ValueError):
        return {"tasks": {}, "measured": "no calibration"}


def step_microseconds(tasks: list[str], n: int, K: int) -> tuple[float, list[str]]:
    """(estimated µs per step on one thread, the tasks without a calibrated cost)."""
    costs = task_costs()["tasks"]
    total, missing = 0.0, []
    for name in [*tasks, CHECK]:
        if name in costs:
            a, b = costs[name]
            total += a + b * n * K
        else:
            missing.append(name)
    return total, missing
