"""`mpmsim plot`: overlay history columns of several runs in one PNG, labelled by deck title."""

from __future__ import annotations

from pathlib import Path

from .output.atomic import atomic_path
from .output.history import history_title, history_units, read_history
from .sweep.metrics import column


def plot_histories(paths: list[Path], x: str, ys: list[str], output: Path, xlabel: str | None = None,
                   ylabel: str | None = None) -> list[str]:
    """Write the PNG; returns the curve labels. The axis labels default to the columns (or
    expressions) with their units (from each history's sidecar)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5))
    units, labels = {}, []
    for path in paths:
        cols = read_history(path)
        units.update(history_units(path))
        label = history_title(path) or Path(path).stem
        for y in ys:
            labels.append(label if len(ys) == 1 else f"{label}: {y}")
            ax.plot(column(cols, x), column(cols, y), lw=1.2, label=labels[-1])
    ax.set_xlabel(xlabel or (f"{x} [{units[x]}]" if x in units else x))
    ax.set_ylabel(ylabel or ", ".join(f"{y} [{units[y]}]" if y in units else y for y in ys))
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(output) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return labels

