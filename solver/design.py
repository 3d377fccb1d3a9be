"""Zero-mode design by judicious constraint placement (paper, "Network Construction Through
Judicious Constraint Placement", Eq. 7).

Start from the k specified nodes (N_D = dk) and add unspecified nodes, each at a point of a
solution space (so every requested motion stays a zero mode) and joined only by bars that raise
rank C (so no self-stress appears), until

    N_D = d·(k + N_U) − N_B = d(d+1)/2 + M.

With no self-stress, N(C) is then exactly the rigid motions ⊕ the M requested modes.

Placement is greedy and deterministic for a seed: each round scores every candidate point by the
rank its bars would add — computed on the small matrix [A·N_old, B] (A: the new rows on the old
columns, N_old: a basis of the current N(C), B: the new rows on the new node's columns), whose
rank equals the rank gained — and keeps the candidate that removes the most degrees of freedom,
breaking ties by conditioning (the smallest pivot of that matrix with unit rows).  A node must
take at least d + 1 independent bars whose directions span R^d, so it never dangles.

Candidates come from the solution space of all k specified nodes when it has real points, and
otherwise (or when geometry stalls the count, as for the coplanar 5-node case in 3D) from the
solution spaces of subsets of them ("anchor sets"), largest subsets first.  Every design is
verified by a full analysis before it is returned.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
from scipy.sparse.linalg import norm as sp_norm

from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.rank import RTOL, nullspace
from zeromode.solver.rigidity import Analysis, analyze, compatibility_matrix, rigid_motions
from zeromode.solver.solution_space import Normalisation, check_targets, solution_space

# Candidates closer than this (normalised units) to an existing node are skipped: a bar there
# would be nearly zero-length and the design ill-conditioned.
MIN_SEPARATION = 0.08
# Candidates farther than this from the centroid (normalised units) are skipped.
MAX_RADIUS = 4.0
# A placed design must satisfy ‖C u‖ ≤ MODE_RTOL·‖C‖‖u‖ on normalised coordinates.
MODE_RTOL = 1e-10


@dataclass(eq=False)
class CandidatePool:
    """Possible unspecified nodes that share one anchor set: positions (n, d), their motion in
    each mode (n, M, d), and the existing nodes they may be joined to (whose bar constraints
    hold at every one of these points)."""

    positions: np.ndarray
    motions: np.ndarray
    anchors: tuple[int, ...]

    def remove(self, i: int) -> None:
        keep = np.arange(len(self.positions)) != i
        self.positions, self.motions = self.positions[keep], self.motions[keep]


@dataclass(frozen=True, eq=False)
class Design:
    """A verified design. modes: (M, N, d); rows 0..k−1 of modes[i] equal the requested u_S^(i)."""

    frame: Frame
    modes: np.ndarray
    analysis: Analysis
    target_zero_modes: int
    anchor_sets: tuple[tuple[int, ...], ...]
    conditioning: float
    mode_residual: float
    notes: tuple[str, ...] = field(default=())

    @property
    def unspecified_nodes(self) -> int:
        return self.frame.n_nodes - len(self.frame.specified)


def target_zero_modes(d: int, n_modes: int) -> int:
    """d(d+1)/2 rigid motions plus one zero mode per requested motion (Eq. 7)."""
    return d * (d + 1) // 2 + n_modes


def check_motions_nonrigid(positions: np.ndarray, motions: np.ndarray) -> None:
    """Raise ``rigid_target`` unless the motions are independent modulo rigid motions.

    positions (k, d); motions (M, k, d). Each u^(i) must have a component outside the rigid
    motions of x_S, and the M components must be linearly independent.
    """
    norm = Normalisation.of(positions, motions[0])
    rigid = rigid_motions(norm.positions_in(positions))
    flat = motions.reshape(len(motions), -1).T  # (k·d, M)
    scale = np.linalg.norm(flat, axis=0)
    if np.any(scale == 0):
        raise DomainError("rigid_target", f"motion {int(np.argmin(scale))} is zero everywhere.")
    residual = (flat - rigid @ (rigid.T @ flat)) / scale
    norms = np.linalg.norm(residual, axis=0)
    if np.any(norms <= 1e-9):
        i = int(np.argmin(norms))
        raise DomainError(
            "rigid_target",
            f"motion {i} is a rigid motion (translation/rotation) of the specified nodes; "
            "only non-rigid motions can be designed.",
        )
    s = np.linalg.svd(residual / norms, compute_uv=False)
    if len(motions) > 1 and s[-1] <= 1e-9 * s[0]:
        raise DomainError(
            "rigid_target", "the requested motions are linearly dependent modulo rigid motions."
        )


def check_specified_distinct(positions: np.ndarray) -> None:
    """Raise ``degenerate_specified`` if two specified nodes coincide (relative to the set's size)."""
    k = len(positions)
    if k < 2:
        return
    scale = float(np.sqrt(np.mean(np.sum((positions - positions.mean(0)) ** 2, axis=1))))
    diff = positions[:, None, :] - positions[None, :, :]
    dist = np.sqrt(np.sum(diff**2, axis=-1))
    np.fill_diagonal(dist, np.inf)
    i, j = np.unravel_index(np.argmin(dist), dist.shape)
    if scale == 0 or dist[i, j] <= 1e-9 * scale:
        raise DomainError(
            "degenerate_specified", f"specified nodes {min(i, j)} and {max(i, j)} coincide."
        )


class _Placement:
    """Mutable state of one greedy construction, in the normalised coordinates of x_S."""

    def __init__(self, x_n: np.ndarray, u_n: np.ndarray, target: int):
        self.d = x_n.shape[1]
        self.positions = [p for p in x_n]
        self.motions = [u_n[:, i, :] for i in range(x_n.shape[0])]  # each (M, d)
        self.edges: list[tuple[int, int]] = []
        self.anchor_sets: list[tuple[int, ...]] = []
        self.target = target
        self.rank = 0
        self._null = np.eye(self.d * len(self.positions))

    @property
    def n_d(self) -> int:
        return self.d * len(self.positions) - len(self.edges)

    def best_in(self, pool: CandidatePool, budget: int) -> tuple[int, float, int, list[int]] | None:
        """Best candidate of ``pool`` if joined to at most ``budget`` of its anchors:
        (rank gained, conditioning, index in pool, anchors chosen), or None.

        For each candidate the rows of the new bars, projected onto the current N(C) for the old
        columns, form R = [A·N_old, B] (a × (z + d)); rank R is the rank gained, its take-th
        singular value (unit rows) the conditioning. One batched SVD scores the whole pool.
        """
        d = self.d
        x = np.asarray(self.positions)
        p = pool.positions
        if len(p) == 0:
            return None
        anchors = np.asarray(pool.anchors)
        sep = np.min(np.linalg.norm(x[None] - p[:, None], axis=2), axis=1)
        valid = (sep >= MIN_SEPARATION) & (np.linalg.norm(p, axis=1) <= MAX_RADIUS)
        diff = x[anchors][None] - p[:, None]  # (n, a, d) bar directions
        null_blocks = self._null.reshape(len(x), d, -1)[anchors]  # (a, d, z)
        rows = np.concatenate([np.einsum("nad,adz->naz", diff, null_blocks), -diff], axis=2)
        rows /= np.maximum(np.linalg.norm(rows, axis=2, keepdims=True), 1e-300)
        s = np.linalg.svd(rows, compute_uv=False)  # (n, min(a, z+d))
        gained = np.count_nonzero(s > 1e-7 * np.maximum(s[:, :1], 1e-300), axis=1)
        take = np.minimum(gained, budget)
        # The node must be pinned: its bars' directions must span R^d.
        spans = np.linalg.matrix_rank(diff, tol=1e-7) >= d
        ok = valid & spans & (take > d)
        if not np.any(ok):
            return None
        cond = np.where(ok, s[np.arange(len(p)), np.maximum(take, 1) - 1], -1.0)
        for i in np.lexsort((-cond, -np.where(ok, take, -1))):
            if not ok[i]:
                break
            chosen = self._choose_anchors(rows[i], anchors, int(take[i]))
            if np.linalg.matrix_rank(x[chosen] - p[i], tol=1e-7) >= d:
                return int(take[i]), float(cond[i]), int(i), chosen
        return None

    @staticmethod
    def _choose_anchors(rows: np.ndarray, anchors: np.ndarray, take: int) -> list[int]:
        """The ``take`` most independent bars (pivoted QR), or all of them when all are needed."""
        if take == len(anchors):
            return [int(a) for a in anchors]
        _, _, piv = sla.qr(rows.T, mode="economic", pivoting=True)
        return sorted(int(anchors[i]) for i in piv[:take])

    def add(self, position: np.ndarray, motions: np.ndarray, anchors: list[int]) -> None:
        index = len(self.positions)
        self.positions.append(position)
        self.motions.append(motions)
        self.edges.extend((a, index) for a in anchors)
        self.anchor_sets.append(tuple(anchors))
        c = compatibility_matrix(np.asarray(self.positions), np.asarray(self.edges), dense=True)
        self._null, self.rank, _ = nullspace(c, RTOL)


def _budget(state: _Placement, nodes_left: int | None) -> int:
    """The most bars the next node may take without overshooting the target count."""
    excess = state.n_d - state.target
    if nodes_left is None:
        return excess + state.d
    # Spread the remaining reduction evenly when the user fixed the number of nodes.
    return state.d + -(-excess // nodes_left)


def place_nodes(
    x_n: np.ndarray,
    u_n: np.ndarray,
    candidate_levels: Iterator[list[CandidatePool]],
    n_unspecified: int | None = None,
) -> _Placement:
    """Greedy judicious placement (normalised coordinates).

    x_n (k, d); u_n (M, k, d). ``candidate_levels`` yields lists of pools in order of
    preference (e.g. the full specified set first, then subsets); a later level is consulted
    only when no earlier candidate can remove a degree of freedom.
    """
    k, d = x_n.shape
    state = _Placement(x_n, u_n, target_zero_modes(d, u_n.shape[0]))
    levels: list[list[CandidatePool]] = []
    level_iter = iter(candidate_levels)
    while state.n_d > state.target:
        nodes_left = None if n_unspecified is None else n_unspecified - len(state.anchor_sets)
        if nodes_left is not None and nodes_left <= 0:
            raise DomainError(
                "no_solution",
                f"{n_unspecified} unspecified nodes cannot remove the {state.n_d - state.target} "
                "remaining degrees of freedom; allow more nodes.",
            )
        budget = _budget(state, nodes_left)
        best = None
        level = 0
        while best is None:
            if level == len(levels):
                nxt = next(level_iter, None)
                if nxt is None:
                    break
                levels.append(nxt)
            for pool in levels[level]:
                found = state.best_in(pool, budget)
                if found and (best is None or found[:2] > best[0][:2]):
                    best = (found, pool)
            level += 1
        if best is None:
            raise DomainError(
                "no_solution",
                f"no real placement removes the remaining {state.n_d - state.target} degrees of "
                "freedom without creating a self-stress.",
            )
        (_, _, i, chosen), pool = best
        state.add(pool.positions[i], pool.motions[i], chosen)
        pool.remove(i)
    return state


def single_mode_levels(
    x_n: np.ndarray, u_n: np.ndarray, rng: np.random.Generator, samples: int = 16
) -> Iterator[list[CandidatePool]]:
    """Candidate levels for one motion: the full specified set, then ever smaller anchor subsets
    (sizes 2d+1 … d+1) whose solution spaces are larger."""
    k, d = x_n.shape
    u = u_n[0]
    yield [p for p in [_pool(x_n, u, tuple(range(k)), rng, samples)] if p is not None]
    for size in range(min(k - 1, 2 * d + 1), d, -1):
        pools = [_pool(x_n, u, sub, rng, samples) for sub in itertools.combinations(range(k), size)]
        yield [p for p in pools if p is not None]


def _pool(
    x_n: np.ndarray, u: np.ndarray, subset: tuple[int, ...], rng: np.random.Generator, samples: int
) -> CandidatePool | None:
    idx = list(subset)
    try:
        space = solution_space(x_n[idx], u[idx])
    except DomainError:
        return None
    positions, motions = space.sample(samples, rng)
    return CandidatePool(positions, motions[:, None, :], subset) if len(positions) else None


def design(
    positions,
    motions,
    dim: int | None = None,
    seed: int = 0,
    n_unspecified: int | None = None,
    levels: Callable[[np.ndarray, np.ndarray, np.random.Generator], Iterator[list[CandidatePool]]] | None = None,
) -> Design:
    """Design a frame whose only non-rigid zero modes are the requested motions.

    positions: x_S (k, d); motions: (M, k, d) or (k, d) for one motion.
    Raises DomainError: ``rigid_target``, ``degenerate_specified``, ``no_solution``.
    """
    x = np.asarray(positions, dtype=float)
    u_all = np.asarray(motions, dtype=float)
    if u_all.ndim == 2:
        u_all = u_all[None]
    for u in u_all:
        check_targets(x, u, dim)
    if len(u_all) == 0:
        raise InvalidInput("invalid_shape", "motions must hold at least one motion.")
    d = x.shape[1]
    check_specified_distinct(x)
    check_motions_nonrigid(x, u_all)
    if n_unspecified is not None and n_unspecified < 0:
        raise InvalidInput("invalid_options", "n_unspecified must be non-negative.")
    norm = Normalisation.of(x, u_all[0])
    x_n = norm.positions_in(x)
    u_n = np.stack([norm.motions_in(u) for u in u_all])
    rng = np.random.default_rng(seed)
    make_levels = levels or single_mode_levels
    if len(u_all) > 1 and levels is None:
        raise DomainError("no_solution", "several motions need the multi-mode construction.")
    state = place_nodes(x_n, u_n, make_levels(x_n, u_n, rng), n_unspecified)
    return _finish(x, u_all, norm, state)


def _finish(x: np.ndarray, u_all: np.ndarray, norm: Normalisation, state: _Placement) -> Design:
    """Map back to the caller's coordinates, keep the specified rows exact, and verify."""
    k, d = x.shape
    xs = np.asarray(state.positions)
    frame_positions = np.vstack([x, norm.positions_out(xs[k:])]) if len(xs) > k else x.copy()
    modes = np.stack(
        [
            np.vstack([u_all[i], norm.motions_out(np.asarray([m[i] for m in state.motions[k:]]))])
            if len(xs) > k
            else u_all[i].copy()
            for i in range(len(u_all))
        ]
    )
    edges = np.asarray(state.edges, dtype=int).reshape(-1, 2)
    frame = Frame.build(frame_positions, edges, specified=range(k))
    return verify(frame, modes, state.anchor_sets)


def verify(frame: Frame, modes: np.ndarray, anchor_sets=()) -> Design:
    """Check a design through a full analysis: exactly d(d+1)/2 + M zero modes, no self-stress,
    d(d+1)/2 rigid motions, and ‖C u‖ ≤ MODE_RTOL‖C‖‖u‖ for every mode (normalised C)."""
    d = frame.dim
    target = target_zero_modes(d, len(modes))
    analysis = analyze(frame)
    c = compatibility_matrix(frame.normalised_positions(), frame.edges)
    c_scale = max(float(sp_norm(c)), 1e-300) if c.shape[0] else 1.0
    residual = max(
        (float(np.linalg.norm(c @ m.ravel())) / (c_scale * max(np.linalg.norm(m), 1e-300)) for m in modes),
        default=0.0,
    )
    problems = []
    if analysis.zero_modes != target:
        problems.append(f"{analysis.zero_modes} zero modes instead of {target}")
    if analysis.self_stresses:
        problems.append(f"{analysis.self_stresses} self-stresses")
    if analysis.rigid_body_modes != d * (d + 1) // 2:
        problems.append("a degenerate configuration")
    if residual > MODE_RTOL:
        problems.append(f"a mode residual of {residual:.1e}")
    if problems:
        raise DomainError(
            "no_solution", "the construction did not verify: " + ", ".join(problems) + "."
        )
    return Design(
        frame=frame,
        modes=modes,
        analysis=analysis,
        target_zero_modes=target,
        anchor_sets=tuple(anchor_sets),
        conditioning=analysis.rank_gap.last_nonzero,
        mode_residual=residual,
    )
