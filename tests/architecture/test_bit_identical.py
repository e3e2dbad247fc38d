"""Every deck in inputs/ (and method variants of a few) gives the stored results to the last bit.

The reference was recorded from the code before the body/integrator seams went in; any change
meant to keep results must keep these digests. See fingerprint.py for what is compared.

The FEM and implicit cases run in one process where every double-precision BLAS and LAPACK
routine ends the process (blas_guard.py): their digests hold on any x86-64 CPU only if no
result passes through a library whose kernels are chosen by CPU. The particle cases run here.
"""

from __future__ import annotations

import json

import pytest

from . import blas_guard
from .fingerprint import REFERENCE, cases, fem_decks, fingerprint

REF = json.loads(REFERENCE.read_text())
GUARDED = set(fem_decks())

_RUN_GUARDED = """
import json, sys
from tests.architecture.fingerprint import fingerprint
want = json.loads(open(sys.argv[1]).read())
out = {name: fingerprint(name, {}, ref["steps"], ref["columns"]) for name, ref in want.items()}
open(sys.argv[2], "w").write(json.dumps(out))
"""


@pytest.fixture(scope="module")
def guard(tmp_path_factory):
    """(the guard library, the routines it replaces)."""
    return blas_guard.build(tmp_path_factory.mktemp("blas_guard"))


@pytest.fixture(scope="module")
def guarded_fingerprints(guard, tmp_path_factory):
    """{case: fingerprint} of the FEM and implicit decks, run with BLAS and LAPACK replaced by
    routines that end the process."""
    folder = tmp_path_factory.mktemp("guarded")
    lib = guard[0]
    want, got = folder / "want.json", folder / "got.json"
    want.write_text(json.dumps({name: REF[name] for name in sorted(GUARDED)}))
    code = f"import sys; sys.argv[1:] = [{str(want)!r}, {str(got)!r}]\n" + _RUN_GUARDED
    run = blas_guard.run_guarded(lib, code)
    assert run.returncode == 0, f"exit {run.returncode}: {run.stderr[-2000:]}"
    return json.loads(got.read_text())


def _compare(name, got, want):
    if got != want:
        rows = [(float.fromhex(a), float.fromhex(b)) for a, b in zip(got["last_row"], want["last_row"])]
        diff = max((abs(a - b) / max(abs(b), 1e-300) for a, b in rows), default=0.0)
        changed = sorted(k for k in want["arrays"] if got["arrays"].get(k) != want["arrays"][k])
        pytest.fail(f"{name}: results changed (history {got['history'] != want['history']}, arrays {changed}, "
                    f"largest relative change in the last history row {diff:.3g})")


@pytest.mark.architecture
@pytest.mark.parametrize("name,deck,overrides", cases(), ids=[c[0] for c in cases()])
def test_results_are_bit_identical(name, deck, overrides, request):
    want = REF[name]
    if name in GUARDED:
        got = request.getfixturevalue("guarded_fingerprints")[name]
    else:
        got = fingerprint(deck, overrides, want["steps"], want["columns"])
    _compare(name, got, want)


@pytest.mark.architecture
@pytest.mark.parametrize("call", [
    "import numpy as np; np.ones(8) @ np.ones(8)",  # numpy's dot
    "import numpy as np; np.linalg.det(np.eye(3))",  # numpy's LAPACK
    "from numba import njit\nimport numpy as np\nnjit(lambda a: a @ a)(np.ones(4))",  # numba's dot
    "import numpy as np, scipy.sparse as sp, scipy.sparse.linalg as sl\n"  # SuperLU's BLAS
    "A = sp.random(60, 60, 0.2, random_state=1) + 60 * sp.eye(60); sl.splu(A.tocsc()).solve(np.ones(60))",
], ids=["numpy-dot", "numpy-lapack", "numba-dot", "superlu"])
def test_the_blas_guard_stops_a_blas_call(call, guard):
    lib, names = guard
    assert len(names) > 300
    run = blas_guard.run_guarded(lib, call, timeout=120)
    assert run.returncode == blas_guard.GUARD_EXIT and "BLAS/LAPACK call" in run.stderr, run.stderr[-500:]
    assert blas_guard.run_guarded(lib, "import numpy as np; np.ones(8).sum()", timeout=120).returncode == 0
