"""Tuning-by-pruning peer for allosteric design (Rocks et al., PNAS 114, 2520 (2017)).

The peer a user would reach for instead of the analytic design: start from a rigid random
spring network, impose a strain ε_S on a source pair of nodes, and greedily remove one bond at a
time — each time the bond whose removal brings the target pair's strain ratio η = ε_T/ε_S
closest to the desired η* — until |η − η*| ≤ tol, or no removable bond lowers |η − η*|.

Mechanics (linear response of a central-force spring network, frame positions x ∈ R^{N×d}):
    unit compatibility matrix  Q = diag(1/ℓ) C  (N_B × dN), C the paper's compatibility matrix
    (Eq. 3), so (Q u)_b is the extension of bond b under the motion u;
    stiffness matrix           K = Qᵀ diag(k) Q,  k_b = 1/ℓ_b  (springs cut from one material);
    pair strain                ε_p(u) = q_pᵀ u / ℓ_p, with q_p the Q-row of a (virtual) bond
                               joining the pair p and ℓ_p its length.
The source strain is imposed as a constraint: minimise ½ uᵀKu subject to q_Sᵀu = ε_S ℓ_S.
The minimiser is u = t K⁺ q_S (a force dipole on the source pair), hence

    η = ε_T / ε_S = (ℓ_S / ℓ_T) · G_TS / G_SS,      G_pq = q_pᵀ K⁺ q_q,

the bond-space Green's function. K⁺ acts on balanced loads (q_p ⟂ rigid motions), and is
realised by pinning d(d+1)/2 degrees of freedom on which the rigid motions are invertible:
the pinned solve differs from K⁺q by a rigid motion, which every q_bᵀ annihilates.

Removing bond b is the rank-one update K' = K − k_b q_b q_bᵀ; by Sherman–Morrison
(the bond-level response of Goodrich, Liu & Nagel, PRL 114, 225501 (2015))

    G'_pq = G_pq + k_b G_pb G_bq / (1 − k_b G_bb).

D_b = 1 − k_b G_bb ∈ [0, 1] is the share of a force dipole on bond b's ends that the rest of the
network carries (bond b itself takes k_b G_bb): it is 0 exactly when b carries no self-stress,
i.e. when removing b opens a zero mode and the response becomes undefined. Such removals are refused, so the network stays
free of nontrivial zero modes throughout. Every greedy step therefore costs one sparse
factorisation of the current K and three solves (source, target, chosen bond), plus an
O(N_B) scoring of all candidates from the maintained diagonal k_b G_bb — not one
factorisation per candidate bond.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.sparse as sp

from zeromode.solver import (
    DomainError,
    Frame,
    InvalidInput,
    analyze,
    compatibility_matrix,
    rigid_motions,
)
from zeromode.solver.analysis.factorisation import cholesky

# A removal is refused when 1 − k_b G_bb falls to this: the new softest mode would be softer
# than 1e-8 of the removed bond's own stiffness (singular value ≳ 1e-4 of the bond's), which
# keeps it far above the 1e-9 singular-value threshold of the project's rank decisions.
FLOPPY_RTOL = 1e-8
# Bars removed between two factorisations (Woodbury updates in between, see SpringNetwork):
# each adds one column to every solve, and 64 keep the refreshed inverse small and accurate.
REFACTOR_AFTER = 64
# Right-hand sides per block when forming the diagonal of the bond Green's function.
_BLOCK = 256


@dataclass(frozen=True, eq=False)
class PruningResult:
    """Outcome of ``prune_for_allostery``.

    frame: the pruned frame (same positions, surviving edges in their original order).
    achieved_ratio: η = ε_T/ε_S of the pruned frame, from a fresh factorisation.
    error: |achieved_ratio − ratio|.  converged: error ≤ tol.
    bars_removed: how many bars were pruned; removed_edges: their indices into the input
    frame's edges, in removal order.  bars_used: bars of the pruned frame.
    iterations: greedy steps taken (each scored every candidate bond).
    stop_reason: "converged", "no_improving_bond" or "no_removable_bond".
    time_s: wall time of the whole call, rigidity check included.
    """

    frame: Frame
    achieved_ratio: float
    error: float
    bars_removed: int
    bars_used: int
    iterations: int
    time_s: float
    converged: bool
    stop_reason: str
    initial_ratio: float
    removed_edges: tuple[int, ...]


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


def _check_pair(frame: Frame, pair, name: str) -> tuple[int, int]:
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
    if np.linalg.norm(frame.positions[i] - frame.positions[j]) <= 1e-12 * max(
        float(np.max(np.abs(frame.positions))), np.finfo(float).tiny
    ):
        raise InvalidInput("invalid_pair", f"{name} {[i, j]} joins two coincident nodes.")
    return i, j


def prune_for_allostery(
    frame: Frame,
    source_pair: tuple[int, int],
    target_pair: tuple[int, int],
    ratio: float,
    tol: float,
    seed: int = 0,
) -> PruningResult:
    """Greedy tuning-by-pruning of ``frame`` towards η = ε_T/ε_S = ``ratio`` (see module doc).

    Each step scores every removable bar b by the exact post-removal ratio
        η_b = (ℓ_S/ℓ_T)(G_TS + k_b G_Tb G_bS / D_b) / (G_SS + k_b G_Sb² / D_b),  D_b = 1 − k_b G_bb,
    and removes the one minimising |η_b − ratio|, provided it beats the current |η − ratio|.
    Removable: D_b > FLOPPY_RTOL (the removal opens no zero mode). ``seed`` only breaks ties
    between equally good bars. The frame must be rigid (no nontrivial zero modes).
    """
    started = time.perf_counter()
    s_pair = _check_pair(frame, source_pair, "source_pair")
    t_pair = _check_pair(frame, target_pair, "target_pair")
    if not (np.isfinite(ratio) and np.isfinite(tol) and tol > 0):
        raise InvalidInput("invalid_target", "ratio must be finite and tol finite and positive.")
    # Counts only: the sparse route avoids a dense SVD that would dwarf the pruning itself.
    if analyze(frame, method="sparse", bases=False).nontrivial_zero_modes:
        raise DomainError(
            "floppy_network",
            "the frame has nontrivial zero modes, so its strain response is not unique.",
        )

    x = frame.normalised_positions()  # η is scale-free; this keeps K well scaled
    edges = frame.edges
    net = SpringNetwork(x, edges, 1.0 / np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1))
    q, k = net.q, net.k
    q_s, l_s = pair_row(x, s_pair)
    q_t, l_t = pair_row(x, t_pair)
    tie_rank = np.random.default_rng(seed).permutation(frame.n_edges)

    removed: list[int] = []
    iterations = 0
    initial = None
    while True:
        u_s, u_t = net.solve(q_s), net.solve(q_t)
        g_s, g_t = q @ u_s, q @ u_t  # G_bS, G_bT for every bar
        g_ss, g_ts = float(q_s @ u_s), float(q_t @ u_s)
        eta = (l_s / l_t) * g_ts / g_ss
        initial = eta if initial is None else initial
        error = abs(eta - ratio)
        if error <= tol:
            stop = "converged"
            break
        candidates = net.removable()
        if candidates.size == 0:
            stop = "no_removable_bond"
            break
        iterations += 1
        d, kb = net.redundancy[candidates], k[candidates]
        eta_b = (
            (l_s / l_t)
            * (g_ts + kb * g_t[candidates] * g_s[candidates] / d)
            / (g_ss + kb * g_s[candidates] ** 2 / d)
        )
        score = np.abs(eta_b - ratio)
        if not score.min() < error:
            stop = "no_improving_bond"
            break
        tied = candidates[score == score.min()]
        best = int(tied[np.argmin(tie_rank[tied])])
        if net.remove(best):
            removed.append(best)

    pruned = Frame.build(frame.positions, edges[net.alive], frame.specified, frame.dim)
    return PruningResult(
        frame=pruned,
        achieved_ratio=float(eta),
        error=float(error),
        bars_removed=len(removed),
        bars_used=int(net.alive.sum()),
        iterations=iterations,
        time_s=time.perf_counter() - started,
        converged=stop == "converged",
        stop_reason=stop,
        initial_ratio=float(initial),
        removed_edges=tuple(removed),
    )
