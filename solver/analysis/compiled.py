"""Compilation of the analysis's inner loops by numba, with its machine code cached on disk.

Compiling is waiting, not computing: the time a thread spends in numba's compiler (or waiting
for another thread's compilation to finish) is not charged to its time budget
(solver/budget.py ``not_charged``), so a request that meets a kernel not yet compiled (a fresh
environment, the service's warm-up still running) is not refused too_expensive for it.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
from numba import njit
from numba.core import event

from zeromode.solver.budget import not_charged

try:
    import fcntl
except ImportError:  # Windows: no advisory file locks; each process compiles what it misses
    fcntl = None


def compiled(function):
    """``function`` compiled by numba, its machine code cached on disk (beside its module, in
    NUMBA_CACHE_DIR or in the user's cache directory, the first of them writable); where none is
    writable (a read-only install run by a user without a home), compiled in each process.

    Compiled when first called with new argument types: see rigidity.warm_up."""
    try:
        return njit(cache=True)(function)
    except RuntimeError:  # numba's "cannot cache function …: no locator available"
        return njit(function)


def kernel_array(array, dtype) -> np.ndarray:
    """``array`` as the one argument type the kernels are compiled for: C-contiguous, of
    ``dtype`` and writable. numba types a read-only array (a Frame's) apart from a writable one
    and would compile each kernel again for it; the kernels never write to their inputs, and
    only a read-only array is copied."""
    a = np.ascontiguousarray(array, dtype=dtype)
    return a if a.flags.writeable else a.copy()


@contextmanager
def compiling_alone(dispatcher) -> Iterator[None]:
    """An exclusive lock on a file in ``dispatcher``'s numba cache directory, held inside: of
    several processes warming up on one cache (the service's workers, the job engine's), one
    compiles and saves while the others wait, then load what it saved (none compiles twice the
    same kernel, on a machine whose cores they share). No lock without a disk cache or fcntl."""
    directory = getattr(getattr(dispatcher, "_cache", None), "_cache_path", None)
    if directory is None or fcntl is None:
        yield
        return
    os.makedirs(directory, exist_ok=True)
    with open(os.path.join(directory, "zeromode-warm-up.lock"), "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


class _CompilationNotCharged(event.Listener):
    """Listens to numba's compiler lock (its events span the wait to acquire it and the
    compilation under it; nested ones are one span): the whole span is not charged to the
    calling thread's time budget."""

    def __init__(self):
        self._local = threading.local()

    def on_start(self, event) -> None:
        depth = getattr(self._local, "depth", 0)
        if depth == 0:
            self._local.start = time.monotonic()
        self._local.depth = depth + 1

    def on_end(self, event) -> None:
        self._local.depth -= 1
        if self._local.depth == 0:
            not_charged(time.monotonic() - self._local.start)


event.register("numba:compiler_lock", _CompilationNotCharged())
