"""Sparse Cholesky factorisation behind one small interface: ``cholesky(A, order).solve(B)``.

A is symmetric positive definite (n × n, scipy sparse); the factorisation is P A Pᵀ = L Lᵀ by
CHOLMOD, through the binding in ``cvxopt`` (cvxopt.cholmod). Nothing else in zeromode sees the
package. CHOLMOD chooses between its simplicial kernel (column by column) and its supernodal one
(dense BLAS kernels on groups of columns with one sparsity pattern) from the flop count per
entry of L, which suits both ends (measured, one core, CᵀC or CCᵀ of lattice patches: at 10²
nodes the simplicial kernel factorises in 0.08–0.18 ms against 0.19–0.25 ms and solves 2–4×
faster; from 10⁴ nodes it picks the supernodal one, within a few per cent of forcing it).

Why this package (measured on the frames of issue 15, CᵀC + δI of lattice patches, one core;
the figures are in docs/benchmarks/analysis.md):
  * cvxopt 1.3.3 ships wheels with CHOLMOD and OpenBLAS for Linux (x86_64, aarch64), macOS
    (x86_64, arm64) and Windows, so ``pip install`` needs no compiler or system library;
  * scikit-sparse 0.5 is a source distribution that needs SuiteSparse headers; sksparse-minimal
    0.3 and cholespy 2.2 have wheels with METIS, but link the reference BLAS, have no macOS
    x86_64 (sksparse-minimal) or Linux aarch64 wheels, and factorise 1.5–2× slower than cvxopt
    with the ordering below; pypardiso needs MKL (220 MB, no macOS arm64); qdldl is a
    simplicial LDLᵀ without a fill-reducing order for 3D (20× slower on a 3D lattice);
  * cvxopt's CHOLMOD has no METIS, so its own ordering (AMD) fills 3D lattices badly; the
    geometric nested dissection below gives METIS-like fill (a 10⁴-node 3D lattice factorises
    in 0.6–0.8 s instead of 2.4 s with AMD, the same as with METIS's order); for smaller
    frames, AMD of the node graph (``minimum_degree``) fills less than CHOLMOD's AMD of CᵀC.
cvxopt's ``cholmod.solve`` loops over the columns of a dense right-hand side, reading the whole
factor for each; its ``cholmod.spsolve`` (a sparse right-hand side) hands CHOLMOD blocks of four
columns, which a supernodal factor solves with dense BLAS-3 kernels, reading it once a block (see
BLOCK_SOLVE_MIN_COLUMNS). The callers keep their blocks thin either way. cvxopt is GPL-3
licensed, and CHOLMOD's supernodal module is GPL-2+: a build that bundles zeromode with it
(the Docker image) is distributed under those terms.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from cvxopt import amd, cholmod
from cvxopt import matrix as cvx_matrix
from cvxopt import sparse as cvx_sparse
from cvxopt import spmatrix as cvx_spmatrix

# Nested dissection stops splitting a part at this many points: measured on 2D and 3D
# lattices, smaller leaves lower the fill until about 32 points, below which the extra levels
# cost more than they save.
LEAF_POINTS = 32
# The dissection tree's path is kept in base 3 in one int64: 39 levels (3³⁹ < 2⁶³) split
# 2³⁹ points, far beyond any frame that fits in memory.
MAX_LEVELS = 39


# CHOLMOD solves a sparse right-hand side in blocks of this many columns (cholmod_spsolve) …
SOLVE_BLOCK = 4
# … and a block of at least this many columns is solved that way when the factor is supernodal:
# its dense kernels then read the factor once for the block, where cvxopt's dense solve reads it
# once a column. Measured (one core, CᵀC + δI, spsolve with both conversions against column
# solves): 3 columns 0.58–0.86 of the time, 4 columns 0.44–0.78 (3D cubic 10⁴ nodes the least,
# a 2D near-isostatic network of 10⁴ the most), 1 column 1.0–1.14; with a simplicial factor (10²
# and 10³ nodes) 1.1–1.45 at any width. Wider blocks go four columns at a time: CHOLMOD's sparse
# result grows past them (16 columns and more in one call: 1.0–1.2).
BLOCK_SOLVE_MIN_COLUMNS = 3
# Two columns gain only where a solve is long, on factors of this order and more: 0.80–0.87 of
# the time at 3·10⁴–2·10⁵ unknowns (3D cubic and near-isostatic 10⁴ nodes, triangulated 10⁵),
# 0.98–1.20 at 2·10⁴ and less (2D lattices and networks of 10⁴ nodes, 3D ones of 10³).
BLOCK_SOLVE_TWO_COLUMNS_MIN_ORDER = 25_000


@dataclass(frozen=True, eq=False)
class Cholesky:
    """P A Pᵀ = L Lᵀ of an n × n symmetric positive definite A; ``solve`` applies A⁻¹.

    ``supernodal``: whether CHOLMOD chose (or was told to use) its supernodal kernel."""

    n: int
    supernodal: bool
    _factor: object
    # sparse right-hand sides by width, every entry in their pattern (see _sparse_solve)
    _full_patterns: dict = field(default_factory=dict)

    def solve(self, b: np.ndarray) -> np.ndarray:
        """A⁻¹ b for b of shape (n,) or (n, k); returns a new array of the same shape."""
        b2 = np.asfortranarray(b, dtype=float).reshape(self.n, -1)
        least = 2 if self.n >= BLOCK_SOLVE_TWO_COLUMNS_MIN_ORDER else BLOCK_SOLVE_MIN_COLUMNS
        if not self.supernodal or b2.shape[1] < least:
            return self._column_solves(b2).reshape(b.shape)
        x = np.empty_like(b2)
        for start in range(0, b2.shape[1], SOLVE_BLOCK):
            block = b2[:, start : start + SOLVE_BLOCK]
            if block.shape[1] < least:
                x[:, start:] = self._column_solves(block)
            else:
                x[:, start : start + SOLVE_BLOCK] = self._sparse_solve(block)
        return x.reshape(b.shape)

    def _sparse_solve(self, b: np.ndarray) -> np.ndarray:
        """A⁻¹ b (n × k, k ≤ SOLVE_BLOCK, Fortran order) by CHOLMOD's sparse solve.

        b goes in as the values of a sparse matrix whose pattern holds every entry (made once
        per width: refilling its values costs a fifth of building a sparse matrix from b,
        0.07 against 0.33 ms at n = 20 000, k = 4), and comes out as the values of CHOLMOD's
        sparse result, which lists a full result column by column (CCS, rows ascending) and
        leaves out only exact zeros (then scattered into a dense matrix instead)."""
        n, k = b.shape
        rhs = self._full_patterns.get(k)
        if rhs is None:
            rhs = self._full_patterns[k] = cvx_sparse(cvx_matrix(np.ones((n, k))))
        rhs.V = cvx_matrix(b.ravel(order="F"))
        solved = cholmod.spsolve(self._factor, rhs)
        if len(solved.V) == n * k:
            return np.asarray(solved.V).reshape(k, n).T
        return np.asarray(cvx_matrix(solved))

    def _column_solves(self, b: np.ndarray) -> np.ndarray:
        """A⁻¹ b (n × k) by cvxopt's dense solve, one column at a time."""
        x = cvx_matrix(b)
        cholmod.solve(self._factor, x)
        return np.asarray(x)

    def pivots(self) -> np.ndarray:
        """The n pivots of the elimination, P A Pᵀ = L D Lᵀ with L unit lower triangular: D's
        diagonal, in elimination order. CHOLMOD's supernodal kernel keeps L̃ L̃ᵀ (D = diag(L̃)²);
        its simplicial one keeps L D Lᵀ, whose D-solve of a vector of ones gives 1/D."""
        if self.supernodal:
            return np.asarray(cholmod.diag(self._factor)).ravel() ** 2
        ones = cvx_matrix(np.ones(self.n))
        cholmod.solve(self._factor, ones, sys=6)
        return 1.0 / np.asarray(ones).ravel()


def cholesky(
    a: sp.spmatrix, order: np.ndarray | None = None, shift: float = 0.0, supernodal: bool = False
) -> Cholesky:
    """Cholesky factor of A + shift·I for a symmetric A (n × n; only its entries on and below
    the diagonal are read, repeated entries of a COO matrix are summed) that is positive
    definite with the shift, eliminating unknowns in ``order`` (a permutation of range(n);
    None: CHOLMOD's own approximate minimum degree order). ``supernodal`` forces the
    supernodal kernel (the benchmarks' yardstick) instead of CHOLMOD's choice. Raises
    ArithmeticError if it is not numerically positive definite."""
    a = a.tocsr()  # no copy when it is CSR already
    return cholesky_csr(a.indptr, a.indices, a.data, order, shift, supernodal)


def cholesky_csr(
    indptr: np.ndarray, indices: np.ndarray, data: np.ndarray, order: np.ndarray | None = None,
    shift: float = 0.0, supernodal: bool = False,
) -> Cholesky:
    """``cholesky`` of A (n × n, n = len(indptr) − 1) given by its CSR arrays, entries on and below
    the diagonal read (the sparse route builds CᵀC and CCᵀ as arrays, solver/analysis/sparse_kernels.py)."""
    n = indptr.size - 1
    # The row of each entry, expanded.
    row, col = np.repeat(np.arange(n, dtype=np.int64), np.diff(indptr)), indices
    low = row >= col
    k = int(np.count_nonzero(low))
    # The entries on and below the diagonal, then the shift on the diagonal: each array written
    # once (concatenating copies touches every page twice: 0.4–1.2 s more at 10⁶ nodes).
    values, rows, cols = np.empty(k + n), np.empty(k + n, dtype=np.int64), np.empty(k + n, dtype=np.int64)
    diagonal = np.arange(n)
    values[:k], values[k:] = data[low], shift
    rows[:k], rows[k:] = row[low], diagonal
    cols[:k], cols[k:] = col[low], diagonal
    # repeated (row, col) entries are summed
    lower = cvx_spmatrix(cvx_matrix(values), cvx_matrix(rows), cvx_matrix(cols), (n, n))
    options = dict(cholmod.options)  # module-wide settings: restore them for other users
    cholmod.options.update({"supernodal": 2 if supernodal else 1, "nmethods": 0 if order is None else 1})
    try:
        if order is None:
            factor = cholmod.symbolic(lower, uplo="L")
        else:
            perm = cvx_matrix(np.asarray(order, dtype=np.int64))
            factor = cholmod.symbolic(lower, p=perm, uplo="L")
        cholmod.numeric(lower, factor)
    finally:
        cholmod.options.clear()
        cholmod.options.update(options)
    try:
        cholmod.diag(factor)  # defined for supernodal factors only
    except ValueError:  # cvxopt's only sign of a simplicial factor
        return Cholesky(n, False, factor)
    return Cholesky(n, True, factor)


def minimum_degree(n: int, pairs: np.ndarray) -> np.ndarray:
    """An elimination order of n unknowns coupled in ``pairs`` (m × 2: a_ij ≠ 0): a permutation
    of range(n), by approximate minimum degree (AMD, through cvxopt's binding) on that graph.

    Called on the nodes of a frame, whose d coordinates are then eliminated together, it orders
    the graph behind CᵀC with d times fewer vertices and d² times fewer entries than CHOLMOD's
    own AMD of CᵀC, and finds less fill (measured, CᵀC of lattice patches, ordering plus
    factorisation, one core: triangulated 10³ nodes 3.2 ms against 4.2 ms, 10⁴ 47 ms against
    57 ms; cubic 125 nodes 0.55 ms against 0.85 ms, 10³ 12 ms against 17 ms).
    """
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    diagonal = np.arange(n, dtype=np.int64)
    # np.maximum of the two columns, not .max(axis=1): a reduction over rows of two is 10×
    # slower (0.77 ms against 0.06 ms for 2·10⁴ pairs)
    rows = cvx_matrix(np.concatenate([np.maximum(pairs[:, 0], pairs[:, 1]), diagonal]))
    cols = cvx_matrix(np.concatenate([np.minimum(pairs[:, 0], pairs[:, 1]), diagonal]))
    pattern = cvx_spmatrix(1.0, rows, cols, (n, n))  # lower triangle; repeated pairs are summed
    return np.asarray(amd.order(pattern, uplo="L"), dtype=np.int64).ravel()


def nested_dissection(points: np.ndarray, pairs: np.ndarray, leaf: int = LEAF_POINTS) -> np.ndarray:
    """An elimination order of n unknowns that live at ``points`` (n × d), coupled in ``pairs``
    (m × 2: a_ij ≠ 0): a permutation of range(n).

    Geometric nested dissection: every part is cut at the median of its widest coordinate;
    of the two rows of points along the cut that have a coupling across it, the smaller is
    the separator. The two halves are numbered first (recursively), the separator last, so
    eliminating one half never fills the other: for a patch of a d-dimensional lattice the
    separators hold O(n^((d−1)/d)) points, the fill of the factor is O(n log n) in 2D and
    O(n^(4/3)) in 3D, as with a graph partitioner. All parts of one level are cut at once.
    The path of a point in the dissection tree is a base-3 number (0: first half, 1: second,
    2: separator) with the digits of finished points padded by zeros, so sorting the paths
    gives the order: each half before its separator, and points in one leaf keep their order.
    """
    n, d = points.shape
    path = np.zeros(n, dtype=np.int64)
    # 32-bit point numbers while they fit: half the memory traffic of the per-level gathers
    index = np.int32 if n < 2**31 else np.int64
    active = np.arange(n, dtype=index) if n > leaf else np.zeros(0, dtype=index)
    part = np.zeros(active.size, dtype=np.int64)  # which part each active point is in
    n_parts = 1
    i, j = np.asarray(pairs, dtype=index).reshape(-1, 2).T
    for _ in range(MAX_LEVELS):
        if active.size == 0:
            break
        p = np.take(points, active, axis=0)  # np.take: several times faster than p[active] on rows
        low = np.full((d, n_parts), np.inf)
        high = np.full((d, n_parts), -np.inf)
        for k in range(d):
            np.minimum.at(low[k], part, p[:, k])
            np.maximum.at(high[k], part, p[:, k])
        extent = high - low
        axis = np.argmax(extent, axis=0)[part]
        # part + (coordinate along its widest axis, scaled into [0, 1/2]): one sort key that
        # lists the parts in turn, each along its axis
        along = (np.take_along_axis(p, axis[:, None], axis=1)[:, 0] - low[axis, part]) / (
            2 * np.maximum(extent[axis, part], 1e-300)
        )
        by_coordinate = np.argsort(part + along)
        size = np.bincount(part, minlength=n_parts)
        second = np.empty(active.size, dtype=bool)
        part_sorted = part[by_coordinate]
        second[by_coordinate] = np.arange(active.size) - (np.cumsum(size) - size)[part_sorted] >= (
            size // 2
        )[part_sorted]
        half = np.zeros(n, dtype=np.int8)  # 0: not being cut, 1: first half, 2: second half
        half[active] = 1 + second
        half_i, half_j = half[i], half[j]
        across = half_i != half_j
        i_across, j_across = i[across], j[across]
        i_first = half_i[across] == 1
        on_first = np.zeros(n, dtype=bool)
        on_second = np.zeros(n, dtype=bool)
        on_first[np.where(i_first, i_across, j_across)] = True
        on_second[np.where(i_first, j_across, i_across)] = True
        on_first_active, on_second_active = on_first[active], on_second[active]
        cut_first = np.bincount(part, on_first_active, n_parts) <= np.bincount(part, on_second_active, n_parts)
        separator = np.where(cut_first[part], on_first_active, on_second_active)
        path *= 3
        path[active] += np.where(separator, 2, second)
        child = 2 * part + second
        child_size = np.bincount(child[~separator], minlength=2 * n_parts)
        keep = ~separator & (child_size[child] > leaf)
        split_again = child_size > leaf
        part, n_parts = (np.cumsum(split_again) - 1)[child[keep]], int(split_again.sum())
        still = np.zeros(n, dtype=bool)
        still[active[keep]] = True
        inside = still[i] & still[j] & ~across
        i, j, active = i[inside], j[inside], active[keep]
    return np.argsort(path, kind="stable")
