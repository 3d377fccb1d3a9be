"""The smallest eigenpairs of a symmetric positive semidefinite matrix on the complement of a subspace.

For K (n × n, symmetric, K ⪰ 0) and D (n × q, orthonormal columns, q ≥ 0), the compression of K
to D^⊥ is  H = Pᵀ K P  with P an orthonormal basis of D^⊥;  its eigenvalues λ_1 ≤ λ_2 ≤ …  are
min–max values over vectors ⟂ D.  Uses: the zero modes of a frame (K = CᵀC, D = the rigid
motions), its uniform rigidity margin (K = CᵀC, D = rigid motions ⊕ designed modes, λ_1) and
the optimal-stiffness margin (K = Cᵀ diag(k) C, several λ_i).

Dense (n ≤ DENSE_MAX_DOF): eigh of H itself.
Sparse: shift-invert Lanczos (ARPACK) on  Π (K + δI)⁻¹ Π,  Π = I − DDᵀ,  whose largest
eigenvalues are 1/(λ_i + δ) when D is invariant under K (it spans eigenvectors of K: rigid
motions and zero modes of C are in N(K)); one sparse Cholesky factorisation of the positive
definite K + δI (factorisation.py) with δ = EIGEN_SHIFT_RTOL·mean diag K.
Whatever D, the returned pairs are then refined by Rayleigh–Ritz on their span ⟂ D, so each value
is a Rayleigh quotient of H (an upper bound on the matching λ_i) and ``residuals`` bound the
distance to an eigenvalue of H: |θ_i − λ| ≤ ‖H v_i − θ_i v_i‖ for some eigenvalue λ of H.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from zeromode.solver.analysis.factorisation import cholesky
from zeromode.solver.analysis.rank import nullspace
from zeromode.solver.analysis.rigidity import DENSE_MAX_DOF
from zeromode.solver.tolerances import ARPACK_TOL, EIGEN_SHIFT_RTOL

# A factorisation of K + δI that fails retries with δ this many times larger.
SHIFT_RETRY = 1e3


@dataclass(frozen=True, eq=False)
class Eigenpairs:
    """values (k,) ascending, vectors (n, k) orthonormal and ⟂ D, residuals (k,) = ‖Π(K v − θ v)‖."""

    values: np.ndarray
    vectors: np.ndarray
    residuals: np.ndarray


def smallest_eigenpairs(
    matrix,
    count: int,
    deflate: np.ndarray | None = None,
    guess: np.ndarray | None = None,
    tol: float = ARPACK_TOL,
) -> Eigenpairs:
    """The ``count`` smallest eigenpairs of K compressed to D^⊥ (see the module docstring).

    matrix: K, (n, n) ndarray or sparse, symmetric positive semidefinite. deflate: D (n, q)
    orthonormal or None. guess: a vector (n,) to start Lanczos from (warm start), or None.
    tol: Lanczos' relative tolerance (sparse route); a loose one converges fast inside
    clusters of nearly equal eigenvalues when only their size matters.
    """
    n = matrix.shape[0]
    d = np.zeros((n, 0)) if deflate is None else deflate
    count = min(count, n - d.shape[1])
    if count <= 0:
        return Eigenpairs(np.zeros(0), np.zeros((n, 0)), np.zeros(0))
    if n <= DENSE_MAX_DOF or count >= n - d.shape[1] - 1:  # ARPACK needs count < n
        k = matrix.toarray() if sp.issparse(matrix) else np.asarray(matrix)
        p = nullspace(d.T)[0] if d.shape[1] else np.eye(n)
        _, coeffs = np.linalg.eigh(p.T @ k @ p)
        vectors = p @ coeffs[:, :count]
    else:
        vectors = _shift_invert(sp.csc_matrix(matrix), count, d, guess, tol)
    return _rayleigh_ritz(matrix, vectors, d)


def _shift_invert(k: sp.csc_matrix, count: int, d: np.ndarray, guess, tol: float) -> np.ndarray:
    n = k.shape[0]
    delta = EIGEN_SHIFT_RTOL * (float(np.mean(k.diagonal())) or 1.0)
    try:
        factor = cholesky(k + delta * sp.identity(n, format="csc"))
    except ArithmeticError:  # not numerically positive definite at this shift
        factor = cholesky(k + SHIFT_RETRY * delta * sp.identity(n, format="csc"))

    def project(v):
        return v - d @ (d.T @ v)

    def apply(v):
        return project(factor.solve(project(v)))

    operator = spla.LinearOperator((n, n), matvec=apply, matmat=apply, dtype=float)
    start = np.random.default_rng(0).standard_normal(n) if guess is None else guess
    _, vectors = spla.eigsh(
        operator, k=count, which="LM", v0=project(start), tol=tol, ncv=min(n, max(2 * count + 1, 20))
    )
    return vectors


def _rayleigh_ritz(matrix, vectors: np.ndarray, d: np.ndarray) -> Eigenpairs:
    """Orthonormalise ``vectors`` ⟂ D, diagonalise K on their span, and measure the residuals."""
    v = vectors - d @ (d.T @ vectors)
    v, _ = np.linalg.qr(v)
    kv = matrix @ v
    values, coeffs = np.linalg.eigh(v.T @ kv)
    v, kv = v @ coeffs, kv @ coeffs
    residual = kv - v * values
    residual -= d @ (d.T @ residual)
    return Eigenpairs(values, v, np.linalg.norm(residual, axis=0))


def nontrivial_zero_modes(c, rigid: np.ndarray, count: int) -> np.ndarray:
    """Orthonormal basis (dN × count) of N(C) ⊖ rigid motions: the ``count`` smallest
    eigenvectors of CᵀC ⟂ ``rigid`` (count = dim N(C) − ρ, decided by rigidity.analyze), for a
    sparse C whose analysis did not keep its bases."""
    return smallest_eigenpairs(sp.csc_matrix(c.T @ c), count, deflate=rigid).vectors
