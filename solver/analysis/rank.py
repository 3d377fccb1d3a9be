"""Numerical rank decisions with a reported margin.

Every rank in zeromode is decided here, on a matrix that the caller has already made
scale-free (see ``Frame.normalised_positions``), by a threshold *relative* to the largest
singular value. The decision is reported with its evidence: the last singular value kept
(σ_r) and the first one dropped (σ_{r+1}), so a user can see how clear the call was.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from zeromode.solver.tolerances import RANK_RTOL as RTOL

# A backward-stable SVD of a k-column matrix returns each singular value within a modest
# multiple of k·ε·σ_1 (LAPACK's error bound, p(m, n)·ε·‖C‖₂); the factor is that multiple,
# taken generously, as the bound is reported, not relied on.
SVD_ERROR_FACTOR = 10


@dataclass(frozen=True)
class RankGap:
    """Evidence for a rank decision: σ_r (last kept) and σ_{r+1} (first dropped; 0 if none).

    ``last_nonzero_error`` bounds the relative error of ``last_nonzero`` as σ_r: the SVD's
    round-off for singular values computed in full (SVD_ERROR_FACTOR), the Weyl bound of a Ritz
    pair's residual for iterated ones (sparse_kernels.relative_error_bound)."""

    last_nonzero: float
    first_zero: float
    last_nonzero_error: float = 0.0


def decide_rank(singular_values: np.ndarray, rtol: float = RTOL) -> tuple[int, RankGap]:
    """Rank from descending singular values (of a full SVD): count σ_i > rtol·σ_1; return it
    with its gap, whose σ_r is exact to SVD_ERROR_FACTOR·k·ε·σ_1 (k singular values)."""
    s = np.asarray(singular_values, dtype=float)
    if s.size == 0 or s[0] == 0.0:
        return 0, RankGap(0.0, float(s[0]) if s.size else 0.0)
    r = int(np.count_nonzero(s > rtol * s[0]))
    error = min(1.0, SVD_ERROR_FACTOR * s.size * np.finfo(float).eps * s[0] / s[r - 1])
    return r, RankGap(float(s[r - 1]), float(s[r]) if r < s.size else 0.0, error)


def orthonormal_range(matrix: np.ndarray, rtol: float = RTOL) -> np.ndarray:
    """Orthonormal basis (columns) of the column space of ``matrix``, rank decided relatively."""
    if matrix.size == 0:
        return np.zeros((matrix.shape[0], 0))
    u, s, _ = np.linalg.svd(matrix, full_matrices=False)
    r, _ = decide_rank(s, rtol)
    return u[:, :r]


def nullspace(matrix: np.ndarray, rtol: float = RTOL) -> tuple[np.ndarray, int, RankGap]:
    """Orthonormal basis (columns) of N(matrix), with the rank and its gap."""
    rows, cols = matrix.shape
    if rows == 0:
        return np.eye(cols), 0, RankGap(0.0, 0.0)
    _, s, vt = np.linalg.svd(matrix, full_matrices=True)
    r, gap = decide_rank(s, rtol)
    return vt[r:].T.copy(), r, gap


def complement_within(space: np.ndarray, sub: np.ndarray) -> np.ndarray:
    """Orthonormal basis of span(space) ⊖ span(sub), for ``space`` orthonormal and span(sub) ⊆ span(space).

    Shapes: space (n, z) orthonormal, sub (n, ρ) orthonormal with ρ ≤ z → result (n, z − ρ).
    """
    if sub.shape[1] == 0:
        return space
    u, _, _ = np.linalg.svd(space.T @ sub, full_matrices=True)
    return space @ u[:, sub.shape[1]:]
