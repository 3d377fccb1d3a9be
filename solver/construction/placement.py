"""The greedy engine of judicious constraint placement (paper, Eq. 7).

Start from the k specified nodes (N_D = dk) and add unspecified nodes, each taken from a pool
of candidate points on a solution space (so every requested motion stays a zero mode) and
joined only by bars that raise rank C (so no self-stress appears), until

    N_D = d·(k + N_U) − N_B = d(d+1)/2 + M.

Each round scores every candidate by the rank its bars would add — the rank of the small matrix
[A·N_old, B] (A: the new rows on the old columns, N_old: a basis of the current N(C), B: the new
rows on the new node's columns) — and keeps the candidate that removes the most degrees of
freedom, ties broken by conditioning (the take-th singular value of that matrix with unit
rows).  A node must take at least d + 1 independent bars whose directions span R^d, so it never
dangles.  All coordinates here are the normalised ones of the specified set.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from math import comb

import numpy as np

from zeromode.solver.analysis.rank import RTOL, nullspace
from zeromode.solver.budget import check_budget
from zeromode.solver.errors import DomainError
from zeromode.solver.progress import report_progress
from zeromode.solver.tolerances import PLACEMENT_RTOL

# Normalised units (the specified set has RMS radius 1).  A candidate is *well placed* when it
# keeps PREFERRED_SEPARATION from every node and lies within PREFERRED_RADIUS; others are used
# only when no well-placed candidate removes as many degrees of freedom (they are still valid
# designs, e.g. the single fourth point of two conics).  Closer than MIN_SEPARATION (a
# near-zero bar) or farther than MAX_RADIUS is never used.
PREFERRED_SEPARATION = 0.08
PREFERRED_RADIUS = 4.0
MIN_SEPARATION = 1e-3
MAX_RADIUS = 1e3
@dataclass(eq=False)
class CandidatePool:
    """Possible unspecified nodes that share one anchor set: positions (n, d), their motion in
    each mode (n, M, d), and the existing nodes they may be joined to (whose bar constraints
    hold at every one of these points)."""

    positions: np.ndarray
    motions: np.ndarray
    anchors: tuple[int, ...]
    # Upper bound on the rank any candidate here can still add: rank gains only fall as bars
    # are added, so the last best gain bounds every later one (lazy greedy).
    bound: int = 1 << 30

    def remove(self, i: int) -> None:
        self.keep(np.arange(len(self.positions)) != i)

    def keep(self, mask: np.ndarray) -> None:
        self.positions, self.motions = self.positions[mask], self.motions[mask]


def admissible(pool: CandidatePool, x: np.ndarray) -> CandidatePool:
    """Drop, once, candidates that can never be placed whatever happens later: too far out, or
    whose bars to the anchors cannot span R^d (the node would dangle)."""
    p = pool.positions
    if len(p):
        d = p.shape[1]
        diff = x[np.asarray(pool.anchors)][None] - p[:, None]
        spans = np.linalg.matrix_rank(diff, tol=PLACEMENT_RTOL) >= d
        pool.keep(spans & (np.linalg.norm(p, axis=1) <= MAX_RADIUS))
    return pool


def target_zero_modes(d: int, n_modes: int) -> int:
    """d(d+1)/2 rigid motions plus one zero mode per requested motion (Eq. 7)."""
    return d * (d + 1) // 2 + n_modes


class Placement:
    """Mutable state of one greedy construction, in the normalised coordinates of x_S.

    null: an orthonormal basis (dk × z) of the motions the specified nodes may still make —
    the identity for free nodes; narrower when a frame built earlier already ties some of them
    (hierarchical placement: a port of an earlier module moves only as that module allows).
    """

    def __init__(self, x_n: np.ndarray, u_n: np.ndarray, target: int, null: np.ndarray | None = None):
        self.d = x_n.shape[1]
        self.positions = [p for p in x_n]
        self.motions = [u_n[:, i, :] for i in range(x_n.shape[0])]  # each (M, d)
        self.edges: list[tuple[int, int]] = []
        self.anchor_sets: list[tuple[int, ...]] = []
        self.target = target
        self.rank = 0
        self._null = np.eye(self.d * len(self.positions)) if null is None else null

    @property
    def n_d(self) -> int:
        """Degrees of freedom left: dim N(C) of the nodes so far (every bar placed raised the rank)."""
        return self._null.shape[1]

    def best_in(self, pool: CandidatePool, budget: int, strict: bool = True) -> tuple[tuple, int, list[int]] | None:
        """Best candidate of ``pool`` if joined to at most ``budget`` of its anchors:
        (ranking key, index in pool, anchors chosen), or None; larger keys are better.
        strict: consider only well-placed candidates (see PREFERRED_SEPARATION).

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
        separation = np.min(np.linalg.norm(x[None] - p[:, None], axis=2), axis=1)
        valid = separation >= MIN_SEPARATION
        diff = x[anchors][None] - p[:, None]  # (n, a, d) bar directions
        null_blocks = self._null.reshape(len(x), d, -1)[anchors]  # (a, d, z)
        rows = np.concatenate([np.einsum("nad,adz->naz", diff, null_blocks), -diff], axis=2)
        rows /= np.maximum(np.linalg.norm(rows, axis=2, keepdims=True), 1e-300)
        s = np.linalg.svd(rows, compute_uv=False)  # (n, min(a, z+d))
        gained = np.count_nonzero(s > PLACEMENT_RTOL * np.maximum(s[:, :1], 1e-300), axis=1)
        take = np.minimum(gained, budget)
        ok = valid & (take > d)
        # Rank gain only falls as bars are added and separation only shrinks, so a candidate
        # that cannot remove a degree of freedom now never will: drop it for good.
        viable = valid & (gained > d)
        pool.bound = int(np.max(gained[viable], initial=0))
        if not np.all(viable):
            pool.keep(viable)
            rows, s, take, ok, p, diff = rows[viable], s[viable], take[viable], ok[viable], p[viable], diff[viable]
            separation = separation[viable]
        if not np.any(ok):
            return None
        cond = np.where(ok, s[np.arange(len(p)), np.maximum(take, 1) - 1], -1.0)
        # Ties in conditioning (exact ones occur, e.g. for the first node) are broken by
        # compactness; both keys are quantised so that rounding noise — which differs between
        # a request and its rescaled copy — never decides.
        reach = np.max(np.linalg.norm(diff, axis=2), axis=1)
        placed = (separation >= PREFERRED_SEPARATION) & (np.linalg.norm(p, axis=1) <= PREFERRED_RADIUS)
        if strict:
            ok &= placed
        order = np.lexsort((np.round(reach, 6), -np.round(cond, 6), -np.where(ok, take, -1)))
        for i in order:
            if not ok[i]:
                break
            chosen = self._choose_anchors(rows[i], anchors, np.linalg.norm(diff[i], axis=1), int(take[i]))
            if np.linalg.matrix_rank(x[chosen] - p[i], tol=PLACEMENT_RTOL) >= d:
                key = (int(take[i]), round(float(cond[i]), 6), -round(float(reach[i]), 6))
                return key, int(i), chosen
        return None

    @staticmethod
    def _choose_anchors(rows: np.ndarray, anchors: np.ndarray, lengths: np.ndarray, take: int) -> list[int]:
        """``take`` independent bars: all of them when all are needed, otherwise greedily in a
        scale-free order (shortest bar first, lengths quantised, then anchor index), keeping a
        bar only if it raises the rank — so rounding noise never decides which bars are used."""
        if take == len(anchors):
            return [int(a) for a in anchors]
        chosen: list[int] = []
        for i in np.lexsort((anchors, np.round(lengths, 6))):
            trial = rows[chosen + [int(i)]]
            s = np.linalg.svd(trial, compute_uv=False)
            if s[-1] > PLACEMENT_RTOL * s[0]:
                chosen.append(int(i))
                if len(chosen) == take:
                    break
        return sorted(int(anchors[i]) for i in chosen)

    def bar_rows(self, position: np.ndarray, anchors) -> np.ndarray:
        """Unit rows (a, z + d) of a new node's bars to ``anchors`` on [N_old, its own
        coordinates]: row i is ((x_i − x)ᵀ N_old[i], −(x_i − x)ᵀ) / its norm (the one-node
        case of ``best_in``'s batch)."""
        x = np.asarray(self.positions)
        idx = np.asarray(anchors)
        diff = x[idx] - position
        null_blocks = self._null.reshape(len(x), self.d, -1)[idx]
        rows = np.hstack([np.einsum("ad,adz->az", diff, null_blocks), -diff])
        return rows / np.linalg.norm(rows, axis=1, keepdims=True)

    def independent_conditioning(self, nodes) -> float | None:
        """The smallest σ_min/σ_max of the unit bar rows (``bar_rows``) of ``nodes`` — (position,
        anchors) pairs, anchors indexing the existing nodes and those before it in the list —
        joined in turn, or None unless each node's bars raise rank C by their number
        (PLACEMENT_RTOL).  The state is unchanged.

        In the coordinates [N_old's z, the new nodes' d each] a node's rows are R_j (its bars:
        (x_i − x)ᵀN_old[i] for an existing anchor, ±(x_i − x)ᵀ on a new node's columns);
        ``add`` would score them on blockdiag(N_cur, I_d) with N_cur an orthonormal basis of
        N(R_1; …; R_{j−1}), and R_j·N_cur has the singular values of R_j·(I − SᵀS), S an
        orthonormal basis of the rows placed before (S Sᵀ = I): so the trial projects the rows
        instead of forming N_cur, O((z + hd)·a) per node, not a copy of the dN × z basis."""
        d, first = self.d, len(self.positions)
        z = self._null.shape[1]
        old_blocks = self._null.reshape(first, d, z)
        width = z + d * len(nodes)
        points = list(self.positions)
        span = np.zeros((0, width))  # orthonormal rows spanning the bars of the nodes before
        score = np.inf
        for j, (position, anchors) in enumerate(nodes):
            diff = np.asarray([points[i] for i in anchors]) - position
            rows = np.zeros((len(anchors), width))
            for r, (i, bar) in enumerate(zip(anchors, diff)):
                if i < first:
                    rows[r, :z] = bar @ old_blocks[i]
                else:
                    rows[r, z + d * (i - first) : z + d * (i - first + 1)] = bar
            rows[:, z + d * j : z + d * (j + 1)] = -diff
            rows -= (rows @ span.T) @ span
            rows /= np.maximum(np.linalg.norm(rows, axis=1, keepdims=True), 1e-300)
            _, s, vt = np.linalg.svd(rows, full_matrices=False)
            if np.count_nonzero(s > PLACEMENT_RTOL * s[0]) != len(anchors):
                return None
            score = min(score, float(s[-1] / s[0]))
            span = np.vstack([span, vt])
            points.append(position)
        return score

    def add(self, position: np.ndarray, motions: np.ndarray, anchors: list[int]) -> None:
        """Join a node at ``position`` to ``anchors`` and update N(C) incrementally.

        A null vector of the grown C is (N_old c, w) with A·N_old c + B w = 0, so
        N_new = blockdiag(N_old, I_d) · N([A·N_old, B]) — orthonormal, from a tiny SVD.
        """
        d = self.d
        kernel, gained, _ = nullspace(self.bar_rows(position, anchors), RTOL)
        z = self._null.shape[1]
        grown = np.zeros((self._null.shape[0] + d, z + d))
        grown[: self._null.shape[0], :z] = self._null
        grown[self._null.shape[0] :, z:] = np.eye(d)
        self._null = grown @ kernel
        self.rank += gained
        self.edges.extend((a, len(self.positions)) for a in anchors)  # the new node's index
        self.positions.append(position)
        self.motions.append(motions)
        self.anchor_sets.append(tuple(anchors))


def anchor_subsets(x: np.ndarray, size: int, cap: int = 64) -> list[tuple[int, ...]]:
    """Anchor sets of ``size`` specified nodes: all of them while there are at most ``cap``,
    otherwise the spatially local ones (each node with its size − 1 nearest neighbours), which
    keeps the search linear in k for large targets (the paper's primary modules are local)."""
    k = len(x)
    if comb(k, size) <= cap:
        return list(itertools.combinations(range(k), size))
    dist = np.linalg.norm(x[:, None] - x[None], axis=2)
    subsets = {tuple(sorted(np.argsort(dist[i], kind="stable")[:size].tolist())) for i in range(k)}
    return sorted(subsets)


def coupling_subsets(
    k: int, sizes: range, rng: np.random.Generator, count: int
) -> list[tuple[int, ...]]:
    """Seeded random anchor sets: the paper's coupling modules, which tie together modules that
    local anchor sets leave free to move relative to each other."""
    subsets = set()
    for size in sizes:
        if size > k:
            continue
        for _ in range(count):
            subsets.add(tuple(sorted(rng.choice(k, size=size, replace=False).tolist())))
    return sorted(subsets)


def _budget(state: Placement, nodes_left: int | None) -> int:
    """The most bars the next node may take without overshooting the target count."""
    excess = state.n_d - state.target
    if nodes_left is None:
        return excess + state.d
    # A fixed node count: spread the reduction evenly, leaving at least one per later node.
    return state.d + min(-(-excess // nodes_left), excess - (nodes_left - 1))


def place_nodes(
    x_n: np.ndarray,
    u_n: np.ndarray,
    candidate_levels: Iterator[list[CandidatePool]],
    n_unspecified: int | None = None,
    start: Placement | None = None,
) -> Placement:
    """Greedy judicious placement (normalised coordinates).

    x_n (k, d); u_n (M, k, d). ``candidate_levels`` yields lists of pools in order of
    preference (e.g. the full specified set first, then subsets); a later level is consulted
    only when no earlier candidate can remove a degree of freedom. ``start``: continue this
    state (its nodes, bars, null space and target) instead of the bare specified nodes.
    """
    d = x_n.shape[1]
    state = start or Placement(x_n, u_n, target_zero_modes(d, u_n.shape[0]))
    levels: list[list[CandidatePool]] = []
    level_iter = iter(candidate_levels)
    if n_unspecified is not None and n_unspecified > state.n_d - state.target:
        raise DomainError(
            "no_solution",
            f"{n_unspecified} unspecified nodes cannot all be used: each must remove at least one "
            f"of the {state.n_d - state.target} degrees of freedom to remove.",
        )
    to_remove = state.n_d - state.target
    # Progress within a round: each level built and pool searched moves the fraction on by a
    # shrinking step, short of the round's end (one more degree of freedom removed).
    round_progress = [0.0, 0]  # the round's start, levels and pools examined in it

    def searched(what: str) -> None:
        round_progress[1] += 1
        report_progress(round_progress[0] + (1 - 1 / (round_progress[1] + 1)) / to_remove, what)

    while state.n_d > state.target:
        check_budget()
        nodes_left = None if n_unspecified is None else n_unspecified - len(state.anchor_sets)
        if nodes_left is not None and nodes_left <= 0:
            raise DomainError(
                "no_solution",
                f"{n_unspecified} unspecified nodes cannot remove the {state.n_d - state.target} "
                "remaining degrees of freedom; allow more nodes.",
            )
        budget = _budget(state, nodes_left)
        best = None
        round_progress[:] = [1 - (state.n_d - state.target) / to_remove, 0]
        # Well-placed candidates first, through every level; any valid one only if none is found.
        for strict in (True, False):
            level = 0
            while best is None:
                if level == len(levels):
                    nxt = next(level_iter, None)
                    if nxt is None:
                        break
                    levels.append([admissible(p, x_n) for p in nxt])
                    searched("built a candidate level")
                # Highest bound first; stop once no remaining pool can reach the best gain found.
                for pool in sorted(levels[level], key=lambda p: -p.bound):
                    if best is not None and min(pool.bound, budget) < best[0][0][0]:
                        break
                    found = state.best_in(pool, budget, strict)
                    searched("searched a candidate pool")
                    if found and (best is None or found[0] > best[0][0]):
                        best = (found, pool)
                level += 1
            if best is not None:
                break
        if best is None:
            why = (
                "the solution spaces have no real point for any anchor set"
                if not any(levels) and not state.anchor_sets
                else "every real candidate point would create a self-stress, leave a node unpinned "
                "or nearly coincide with an existing node"
            )
            raise DomainError(
                "no_solution",
                f"no real placement removes the remaining {state.n_d - state.target} degrees of "
                f"freedom: {why}.",
            )
        (_, i, chosen), pool = best
        state.add(pool.positions[i], pool.motions[i], chosen)
        pool.remove(i)
        report_progress(
            1 - (state.n_d - state.target) / to_remove,
            f"placed {len(state.anchor_sets)} unspecified nodes",
        )
    return state


def candidate_levels(
    x_n: np.ndarray,
    largest_subset: int,
    rng: np.random.Generator,
    pool: Callable[[tuple[int, ...]], CandidatePool | None],
) -> Iterator[list[CandidatePool]]:
    """Levels of candidate pools for the lazy greedy placement (place_nodes).

    The whole specified set first, then anchor sets of sizes ``largest_subset`` … d + 1 (a
    smaller set has a larger solution space), then, for large targets (C(k, d+1) > 64),
    seeded coupling modules in batches of 16: a batch is built only if the ones before it
    could not remove a degree of freedom. ``pool(subset)`` builds one anchor set's candidates
    (None when its solution space has no real point). x_n: normalised x_S (k, d).
    """
    k, d = x_n.shape
    sizes = range(min(k - 1, largest_subset), d, -1)
    for size in [k, *sizes]:
        pools = [pool(subset) for subset in anchor_subsets(x_n, size)]
        yield [p for p in pools if p is not None]
    if comb(k, d + 1) > 64:
        subsets = coupling_subsets(k, sizes, rng, 2 * k)
        for start in range(0, len(subsets), 16):
            pools = [pool(subset) for subset in subsets[start : start + 16]]
            yield [p for p in pools if p is not None]

