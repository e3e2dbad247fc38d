"""Fuzz the decks of inputs/: N cases, each a deck with one thing broken (tests/reliability/
fuzz.py), through `mpmsim check` and `mpmsim run --steps 2` with a time limit. Prints the
table of outcomes (mutation class x outcome) as markdown and lists every case that did not end
cleanly; writes the cases to a CSV.

    python bench/fuzz.py --cases 5000 --seed 1 --out results/fuzz.csv
"""

from __future__ import annotations

import argparse
import csv
import random
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.reliability.fuzz import DECKS, KINDS, run_case, workspace  # noqa: E402

CLEAN = ("ok", "bad deck", "stopped (unstable)", "output fault")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", type=int, default=5000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--seconds", type=float, default=120.0, help="time limit of one check or run")
    ap.add_argument("--out", type=Path, default=Path("results/fuzz.csv"))
    args = ap.parse_args()
    import numba

    numba.set_num_threads(1)
    rows = []
    t0 = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        folder = workspace(Path(tmp))
        for i in range(args.cases):
            rng = random.Random(args.seed * 1_000_003 + i)
            name = DECKS[i % len(DECKS)]
            o = run_case(name, rng.choice, folder, args.seconds)
            rows.append(o)
            if o.outcome not in CLEAN:
                print(f"case {i}: {o.deck}: {o.mutation}: {o.outcome}: {o.detail}", flush=True)
            if (i + 1) % 250 == 0:
                print(f"{i + 1} cases, {time.time() - t0:.0f} s", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with open(args.out, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["deck", "mutation", "kind", "outcome", "detail"])
        for o in rows:
            w.writerow([o.deck, o.mutation, o.kind, o.outcome, o.detail])
    outcomes = CLEAN + tuple(sorted({o.outcome for o in rows} - set(CLEAN)))
    count = Counter((o.kind, o.outcome) for o in rows)
    print(f"\n{len(rows)} cases, seed {args.seed}, {time.time() - t0:.0f} s, {len(DECKS)} decks\n")
    print("| mutation | " + " | ".join(outcomes) + " |")
    print("|---|" + "---:|" * len(outcomes))
    for kind in KINDS:
        print(f"| {kind} | " + " | ".join(str(count[(kind, o)]) for o in outcomes) + " |")
    print("| **all** | " + " | ".join(str(sum(count[(k, o)] for k in KINDS)) for o in outcomes) + " |")
    bad = sum(1 for o in rows if o.outcome not in CLEAN)
    print(f"\nnot clean: {bad}")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
