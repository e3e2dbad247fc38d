"""Where numba keeps the compiled kernels of mpmsim.

Numba caches a kernel next to its source (`__pycache__` in the package) unless NUMBA_CACHE_DIR
says otherwise. A package installed by another user (a shared environment, a system install)
is not writable, and numba would then fail with "cannot cache function". mpmsim therefore
picks the directory when it is imported, before any kernel is defined:

1. NUMBA_CACHE_DIR, when the user set it;
2. the package directory, when this process can write it (the usual editable install);
3. otherwise the user's cache directory, $XDG_CACHE_HOME/mpmsim/numba (default
   ~/.cache/mpmsim/numba).
"""

from __future__ import annotations

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
        return PACKAGE_DIR
    where.mkdir(parents=True, exist_ok=True)
    numba.config.CACHE_DIR = str(where)
    os.environ.setdefault("NUMBA_CACHE_DIR", str(where))  # for worker processes (sweeps)
    return where


def is_empty() -> bool:
    """Whether no kernel of mpmsim is cached yet (a first run compiles them all)."""
    import numba

    root = Path(numba.config.CACHE_DIR) if numba.config.CACHE_DIR else PACKAGE_DIR
    return not root.exists() or not any(root.rglob("*.nbi"))
