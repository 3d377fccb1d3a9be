"""Helpers shared by the API tests (tests/ is on sys.path through tests/conftest.py)."""

import math

# The integer fields (and rank_gap) of /v1/analyze, also embedded as report.analysis.
COUNT_FIELDS = {
    "nodes",
    "edges",
    "dim",
    "maxwell_count",
    "rank",
    "zero_modes",
    "rigid_body_modes",
    "nontrivial_zero_modes",
    "self_stresses",
    "rank_gap",
}


def is_number(v) -> bool:
    """A finite JSON number (not a bool)."""
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
