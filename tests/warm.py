"""Fill numba's kernel cache before the test workers start: `python -m tests.warm`.

Test workers started on an empty cache all compile the kernels every scene needs (the particle
transfers, the stress update, ...) at the same moment, each for itself. Here two processes
compile disjoint halves first, one step of every case of the architecture fingerprints (every
deck in inputs/ and the method variants: tests/architecture/fingerprint.py): the FEM and
implicit decks with half of the variants, the particle decks with the other half. The workers
then load those kernels and compile only what their tests add. With a warm cache it only builds
the scenes and loads the kernels; a case that fails here fails again, with its message, in its
test.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def part(k: int) -> list[tuple[str, str, dict]]:
    from tests.architecture.fingerprint import VARIANTS, fem_decks, particle_decks

    if k == 0:
        return [(d, d, {}) for d in fem_decks()] + VARIANTS[0::2]
    return [(d, d, {}) for d in particle_decks()] + VARIANTS[1::2]


def run_part(k: int) -> int:
    from tests.architecture.fingerprint import run_case

    failed = 0
    t0 = time.perf_counter()
    for name, deck, overrides in part(k):
        try:
            run_case(deck, overrides, steps=1, columns=[])
        except Exception as exc:  # noqa: BLE001 (the case's own test reports it)
            failed += 1
            print(f"warm: {name}: {type(exc).__name__}: {str(exc)[:200]}", file=sys.stderr)
    print(f"warm: half {k} ({'FEM and implicit decks' if k == 0 else 'particle decks'}, half the variants) in "
          f"{time.perf_counter() - t0:.0f} s")
    return failed


def main() -> int:
    if len(sys.argv) > 1:
        run_part(int(sys.argv[1]))
        return 0
    t0 = time.perf_counter()
    env = {**os.environ, "NUMBA_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
    procs = [subprocess.Popen([sys.executable, "-m", "tests.warm", str(k)], cwd=ROOT, env=env) for k in (0, 1)]
    for p in procs:
        p.wait()
    print(f"kernel cache filled in {time.perf_counter() - t0:.0f} s (tests/warm.py)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
