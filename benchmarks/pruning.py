"""Tuning-by-pruning peer for allosteric design (Rocks et al., PNAS 114, 2520 (2017)).

The peer a user would reach for instead of the analytic design: start from a rigid random
spring network, impose a strain ε_S on a source pair of nodes, and greedily remove one bond at a
time — each time the bond whose removal brings the target pair's strain ratio η = ε_T/ε_S
closest to the desired η* — until |η − η*| ≤ tol, or no removable bond lowers |η − η*|.

Mechanics (linear response of a central-force spring network, frame positions x ∈ R^{N×d};
solver/analysis/bond_green.py holds the spring network and its bond Green's function):
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

from zeromode.solver import DomainError, Frame, InvalidInput, analyze
from zeromode.solver.analysis.bond_green import SpringNetwork, check_pair, pair_row


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
    s_pair = check_pair(frame, source_pair, "source_pair")
    t_pair = check_pair(frame, target_pair, "target_pair")
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
