"""mpmsim: material point method simulator for multimaterial contact mechanics."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("mpmsim")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"

from . import kernel_cache as _kernel_cache  # noqa: E402  (before any kernel is defined)

CACHE_DIR = _kernel_cache.configure()
