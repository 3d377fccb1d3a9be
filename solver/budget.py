"""A cooperative time budget for long computations.

The caller opens ``time_budget(seconds)``; long loops call ``check_budget()`` once per
iteration, which raises DomainError ``too_expensive`` (with the limit in the message) once the
deadline has passed.  The deadline lives in a context variable, so concurrent requests (threads
or tasks) each see their own.  Time spent waiting rather than computing (numba compiling a kernel,
solver/analysis/compiled.py) is not charged: ``not_charged`` moves the deadline later by it.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

from zeromode.solver.errors import DomainError

_DEADLINE: ContextVar[tuple[float, float] | None] = ContextVar("zeromode_deadline", default=None)


@contextmanager
def time_budget(seconds: float | None, stated: float | None = None) -> Iterator[None]:
    """Within this block, ``check_budget`` fails once ``seconds`` have passed (None: no limit),
    naming ``stated`` as the budget (default ``seconds``: a request's budget of which only
    ``seconds`` are left when its computation starts elsewhere)."""
    token = _DEADLINE.set(None if seconds is None else (time.monotonic() + seconds, seconds if stated is None else stated))
    try:
        yield
    finally:
        _DEADLINE.reset(token)


def remaining() -> float | None:
    """Seconds left in the current budget (None when unlimited)."""
    deadline = _DEADLINE.get()
    return None if deadline is None else max(deadline[0] - time.monotonic(), 0.0)


def not_charged(seconds: float) -> None:
    """Move the current deadline ``seconds`` later (nothing without a budget): time spent waiting
    for something other than this computation."""
    deadline = _DEADLINE.get()
    if deadline is not None:
        _DEADLINE.set((deadline[0] + seconds, deadline[1]))


def check_budget() -> None:
    deadline = _DEADLINE.get()
    if deadline is not None and time.monotonic() > deadline[0]:
        raise DomainError(
            "too_expensive",
            f"the computation needs more than its time budget of {deadline[1]:g} s; "
            "ask for a smaller problem or a larger budget.",
        )
