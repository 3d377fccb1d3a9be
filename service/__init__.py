"""zeromode.service — the thin REST layer (FastAPI) over zeromode.solver."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("zeromode")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0+unknown"
