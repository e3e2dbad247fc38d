"""`mpmsim plot`: overlay history columns of several runs in one PNG, labelled by deck title."""

from __future__ import annotations

from pathlib import Path

from .output.atomic import atomic_path
from .output.history import history_title, history_units, read_history
from .sweep.metrics import column


class PlotError(Exception):
    """A history file or an option `mpmsim plot` cannot use: one line that names it."""


def _why(exc: OSError) -> str:
    reason = exc.strerror or str(exc)
    return reason[:1].lower() + reason[1:]


def _history(path: Path) -> dict:
    try:
        return read_history(path)
    except IsADirectoryError:
        raise PlotError(f"{path}: is a folder, not a history CSV (give the *_history.csv in it)") from None
    except OSError as exc:
        raise PlotError(f"{path}: cannot read it: {_why(exc)}") from None
    except ValueError as exc:
        raise PlotError(f"{path}: not a history CSV: {exc}") from None


def _column(cols: dict, expr: str, option: str, path: Path):
    try:
        return column(cols, expr)
    except KeyError:
        raise PlotError(f"{option} {expr}: no such column in {path} (its columns: {', '.join(cols)})") from None
    except Exception as exc:  # noqa: BLE001 (an expression that does not evaluate: SyntaxError, TypeError, ...)
        raise PlotError(f"{option} {expr}: not a column nor an expression of columns of {path} "
                        f"({type(exc).__name__}: {exc})") from None


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
        cols = _history(path)
        units.update(history_units(path))
        label = history_title(path) or Path(path).stem
        for y in ys:
            labels.append(label if len(ys) == 1 else f"{label}: {y}")
            ax.plot(_column(cols, x, "--x", path), _column(cols, y, "--y", path), lw=1.2, label=labels[-1])
    ax.set_xlabel(xlabel or (f"{x} [{units[x]}]" if x in units else x))
    ax.set_ylabel(ylabel or ", ".join(f"{y} [{units[y]}]" if y in units else y for y in ys))
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    output = Path(output)
    try:
        output.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(output) as tmp:
            fig.savefig(tmp, dpi=110, format="png")
    except OSError as exc:
        raise PlotError(f"--out {output}: cannot write it: {_why(exc)}") from None
    finally:
        plt.close(fig)
    return labels

