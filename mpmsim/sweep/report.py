"""The sweep table: one CSV row per run (references included), metrics computed from the saved
histories, so changing a metric needs no re-run; then the chart. A partial sweep (killed, or
--limit) gets a table and chart too, its missing runs marked `pending`."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

from ..output.atomic import write_text
from .matrix import Run
from .metrics import evaluate
from .records import history_arrays, load_record

COST_COLUMNS = ["steps", "particles", "particle_steps", "cpu_s", "run_s", "wall_s", "particle_steps_per_s",
                "peak_mem_mb", "start_mem_mb"]


def table(loaded, runs: list[Run], refs: list[Run], runs_dir: Path) -> list[dict]:
    sw = loaded.sweep
    pending = {"status": "pending", "history": {}}  # not run yet: the table of a partial sweep shows it
    records = {r.id: load_record(runs_dir, r.id) if (runs_dir / f"{r.id}.json").exists() else pending
               for r in refs + runs}
    rows = []
    for run in refs + runs:
        rec = records[run.id]
        is_ref = run.role == "reference" or run.reference == run.id  # (finest: its own reference)
        row = {"id": run.id, "role": "reference" if is_ref else "run", "method": run.method}
        row.update({axis: run.values.get(axis, "") for axis in sw.axes})
        row.update({"status": rec["status"], "stopped_at": rec.get("stopped_at")})
        row.update({c: rec.get(c) for c in COST_COLUMNS})
        own = history_arrays(rec)
        ref = None
        if run.reference is not None and not is_ref:
            ref = history_arrays(records[run.reference]) or None
        for m in sw.metrics:
            value = float("nan")  # a reference row, or a run whose reference is not there yet
            needs_ref = needs_reference(m, sw.reference.analytic)
            if own and not (needs_ref and (is_ref or ref is None)):
                try:
                    value = evaluate(m, own, ref, sw.reference.analytic)
                except (KeyError, ValueError, ZeroDivisionError) as exc:
                    rec["message"] = rec.get("message") or f"metric {m.name}: {exc}"
            row[m.name] = value
        row["message"] = rec.get("message", "")
        rows.append(row)
    return rows


def needs_reference(metric, analytic) -> bool:
    """Whether the metric compares with the reference run's history."""
    return ((metric.type == "max_rel_error" and analytic is None)
            or (metric.type == "period_error" and metric.expected is None))


def write_csv(rows: list[dict], path: Path) -> None:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    w.writeheader()
    for row in rows:
        w.writerow({k: _fmt(v) for k, v in row.items()})
    write_text(path, buf.getvalue())


def _fmt(v):
    if isinstance(v, float):
        return "" if math.isnan(v) else f"{v:.6g}"
    return "" if v is None else v


def read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def assemble(loaded, runs, refs, runs_dir: Path, out: Path) -> tuple[Path, Path]:
    """<name>.csv, <name>.png (the chart metric) and <name>_<metric>.png for each other metric."""
    from .chart import chart

    rows = table(loaded, runs, refs, runs_dir)
    sw, name = loaded.sweep, loaded.path.stem
    csv_path, png_path = out / f"{name}.csv", out / f"{name}.png"
    write_csv(rows, csv_path)
    for m in sw.metrics:
        chart(rows, sw, png_path if m.name == sw.chart else out / f"{name}_{m.name}.png", m.name,
              title=sw.title or name, label=m.label)
    return csv_path, png_path
