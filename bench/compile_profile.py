"""Where the first compile goes: one step of each case `make test` warms (tests/warm.py's two
halves, the fingerprint cases), in one process, on an empty kernel cache of its own, with
numba's compile events timed. Prints the kernels by their own compile time (a nested compile's
time counted in the callee, not twice) summed over their specializations, and the time per case.

    python bench/compile_profile.py [--top 40] [--cases two_blocks/avg disks ...] [--json out.json]

It runs on a temporary NUMBA_CACHE_DIR, so the package's cache is left alone; minutes of one core.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--top", type=int, default=40)
    ap.add_argument("--cases", nargs="*", help="fingerprint case names (default: all)")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()

    os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="mpmsim-compile-profile-")
    os.environ["NUMBA_NUM_THREADS"] = "1"
    sys.path.insert(0, str(ROOT))
    from numba.core import event

    from machine import describe  # (bench/machine.py: run as python bench/compile_profile.py)
    from tests.architecture.fingerprint import cases, run_case

    own: dict[str, float] = defaultdict(float)
    count: dict[str, int] = defaultdict(int)
    stack: list[list] = []

    class Timer(event.Listener):
        def on_start(self, ev):
            stack.append([time.perf_counter(), 0.0])

        def on_end(self, ev):
            t0, children = stack.pop()
            spent = time.perf_counter() - t0
            if stack:
                stack[-1][1] += spent
            disp = ev.data.get("dispatcher") if isinstance(ev.data, dict) else None
            func = getattr(disp, "py_func", None)
            name = f"{func.__module__}.{func.__qualname__}" if func is not None else "?"
            own[name] += spent - children
            count[name] += 1

    per_case = []
    event.register("numba:compile", Timer())
    t_all = time.perf_counter()
    for name, deck, overrides in cases():
        if args.cases and name not in args.cases:
            continue
        t0 = time.perf_counter()
        try:
            run_case(deck, overrides, steps=1, columns=[])
            status = "ok"
        except Exception as exc:  # noqa: BLE001 (a case that fails is reported, the others go on)
            status = f"{type(exc).__name__}: {str(exc)[:80]}"
        per_case.append((name, time.perf_counter() - t0, status))
        print(f"{name:40s} {per_case[-1][1]:7.1f} s  {status}", flush=True)
    total = time.perf_counter() - t_all

    print(f"\n{describe(1)}")
    print(f"one step of {len(per_case)} cases: {total:.0f} s, of which compiling {sum(own.values()):.0f} s\n")
    print(f"{'kernel':78s} {'forms':>5s} {'own s':>7s}")
    for name, spent in sorted(own.items(), key=lambda kv: -kv[1])[: args.top]:
        print(f"{name[:78]:78s} {count[name]:5d} {spent:7.1f}")
    if args.json:
        args.json.write_text(json.dumps({"total_s": total, "cases": per_case,
                                         "kernels": {k: [count[k], own[k]] for k in own}}, indent=1))


if __name__ == "__main__":
    main()
