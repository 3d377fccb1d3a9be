"""The bond Green's function of a central-force spring network, kept current as bars are removed
(Rocks et al., PNAS 114, 2520 (2017); Goodrich, Liu & Nagel, PRL 114, 225501 (2015)).

Frame positions x ∈ R^{N×d} (normalised), bars b = (i, j) with stiffness k_b:
    unit compatibility matrix  Q = diag(1/ℓ) C  (N_B × dN), C the paper's compatibility matrix
    (Eq. 3), so (Q u)_b is the extension of bar b under the motion u;
    stiffness matrix           K = Qᵀ diag(k) Q;
    bond Green's function      G_bc = q_bᵀ K⁺ q_c  (q_b the Q-row of bar b, or of a virtual bar
                               joining a node pair), K⁺ realised by pinning d(d+1)/2 degrees of
                               freedom on which the rigid motions are invertible.
D_b = 1 − k_b G_bb ∈ [0, 1] is the share of a force dipole on bar b's ends that the rest of the
network carries: 0 exactly when b carries no self-stress, i.e. when removing b opens a zero mode.
Changing bar b's stiffness by δ is the rank-one update K' = K + δ q_b q_bᵀ, and by
Sherman–Morrison
    G'_pq = G_pq − δ G_pb G_bq / (1 + δ G_bb)                                         (SM)
(removal: δ = −k_b, denominator D_b). Used by the elastic response model
(applications/elastic_allostery.py) and by the tuning-by-pruning peer (benchmarks/pruning.py).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.sparse as sp

from zeromode.solver.analysis.factorisation import cholesky
from zeromode.solver.analysis.rigidity import compatibility_matrix, rigid_motions
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.tolerances import COINCIDENT_RTOL, FLOPPY_RTOL

# Bars removed between two factorisations (Woodbury updates in between, see SpringNetwork):
# each adds one column to every solve, and 64 keep the refreshed inverse small and accurate.
REFACTOR_AFTER = 64
# Right-hand sides per block when forming the diagonal of the bond Green's function.
_BLOCK = 256



def unit_compatibility(positions: np.ndarray, edges: np.ndarray) -> sp.csr_matrix:
    """Q = diag(1/ℓ) C (N_B × dN): row b maps a motion u to the extension of bar b."""
    c = compatibility_matrix(positions, edges)
    lengths = np.linalg.norm(positions[edges[:, 0]] - positions[edges[:, 1]], axis=1)
    return sp.diags(1.0 / lengths) @ c


def pair_row(positions: np.ndarray, pair: tuple[int, int]) -> tuple[np.ndarray, float]:
    """(q_p, ℓ_p): the dense Q-row (dN,) of a virtual bond joining ``pair``, and its length."""
    i, j = pair
    q = unit_compatibility(positions, np.array([[i, j]])).toarray().ravel()
    return q, float(np.linalg.norm(positions[i] - positions[j]))


def check_pair(frame: Frame, pair, name: str) -> tuple[int, int]:
    """(i, j): ``pair`` checked as two node indices of ``frame`` at distinct positions (a virtual
    bar); InvalidInput("invalid_pair") otherwise."""
    try:
        raw = np.asarray(pair, dtype=float)
    except (TypeError, ValueError):
        raw = np.zeros(0)
    if raw.shape != (2,) or not np.all(raw == np.round(raw)):
        raise InvalidInput("invalid_pair", f"{name} must be two integer node indices.")
    i, j = (int(v) for v in raw)
    n = frame.n_nodes
    if not (0 <= i < n and 0 <= j < n):
        raise InvalidInput("invalid_pair", f"{name} {[i, j]} names a node outside 0..{n - 1}.")
    if np.linalg.norm(frame.positions[i] - frame.positions[j]) <= COINCIDENT_RTOL * max(
        float(np.max(np.abs(frame.positions))), np.finfo(float).tiny
    ):
        raise InvalidInput("invalid_pair", f"{name} {[i, j]} joins two coincident nodes.")
    return i, j


def free_dofs(positions: np.ndarray) -> np.ndarray:
    """Mask (dN,) of the degrees of freedom left after pinning d(d+1)/2 that fix the rigid motions.

    The pinned set is chosen by column-pivoted QR of Rᵀ (R the dN×ρ rigid-motion basis), so the
    ρ×ρ block of R on the pinned dofs is as well conditioned as the frame allows; a balanced
    load then meets no reaction at the pins. ``positions`` (N, d) should be normalised.
    """
    rigid = rigid_motions(positions)
    _, _, pivots = scipy.linalg.qr(rigid.T, pivoting=True, mode="economic")
    free = np.ones(positions.size, dtype=bool)
    free[pivots[: rigid.shape[1]]] = False
    return free


class SpringNetwork:
    """A rigid central-force spring network whose bars can be removed one at a time.

    positions (N, d), normalised; edges (N_B, 2); stiffness k (N_B,). Holds a sparse Cholesky
    factor of K₀ = Qᵀ diag(k) Q over the bars alive when it was last factorised, rigid motions
    pinned, and the redundancy D_b = 1 − k_b G_bb of every bar, kept current by Sherman–Morrison.
    The m bars removed since (m < REFACTOR_AFTER) enter every solve by the Woodbury identity:
    with U their unit rows (columns q_b on the free dofs) and D = diag(k_b),
        (K₀ − U D Uᵀ)⁻¹ f = y + W (D⁻¹ − Uᵀ W)⁻¹ Uᵀ y,   y = K₀⁻¹ f,  W = K₀⁻¹ U,
    so a removal costs one solve instead of a factorisation.
    Raises DomainError("floppy_network") if K is singular on the free degrees of freedom.
    """

    def __init__(self, positions: np.ndarray, edges: np.ndarray, stiffness: np.ndarray):
        self.q = unit_compatibility(positions, edges)
        self.k = np.asarray(stiffness, dtype=float)
        self.alive = np.ones(len(edges), dtype=bool)
        self._free = free_dofs(positions)
        self._factorise()
        self.redundancy = 1.0 - self.k * self._green_diagonal()

    def _factorise(self) -> None:
        qa = self.q[self.alive]
        stiffness = (qa.T @ sp.diags(self.k[self.alive]) @ qa).tocsc()
        try:
            # K is symmetric positive definite on the free dofs: a supernodal Cholesky factor
            # (CHOLMOD, solver/analysis/factorisation.py) is several times faster than a sparse LU here.
            self._factor = cholesky(stiffness[self._free][:, self._free].tocsc())
        except ArithmeticError as exc:  # not positive definite: a zero mode
            raise DomainError("floppy_network", "the spring network has a zero mode.") from exc
        nfree = int(self._free.sum())
        self._u, self._w = np.zeros((nfree, 0)), np.zeros((nfree, 0))
        self._inner = np.zeros((0, 0))  # (D⁻¹ − Uᵀ W)⁻¹
        self._since: list[int] = []

    def solve(self, f: np.ndarray) -> np.ndarray:
        """u with K u = f for a balanced load f of shape (dN,) or (dN, m); = K⁺f + rigid motion."""
        u = np.zeros(f.shape)
        y = self._factor.solve(np.ascontiguousarray(f[self._free]))
        if self._since:
            y = y + self._w @ (self._inner @ (self._u.T @ y))
        u[self._free] = y
        return u

    def _green_diagonal(self) -> np.ndarray:
        """G_bb = q_bᵀ K⁺ q_b for every bar (N_B,), solved in blocks of columns."""
        out = np.empty(self.q.shape[0])
        for start in range(0, len(out), _BLOCK):
            block = self.q[start : start + _BLOCK]
            response = self.solve(block.T.toarray())  # (dN, m)
            out[start : start + _BLOCK] = np.asarray(block.multiply(response.T).sum(axis=1)).ravel()
        return out

    def removable(self) -> np.ndarray:
        """Indices of surviving bars whose removal opens no zero mode (D_b > FLOPPY_RTOL)."""
        return np.flatnonzero(self.alive & (self.redundancy > FLOPPY_RTOL))

    def remove(self, b: int) -> bool:
        """Remove bar b unless a fresh solve finds D_b ≤ FLOPPY_RTOL; return whether it went.

        The bar's column of the bond Green's function G_{·b} = Q K⁺ q_b, from the current
        factorisation, both re-checks D_b from scratch and carries the update
        D'_c = D_c − k_c k_b G_cb² / D_b of every other bar.
        """
        column = self.q @ self.solve(self.q[b].toarray().ravel())
        d_b = 1.0 - self.k[b] * column[b]
        if d_b <= FLOPPY_RTOL:
            self.redundancy[b] = d_b  # the maintained value had drifted; drop it from candidates
            return False
        self.redundancy -= self.k * self.k[b] * column**2 / d_b
        self.alive[b] = False
        if len(self._since) + 1 >= REFACTOR_AFTER:
            self._factorise()
        else:
            row = self.q[b].toarray().ravel()[self._free]
            self._since.append(b)
            self._u = np.column_stack([self._u, row])
            self._w = np.column_stack([self._w, self._factor.solve(row)])
            self._inner = np.linalg.inv(np.diag(1.0 / self.k[self._since]) - self._u.T @ self._w)
        return True
