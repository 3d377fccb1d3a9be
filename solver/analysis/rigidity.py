"""Rigidity analysis of a frame: compatibility matrix, zero modes, rigid motions, self-stresses.

Definitions (paper, Eq. 3 and Supplementary "Edge Constraint Satisfaction"):
    the compatibility matrix C ∈ R^{N_B × dN} has, in the row of bar e = (i, j), the entries
    (x_i − x_j)ᵀ in the columns of node i and (x_j − x_i)ᵀ in those of node j, so (C u)_e = 0
    is the linearised bar constraint (x_i − x_j)·(u_i − u_j) = 0.
    zero modes   N(C),   dim = dN − rank C
    self-stresses N(Cᵀ), dim = N_B − rank C
    rigid motions of the configuration: translations and infinitesimal rotations u_i = Ω x_i
    (Ω skew); their span has dimension d(d+1)/2 unless the nodes are degenerate.

Rank is decided on C of the *normalised* configuration (centred, divided by its RMS radius),
which makes every count invariant under translation, rotation and scaling.

Two routes, with identical counts and subspaces where both apply:
  * dense: a full SVD of C (small frames; exact bases of both null spaces);
  * sparse: shift-invert subspace iteration with one sparse Cholesky factorisation of
    CᵀC + δI or CCᵀ + δI (solver/analysis/factorisation.py, nested-dissection order), then a
    Rayleigh–Ritz step on C itself so the singular values (and the rank decision) come from C,
    not from CᵀC whose small eigenvalues are squared into round-off. The one factorisation
    serves both null spaces: I − Cᵀ(CCᵀ + δI)⁻¹C = δ(CᵀC + δI)⁻¹ and I − C(CᵀC + δI)⁻¹Cᵀ =
    δ(CCᵀ + δI)⁻¹ (push-through identity), so either shifted inverse is one solve away.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.linalg import blas, lapack

from zeromode.solver.analysis import sparse_kernels
from zeromode.solver.analysis.compiled import compiling_alone, kernel_array
from zeromode.solver.analysis.factorisation import cholesky_csr, minimum_degree, nested_dissection
from zeromode.solver.analysis.normalisation import normalised
from zeromode.solver.analysis.rank import RTOL, RankGap, complement_within, decide_rank
from zeromode.solver.budget import check_budget
from zeromode.solver.errors import DomainError
from zeromode.solver.frame import Frame
from zeromode.solver.progress import report_detail
from zeromode.solver.tolerances import BASIS_ANGLE, BASIS_ROUNDOFF_RTOL, NULL_SHIFT_RTOL

# Dense linear algebra up to this many degrees of freedom (dN) in the modules that share this
# crossover (finite motion, eigenmodes, certificates, zero_mode_residual below).
DENSE_MAX_DOF = 400
# analyze takes the SVD of C while C has at most this many entries (N_B·dN), the sparse route
# above: the break-even of the two, measured (benchmarks/bench_analysis.py, crossover table in
# docs/benchmarks/analysis.md: both routes on the same frames, timed in turn, one core; two runs
# of the same day, the sparse route's fixed cost of 0.1–0.2 ms at this size moving with the
# machine's state). The SVD's cost grows as N_B·dN·min(N_B, dN). Counts alone: the SVD ahead to
# 2 256–2 800 entries in one run (networks 0.12 against 0.14–0.17 ms; triangulated level, 0.14
# against 0.15) and to 4 692–6 006 in the other (3D network 0.24 against 0.32 ms at 4 692, 0.30
# against 0.33 at 6 006; 2D network 0.24 against 0.29 at 5 040), the sparse route ahead from
# 6 006–6 120 in the first (3D network 0.25 against 0.23 ms, triangulated 0.27 against 0.19) and
# 6 120–6 560 in the second (triangulated 0.31 against 0.28, 2D network level at 0.31 and 0.30).
# With bases (sized by dN·max(N_B, dN), as the SVD then also holds the dN × dN matrix V) the SVD
# ahead to 870–1 056 entries and behind from 2 256 in the first run (0.29–0.36 against
# 0.26–0.29 ms), ahead to 2 256–3 720 and behind from 4 692 in the second (0.48–0.57 against
# 0.46–0.51 ms at 3 540–5 040). Both routes state σ_r's accuracy (rank_gap.last_nonzero_error):
# the SVD's is round-off, the sparse route's a Ritz value's bound unless gap_rtol asks for more.
DENSE_MAX_ENTRIES_COUNTS = 6_000
DENSE_MAX_ENTRIES_BASES = 2_500
# Bases are returned only while they stay this small (numbers); counts are always exact.
BASIS_MAX_NUMBERS = 4_000_000
# The dense route asked for by name is refused (too_expensive) past this many rows or columns of
# C: its SVD grows as the cube of the larger side (with bases U and V are side² each); one core,
# loaded machine: 2 000 × 2 000 with bases 4.6 s, 3 000 × 3 000 ≈ 15 s, 4 000 × 4 000 39 s,
# 6 000 × 3 000 (1 000 nodes in 3D) 195 s.
DENSE_MAX_SIDE = 3_000


def compatibility_matrix(positions: np.ndarray, edges: np.ndarray, dense: bool = False):
    """C (N_B × dN): row e holds (x_i − x_j) at node i and (x_j − x_i) at node j.

    Sparse CSR by default; ``dense=True`` returns an ndarray (cheaper for tiny frames).
    """
    n, d = positions.shape
    indptr, indices, data = sparse_kernels.compatibility_csr(
        kernel_array(positions, float), kernel_array(edges, np.int64).reshape(-1, 2)
    )
    nb = indptr.size - 1
    if dense:
        c = np.zeros((nb, n * d))
        c[np.repeat(np.arange(nb), 2 * d), indices] = data  # (row, col) pairs are distinct
        return c
    return sp.csr_matrix((data, indices, indptr), shape=(nb, n * d))


def rigid_motions(positions: np.ndarray, rtol: float = RTOL) -> np.ndarray:
    """Orthonormal basis (dN × ρ) of the rigid motions of this configuration.

    Spans the d translations and the d(d−1)/2 infinitesimal rotations u_i = E_ab x_i (E_ab the
    elementary skew matrices); ρ = d(d+1)/2 unless the points are degenerate (one point: d;
    collinear in 3D: 5). ``positions`` should be normalised (see Frame.normalised_positions).
    """
    if positions.size == 0:
        return np.zeros((0, 0))
    u, s = sparse_kernels.rigid_motion_svd(kernel_array(positions, float))
    rank, _ = decide_rank(s, rtol)
    return u[:, :rank]


def non_rigid_part(positions: np.ndarray, motion: np.ndarray, rtol: float = RTOL) -> np.ndarray:
    """u − R Rᵀ u: the part of ``motion`` (N, d) orthogonal to every rigid motion of ``positions``.

    R = rigid_motions of the normalised positions (any translation or scale of ``positions``
    gives the same projector). Returns an (N, d) array; zero exactly when u is rigid.
    """
    x = Frame.build(positions, []).normalised_positions()
    rigid = rigid_motions(x, rtol)
    u = np.asarray(motion, dtype=float).ravel()
    return (u - rigid @ (rigid.T @ u)).reshape(x.shape)


def zero_mode_residual(frame: Frame, mode: np.ndarray) -> float:
    """‖C u‖ / (‖C‖_F ‖u‖) with C of the normalised frame: 0 for an exact zero mode u (N, d).

    u is divided by max |u| first, so no magnitude (1e±200) can under- or overflow the norms.
    """
    peak = float(np.max(np.abs(mode), initial=0.0))
    if peak == 0.0 or not np.isfinite(peak):
        return 0.0 if peak == 0.0 else float("inf")
    u = mode.ravel() / peak
    dense = frame.dim * frame.n_nodes <= DENSE_MAX_DOF
    c = compatibility_matrix(frame.normalised_positions(), frame.edges, dense=dense)
    if c.shape[0] == 0:
        return 0.0
    c_norm = np.linalg.norm(c) if dense else spla.norm(c)
    return float(np.linalg.norm(c @ u) / (c_norm * np.linalg.norm(u)))


@dataclass(frozen=True, eq=False)
class Analysis:
    """The counts and bases of /v1/analyze for one frame: the rank r of its compatibility
    matrix C (N_B × dN, Eq. 3), the zero modes (C u = 0) and self-stresses (Cᵀ s = 0).

    Bases are empty when ``bases_included`` is False (too large to return); the counts are exact
    either way.

    Attributes
    ----------
    nodes, edges, dim : int
        N, N_B and d of the frame.
    rank : int
        r, the rank of C.
    rigid_body_modes : int
        The rigid motions the frame has (d(d+1)/2 unless its nodes span a lower dimension).
    rank_gap : RankGap
        The evidence for r: σ_r, σ_{r+1} and σ_r's error bound.
    modes : np.ndarray
        (z, N, d) orthonormal nontrivial zero modes, ⟂ rigid motions (flattened row-major).
    stresses : np.ndarray
        (s, N_B) orthonormal self-stresses.
    method : str
        "dense" (full SVD) or "sparse" (shift-invert subspace iteration): the route that ran.
    bases_included : bool
        Whether ``modes`` and ``stresses`` hold the bases.
    rigid_basis : np.ndarray
        The rigid motions' orthonormal basis (dN × ρ) of the normalised frame (rigid_motions).
    """

    nodes: int
    edges: int
    dim: int
    rank: int
    rigid_body_modes: int
    rank_gap: RankGap
    modes: np.ndarray
    stresses: np.ndarray
    method: str
    bases_included: bool = True
    rigid_basis: np.ndarray = field(default=None, repr=False)

    @property
    def maxwell_count(self) -> int:
        """N_D = dN − N_B, Maxwell's count (Eq. 2)."""
        return self.dim * self.nodes - self.edges

    @property
    def zero_modes(self) -> int:
        """dN − r: the zero modes, rigid motions included."""
        return self.dim * self.nodes - self.rank

    @property
    def nontrivial_zero_modes(self) -> int:
        """The zero modes beyond the rigid motions (the mechanisms)."""
        return self.zero_modes - self.rigid_body_modes

    @property
    def self_stresses(self) -> int:
        """N_B − r: the independent self-stresses."""
        return self.edges - self.rank


def check_dense_size(frame: Frame, method: str) -> None:
    """analyze's refusal from sizes alone: DomainError ``too_expensive`` when the dense route is
    asked for (``method`` "dense") and C (N_B × dN) has a side past DENSE_MAX_SIDE."""
    if method == "dense" and max(frame.n_edges, frame.dim * frame.n_nodes) > DENSE_MAX_SIDE:
        raise DomainError(
            "too_expensive",
            f"the dense route's C is {frame.n_edges} × {frame.dim * frame.n_nodes}; it is limited to "
            f"{DENSE_MAX_SIDE} rows and columns (use method 'auto' or 'sparse').",
        )


def analyze(
    frame: Frame, rtol: float = RTOL, method: str = "auto", bases: bool = True, basis_limit: int = BASIS_MAX_NUMBERS,
    gap_rtol: float | None = None, require_gap: bool = True,
) -> Analysis:
    """Analyse ``frame``: rank of C, zero modes, rigid motions, self-stresses, and their bases.

    method: "dense" (full SVD), "sparse" (shift-invert subspace iteration) or "auto"
    (dense while C has at most DENSE_MAX_ENTRIES_BASES entries, or DENSE_MAX_ENTRIES_COUNTS
    with bases=False).  bases=False skips the bases; so do bases of more than ``basis_limit``
    numbers in all (counts stay exact, ``bases_included`` says which).  ``gap_rtol``: the sparse
    route widens σ_r's Ritz space until rank_gap.last_nonzero_error ≤ gap_rtol (a full SVD is
    already exact to round-off); DomainError ``not_converged`` when that bound stays above it,
    unless ``require_gap`` is False (the bound reached is reported either way).
    """
    x = frame.normalised_positions()
    rigid = rigid_motions(x, rtol)
    if method == "auto":
        limit = DENSE_MAX_ENTRIES_BASES if bases else DENSE_MAX_ENTRIES_COUNTS
        # The dense SVD holds C and, with bases, the dN × dN matrix V: a frame with few bars
        # (none, at the extreme) is dense-sized by dN, not by its handful of rows.
        ndof = frame.dim * frame.n_nodes
        size = ndof * max(frame.n_edges, ndof if bases else 0)
        method = "dense" if size <= limit else "sparse"
    check_dense_size(frame, method)
    if method == "dense":
        c = compatibility_matrix(x, frame.edges, dense=True)
        modes, stresses, rank, gap = _dense_null_spaces(c, rigid, rtol, bases)
    elif method == "sparse":
        modes, stresses, rank, gap = _sparse_null_spaces(x, frame.edges, rigid, rtol, bases, basis_limit, gap_rtol)
    else:
        raise ValueError(f"unknown method {method!r}")
    if require_gap and gap_rtol is not None and gap.last_nonzero_error > gap_rtol:
        raise DomainError(
            "not_converged",
            f"σ_r of C is known to a relative {gap.last_nonzero_error:.1e} ({method} route), "
            f"not the {gap_rtol:.1e} asked for (gap_rtol).",
        )
    n, d = frame.n_nodes, frame.dim
    z_nontrivial = d * n - rank - rigid.shape[1]
    include = (
        bases
        and modes is not None
        and _bases_fit(z_nontrivial, frame.n_edges - rank, (frame.n_edges, d * n), basis_limit)
        and modes.shape[1] == z_nontrivial
    )
    return Analysis(
        nodes=n,
        edges=frame.n_edges,
        dim=d,
        rank=rank,
        rigid_body_modes=rigid.shape[1],
        rank_gap=gap,
        modes=modes.T.reshape(-1, n, d) if include else np.zeros((0, n, d)),
        stresses=stresses.T if include else np.zeros((0, frame.n_edges)),
        method=method,
        bases_included=include,
        rigid_basis=rigid,
    )


def _bases_fit(modes: int, stresses: int, shape: tuple[int, int], limit: int) -> bool:
    """Whether m nontrivial modes (dN each) and s self-stresses (N_B each) fit in ``limit`` numbers."""
    nb, ndof = shape
    return max(modes, 0) * ndof + max(stresses, 0) * nb <= limit


def _dense_null_spaces(c: np.ndarray, rigid: np.ndarray, rtol: float, want_bases: bool):
    """Full SVD of C: (nontrivial modes dN × m, ⟂ rigid; stresses N_B × s; rank; gap); the
    singular values alone (bases None) unless ``want_bases``."""
    nb, ndof = c.shape
    if nb == 0:
        return complement_within(np.eye(ndof), rigid), np.zeros((0, 0)), 0, RankGap(0.0, 0.0)
    if not want_bases:
        rank, gap = decide_rank(np.linalg.svd(c, compute_uv=False), rtol)
        return None, None, rank, gap
    u, s, vt = np.linalg.svd(c, full_matrices=True)
    rank, gap = decide_rank(s, rtol)
    return complement_within(vt[rank:].T, rigid), u[:, rank:], rank, gap


# Columns of the iterated block beyond the lower bound on the null space being found: they
# carry the smallest nonzero singular values, whose Ritz value the rank's gap reports as σ_r and
# whose settling ends the iteration (a block that fills with null vectors is doubled, see
# _null_by_subspace_iteration). Two, not one: the block starts from fixed random columns (the
# same answer every time), and a single column whose part along σ_r's singular vector happens
# to be small converges to a larger singular value first and stalls there, which the gap then
# reports as σ_r (20 000 random frames of 10–80 nodes, 2D and 3D, N_B within 12 of dN, against
# numpy's SVD: the Ritz value over σ_r above 2 in 14 frames with one column, up to 2.37; at most
# 1.80 with two; from NumPy's uniform starting columns 23 frames and 2.6, at most 1.53; from
# Gaussian ones 16 frames and 3.3, at most 1.48). The second
# column costs 5–13 % of the count's time on the benchmark's frames of 10²–10⁴ nodes (measured
# in turn).
OVERSAMPLE = 2
# A pivot of the shifted Gram matrix's factorisation (factorisation.Cholesky.pivots) at most this
# many times δ counts towards the block's starting width. A singular positive semidefinite matrix
# has as many zero pivots as null vectors; with the shift a null vector v gives a pivot of about
# δ/‖v_T‖² (v_T its part on the unknowns eliminated last), so spread ones are undercounted at
# scale, and directions of small singular values add some. The guess only sets the starting
# width (widening still finds the rest; wrong guesses cost solves, never a count). Measured,
# small pivots beyond the known null vectors against the null space's dimension: near-isostatic
# networks of 10²–10⁴ nodes in 2D and 3D (3 seeds) −3 … +2, mostly exact; lattice patches to
# 3·10⁵ nodes none. Column solves of the iteration alone over seeds 0–7 against a one-column
# start (before the stop and widening rules of _null_by_subspace_iteration): 2D networks 10³ 64
# against 85, 10⁴ 126 against 188; 3D 10³ 94 against 95, 10⁴ (seeds 0–3) 58 against 61. At 1e5
# the undercounts cost more (2D 10³ 79, 3D 10³ 104, 3D 10⁴ 75).
SMALL_PIVOT = 1e6
# … and at most this many: past it the block (n × width numbers) would grow on a guess rather
# than on null vectors found, which widening doubles to anyway (a 64-column start saves at most
# six widenings).
SMALL_PIVOT_MAX_START = 64
# σ_max(C) (for the rank's relative threshold and the shift) is √λ_max of AᵀA (A = C or Cᵀ,
# the counted side), the largest eigenvalue of the tridiagonal T_k of this many Lanczos steps on
# AᵀA from a random start (sparse_kernels.largest_singular_value): a Rayleigh quotient on the
# Krylov space, so never above λ_max (round-off allowing). Measured on 2D and 3D lattices of
# 10²–10⁴ nodes: six steps give σ_max within 3.6 % from below, closer than ten steps of the power
# iteration (within 4.5 %), and over 400 random starts on five 300-node lattice patches within
# 6.2 % (median 2–3 %): ample for a relative threshold and a shift. AᵀA q is taken as Σ_r a_r (a_r · q)
# in one pass over A's rows (sparse_kernels.normal_product; a 10⁴-node 2D network: 0.08 ms, against
# 0.27 ms for A q then Aᵀ(A q) and 0.18 ms for a product with the Gram matrix).
LANCZOS_STEPS = 6
# σ_r as the count leaves it is the smallest Ritz value of its last block, never below σ_r but
# not converged to it: over lattice patches of 27–10³ nodes 0.06–12 % above (clustered small
# singular values, which subspace iteration separates slowly), near-isostatic networks 1e-9 to
# 5e-4. Asked for (gap_rtol), the block's nonzero Ritz vectors are widened one shifted solve of
# the current Ritz vector at a time (a Krylov space of the shifted inverse, Lanczos-fast) until
# the Weyl bound of the Ritz pair's residual is within gap_rtol. For 1e-6 (10²–10³ nodes):
# networks 1–4 solves, triangulated and cubic patches 6–8, fcc 5–21, kagome 18–24, each value
# then within 3e-13 of the SVD's (the bound is that conservative); at most this many steps …
MAX_WIDENING_STEPS = 60
# … and at most this many numbers in the widened space and its image under the counted side's
# matrix A (n + m per step: 10⁶-node frames 2·10⁶ + 3·10⁶, 40 steps within 1.6 GB).
WIDENING_MAX_NUMBERS = 200_000_000
# A block of dim columns projected from random ones is about as ill-conditioned as a random
# dim × dim matrix (condition ~ dim), and orthonormalising it raises its residual by up to
# that much (a 900-column block: 1.2e-13 to 3.4e-11), so the quick steps orthonormalise only
# once the residual is this far under the target; one QR of a wide block costs more than a step
# (1 024-node triangulated patch: 0.3 s against 0.18 s).
ORTHONORMAL_HEADROOM = 1e-3
# Cholesky QR is used for blocks whose Cholesky factor's diagonal spans at most this ratio
# (cond ≲ 1e6, well inside its stable range cond ≲ 1/√ε ≈ 1e8).
CHOLQR_MAX_RATIO = 1e6
# … and only for blocks wider than this: thin blocks take Householder QR, whose two LAPACK calls
# cost less than Cholesky QR's eight steps (measured, one core: n × 3 blocks 6 µs against 37 µs
# at n = 200, 0.19 ms against 0.99 ms at n = 20 000; even at 10 columns, 2 000 rows; Cholesky
# QR ahead from about 30 columns, 4× at 900).
HOUSEHOLDER_MAX_COLUMNS = 16
# A null vector is locked (kept aside, no longer iterated) once its Ritz value is this far under
# the rank's threshold: one just under it may still hold a trace of a small singular value, and
# its Ritz value, reported as σ_{r+1}, would make a clear rank call look close (a 10⁵-node
# network: σ_{r+1} 2.6e-11 against σ_r 7.7e-11 when locked at the threshold; 3.2e-13 iterated on).
SETTLED = 1e-3
# The rounds' stop watches the Ritz values with θ² below this many times δ (and the null ones
# not yet locked): above it, the shift damps the direction by 1e-4 or more a step, so a null
# direction mixed into that Ritz vector would have grown 1e8-fold against it in the first two
# steps and cannot hide there; such a θ falling is the block turning within a cluster of nonzero
# singular values (a 3D network of 10³ nodes: 6.3e-4 → 4.4e-4 → 4.3e-4, θ² ≈ 2e6 δ), which
# would only cost a round.
DAMPED = 1e4
# Above this many independent null vectors on the side counted, the block is too wide.
MAX_NULL_VECTORS = 20_000
# Geometric nested dissection orders the Gram matrix from this many nodes; below, CᵀC is
# ordered by approximate minimum degree of the node graph (factorisation.minimum_degree) and
# CCᵀ by CHOLMOD's own. Measured (ordering + factorisation, one core): in 3D dissection wins
# from about 500 nodes (fcc 864: 9.3 ms against 13.1 ms; cubic 2 197: 37 ms against 42 ms;
# cubic 10⁴: 0.6–0.8 s against 1.3 s) and ties or loses below (cubic 512: 5.9 ms against
# 5.5 ms; 216: 2.0 ms against 1.6 ms); for CᵀC in 2D the two orders tie at 10⁵ nodes
# (triangulated 1.05 s against 0.98 s), dissection wins above (3·10⁵: 2.9 s against 3.5 s;
# 10⁶: 18 s against 22 s); for CCᵀ in 2D CHOLMOD's minimum degree wins at every size (kagome
# 10⁵: 0.74 s against 1.17 s; 3·10⁵: 3.3 s against 5.5 s), also over the bars ordered by the
# node graph's minimum degree (kagome 10³: 2.3 ms against 3.4 ms).
NESTED_DISSECTION_MIN_NODES = {(3, True): 500, (3, False): 500, (2, True): 100_000, (2, False): None}
# … and CᵀC only while the frame's mean degree 2N_B/N exceeds this many times d (2d bars a node:
# isostatic): the measurements above are of lattice patches (mean degree 2d + 2 and more), whose
# geometric separators are small; near-isostatic disordered networks (mean degree ≈ 2d) fill
# less under minimum degree at every size measured (ordering + factorisation, one core: 3D 10³
# nodes 6.2 ms against 8.2 ms, 10⁴ 0.31 s against 0.32 s; 2D 10⁵ 0.39 s against 0.59 s), and
# under CHOLMOD's own minimum degree of CᵀC than under that of the node graph (whole counts,
# paired: 2D networks of 10², 10³, 10⁴ nodes 0.39, 2.72, 39 ms against 0.41, 2.76, 41 ms; 3D
# 0.78, 9.05, 378 ms against 0.82, 9.09, 402 ms), while lattice patches below the dissection's
# threshold fill less under the node graph's (triangulated 10³: 3.3 ms against 3.8 ms).
DISSECTION_MIN_DEGREE = 2.5


@dataclass(frozen=True, eq=False)
class _Sparse:
    """A sparse matrix A (m × n) as the CSR arrays of A and of Aᵀ, for the compiled steps
    (solver/analysis/sparse_kernels.py): ``a @ y`` is A·Y, ``a.T`` is Aᵀ (no copy)."""

    indptr: np.ndarray
    indices: np.ndarray
    data: np.ndarray
    t_indptr: np.ndarray
    t_indices: np.ndarray
    t_data: np.ndarray
    shape: tuple[int, int]

    @property
    def T(self) -> _Sparse:
        return _Sparse(self.t_indptr, self.t_indices, self.t_data, self.indptr, self.indices, self.data,
                       self.shape[::-1])

    def __matmul__(self, y: np.ndarray) -> np.ndarray:
        """A·y for y (n,) or (n, k)."""
        block = np.ascontiguousarray(y, dtype=float).reshape(self.shape[1], -1)
        out = sparse_kernels.times(self.indptr, self.indices, self.data, block)
        return out.reshape(self.shape[0]) if y.ndim == 1 else out


@dataclass(frozen=True, eq=False)
class _NullProblem:
    """N(matrix) ⊖ span(known) by shift-invert subspace iteration.

    matrix: m × n (C for zero modes, Cᵀ for self-stresses); inverse: applies a positive
    multiple of (matrixᵀ·matrix + δI)⁻¹ to an n × k block; known: n × ρ orthonormal null
    vectors known in advance (the rigid motions), kept out of the block.
    """

    matrix: _Sparse
    inverse: object
    known: np.ndarray  # C-contiguous

    def step(self, y: np.ndarray) -> np.ndarray:
        """One shift-invert step: the inverse, the known null vectors projected out, QR."""
        # A thin block's projection and Householder QR in one compiled call (the NumPy and
        # LAPACK calls' overhead outweighed their work at 10² nodes); wider ones as _orthonormal.
        if y.shape[1] <= HOUSEHOLDER_MAX_COLUMNS:
            return sparse_kernels.project_out_and_orthonormalise(np.ascontiguousarray(self.inverse(y)), self.known)
        return _orthonormal(self.deflate(self.inverse(y)))

    def deflate(self, y: np.ndarray) -> np.ndarray:
        """y with its components along the known null vectors removed."""
        return y - self.known @ (self.known.T @ y) if self.known.size else y

    def residual(self, y: np.ndarray) -> float:
        """max over the columns v of ‖matrix·v‖ / ‖v‖."""
        return float(np.max(np.linalg.norm(self.matrix @ y, axis=0) / np.linalg.norm(y, axis=0)))


def _sparse_null_spaces(x: np.ndarray, edges: np.ndarray, rigid: np.ndarray, rtol: float, want_bases: bool,
                        basis_limit: int, gap_rtol: float | None = None):
    """Rank of a large sparse C (N_B × dN) of the frame at x (N, d) with ``edges`` and, when
    wanted, bases of N(C) ⊖ rigid and N(Cᵀ).

    dim N(C) − dim N(Cᵀ) = dN − N_B (the Maxwell count) and N(C) holds the ρ rigid motions,
    which are known exactly, so with f = max(dN − N_B, ρ) there are at least f − ρ nontrivial
    zero modes and f − (dN − N_B) self-stresses. The rank is decided on the side with the
    smaller bound (zero modes when dN − N_B ≤ ρ, as in over-braced frames; self-stresses for
    under-braced ones such as kagome patches with hundreds of boundary modes), where the
    iterated block stays thin, and that side's Gram matrix (CᵀC + δI, dN × dN, or CCᵀ + δI,
    N_B × N_B) is the one factorised; the other side's shifted inverse comes from the same
    factor by the push-through identity. The singular values are those of C either way.

    Returns (modes dN × m ⟂ rigid, stresses N_B × s, rank, gap); the bases are None unless
    ``want_bases`` and they fit in ``basis_limit`` numbers.
    """
    nb, ndof = len(edges), x.size
    rho = rigid.shape[1]
    if nb == 0:
        empty = want_bases and _bases_fit(ndof - rho, 0, (nb, ndof), basis_limit)
        modes = complement_within(np.eye(ndof), rigid) if empty else None
        return modes, np.zeros((0, 0)), 0, RankGap(0.0, 0.0)
    edges = kernel_array(edges, np.int64).reshape(-1, 2)
    rigid = np.ascontiguousarray(rigid)
    surplus = ndof - nb
    count_modes = surplus <= rho
    stream = _random_stream()
    # C, Cᵀ, σ_max and the Gram matrix of the counted side (CᵀC or CCᵀ), see LANCZOS_STEPS
    rows, columns, sigma_max, gram = sparse_kernels.count_setup(
        kernel_array(x, float), edges, count_modes, stream, LANCZOS_STEPS
    )
    c = _Sparse(*rows, *columns, (nb, ndof))
    a, b = (c, c.T) if count_modes else (c.T, c)  # the counted side's matrix, the other's
    tol = rtol * sigma_max
    shift = NULL_SHIFT_RTOL * sigma_max**2
    factor = cholesky_csr(*gram, _elimination_order(x, edges, count_modes), shift=shift)
    report_detail(0.3, "factorised the Gram matrix")
    floor = max(surplus, rho)
    bound = floor - rho if count_modes else floor - surplus
    no_known = np.zeros((nb, 0))
    counted = _NullProblem(a, factor.solve, rigid if count_modes else no_known)
    other = _NullProblem(b, lambda w: w - a @ factor.solve(b @ w), no_known if count_modes else rigid)
    # the factor's small pivots guess the null space's dimension (SMALL_PIVOT), known ones aside
    small = int(np.count_nonzero(factor.pivots() <= SMALL_PIVOT * shift)) - counted.known.shape[1]
    start = max(bound, min(small, SMALL_PIVOT_MAX_START))
    found, kept, dropped, error = _null_by_subspace_iteration(counted, tol, start, stream, shift, gap_rtol)
    if rho:  # the rigid motions are zeros of C too: the largest of them may top the found ones
        # ‖C R‖₂ from the ρ × ρ Gram matrix of C R (its entries are round-off, ≈ 1e-16 σ_max)
        dropped = max(dropped, float(sparse_kernels.product_norm(c.indptr, c.indices, c.data, rigid)))
    rank = ndof - rho - found.shape[1] if count_modes else nb - found.shape[1]
    gap = RankGap(kept, dropped, error)
    report_detail(0.7, "decided the rank")
    n_modes, n_stresses = ndof - rho - rank, nb - rank
    if not (want_bases and _bases_fit(n_modes, n_stresses, (nb, ndof), basis_limit)):
        return None, None, rank, gap
    # The counted side's vectors take one more step together (polish); the other side's
    # dimension is now known.
    target = max(BASIS_ANGLE * kept, BASIS_ROUNDOFF_RTOL * sigma_max)
    found = _null_basis(counted, target, found.shape[1], shift, start=found, floor=dropped)
    rest = _null_basis(other, target, n_stresses if count_modes else n_modes, shift, floor=dropped)
    return (found, rest, rank, gap) if count_modes else (rest, found, rank, gap)


def _elimination_order(x: np.ndarray, edges: np.ndarray, count_modes: bool) -> np.ndarray | None:
    """The order in which the Gram matrix's unknowns (CᵀC if ``count_modes``, else CCᵀ) are
    eliminated: geometric nested dissection of the nodes from NESTED_DISSECTION_MIN_NODES on
    (for CᵀC, only on frames whose mean degree is past DISSECTION_MIN_DEGREE·d); otherwise
    minimum degree of the nodes for CᵀC of such frames, and None (CHOLMOD's own minimum degree)
    for CCᵀ and for CᵀC of frames near isostatic.

    Both Gram matrices follow the bar graph: (CᵀC)_ij ≠ 0 for the d × d blocks of joined
    nodes, (CCᵀ)_ef ≠ 0 for bars sharing a node. One order of the nodes orders both:
    a node's d coordinates together, a bar with the later of its two nodes (with dissection,
    bars inside one half never share a node with bars inside the other, so the halves stay
    separated).
    """
    n, d = x.shape
    threshold = NESTED_DISSECTION_MIN_NODES[d, count_modes]
    dense_enough = not count_modes or 2 * len(edges) > DISSECTION_MIN_DEGREE * d * n
    dissect = threshold is not None and n >= threshold and dense_enough
    if not (dissect or (count_modes and dense_enough)):
        return None
    node_order = nested_dissection(x, edges) if dissect else minimum_degree(n, edges)
    if count_modes:
        return (d * node_order[:, None] + np.arange(d)).ravel()
    position = np.empty_like(node_order)
    position[node_order] = np.arange(node_order.size)
    return np.argsort(np.maximum(position[edges[:, 0]], position[edges[:, 1]]), kind="stable")


def _random_stream() -> np.ndarray:
    """The state of a fresh pseudo-random stream (seed 0) for sparse_kernels.uniform_block (its
    callers' random starts): each count draws the same numbers, so the same frame gets the same
    answer."""
    return np.zeros(1, dtype=np.uint64)


def _random_block(stream: np.ndarray, n: int, k: int | None = None) -> np.ndarray:
    """Random starting columns (n × k; a vector of n for k None), entries uniform in [−1, 1),
    the next ones of ``stream`` (SplitMix64, sparse_kernels.uniform_block).

    A start only needs no direction it must find to be nearly missing: entries independent and
    symmetric give each fixed direction about the same chance of a small part as Gaussian ones
    do, and uniform ones cost a third to draw (20 000 × 5: 0.26 against 0.87 ms, one core).
    Compiled rather than NumPy's Generator, whose construction alone took 20 µs inside a count
    at 10² nodes."""
    block = sparse_kernels.uniform_block(stream, n, 1 if k is None else k)
    return block[:, 0] if k is None else block


def _null_by_subspace_iteration(
    problem: _NullProblem, tol: float, expected: int, stream: np.ndarray, shift: float,
    gap_rtol: float | None = None, first_steps: int = 2, max_rounds: int = 60,
):
    """Orthonormal basis of N(matrix) ⊖ span(known) (columns), the smallest nonzero Ritz
    singular value, the largest zero one and the first's relative error bound: the count behind
    the rank (with ``gap_rtol``, σ_r's Ritz value converged to that bound; MAX_WIDENING_STEPS).

    Shift-invert subspace iteration (δ = ``shift``) from a block of ``expected`` + OVERSAMPLE
    columns (``expected`` is a guess at the null space's dimension, which only sets the starting
    width), compiled as sparse_kernels.null_space_rounds (its docstring states the rounds,
    the locking, the widening and the stop); this drives it: applies the shifted inverse and
    the QR of wide blocks where it asks, checks the time budget once a round, and refuses a null
    space of more than MAX_NULL_VECTORS vectors.
    """
    a = problem.matrix
    rounds = sparse_kernels.null_space_rounds(
        a.indptr, a.indices, a.data, problem.known, expected + OVERSAMPLE,
        stream, tol, shift, SETTLED, DAMPED, HOUSEHOLDER_MAX_COLUMNS, MAX_NULL_VECTORS, first_steps, max_rounds,
        0.0 if gap_rtol is None else gap_rtol,
        0 if gap_rtol is None else min(MAX_WIDENING_STEPS, WIDENING_MAX_NUMBERS // sum(a.shape)),
    )
    for request, block, kept, dropped, error in rounds:
        if request == sparse_kernels.SOLVE:
            block[...] = problem.inverse(block)
        elif request == sparse_kernels.ORTHONORMALISE:
            block[...] = _orthonormal(block)
        elif request == sparse_kernels.ROUND:
            check_budget()
        elif request == sparse_kernels.TOO_MANY:
            raise DomainError("too_expensive", f"the frame has more than {MAX_NULL_VECTORS} independent zero modes.")
    return block, kept, dropped, error  # the last message, DONE


def _null_basis(
    problem: _NullProblem, target: float, dim: int, shift: float, start: np.ndarray | None = None,
    floor: float = 0.0, quick_steps: int = 3, max_steps: int = 60,
) -> np.ndarray:
    """Orthonormal basis (n × dim) of N(matrix) ⊖ span(known) when its dimension is known.

    The same shift-invert steps on a block of exactly ``dim`` columns (``start`` first, the
    rest random) until every column v has ‖matrix·v‖ ≤ ``target``: the count has already
    established the dimension, and with a clear gap (σ_r² ≫ δ) a few steps suffice. Scaled by
    δ the shifted inverse has eigenvalues δ/(σ² + δ) ∈ (0, 1], 1 on the null space, so the
    block needs no re-orthonormalisation between these steps (columns are only rescaled), and
    one QR at the end, taken once the residual is ORTHONORMAL_HEADROOM under the target (the
    QR may raise it by the block's condition). If ``quick_steps`` are not enough, some nonzero
    singular values are small enough (σ² ≲ δ, δ = ``shift``) to converge slowly: the block then
    takes OVERSAMPLE more columns, which catch those directions, and every step is followed by
    a QR and a Rayleigh–Ritz step that keeps the dim Ritz vectors of smallest θ, until their
    θ ≤ max(``target``, ``floor``), ``floor`` being the largest Ritz value the count took as
    zero, above a singular value below the rank's threshold that its singular vector cannot go
    below (only after the quick steps: that Ritz value is only an upper bound, possibly far
    above the singular value, and a few steps bring the vector down to it). The extra
    columns are doubled while even the largest Ritz value has θ² < δ (more such directions than
    columns).
    """
    n = problem.matrix.shape[1]
    if dim == 0:
        return np.zeros((n, 0))
    stream = _random_stream()
    y = _random_block(stream, n, dim)
    if start is not None:
        y[:, : start.shape[1]] = start
    y = problem.deflate(y)
    theta = None  # the Ritz values of the last step after the quick ones
    for step in range(max_steps):
        check_budget()
        if step < quick_steps:
            y = problem.deflate(problem.inverse(y))
            y /= np.linalg.norm(y, axis=0)
            if problem.residual(y) <= ORTHONORMAL_HEADROOM * target:
                y = _orthonormal(y)
                if problem.residual(y) <= target:
                    return y
            continue
        room = n - problem.known.shape[1] - y.shape[1]
        if theta is None or (theta[-1] ** 2 < shift and room > 0):
            extra = min(max(OVERSAMPLE, y.shape[1] - dim), room)
            y = np.hstack([y, problem.deflate(_random_block(stream, n, extra))])
        theta, y = _ritz_pairs(problem.matrix, problem.step(y))
        if theta[dim - 1] <= max(target, floor):
            break
    return y[:, :dim]


def _orthonormal(y: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the columns of y (n × k, full column rank).

    Cholesky QR twice (Q₁ = y R₁⁻¹ with R₁ᵀR₁ = yᵀy, then the same on Q₁): two passes over y
    with BLAS-3 kernels each, where Householder QR makes about 2k passes; stable while
    cond(y) ≲ 1/√ε. A block just out of a shift-invert step can be far worse conditioned (its
    null components grew by 1/δ), so when the Cholesky factor's diagonal spans more than
    CHOLQR_MAX_RATIO, or the factorisation fails, Householder QR is used instead, as it is
    for blocks of at most HOUSEHOLDER_MAX_COLUMNS columns.
    """
    if y.shape[1] <= HOUSEHOLDER_MAX_COLUMNS:
        return _householder_q(y)
    q = y
    for _ in range(2):
        r, info = lapack.dpotrf(q.T @ q)  # upper R, RᵀR = qᵀq; info > 0: not positive definite
        diagonal = np.abs(r.diagonal())
        if info or diagonal.min() * CHOLQR_MAX_RATIO < diagonal.max():
            return _householder_q(y)
        q = blas.dtrsm(1.0, r, q, side=1)  # q R⁻¹
    return q


def _householder_q(y: np.ndarray) -> np.ndarray:
    """The n × k factor Q of y = QR (n ≥ k) by Householder reflections (LAPACK geqrf, orgqr)."""
    qr, tau, _, _ = lapack.dgeqrf(y)
    return lapack.dorgqr(qr, tau)[0]


def _ritz_pairs(matrix: _Sparse, y: np.ndarray):
    """Ritz singular values θ (ascending) and vectors (columns) of ``matrix`` on span(y), y orthonormal.

    The singular values of matrix·y are those of its triangular factor R, whose SVD also gives
    the right singular vectors W (completed with zeros when the matrix has fewer rows than y
    has columns; sparse_kernels.ritz_pairs).
    """
    if y.shape[1] == 0:
        return np.zeros(0), y
    return sparse_kernels.ritz_pairs(matrix.indptr, matrix.indices, matrix.data, np.ascontiguousarray(y))


def warm_up() -> None:
    """Compile the kernels (solver/analysis/sparse_kernels.py, solver/analysis/normalisation.py) for the one set of
    argument types the analysis passes them (int64 indices, float64 writable C-contiguous arrays:
    compiled.kernel_array), or load them from numba's cache: in a fresh environment 28 s of CPU
    (25 specialisations; 48 s of wall time at load 5 on 2 cores, 40 s of CPU and 2–2.5 min at load
    7–14), from the cache 0.3–0.4 s. The kernels of every analysis (the
    normalisation, the rigid motions, C) come first, then the sparse route's. Processes that
    share a cache take turns (compiled.compiling_alone): one compiles, the others load. The
    service runs this in the background when it starts (a request that meets a kernel not yet
    compiled waits for it, not charged to its time budget), its job engine's workers before they
    take work, and the container image when it is built. The complete graph on four nodes in the
    plane counts its zero modes (one self-stress), the square its self-stresses (one mechanism),
    both with bases."""
    positions = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    bars = np.array([[0, 1], [1, 2], [2, 3], [0, 3], [0, 2], [1, 3]], dtype=np.int64)
    with compiling_alone(sparse_kernels.null_space_rounds):
        rigid_motions(normalised(positions))
        compatibility_matrix(positions, bars)
        for frame in (Frame.build(positions, bars), Frame.build(positions, bars[:4])):
            for bases in (False, True):
                analyze(frame, method="sparse", bases=bases)
