"""Tests that need a part of the machine that ``pip install -e ".[test]"`` does not bring (a
browser, a database server): ``.ci/run`` installs them with apt."""

from __future__ import annotations

import os
from typing import NoReturn

import pytest


def missing(tests: str, how_to_get_it: str) -> NoReturn:
    """Skip with the way to get the part, except under CI (``CI=true``), where it fails: CI must
    run ``tests``."""
    if os.environ.get("CI") == "true":
        pytest.fail(f"CI must run {tests}, but {how_to_get_it}")
    pytest.skip(how_to_get_it)
