"""Sweeps: a base deck, axes to vary, a reference and error metrics -> a CSV table of error
and cost per run and an error-against-cost chart (docs/sweep.md).

    spec.py     the sweep file (pydantic; errors name the key path and line)
    matrix.py   axes -> runs with stable ids, plus the reference runs
    runner.py   Dask workers (or this process), one JSON per finished run (resume), cost and memory
    metrics.py  max relative error of a column, period from zero crossings, energy change
    report.py   the CSV table;  chart.py  error against cost with the Pareto front
"""

from .runner import SweepResult, run_sweep
from .spec import LoadedSweep, load_sweep

__all__ = ["LoadedSweep", "SweepResult", "load_sweep", "run_sweep"]
