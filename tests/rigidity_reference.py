"""Reference implementations for the analysis tests, written independently of zeromode.solver.

Deliberately plain: a per-edge loop for the compatibility matrix (paper Eq. 3: row e = (i, j)
holds (x_i − x_j)ᵀ at node i and (x_j − x_i)ᵀ at node j), rigid motions written out as
translations and cross products, ranks from numpy's SVD with a relative threshold.
Flattening is node-major: coordinate a of node i is entry d·i + a.
"""

from __future__ import annotations

import itertools

import numpy as np

# Looser than the solver's 1e-9 on purpose: the frames tested here either have exact zeros
# (σ ~ 1e-15 σ_max) or generic gaps far above both thresholds.
REFERENCE_RTOL = 1e-8


def compatibility_matrix(positions, edges) -> np.ndarray:
    """Dense C (N_B × dN) built edge by edge."""
    x = np.asarray(positions, dtype=float)
    n, d = x.shape
    c = np.zeros((len(edges), d * n))
    for row, (i, j) in enumerate(edges):
        c[row, d * i : d * i + d] = x[i] - x[j]
        c[row, d * j : d * j + d] = x[j] - x[i]
    return c


def rigid_generators(positions) -> np.ndarray:
    """dN × d(d+1)/2: the d translations and the infinitesimal rotations u_i = ω × x_i (2D: ω ẑ)."""
    x = np.asarray(positions, dtype=float)
    n, d = x.shape
    columns = [np.tile(np.eye(d)[a], n) for a in range(d)]
    if d == 2:
        columns.append(np.column_stack([-x[:, 1], x[:, 0]]).ravel())
    else:
        columns += [np.cross(np.eye(3)[a], x).ravel() for a in range(3)]
    return np.column_stack(columns)


def normalised(positions) -> np.ndarray:
    """Centred and divided by the RMS radius (so thresholds are scale-free)."""
    x = np.asarray(positions, dtype=float)
    x = x - x.mean(axis=0)
    r = np.sqrt(np.mean(np.sum(x**2, axis=1)))
    return x / r if r > 0 else x


def singular_values(matrix: np.ndarray) -> np.ndarray:
    return np.linalg.svd(matrix, compute_uv=False) if matrix.size else np.zeros(0)


def numerical_rank(matrix: np.ndarray, rtol: float = REFERENCE_RTOL) -> int:
    s = singular_values(matrix)
    return int(np.count_nonzero(s > rtol * s[0])) if s.size and s[0] > 0 else 0


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


def reference_counts(positions, edges) -> dict:
    """rank, zero modes, rigid-body modes and self-stresses from the reference routines."""
    x = normalised(positions)
    n, d = x.shape
    rank = numerical_rank(compatibility_matrix(x, edges))
    rigid = numerical_rank(rigid_generators(x))
    return {
        "rank": rank,
        "zero_modes": d * n - rank,
        "rigid_body_modes": rigid,
        "nontrivial_zero_modes": d * n - rank - rigid,
        "self_stresses": len(edges) - rank,
    }


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


def random_frame(rng: np.random.Generator, dim: int, n: int, n_edges: int, lattice: bool = False):
    """Positions (n × dim) and n_edges distinct edges drawn uniformly among all pairs.

    lattice=True puts the nodes on distinct points of a small integer grid (side ≥ 4), which produces
    exact degeneracies (collinear and coplanar subsets) on purpose.
    """
    if lattice:
        side = max(4, int(np.ceil(n ** (1 / dim))) + 1)
        grid = np.array(list(itertools.product(range(side), repeat=dim)), dtype=float)
        positions = grid[rng.choice(len(grid), size=n, replace=False)]
    else:
        positions = rng.standard_normal((n, dim))
    pairs = list(itertools.combinations(range(n), 2))
    n_edges = min(n_edges, len(pairs))
    chosen = rng.choice(len(pairs), size=n_edges, replace=False) if n_edges else []
    edges = [list(pairs[k]) for k in chosen]
    for edge in edges:
        if rng.random() < 0.5:
            edge.reverse()  # orientation must not matter
    return positions, edges


def random_rotation(rng: np.random.Generator, dim: int) -> np.ndarray:
    """A uniformly random proper rotation (QR of a Gaussian matrix, sign-fixed, det +1)."""
    q, r = np.linalg.qr(rng.standard_normal((dim, dim)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


def as_columns(modes) -> np.ndarray:
    """A stack of z motions (z × N × d) as the dN × z matrix of their node-major flattenings."""
    z, n, d = np.shape(modes)
    return np.asarray(modes, dtype=float).reshape(z, n * d).T
