"""The REST contract's JSON shapes (/work/shared/API.md): numbers, matrices, error bodies."""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np

SNAKE_CASE = re.compile(r"[a-z][a-z0-9]*(_[a-z0-9]+)*")


def is_int(value: Any) -> bool:
    """A JSON integer (not a bool)."""
    return isinstance(value, int) and not isinstance(value, bool)


def is_number(value: Any) -> bool:
    """A finite JSON number (not a bool)."""
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def matrix(value: Any, rows: int | None, cols: int) -> np.ndarray:
    """A JSON row list of rows × cols finite numbers (any number of rows when rows is None)."""
    assert isinstance(value, list) and (rows is None or len(value) == rows), (type(value), rows)
    for row in value:
        assert isinstance(row, list) and len(row) == cols, (row, cols)
        assert all(is_number(v) for v in row), row
    return np.array(value, dtype=float).reshape(len(value), cols)


def assert_error(response, code: str | set[str] | None = None, status: int | None = 422) -> dict:
    """A 4xx (``status``, or any 4xx when None) whose body is {"detail": {"code": <snake_case>,
    "message": <a sentence>}} with the given code (or one of a set); returns the detail."""
    if status is None:
        assert 400 <= response.status_code < 500, (response.status_code, response.text[:300])
    else:
        assert response.status_code == status, (response.status_code, response.text[:300])
    detail = response.json()["detail"]
    assert isinstance(detail, dict), detail
    assert isinstance(detail["code"], str) and SNAKE_CASE.fullmatch(detail["code"]), detail
    message = detail["message"]
    assert isinstance(message, str) and len(message) > 10 and len(message.split()) >= 3, detail
    if code is not None:
        assert detail["code"] in ({code} if isinstance(code, str) else code), detail
    return detail


def frame_body(frame) -> dict:
    """The JSON frame {"dim", "positions", "edges", "specified"} of a solver Frame."""
    return {
        "dim": frame.dim,
        "positions": frame.positions.tolist(),
        "edges": frame.edges.tolist(),
        "specified": list(frame.specified),
    }
