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

# The dense SVD is exact and fast up to about this many degrees of freedom (dN).
DENSE_MAX_DOF = 1200
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


def zero_mode_residual(frame: Frame, mode: np.ndarray) -> float:
    """‖C u‖ / (‖C‖_F ‖u‖) with C of the normalised frame: 0 for an exact zero mode u (N, d)."""
    dense = frame.dim * frame.n_nodes <= DENSE_MAX_DOF
    c = compatibility_matrix(frame.normalised_positions(), frame.edges, dense=dense)
    if c.shape[0] == 0:
        return 0.0
    c_norm = np.linalg.norm(c) if dense else spla.norm(c)
    return float(np.linalg.norm(c @ mode.ravel()) / (c_norm * max(np.linalg.norm(mode), 1e-300)))


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

    def counts(self) -> dict:
        """The integer fields and the rank gap, as in the /v1/analyze response."""
        return {
            "nodes": self.nodes,
            "edges": self.edges,
            "dim": self.dim,
            "maxwell_count": self.maxwell_count,
            "rank": self.rank,
            "zero_modes": self.zero_modes,
            "rigid_body_modes": self.rigid_body_modes,
            "nontrivial_zero_modes": self.nontrivial_zero_modes,
            "self_stresses": self.self_stresses,
            "rank_gap": self.rank_gap.to_dict(),
        }


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
    z_nontrivial = null.shape[1] - rigid.shape[1]
    size = max(z_nontrivial, 0) * d * n + (frame.n_edges - rank) * frame.n_edges
    include = bases and size <= BASIS_MAX_NUMBERS and stresses is not None
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
    """Null spaces of a large sparse C without forming it densely.

    N(C) = N(CᵀC); subspace iteration with (CᵀC + δI)⁻¹ damps every non-null direction by
    δ/(σ² + δ) per step, so a handful of steps isolate N(C). The block grows until its
    Ritz values on C show a nonzero singular value, i.e. the whole null space is inside it.
    """
    nb, ndof = c.shape
    if nb == 0:
        return np.eye(ndof), np.zeros((0, 0)), 0, RankGap(0.0, 0.0)
    sigma_max = _largest_singular_value(c)
    null, sig_kept, sig_dropped = _null_by_subspace_iteration(
        c, sigma_max, rtol, lower_bound=max(ndof - nb, rigid_dim)
    )
    rank = ndof - null.shape[1]
    gap = RankGap(sig_kept, sig_dropped)
    stresses = None
    if want_stresses and (nb - rank) * nb <= BASIS_MAX_NUMBERS:
        stresses, _, _ = _null_by_subspace_iteration(
            c.T.tocsr(), sigma_max, rtol, lower_bound=nb - rank, exact_dim=nb - rank
        )
    return null, stresses, rank, gap


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
    steps: int = 4,
):
    """Orthonormal basis of N(c) (columns), σ_r of the kept block and σ_{r+1} (largest dropped).

    Returns (basis, smallest nonzero Ritz singular value, largest zero one).
    """
    ndof = c.shape[1]
    m = (c.T @ c).tocsc()
    delta = 1e-10 * sigma_max**2
    lu = spla.splu((m + delta * sp.identity(ndof, format="csc")).tocsc())
    rng = np.random.default_rng(0)
    block = min(ndof, max(lower_bound, 1) + oversample)
    while True:
        check_budget()
        y = rng.standard_normal((ndof, block))
        for _ in range(steps):
            y, _ = np.linalg.qr(lu.solve(y))
        # Rayleigh–Ritz on C itself: singular values of C restricted to span(y).
        # Economic SVD unless C has fewer rows than the block (then V must be completed).
        _, s_nonzero, vt = np.linalg.svd(c @ y, full_matrices=c.shape[0] < block)
        s = np.zeros(block)  # when N_B < block, the missing singular values are zero
        s[: s_nonzero.size] = s_nonzero
        order = np.argsort(s, kind="stable")
        s, vt = s[order], vt[order]
        zero = s <= rtol * sigma_max
        z = int(np.count_nonzero(zero)) if exact_dim is None else exact_dim
        if z < block or block == ndof:
            basis = y @ vt[:z].T
            basis, _ = np.linalg.qr(basis)
            kept = float(s[z]) if z < block else 0.0
            dropped = float(s[z - 1]) if z > 0 else 0.0
            return basis, kept, dropped
        if block >= 20000:
            raise DomainError(
                "too_expensive", "the frame has more than 20000 independent zero modes."
            )
        block = min(ndof, 2 * block)



