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
  * sparse: shift-invert subspace iteration on CᵀC + δI with one sparse LU factorisation,
    then a Rayleigh–Ritz step on C itself so the singular values (and the rank decision)
    come from C, not from CᵀC whose small eigenvalues are squared into round-off.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from zeromode.solver.budget import check_budget
from zeromode.solver.errors import DomainError
from zeromode.solver.frame import Frame
from zeromode.solver.rank import RTOL, RankGap, complement_within, decide_rank, orthonormal_range

# Dense full SVD up to this many degrees of freedom (dN), sparse subspace iteration above.
# Measured (benchmarks/bench_analysis.py): with bases (the default) both cost the same near
# dN = 400 on 2D lattices and sparse is 1.6–14× faster at 1000; on over-braced 3D lattices,
# whose stress basis is large, sparse stays 1.2–1.5× slower up to 1000; counts alone are
# 2–70× faster sparse from dN = 200. Below the crossover the exact SVD is kept.
DENSE_MAX_DOF = 400
# Bases are returned only while they stay this small (numbers); counts are always exact.
BASIS_MAX_NUMBERS = 4_000_000


def compatibility_matrix(positions: np.ndarray, edges: np.ndarray, dense: bool = False):
    """C (N_B × dN): row e holds (x_i − x_j) at node i and (x_j − x_i) at node j.

    Sparse CSR by default; ``dense=True`` returns an ndarray (cheaper for tiny frames).
    """
    n, d = positions.shape
    nb = len(edges)
    if nb == 0:
        return np.zeros((0, n * d)) if dense else sp.csr_matrix((0, n * d))
    i, j = edges[:, 0], edges[:, 1]
    diff = positions[i] - positions[j]  # (N_B, d)
    rows = np.repeat(np.arange(nb), 2 * d)
    cols = np.concatenate(
        [(d * i)[:, None] + np.arange(d), (d * j)[:, None] + np.arange(d)], axis=1
    ).ravel()
    vals = np.concatenate([diff, -diff], axis=1).ravel()
    if dense:
        c = np.zeros((nb, n * d))
        c[rows, cols] = vals  # (row, col) pairs are distinct: i ≠ j within a row
        return c
    return sp.csr_matrix((vals, (rows, cols)), shape=(nb, n * d))


def rigid_motions(positions: np.ndarray, rtol: float = RTOL) -> np.ndarray:
    """Orthonormal basis (dN × ρ) of the rigid motions of this configuration.

    Spans the d translations and the d(d−1)/2 infinitesimal rotations u_i = E_ab x_i (E_ab the
    elementary skew matrices); ρ = d(d+1)/2 unless the points are degenerate (one point: d;
    collinear in 3D: 5). ``positions`` should be normalised (see Frame.normalised_positions).
    """
    n, d = positions.shape
    generators = []
    for a in range(d):
        t = np.zeros((n, d))
        t[:, a] = 1.0
        generators.append(t.ravel())
    for a in range(d):
        for b in range(a + 1, d):
            r = np.zeros((n, d))
            r[:, a] = -positions[:, b]
            r[:, b] = positions[:, a]
            generators.append(r.ravel())
    return orthonormal_range(np.column_stack(generators), rtol)


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
    """The counts and bases of /v1/analyze for one frame.

    modes: (z, N, d) orthonormal nontrivial zero modes, ⟂ rigid motions (flattened row-major).
    stresses: (s, N_B) orthonormal self-stresses.  Bases are empty when ``bases_included`` is
    False (too large to return); the counts are exact either way.
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
        return self.dim * self.nodes - self.edges

    @property
    def zero_modes(self) -> int:
        return self.dim * self.nodes - self.rank

    @property
    def nontrivial_zero_modes(self) -> int:
        return self.zero_modes - self.rigid_body_modes

    @property
    def self_stresses(self) -> int:
        return self.edges - self.rank


def analyze(frame: Frame, rtol: float = RTOL, method: str = "auto", bases: bool = True) -> Analysis:
    """Analyse ``frame``: rank of C, zero modes, rigid motions, self-stresses, and their bases.

    method: "dense" (full SVD), "sparse" (shift-invert subspace iteration) or "auto"
    (dense up to DENSE_MAX_DOF degrees of freedom).  bases=False skips the bases.
    """
    x = frame.normalised_positions()
    rigid = rigid_motions(x, rtol)
    if method == "auto":
        method = "dense" if frame.dim * frame.n_nodes <= DENSE_MAX_DOF else "sparse"
    c = compatibility_matrix(x, frame.edges, dense=method == "dense")
    if method == "dense":
        null, stresses, rank, gap = _dense_null_spaces(c, rtol)
    elif method == "sparse":
        null, stresses, rank, gap = _sparse_null_spaces(c, rtol, rigid.shape[1], want_stresses=bases)
    else:
        raise ValueError(f"unknown method {method!r}")
    n, d = frame.n_nodes, frame.dim
    z_nontrivial = d * n - rank - rigid.shape[1]
    size = max(z_nontrivial, 0) * d * n + (frame.n_edges - rank) * frame.n_edges
    include = bases and size <= BASIS_MAX_NUMBERS and stresses is not None and null.shape[1] == d * n - rank
    if include:
        modes = complement_within(null, rigid).T.reshape(-1, n, d)
        stress_basis = stresses.T
    else:
        modes = np.zeros((0, n, d))
        stress_basis = np.zeros((0, frame.n_edges))
    return Analysis(
        nodes=n,
        edges=frame.n_edges,
        dim=d,
        rank=rank,
        rigid_body_modes=rigid.shape[1],
        rank_gap=gap,
        modes=modes,
        stresses=stress_basis,
        method=method,
        bases_included=include,
        rigid_basis=rigid,
    )


def _dense_null_spaces(c: np.ndarray, rtol: float):
    """Full SVD of C: (null basis dN×z, stress basis N_B×s, rank, gap)."""
    nb, ndof = c.shape
    if nb == 0:
        return np.eye(ndof), np.zeros((0, 0)), 0, RankGap(0.0, 0.0)
    u, s, vt = np.linalg.svd(c, full_matrices=True)
    rank, gap = decide_rank(s, rtol)
    return vt[rank:].T, u[:, rank:], rank, gap


def _sparse_null_spaces(c: sp.csr_matrix, rtol: float, rigid_dim: int, want_stresses: bool):
    """Rank of a large sparse C (N_B × dN) and, when wanted, bases of N(C) and N(Cᵀ).

    dim N(C) − dim N(Cᵀ) = dN − N_B (the Maxwell count) and N(C) holds the ρ rigid motions,
    so dim N(C) ≥ z₀ = max(dN − N_B, ρ) and dim N(Cᵀ) ≥ z₀ − (dN − N_B). The rank is decided
    on the side with the smaller bound (zero modes for over-braced frames, self-stresses for
    under-braced ones such as kagome patches with hundreds of boundary modes), where the
    subspace-iteration block stays small; the singular values are those of C either way.

    Returns (zero-mode basis dN × z, self-stress basis N_B × s or None, rank, gap). The bases are
    computed only when ``want_stresses`` and both fit in BASIS_MAX_NUMBERS (as ``analyze``
    returns them); otherwise the zero-mode basis is an empty dN × 0 array and the stresses None.
    """
    nb, ndof = c.shape
    if nb == 0:
        return np.eye(ndof), np.zeros((0, 0)), 0, RankGap(0.0, 0.0)
    sigma_max = _largest_singular_value(c)
    z_bound = max(ndof - nb, rigid_dim)
    s_bound = z_bound - (ndof - nb)
    if s_bound < z_bound:
        stresses, kept, dropped = _null_by_subspace_iteration(c.T.tocsr(), sigma_max, rtol, s_bound)
        rank = nb - stresses.shape[1]
        null = None
    else:
        null, kept, dropped = _null_by_subspace_iteration(c, sigma_max, rtol, z_bound)
        rank = ndof - null.shape[1]
        stresses = None
    z, s = ndof - rank, nb - rank
    if want_stresses and max(z - rigid_dim, 0) * ndof + s * nb <= BASIS_MAX_NUMBERS:
        if null is None:
            null, _, _ = _null_by_subspace_iteration(c, sigma_max, rtol, z, exact_dim=z)
        if stresses is None:
            stresses, _, _ = _null_by_subspace_iteration(
                c.T.tocsr(), sigma_max, rtol, s, exact_dim=s
            )
        return null, stresses, rank, RankGap(kept, dropped)
    return np.zeros((ndof, 0)), None, rank, RankGap(kept, dropped)


def _largest_singular_value(c: sp.csr_matrix, steps: int = 30) -> float:
    """σ_max(C) by seeded power iteration on CᵀC; a few per cent is ample for a relative threshold."""
    v = np.random.default_rng(0).standard_normal(c.shape[1])
    for _ in range(steps):
        v = c.T @ (c @ v)
        v /= np.linalg.norm(v)
    return float(np.linalg.norm(c @ v))


def _null_by_subspace_iteration(
    c: sp.csr_matrix,
    sigma_max: float,
    rtol: float,
    lower_bound: int,
    exact_dim: int | None = None,
    oversample: int = 8,
    first_steps: int = 2,
    max_rounds: int = 60,
):
    """Orthonormal basis of N(c) (columns), the smallest nonzero Ritz singular value and the largest zero one.

    Shift-invert subspace iteration with (cᵀc + δI)⁻¹, δ = 1e-10 σ_max²: one sparse LU
    (symmetric minimum-degree order, diagonal pivots: the matrix is positive definite) damps a
    singular direction σ by δ/(σ² + δ) per step relative to N(c). After each round a
    Rayleigh–Ritz step on c itself gives the Ritz singular values θ ≥ σ of c on the block;
    Ritz vectors with θ ≤ rtol·σ_max join the null basis and are deflated from the block, which
    goes on with the rest. A null direction not yet found shows up as a small nonzero θ that
    keeps falling by δ/(σ² + δ) per step, so the rounds (one step each after the first) stop
    only when a round finds no new null vector and the smallest θ moved by less than 10 %. A
    block whose Ritz values are all zero may miss part of N(c): it is replaced by as many fresh
    random directions as there are null vectors found. The whole block (null vectors and the
    rest) then takes two more steps and a last Rayleigh–Ritz step on it decides the count,
    which by interlacing never exceeds dim N(c). ``exact_dim`` (known from the other side) stops once that many null vectors are
    found.
    """
    ndof = c.shape[1]
    tol = rtol * sigma_max
    shifted = (c.T @ c + 1e-10 * sigma_max**2 * sp.identity(ndof, format="csc")).tocsc()
    lu = spla.splu(
        shifted, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
    )
    rng = np.random.default_rng(0)
    null = np.zeros((ndof, 0))
    y = rng.standard_normal((ndof, min(ndof, max(lower_bound, 1) + oversample)))
    steps, previous = first_steps, None
    for _ in range(max_rounds):
        check_budget()
        for _ in range(steps):
            y = lu.solve(y)
            y, _ = np.linalg.qr(y - null @ (null.T @ y))
        theta, ritz = _ritz_pairs(c, y)
        z = int(np.count_nonzero(theta <= tol))
        null, y = np.hstack([null, ritz[:, :z]]), ritz[:, z:]
        if exact_dim is not None:
            if null.shape[1] >= exact_dim or y.shape[1] == 0:
                break
        elif y.shape[1] == 0:
            if null.shape[1] == ndof:
                break
            if null.shape[1] >= 20000:
                raise DomainError(
                    "too_expensive", "the frame has more than 20000 independent zero modes."
                )
            fresh = rng.standard_normal((ndof, min(null.shape[1], ndof - null.shape[1])))
            y = fresh - null @ (null.T @ fresh)
            steps, previous = first_steps, None
            continue
        elif previous is not None and z == 0 and theta[0] >= 0.9 * previous:
            break
        steps, previous = 1, theta[z]
    # Null vectors found early were deflated after a few steps: polish them together with the
    # rest of the block (which keeps the oversampling), then decide on the whole block.
    block = np.hstack([null, y])
    for _ in range(first_steps):
        block, _ = np.linalg.qr(lu.solve(block))
    theta, ritz = _ritz_pairs(c, block)
    z = int(np.count_nonzero(theta <= tol)) if exact_dim is None else min(exact_dim, theta.size)
    kept = float(theta[z]) if z < theta.size else 0.0
    dropped = float(theta[z - 1]) if z > 0 else 0.0
    return ritz[:, :z], kept, dropped


def _ritz_pairs(c: sp.csr_matrix, y: np.ndarray):
    """Ritz singular values θ (ascending) and vectors (columns) of c on span(y), y orthonormal.

    The singular values of c·y are those of its triangular factor R, whose SVD also gives the
    right singular vectors W (completed with zeros when c has fewer rows than y has columns).
    """
    k = y.shape[1]
    if k == 0:
        return np.zeros(0), y
    _, s, wt = np.linalg.svd(np.linalg.qr(c @ y, mode="r"))
    theta = np.zeros(k)
    theta[: s.size] = s
    order = np.argsort(theta, kind="stable")
    return theta[order], y @ wt[order].T
