"""floe-impact study runner."""
from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("floe-impact")
except PackageNotFoundError:                    # a source tree that was not installed
    __version__ = "unknown"
