"""Rank, counts and bases of a frame from the definitions, independent of zeromode.solver.

Deliberately plain: a per-edge loop for the compatibility matrix (paper, Eq. 3: row e = (i, j)
holds (x_i − x_j)ᵀ at node i and (x_j − x_i)ᵀ at node j), rigid motions written out as
translations and infinitesimal rotations, ranks from numpy's full SVD with a relative threshold
on the scale-normalised frame.  Flattening is node-major: coordinate a of node i is entry d·i + a.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla

# The integer fields of /v1/analyze (also report.analysis of every design), in the contract's
# order; rank_gap carries RANK_GAP_FIELDS.
COUNT_FIELDS = (
    "nodes",
    "edges",
    "dim",
    "maxwell_count",
    "rank",
    "zero_modes",
    "rigid_body_modes",
    "nontrivial_zero_modes",
    "self_stresses",
)
RANK_GAP_FIELDS = ("last_nonzero", "first_zero", "last_nonzero_error")

# σ ≤ REFERENCE_RTOL·σ_max counts as zero on the normalised frame. The frames tested have exact
# zeros (σ ~ 1e-15 σ_max) or gaps far above it (designed frames: σ_r/σ_max ≳ 1e-4), so the
# decision does not depend on where in between the threshold sits.
REFERENCE_RTOL = 1e-9

# Above this many entries C is too large for a dense SVD inside a test: its 2-norm comes from
# ARPACK instead (mode_residual) and its rank from the Gram matrix (gram_rank), where
# λ = σ² ≤ GRAM_RTOL·λ_max (σ ≤ 1e-6·σ_max) counts as zero.
DENSE_ENTRIES = 1_000_000
GRAM_RTOL = 1e-12


def compatibility_matrix(positions, edges) -> np.ndarray:
    """Dense C (N_B × dN) built edge by edge."""
    x = np.asarray(positions, dtype=float)
    n, d = x.shape
    c = np.zeros((len(edges), d * n))
    for row, (i, j) in enumerate(np.asarray(edges, dtype=int).reshape(-1, 2)):
        c[row, d * i : d * i + d] = x[i] - x[j]
        c[row, d * j : d * j + d] = x[j] - x[i]
    return c


def rigid_generators(positions) -> np.ndarray:
    """dN × d(d+1)/2: the d translations, then u_i = Ω x_i for the basic skew Ω of each plane."""
    x = np.asarray(positions, dtype=float)
    n, d = x.shape
    columns = [np.tile(np.eye(d)[a], n) for a in range(d)]
    for a in range(d):
        for b in range(a + 1, d):
            rotation = np.zeros((n, d))
            rotation[:, a], rotation[:, b] = -x[:, b], x[:, a]
            columns.append(rotation.ravel())
    return np.column_stack(columns)


def normalised(positions) -> np.ndarray:
    """Centred and divided by the RMS radius (so thresholds are scale-free)."""
    x = np.asarray(positions, dtype=float)
    x = x - x.mean(axis=0)
    r = np.sqrt(np.mean(np.sum(x**2, axis=1)))
    return x / r if r > 0 else x


def singular_values(matrix: np.ndarray) -> np.ndarray:
    return np.linalg.svd(matrix, compute_uv=False) if matrix.size else np.zeros(0)


def rank_of(s: np.ndarray, rtol: float = REFERENCE_RTOL) -> int:
    """How many of the descending singular values ``s`` exceed rtol·σ_max."""
    return int(np.count_nonzero(s > rtol * s[0])) if s.size and s[0] > 0 else 0


def numerical_rank(matrix: np.ndarray, rtol: float = REFERENCE_RTOL) -> int:
    return rank_of(singular_values(matrix), rtol)


def span(matrix: np.ndarray, rtol: float = REFERENCE_RTOL) -> np.ndarray:
    """Orthonormal basis (columns) of the column space."""
    if matrix.size == 0:
        return np.zeros((matrix.shape[0], 0))
    u, _, _ = np.linalg.svd(matrix, full_matrices=False)
    return u[:, : numerical_rank(matrix, rtol)]


def kernel(matrix: np.ndarray, rtol: float = REFERENCE_RTOL) -> np.ndarray:
    """Orthonormal basis (columns) of the null space."""
    if matrix.shape[0] == 0:
        return np.eye(matrix.shape[1])
    _, _, vt = np.linalg.svd(matrix, full_matrices=True)
    return vt[numerical_rank(matrix, rtol) :].T


def projector(basis: np.ndarray) -> np.ndarray:
    """Orthogonal projector onto span(basis) for an orthonormal basis given as columns."""
    return basis @ basis.T


def rigid_motions(positions) -> np.ndarray:
    """Orthonormal basis (dN × ρ) of the rigid motions; ρ < d(d+1)/2 on degenerate frames."""
    return span(rigid_generators(normalised(positions)))


def reference_counts(positions, edges, rtol: float = REFERENCE_RTOL) -> dict[str, int]:
    """The COUNT_FIELDS of a frame, from the SVD of C and of the rigid generators."""
    x = normalised(positions)
    n, d = x.shape
    n_edges = len(edges)
    rank = numerical_rank(compatibility_matrix(x, edges), rtol)
    rigid = numerical_rank(rigid_generators(x), rtol)
    return {
        "nodes": n,
        "edges": n_edges,
        "dim": d,
        "maxwell_count": d * n - n_edges,
        "rank": rank,
        "zero_modes": d * n - rank,
        "rigid_body_modes": rigid,
        "nontrivial_zero_modes": d * n - rank - rigid,
        "self_stresses": n_edges - rank,
    }


def rank_gap(positions, edges, rtol: float = REFERENCE_RTOL) -> dict[str, float]:
    """σ_r and σ_{r+1} of C on the normalised frame (0 where there is no such σ)."""
    s = singular_values(compatibility_matrix(normalised(positions), edges))
    r = rank_of(s, rtol)
    return {
        "last_nonzero": float(s[r - 1]) if r else 0.0,
        "first_zero": float(s[r]) if r < s.size else 0.0,
    }


def nontrivial_flexes(positions, edges, rtol: float = REFERENCE_RTOL) -> np.ndarray:
    """Orthonormal basis (dN × f) of the zero modes orthogonal to the rigid motions.

    N(C) and the span of the rigid motions are the same on the normalised frame (C only scales
    and the rigid span only shifts by translations), so the basis serves the original frame."""
    x = normalised(positions)
    null = kernel(compatibility_matrix(x, edges), rtol)
    rigid = span(rigid_generators(x), rtol)
    return null @ kernel(rigid.T @ null, rtol)


def self_stresses(positions, edges, rtol: float = REFERENCE_RTOL) -> np.ndarray:
    """Orthonormal basis (N_B × s) of N(Cᵀ): bar tensions in equilibrium at every node."""
    return kernel(compatibility_matrix(normalised(positions), edges).T, rtol)


def relative_residual(matrix: np.ndarray, vectors: np.ndarray) -> float:
    """max_k ‖matrix · v_k‖ / (‖matrix‖₂ ‖v_k‖) over the columns v_k (0 when there are none)."""
    if vectors.size == 0 or matrix.size == 0:
        return 0.0
    norm = singular_values(matrix)[0]
    if norm == 0:
        return 0.0
    return float(
        np.max(np.linalg.norm(matrix @ vectors, axis=0) / (norm * np.linalg.norm(vectors, axis=0)))
    )


def mode_residual(c: np.ndarray, mode: np.ndarray) -> float:
    """‖C u‖ / (‖C‖₂ ‖u‖); ‖C‖₂ by ARPACK for large C (a dense SVD would dominate the test)."""
    if c.size <= DENSE_ENTRIES:
        norm = np.linalg.norm(c, 2)
    else:
        norm = spla.svds(sps.csr_matrix(c), k=1, return_singular_vectors=False)[0]
    return float(np.linalg.norm(c @ np.ravel(mode)) / (norm * np.linalg.norm(mode)))


def gram_rank(c: np.ndarray) -> int:
    """Rank of a large C from the eigenvalues of CᵀC: λ > GRAM_RTOL·λ_max.

    The eigenvalues carry absolute errors ~1e-16·λ_max, so zero ones scatter there and the
    threshold must sit well above; designed gaps σ_r/σ_max ≳ 1e-3 give λ_r/λ_max ≳ 1e-6."""
    sparse = sps.csr_matrix(c)
    ev = np.linalg.eigvalsh((sparse.T @ sparse).toarray())
    return int(np.count_nonzero(ev > GRAM_RTOL * ev[-1]))


def zero_modes_and_stresses(positions, edges) -> tuple[int, int]:
    """(dim N(C), dim N(Cᵀ)) of a frame of any size: the SVD, or gram_rank for large C."""
    c = compatibility_matrix(normalised(positions), edges)
    rank = numerical_rank(c) if c.size <= DENSE_ENTRIES else gram_rank(c)
    return c.shape[1] - rank, c.shape[0] - rank


def outside_fraction(basis: np.ndarray, v: np.ndarray) -> float:
    """‖v − P v‖ / ‖v‖ with P the orthogonal projector onto span(basis)."""
    q = span(basis, 1e-12)
    v = np.ravel(v)
    return float(np.linalg.norm(v - q @ (q.T @ v)) / np.linalg.norm(v))


def as_columns(modes) -> np.ndarray:
    """A stack of z motions (z × N × d) as the dN × z matrix of their node-major flattenings."""
    z, n, d = np.shape(modes)
    return np.asarray(modes, dtype=float).reshape(z, n * d).T


def driven_response(positions, edges, source, source_motion) -> np.ndarray:
    """The zero mode (N, d) whose rows at the ``source`` nodes equal ``source_motion``; asserts
    that it exists and is unique (no zero mode moves anything while the source stays still)."""
    positions = np.asarray(positions, dtype=float)
    n, d = positions.shape
    null = kernel(compatibility_matrix(normalised(positions), edges))
    rows = (np.asarray(source)[:, None] * d + np.arange(d)).ravel()
    wanted = np.ravel(source_motion)
    coef, *_ = np.linalg.lstsq(null[rows], wanted, rcond=None)
    assert np.linalg.matrix_rank(null[rows], tol=1e-8) == null.shape[1], "response not unique"
    assert np.linalg.norm(null[rows] @ coef - wanted) <= 1e-9 * np.linalg.norm(wanted)
    return (null @ coef).reshape(n, d)
