"""Optional parts: packages that only some features need, checked before the work that needs them.

The ``tables`` extra (``pip install 'zeromode[tables]'``: pandas, pyarrow) gives sweep tables
as DataFrames and Parquet files. ``require`` imports the packages a feature needs and, when one
is missing, raises MissingExtra with one sentence that names the install line to type — the
CLI's exit code 2, the library's exception and the service's 501 ``parquet_unavailable`` all
come from it, each before any work starts.
"""

from __future__ import annotations

import importlib

# The extra of pyproject.toml that installs each optional package.
EXTRA_OF = {"pandas": "tables", "pyarrow": "tables"}


class MissingExtra(ImportError):
    """An optional package a feature needs is not installed; the message says what to type."""

    def __init__(self, feature: str, missing: list[str]):
        extras = sorted({EXTRA_OF[name.split(".")[0]] for name in missing})
        line = " ".join(f"'zeromode[{extra}]'" for extra in extras)
        super().__init__(
            f"{feature} needs {' and '.join(missing)}, which {'is' if len(missing) == 1 else 'are'} "
            f"not installed here: pip install {line}"
        )
        self.feature, self.missing, self.install = feature, missing, f"pip install {line}"


def require(feature: str, *packages: str) -> None:
    """Import ``packages`` (modules of the packages in EXTRA_OF); MissingExtra naming the missing ones and the
    install line when any cannot be imported. ``feature`` is what needs them, e.g. "a Parquet
    table"."""
    missing = []
    for name in packages:
        try:
            importlib.import_module(name)
        except ImportError:
            missing.append(name)
    if missing:
        raise MissingExtra(feature, missing)
