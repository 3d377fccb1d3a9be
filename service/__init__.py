"""zeromode.service — the three service layers over the library (docs/architecture.md), each
importing only those below it: ``wire`` (settings, schemas, the one place results become bodies),
``jobs`` (the job engine: records, Dask tasks, sweeps), ``rest`` (the FastAPI app and its routes),
and ``cli.py`` on top."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("zeromode")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0+unknown"
