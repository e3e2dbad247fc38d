"""Where numba keeps the compiled kernels of mpmsim.

Numba caches a kernel next to its source (`__pycache__` in the package) unless NUMBA_CACHE_DIR
says otherwise. A package installed by another user (a shared environment, a system install)
is not writable, and numba would then fail with "cannot cache function". mpmsim therefore
picks the directory when it is imported, before any kernel is defined:

1. NUMBA_CACHE_DIR, when the user set it;
2. the package directory, when this process can write it (the usual editable install);
3. otherwise the user's cache directory, $XDG_CACHE_HOME/mpmsim/numba (default
   ~/.cache/mpmsim/numba).

Numba checks a cached kernel only against its own source file. Two changes it misses:
- a kernel calls (or inlines) compiled helpers from other files; when a helper's file
  changes (an update of the package, an edit) and the kernel's file does not, numba loads
  the kernel compiled with the old helper, silently (measured: f(x) = 2 g(x) cached with
  g(x) = x + 1 still returned 4 for f(1) after g became x + 100);
- the index names the types of a kernel's arguments by module; when modules of mpmsim move,
  that index names a module that no longer exists and numba fails loading it
  (ModuleNotFoundError) instead of compiling again.
So the cache root keeps a stamp of the package's sources (their paths and contents), and the
cached kernels are dropped when the stamp differs (`drop_if_moved`): after any change to the
package's code, every kernel compiles again once.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent


def choose(env: dict | None = None, package_dir: Path = PACKAGE_DIR, writable=None) -> Path | None:
    """The cache directory to set (None: numba's default, next to the sources)."""
    env = os.environ if env is None else env
    if env.get("NUMBA_CACHE_DIR"):
        return Path(env["NUMBA_CACHE_DIR"])
    can_write = writable(package_dir) if writable is not None else os.access(package_dir, os.W_OK)
    if can_write:
        return None
    base = Path(env.get("XDG_CACHE_HOME") or Path(env.get("HOME", "~")).expanduser() / ".cache")
    return base / "mpmsim" / "numba"


def configure() -> Path:
    """Point numba at the chosen directory; returns the directory kernels are cached in."""
    import numba

    where = choose()
    if where is None:
        drop_if_moved(PACKAGE_DIR)
        return PACKAGE_DIR
    where.mkdir(parents=True, exist_ok=True)
    drop_if_moved(where)
    numba.config.CACHE_DIR = str(where)
    os.environ.setdefault("NUMBA_CACHE_DIR", str(where))  # for worker processes (sweeps)
    return where


def is_empty() -> bool:
    """Whether no kernel of mpmsim is cached yet (a first run compiles them all)."""
    import numba

    root = Path(numba.config.CACHE_DIR) if numba.config.CACHE_DIR else PACKAGE_DIR
    return not root.exists() or not any(root.rglob("*.nbi"))


STAMP = ".mpmsim-layout"


def layout(package_dir: Path = PACKAGE_DIR) -> str:
    """A digest of the package's modules: their paths and contents (a few ms at import)."""
    digest = hashlib.sha256()
    for path in sorted(package_dir.rglob("*.py")):
        digest.update(str(path.relative_to(package_dir)).encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def drop_if_moved(root: Path, package_dir: Path = PACKAGE_DIR) -> bool:
    """Delete the cached kernels under `root` when the stamp there is not the package's current
    sources' digest (`layout`), then stamp it; True when kernels were dropped. Silent where root is not
    writable (numba then reports its own error)."""
    stamp = Path(root) / STAMP
    now = layout(package_dir)
    try:
        if stamp.exists() and stamp.read_text() == now:
            return False
        dropped = False
        for f in Path(root).rglob("*.nb[ic]"):
            f.unlink(missing_ok=True)
            dropped = True
        stamp.write_text(now)
        return dropped
    except OSError:
        return False
