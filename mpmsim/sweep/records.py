"""A sweep run's record (runs/<id>.json: its deck, status and history columns), written whole
by the runner and read by the report."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..output.atomic import write_text


def save_record(runs_dir: Path, record: dict) -> None:
    write_text(Path(runs_dir) / f"{record['id']}.json", json.dumps(record, default=float))


def load_record(runs_dir: Path, run_id: str) -> dict:
    return json.loads((runs_dir / f"{run_id}.json").read_text())


def history_arrays(record: dict) -> dict:
    return {k: np.asarray(v, dtype=float) for k, v in record.get("history", {}).items()}
