"""Progress reports from long computations.

The caller opens ``progress_scope(callback)``; main loops call ``report_progress(fraction,
message)`` where they know how far they are, and the callback receives the fraction clamped to
[0, 1]. Outside a scope a report costs one context-variable lookup and goes nowhere. The
scope lives in a context variable (like the time budget of budget.py), so concurrent jobs
each report to their own.

Stages nest: ``progress_stage(lo, hi, label)`` maps the inner fractions 0..1 affinely onto
[lo, hi] of the enclosing stage (the scope is the stage [0, 1]), so a pipeline whose parts each
report 0..1 reports one fraction overall, monotone when each part is and the stages of one
level are entered in increasing, non-overlapping order. A function that reports is called
inside a stage by any caller that reports around it; its reports then stay within the share the
caller gave it. Entering a stage reports its start, leaving it (without an exception) its end.

A building block called from many places inside other stages' loops (the rigidity analysis,
run at every step of a continuation) reports with ``report_detail``: only into a stage its
caller opened with ``detail=True`` for that one call, so its fractions never interleave with
those of a loop around it.

An opaque call (one solver call without callbacks) reports through ``progress_heartbeat``: a
thread reports the clock while it runs.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass

ProgressCallback = Callable[[float, str], None]
# Reported fractions are rounded to this many decimals (_exact).
DIGITS = 12


@dataclass(frozen=True)
class _Stage:
    """The scope's callback and the interval [lo, hi] of the scope's fraction that this stage's
    0..1 maps onto; ``label`` prefixes its messages; ``detail``: report_detail goes out."""

    callback: ProgressCallback
    lo: float
    hi: float
    label: str
    detail: bool = False


_STAGE: ContextVar[_Stage | None] = ContextVar("zeromode_progress", default=None)


@contextmanager
def progress_scope(callback: ProgressCallback | None) -> Iterator[None]:
    """Within this block, ``report_progress`` calls ``callback(fraction, message)``; None turns
    the reports of an enclosing scope off."""
    token = _STAGE.set(None if callback is None else _Stage(callback, 0.0, 1.0, ""))
    try:
        yield
    finally:
        _STAGE.reset(token)


@contextmanager
def progress_stage(lo: float, hi: float, label: str = "", detail: bool = False) -> Iterator[None]:
    """Within this block, a report of f (0..1) is the enclosing stage's lo + f·(hi − lo)
    (0 ≤ lo ≤ hi ≤ 1), its message prefixed by ``label``. Reports lo on entry, hi on a normal
    exit. detail: the block is one call of a building block whose report_detail calls go out
    (not those of stages nested in it). Outside a scope: nothing."""
    outer = _STAGE.get()
    if outer is None:
        yield
        return
    width = outer.hi - outer.lo
    if outer.label and label:
        label = f"{outer.label}: {label}"
    stage = _Stage(outer.callback, _exact(outer.lo + width * lo), _exact(outer.lo + width * hi), label or outer.label, detail)
    token = _STAGE.set(stage)
    try:
        report_progress(0.0, "started")
        yield
        report_progress(1.0, "done")
    finally:
        _STAGE.reset(token)


def report_progress(fraction: float, message: str = "") -> None:
    """Tell the current stage that ``fraction`` (0..1) of its work is done."""
    stage = _STAGE.get()
    if stage is not None:
        f = min(max(float(fraction), 0.0), 1.0)
        text = f"{stage.label}: {message}" if stage.label and message else message or stage.label
        stage.callback(_exact(stage.lo + (stage.hi - stage.lo) * f), text)


@contextmanager
def progress_heartbeat(expected_s: float, message: str, interval_s: float = 0.5) -> Iterator[None]:
    """While the block runs, a thread reports 1 − exp(−t / expected_s) of the current stage
    every ``interval_s`` seconds (t since entry): a fraction that grows with the clock, about
    2/3 at the expected duration, never reaching the end, which the caller reports. The block
    must not report itself (the thread's reports would interleave with its own); the thread is
    joined on exit. Outside a scope: nothing, no thread. The scope's callback is then called
    from that thread too."""
    stage = _STAGE.get()
    if stage is None:
        yield
        return
    done = threading.Event()
    t0 = time.perf_counter()

    def beat() -> None:
        while not done.wait(interval_s):
            f = 1.0 - math.exp(-(time.perf_counter() - t0) / expected_s)
            text = f"{stage.label}: {message}" if stage.label else message
            stage.callback(stage.lo + (stage.hi - stage.lo) * f, text)

    thread = threading.Thread(target=beat, name="zeromode-progress", daemon=True)
    thread.start()
    try:
        yield
    finally:
        done.set()
        thread.join()


def _exact(fraction: float) -> float:
    """``fraction`` rounded to DIGITS decimals: fractions equal in exact arithmetic but reached
    by different roundings (a stage's end, the next one's start, the parent's own report there)
    compare equal, so the reports stay monotone."""
    return round(fraction, DIGITS)


def report_detail(fraction: float, message: str = "") -> None:
    """report_progress from a building block: only within a stage opened with ``detail=True``."""
    stage = _STAGE.get()
    if stage is not None and stage.detail:
        report_progress(fraction, message)


def report_steps(total: int, message: str, step: float = 0.01) -> Callable[[int], None]:
    """For a loop of ``total`` iterations: ``tick(i)`` reports (i + 1)/total when that moved by
    at least ``step`` since the last report (and at the last iteration), so a fast loop
    reports about 1/step times whatever its length. Outside a scope ``tick`` does nothing."""
    if _STAGE.get() is None or total <= 0:
        return _nothing
    stride = max(1, int(step * total))

    def tick(i: int) -> None:
        if (i + 1) % stride == 0 or i + 1 == total:
            report_progress((i + 1) / total, message)

    return tick


def _nothing(i: int) -> None:
    """report_steps' tick outside a scope."""
