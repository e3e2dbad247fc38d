"""Error against cost, log-log: one colour and marker per method (its runs joined in axis
order, e.g. coarse to fine), the Pareto front (no other run both cheaper and more accurate),
unstable runs as red crosses at their cost and the error they had when they stopped (at the
top of the axis if they had none)."""

from __future__ import annotations

import math
from pathlib import Path

from ..output.atomic import atomic_path

COST = "cpu_s"
COST_LABEL = "CPU time per run (s, one thread, after the first step)"


def _num(v) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")


def pareto_front(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The points no other point beats in both cost and error, by increasing cost."""
    front, best = [], math.inf
    for x, y in sorted(points):
        if y < best:
            front.append((x, y))
            best = y
    return front


def chart(rows: list[dict], sweep, path: Path, metric: str, title: str = "", label: str | None = None) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    runs = [r for r in rows if r["role"] == "run" and math.isfinite(_num(r.get(COST)))]
    ok = [r for r in runs if r["status"] == "ok" and math.isfinite(_num(r[metric])) and _num(r[metric]) > 0]
    bad = [r for r in runs if r["status"] == "unstable"]
    fig, ax = plt.subplots(figsize=(9, 6))
    ys = [_num(r[metric]) for r in ok] + [_num(r[metric]) for r in bad if _num(r[metric]) > 0]
    top = 2 * max(ys) if ys else 1.0
    methods = list(dict.fromkeys(r["method"] for r in runs))
    cmap = plt.get_cmap("tab20" if len(methods) > 10 else "tab10")
    markers = "osD^v<>pP*hX"
    for i, m in enumerate(methods):
        mine = [r for r in ok if r["method"] == m]
        if not mine:
            continue
        xs, yv = [_num(r[COST]) for r in mine], [_num(r[metric]) for r in mine]
        ax.plot(xs, yv, marker=markers[i % len(markers)], color=cmap(i % cmap.N), lw=0.8, ms=6, label=m)
    if bad:
        ax.scatter([_num(r[COST]) for r in bad],
                   [_num(r[metric]) if _num(r[metric]) > 0 else top for r in bad],
                   marker="x", s=70, color="red", zorder=5, label=f"stopped as unstable ({len(bad)})")
    front = pareto_front([(_num(r[COST]), _num(r[metric])) for r in ok])
    if front:
        fx, fy = zip(*front)
        ax.step(fx, fy, where="post", color="k", lw=1.5, ls="--", alpha=0.7, label="Pareto front", zorder=4)
    ax.set_xscale("log")
    ax.set_yscale("log")
    from matplotlib.ticker import NullFormatter

    ax.xaxis.set_minor_formatter(NullFormatter())  # minor labels collide on short decades
    ax.set_xlabel(COST_LABEL)
    ax.set_ylabel(label or metric)
    ax.set_title(title, fontsize=10)
    ax.grid(True, which="both", alpha=0.25)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
