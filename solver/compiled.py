"""Compilation of the analysis's inner loops by numba, with its machine code cached on disk."""

from __future__ import annotations

from numba import njit


def compiled(function):
    """``function`` compiled by numba, its machine code cached on disk (beside its module, in
    NUMBA_CACHE_DIR or in the user's cache directory, the first of them writable); where none is
    writable (a read-only install run by a user without a home), compiled in each process.

    Compiled when first called with new argument types: see rigidity.warm_up."""
    try:
        return njit(cache=True)(function)
    except RuntimeError:  # numba's "cannot cache function …: no locator available"
        return njit(function)
