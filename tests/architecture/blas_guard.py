"""Run Python code in a process where every BLAS and LAPACK routine ends the process.

OpenBLAS picks its kernels by CPU when it loads, so a result that passed through a BLAS call can
round differently on another x86-64 CPU. To show that a path makes no such call, the routines
themselves are replaced: a small shared library defines every function that the BLAS and LAPACK
libraries of this process export (numpy's and scipy's OpenBLAS, and a system BLAS that CHOLMOD
brings), each printing its name and aborting; the dynamic loader binds the
callers (numpy, scipy's SuperLU and cython_blas, which numba's np.dot and np.linalg call) to it
first (LD_PRELOAD). Housekeeping entry points (thread counts, configuration) stay real. The
process aborts, and Python's fault handler prints where the call came from.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

GUARD_EXIT = -6  # SIGABRT: Python's fault handler prints the traceback of the call
ROOT = Path(__file__).resolve().parents[2]

# load the libraries as the step does, then list the BLAS/LAPACK files of this process
_FIND = """
import numpy, scipy.linalg, scipy.sparse.linalg
import mpmsim.integrators.implicit
import numba.np.linalg
for line in open('/proc/self/maps'):
    path = line.split()[-1]
    name = path.rsplit('/', 1)[-1].lower()
    if path.startswith('/') and name.startswith('lib') and ('blas' in name or 'lapack' in name) and '.so' in name:
        print(path)
"""
# the double-precision routines, under every name these libraries give them (ddot_, cblas_ddot,
# scipy_cblas_ddot64_, LAPACKE_dgesv, idamax_, ...); numpy's import-time check of a float32 dot
# and the libraries' housekeeping stay real
_DOUBLE = re.compile(r"(scipy_)?(cblas_|LAPACKE_)?i?d[a-z0-9]+(_64_|64_|_)?")


def libraries() -> list[str]:
    out = subprocess.run([sys.executable, "-c", _FIND], capture_output=True, text=True, check=True, cwd=ROOT)
    return sorted(set(out.stdout.split()))


def routines(paths: list[str]) -> list[str]:
    """The double-precision routines the libraries export."""
    names = set()
    for path in paths:
        out = subprocess.run(["nm", "-D", "--defined-only", path], capture_output=True, text=True, check=True)
        for line in out.stdout.splitlines():
            parts = line.split()
            if len(parts) == 3 and parts[1] in ("T", "W", "i"):
                name = parts[2].split("@")[0]
                if _DOUBLE.fullmatch(name):
                    names.add(name)
    return sorted(names)


def build(folder: Path) -> tuple[Path, list[str]]:
    """The guard library in `folder`, and the routines it replaces."""
    names = routines(libraries())
    src = folder / "blas_guard.c"
    body = ["#include <unistd.h>", "#include <string.h>", "#include <stdlib.h>",
            "static void stop(const char *name) {",
            '  const char *a = "BLAS/LAPACK call: ";',
            "  write(2, a, strlen(a)); write(2, name, strlen(name)); write(2, \"\\n\", 1);",
            "  abort();", "}"]
    body += [f'void {n}(void) {{ stop("{n}"); }}' for n in names]
    src.write_text("\n".join(body) + "\n")
    lib = folder / "blas_guard.so"
    subprocess.run(["cc", "-shared", "-fPIC", "-O0", "-o", str(lib), str(src)], check=True, capture_output=True)
    return lib, names


def run_guarded(lib: Path, code: str, timeout: float = 900) -> subprocess.CompletedProcess:
    """Run `code` (Python) from the repository root with the guard preloaded."""
    env = dict(os.environ, LD_PRELOAD=str(lib), NUMBA_NUM_THREADS="1", PYTHONFAULTHANDLER="1")
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          cwd=ROOT, env=env, timeout=timeout)
