"""mpmsim's version, as installed (a module of its own, so that modules of the package read it
without importing the package's __init__)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("mpmsim")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"
