"""Bordered linear systems  M = [[A, W], [Wᵀ, 0]]  with a singular A and the sign of det M.

A (n × n, dense or scipy.sparse) is a stiffness-like matrix whose null space is (close to) the
span of W (n × z, orthonormal columns): the bordering makes M regular, and

    M [x; μ] = [r; s]

is the Newton step of continuation with the gauge and arclength conditions Wᵀx = s
(finite_motion), or a least-squares solve of C x ≈ b on N(C)^⊥ (certificates, where
A = CᵀC and r = Cᵀb).  When A = C_kᵀ C(Y) is the Galerkin Jacobian of a continuation step,
det M changes sign where C(Y) loses rank on W^⊥, which is how singular points are detected.

Dense A: one LU of M itself (partial pivoting); sign det M from U's diagonal and the pivots.

Sparse A: the dense border must stay out of the sparse factorisation (a dense row or column
in a sparse LU fills it). A is made regular by pinning z coordinates E, chosen by pivoted QR
of Wᵀ so that EᵀW is well conditioned:  A_r = A + γ E Eᵀ  (γ = mean |diag A|, so the pins have
the scale of A).  The extended matrix

    N = [[A_r, W, √γE], [Wᵀ, 0, 0], [√γEᵀ, 0, I_z]]

has M as its Schur complement on the last block (A_r − γEEᵀ = A), hence det N = det M and the
solution of M is the first two blocks of the solution of N. Block elimination with A_r:
G = [W, √γE] (n × 2z), H = diag(0_z, I_z), S = H − Gᵀ A_r⁻¹ G (2z × 2z),

    ξ = S⁻¹([s; 0] − Gᵀ A_r⁻¹ r),   x = A_r⁻¹ r − A_r⁻¹ G ξ,   μ = ξ[:z],
    det M = det A_r · det S.

A_r is factorised once (sparse LU, fill-reducing order of A + Aᵀ, preferring diagonal pivots:
A is close to symmetric positive semidefinite); sign det A_r = sign(det P_r)·sign(det P_c)·
Π sign(U_ii) (L has a unit diagonal).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import connected_components

# Threshold partial pivoting of the sparse LU: the diagonal pivot is kept unless another entry
# of its column is 10× larger (A_r is near symmetric positive definite, so this is rare and
# keeps the fill of the symmetric ordering).
DIAG_PIVOT_THRESH = 0.1
# Block elimination through A_r is not backward stable when M is nearly singular (next to a
# singular point of a motion, A_r has the same soft direction): iterative refinement on M's
# own residual restores the accuracy a direct LU of M would have.
REFINEMENT_STEPS = 2


def permutation_sign(perm: np.ndarray) -> int:
    """(−1)^(n − number of cycles) of a permutation given as an index array (the cycles are the
    connected components of the graph i → perm[i])."""
    n = perm.size
    graph = sp.csr_matrix((np.ones(n), (np.arange(n), perm)), shape=(n, n))
    cycles, _ = connected_components(graph, directed=True, connection="weak")
    return -1 if (n - cycles) % 2 else 1


def pinned_coordinates(w: np.ndarray) -> np.ndarray:
    """z coordinates on which W (n × z) is best conditioned: the pivots of a pivoted QR of Wᵀ."""
    return sla.qr(w.T, mode="r", pivoting=True)[1][: w.shape[1]]


class BorderedFactor:
    """A factorisation of M = [[A, W], [Wᵀ, 0]]: ``solve``, ``sign`` (of det M) and
    ``logabsdet`` (log |det M|).

    a: (n, n) ndarray or sparse matrix; w: (n, z) with orthonormal columns, z ≥ 1; pins: the
    pinned coordinates of the sparse route (default pinned_coordinates(w); pass them when
    factorising several matrices with one W). Raises numpy.linalg.LinAlgError when M is exactly
    singular.
    """

    def __init__(self, a, w: np.ndarray, pins: np.ndarray | None = None):
        self.n, self.z = w.shape
        self.w = w
        if sp.issparse(a):
            self._factor_sparse(a.tocsc(), w, pinned_coordinates(w) if pins is None else pins)
        else:
            m = np.block([[np.asarray(a), w], [w.T, np.zeros((self.z, self.z))]])
            try:
                self._lu = sla.lu_factor(m, check_finite=False)
            except ValueError as exc:  # non-finite entries
                raise np.linalg.LinAlgError(str(exc)) from None
            self.sign, self.logabsdet = _lu_sign_and_log(self._lu)
            self._sparse = False

    def _factor_sparse(self, a, w, pins):
        n, z = self.n, self.z
        self._a = a
        gamma = float(np.mean(np.abs(a.diagonal()))) or 1.0
        pinned = sp.csc_matrix((np.full(z, gamma), (pins, pins)), shape=(n, n))
        try:
            self._lu = spla.splu(
                (a + pinned).tocsc(),
                permc_spec="MMD_AT_PLUS_A",
                diag_pivot_thresh=DIAG_PIVOT_THRESH,
                options={"SymmetricMode": True},
            )
        except RuntimeError as exc:  # "Factor is exactly singular"
            raise np.linalg.LinAlgError(str(exc)) from None
        e = np.zeros((n, z))
        e[pins, np.arange(z)] = np.sqrt(gamma)
        self._g = np.hstack([w, e])
        self._ag = self._lu.solve(self._g)
        h = np.zeros((2 * z, 2 * z))
        h[z:, z:] = np.eye(z)
        if not np.all(np.isfinite(self._ag)):
            raise np.linalg.LinAlgError("the bordered matrix is singular")
        self._s_lu = sla.lu_factor(h - self._g.T @ self._ag, check_finite=False)
        diag_u = self._lu.U.diagonal()
        sign_s, log_s = _lu_sign_and_log(self._s_lu)
        self.sign = int(
            np.prod(np.sign(diag_u))
            * permutation_sign(self._lu.perm_r)
            * permutation_sign(self._lu.perm_c)
            * sign_s
        )
        if self.sign == 0:
            raise np.linalg.LinAlgError("the bordered matrix is singular")
        self.logabsdet = float(np.sum(np.log(np.abs(diag_u)))) + log_s
        self._sparse = True

    def solve(self, r: np.ndarray, s: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(x, μ) with A x + W μ = r and Wᵀ x = s (s = 0 by default); r (n,) or (n, k)."""
        r = np.asarray(r, dtype=float)
        if s is None:
            s = np.zeros((self.z, *r.shape[1:]))
        if not self._sparse:
            sol = sla.lu_solve(self._lu, np.concatenate([r, s]), check_finite=False)
            return sol[: self.n], sol[self.n :]
        x, mu = self._eliminate(r, s)
        for _ in range(REFINEMENT_STEPS):
            dx, dmu = self._eliminate(r - self._a @ x - self.w @ mu, s - self.w.T @ x)
            x, mu = x + dx, mu + dmu
        return x, mu

    def _eliminate(self, r, s):
        """One block-elimination solve of N (module docstring)."""
        ar = self._lu.solve(r)
        border = np.concatenate([s, np.zeros_like(s)]) - self._g.T @ ar
        xi = sla.lu_solve(self._s_lu, border, check_finite=False)
        return ar - self._ag @ xi, xi[: self.z]


def _lu_sign_and_log(lu) -> tuple[int, float]:
    """(sign det, log |det|) from scipy.linalg.lu_factor's (LU, piv); LinAlgError if singular."""
    diag = np.diag(lu[0])
    if not np.all(diag != 0):
        raise np.linalg.LinAlgError("the bordered matrix is singular")
    flips = np.count_nonzero(lu[1] != np.arange(lu[1].size))
    return int(np.prod(np.sign(diag)) * (-1) ** flips), float(np.sum(np.log(np.abs(diag))))
