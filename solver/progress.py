"""Progress reports from long computations.

The caller opens ``progress_scope(callback)``; main loops call ``report_progress(fraction,
message)`` where they know how far they are, and the callback receives the fraction clamped to
[0, 1]. Outside a scope a report costs one context-variable lookup and goes nowhere. The
callback lives in a context variable (like the time budget of budget.py), so concurrent jobs
each report to their own.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar

ProgressCallback = Callable[[float, str], None]

_CALLBACK: ContextVar[ProgressCallback | None] = ContextVar("zeromode_progress", default=None)


@contextmanager
def progress_scope(callback: ProgressCallback | None) -> Iterator[None]:
    """Within this block, ``report_progress`` calls ``callback(fraction, message)``."""
    token = _CALLBACK.set(callback)
    try:
        yield
    finally:
        _CALLBACK.reset(token)


def report_progress(fraction: float, message: str = "") -> None:
    """Tell the current scope that ``fraction`` (0..1) of the work is done."""
    callback = _CALLBACK.get()
    if callback is not None:
        callback(min(max(float(fraction), 0.0), 1.0), message)
