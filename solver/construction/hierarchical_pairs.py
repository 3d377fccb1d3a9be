"""Several motions beyond the bipartite construction: hierarchical pairs of unspecified nodes
(paper, Discussion: "hierarchical judicious constraining of networks along the solution spaces
in bipartite networks of specified *and* unspecified nodes").

The bound of the bipartite construction. An unspecified node joined by a bars to nodes whose M
motions are fixed must satisfy a·M bilinear equations (x_a − x_U)·(u_a^(i) − u_U^(i)) = 0 in
its d(M + 1) unknowns (x_U and one motion per mode). It removes a degree of freedom only with
a ≥ d + 1 bars, so in general it exists only when (d + 1)·M ≤ d·(M + 1), i.e. M ≤ d. Joining it
to earlier unspecified nodes changes nothing as long as their motions are already fixed: past
M = d motions (2D: M = 3, 4; 3D: M = 4) no single node can be placed.

Groups. First h helper nodes U_j, each with exactly d bars to specified nodes: at any position
x_Uj its motions u_Uj^(i) follow from a d × d solve, so a helper keeps its d coordinates free
(and removes no degree of freedom). Then a node V with d + 1 bars, to d + 1 − h specified nodes
and to the helpers: for each motion the d + 1 equations in the d unknowns u_V^(i) are
consistent iff
    f_i(x_U, x_V) = nᵀ r_i = 0,   n the cofactor (left null) vector of the (d + 1) × d matrix
    G = [x_a − x_V]_a,  r_{i,a} = (x_a − x_V)·u_a^(i)  (a over V's anchors, U included;
    divided by the product of the bar lengths, which removes the trivial roots x_V = x_a),
— M equations in the (h + 1)d unknowns (x_U1 … x_Uh, x_V). One helper (a pair) already makes
them solvable in general iff M ≤ 2d (2D: M ≤ 4, 3D: M ≤ 6); at M = 2d its real solutions are
isolated and often far, so a second helper (a one-dimensional family) is tried when pairs fail.
A group adds (h + 1)d coordinates and hd + d + 1 bars: one degree of freedom less. Groups are
found by Gauss–Newton (minimum-norm steps) from seeded starts and placed until
N_D = d(d+1)/2 + M, each kept only if its bars raise rank C by hd + d + 1, the best conditioned
of GROUP_TRIES tries. The starts of a round, and of the rounds after it (LOOKAHEAD_ROUNDS),
are solved together: the consistency equations involve the specified nodes only, so one batched
Gauss–Newton serves them all, and the placed nodes enter only the checks of each round. The
helpers' free positions are what let V's over-determined system close.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from zeromode.solver.analysis.rank import RTOL
from zeromode.solver.budget import check_budget
from zeromode.solver.construction.placement import (
    MAX_RADIUS,
    PREFERRED_SEPARATION,
    Placement,
    target_zero_modes,
)
from zeromode.solver.errors import DomainError
from zeromode.solver.progress import report_progress
from zeromode.solver.tolerances import (
    CONSTRAINT_ATOL,
    PAIR_JACOBIAN_STEP,
    PAIR_NEWTON_ATOL,
    PLACEMENT_RTOL,
)

# Seeded starts per group; the best conditioned solution among them is placed.
GROUP_TRIES = 24
# Helpers per group: one (a pair) first, two when no pair is found.
HELPERS = (1, 2)
# Gauss–Newton steps per pair (solved at PAIR_NEWTON_ATOL).
NEWTON_STEPS = 40
# Rounds whose pair tries are drawn and solved in one batch (no more than the rounds left: each
# group removes exactly one degree of freedom); the tries are the seeded ones of those rounds, so
# only the fixed cost of each batched step is shared (5 300 batched steps for the 182 rounds of a
# 3D k = 64, M = 4 design, 0.35 ms each, one round at a time).
LOOKAHEAD_ROUNDS = 8
# Minimum-norm steps drop singular values of the Jacobian below this times max(M, (h + 1)d)
# times the largest: numpy's lstsq default (rcond=None), one batched pseudo-inverse for all starts.
LSTSQ_RTOL = float(np.finfo(float).eps)


def check_motion_count(d: int, m: int) -> None:
    """Refuse up front what no placement can build: ``too_many_motions`` past M = 2d."""
    if m > 2 * d:
        raise DomainError(
            "too_many_motions",
            f"{m} motions in {d}D cannot be designed: a node joined by d + 1 bars must satisfy "
            f"(d + 1)·M bar equations in d·(M + 1) unknowns, which leaves M − d equations for the "
            f"positions of the unspecified nodes it joins; a hierarchical pair has d of them, so "
            f"this construction reaches at most M = 2d = {2 * d} motions.",
        )


@dataclass(frozen=True, eq=False)
class _Group:
    """Helper positions (h, d) and motions (h, M, d) with their anchors (d specified nodes each);
    V's position (d,), motions (M, d) and specified anchors (the helpers are added after them);
    score: the smallest conditioning of the nodes' bar rows."""

    x_h: np.ndarray
    u_h: np.ndarray
    anchors_h: tuple[tuple[int, ...], ...]
    x_v: np.ndarray
    u_v: np.ndarray
    anchors_v: tuple[int, ...]
    score: float


def _helper_motions(x: np.ndarray, u: np.ndarray, anchors_h: np.ndarray, x_h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """u_U^(i) of every helper from its d bars, (x_b − x_U)·u_U = (x_b − x_U)·u_b^(i), for a batch
    of B groups: x (k, d), u (M, k, d), anchors_h (B, h, d), x_h (B, h, d) → motions (B, h, M, d)
    and whether every helper's d × d system is conditioned within 1/PLACEMENT_RTOL (B,)."""
    d = x.shape[1]
    g = x[anchors_h] - x_h[:, :, None, :]  # (B, h, d, d): row b is x_b − x_U
    with np.errstate(divide="ignore", invalid="ignore"):
        good = np.linalg.cond(g) <= 1 / PLACEMENT_RTOL  # (B, h); NaN (non-finite x_h) is not good
    g = np.where(good[:, :, None, None], g, np.eye(d))  # solvable stand-ins where not good
    rhs = np.einsum("bhad,mbhad->bham", g, u[:, anchors_h])  # (B, h, d, M): one column per motion
    return np.linalg.solve(g, rhs).transpose(0, 1, 3, 2), np.all(good, axis=1)


def _v_system(x, u, anchors_h, anchors_v, z):
    """At each of B points z (B, (h + 1)d) = (x_U1 … x_Uh, x_V): G = [x_a − x_V]_a (B, d + 1, d),
    the motions of V's anchors (B, M, d + 1, d; its specified anchors ``anchors_v`` (B, d + 1 − h)
    first, then the helpers, anchored at ``anchors_h`` (B, h, d)), the helpers' motions
    (B, h, M, d) and where the helpers' motions exist (B,)."""
    d = x.shape[1]
    h = anchors_h.shape[1]
    x_h, x_v = z[:, : h * d].reshape(len(z), h, d), z[:, h * d :]
    u_h, ok = _helper_motions(x, u, anchors_h, x_h)
    g = np.concatenate([x[anchors_v], x_h], axis=1) - x_v[:, None, :]
    motions = np.concatenate([u[:, anchors_v].transpose(1, 0, 2, 3), u_h.transpose(0, 2, 1, 3)], axis=2)
    return g, motions, u_h, ok


def _consistency(x, u, anchors_h, anchors_v, z) -> np.ndarray:
    """f(z) (B, M): V's d + 1 bars consistent for every motion (module docstring), at B points
    z (B, (h + 1)d) with their own anchors (_v_system); NaN rows where f does not exist."""
    d = x.shape[1]
    g, motions, _, ok = _v_system(x, u, anchors_h, anchors_v, z)
    r = np.einsum("bad,bmad->bma", g, motions)
    minors = np.stack([np.delete(g, a, axis=1) for a in range(d + 1)], axis=1)  # (B, d + 1, d, d)
    n = np.linalg.det(minors) * (-1.0) ** np.arange(d + 1)
    norm = np.linalg.norm(n, axis=1)
    # V on one of its anchors solves f = 0 trivially (a bar of zero length): dividing by the
    # product of the bar lengths (times their mean to the d-th power, to stay scale-free) moves
    # those roots away and leaves the others where they are.
    lengths = np.linalg.norm(g, axis=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.einsum("bma,ba->bm", r, n) / norm[:, None] * (lengths.mean(axis=1) ** d / np.prod(lengths, axis=1))[:, None]
    f[~ok | (norm == 0)] = np.nan
    return f


def _solve_groups(x, u, anchors_h, anchors_v, z) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Newton with minimum-norm steps on f(z) = 0 (M equations, (h + 1)d unknowns) from B
    starts z (B, (h + 1)d) at once, each with its anchors, the Jacobian by central differences:
    the last iterates (B, (h + 1)d) and which of them solve f = 0 to PAIR_NEWTON_ATOL (B,).  A start
    fails where f or its Jacobian does not exist or is not finite, or past MAX_RADIUS."""
    z = np.array(z, dtype=float)
    b, n = z.shape
    offsets = np.vstack([np.zeros(n), PAIR_JACOBIAN_STEP * np.eye(n), -PAIR_JACOBIAN_STEP * np.eye(n)])
    active, solved = np.ones(b, dtype=bool), np.zeros(b, dtype=bool)
    for _ in range(NEWTON_STEPS):
        idx = np.flatnonzero(active)
        if len(idx) == 0:
            break
        points = (z[idx, None, :] + offsets).reshape(-1, n)
        f_all = _consistency(
            x, u, np.repeat(anchors_h[idx], len(offsets), axis=0), np.repeat(anchors_v[idx], len(offsets), axis=0), points
        ).reshape(len(idx), len(offsets), -1)
        f = f_all[:, 0]
        jac = (f_all[:, 1 : n + 1] - f_all[:, n + 1 :]).transpose(0, 2, 1) / (2 * PAIR_JACOBIAN_STEP)  # (A, M, n)
        finite = np.all(np.isfinite(f), axis=1)
        done = finite & (np.linalg.norm(np.where(finite[:, None], f, 0.0), axis=1) <= PAIR_NEWTON_ATOL)
        solved[idx[done]] = True
        step = finite & ~done & np.all(np.isfinite(jac), axis=(1, 2))
        active[idx[~step]] = False
        moved = idx[step]
        z[moved] -= np.einsum("anm,am->an", np.linalg.pinv(jac[step], rtol=LSTSQ_RTOL * max(jac.shape[1:])), f[step])
        active[moved] = np.linalg.norm(z[moved], axis=1) <= MAX_RADIUS
    return z, solved


def _draw_tries(x: np.ndarray, k: int, helpers: int, rng: np.random.Generator):
    """GROUP_TRIES seeded tries: anchors_h (T, h, d), anchors_v (T, d + 1 − h) and starts
    (T, (h + 1)d), T ≤ GROUP_TRIES (a draw whose anchor sets repeat a node is dropped).

    V's bars add a constraint only on motions of the anchors' union that the rigid and designed
    motions leave free: the union must be as large as it can be, so the anchor sets are taken in
    turn from one permutation of the specified nodes (disjoint while they last); the start is
    the anchor sets' centres plus seeded noise."""
    d = x.shape[1]
    tries_h, tries_v, starts = [], [], []
    for _ in range(GROUP_TRIES):
        order = np.concatenate([rng.permutation(k) for _ in range(helpers + 1)])
        anchors_h = [sorted(order[j * d : (j + 1) * d].tolist()) for j in range(helpers)]
        anchors_v = sorted(order[helpers * d : helpers * d + d + 1 - helpers].tolist())
        if any(len(set(a)) < len(a) for a in (*anchors_h, anchors_v)):
            continue
        centres = [x[a].mean(0) for a in (*anchors_h, anchors_v)]
        tries_h.append(anchors_h)
        tries_v.append(anchors_v)
        starts.append(np.concatenate(centres) + rng.normal(0, 0.7, (helpers + 1) * d))
    return (
        np.asarray(tries_h, dtype=int).reshape(-1, helpers, d),
        np.asarray(tries_v, dtype=int).reshape(-1, d + 1 - helpers),
        np.asarray(starts, dtype=float).reshape(-1, (helpers + 1) * d),
    )


def _solved_rounds(x: np.ndarray, u: np.ndarray, k: int, helpers: int, rng: np.random.Generator, rounds: int):
    """The seeded tries of ``rounds`` rounds (_draw_tries, in turn) solved by one batched
    Gauss–Newton (_solve_groups): per round (anchors_h, anchors_v, z, solved)."""
    draws = [_draw_tries(x, k, helpers, rng) for _ in range(rounds)]
    anchors_h, anchors_v, starts = (np.concatenate(parts) for parts in zip(*draws))
    z, solved = _solve_groups(x, u, anchors_h, anchors_v, starts)
    ends = np.cumsum([len(draw[2]) for draw in draws])
    return [
        (anchors_h[lo:hi], anchors_v[lo:hi], z[lo:hi], solved[lo:hi]) for lo, hi in zip([0, *ends[:-1]], ends)
    ]


def _groups_at(state: Placement, k: int, anchors_h: np.ndarray, anchors_v: np.ndarray, z: np.ndarray) -> list[_Group | None]:
    """The group at each solution z (B, (h + 1)d) of f = 0 (anchors_h (B, h, d), anchors_v
    (B, d + 1 − h)), or None where one of its nodes comes closer than PREFERRED_SEPARATION to
    another node, where V's least-squares motions miss one of its bars by more than
    CONSTRAINT_ATOL, or where a node's bars, placed in turn, do not raise rank C by their
    number (helpers d, V d + 1; Placement.independent_conditioning)."""
    d, b = state.d, len(z)
    if b == 0:
        return []
    helpers = anchors_h.shape[1]
    x = np.asarray(state.positions)
    u = np.asarray(state.motions).transpose(1, 0, 2)  # (M, N, d)
    nodes = z.reshape(b, helpers + 1, d)
    apart = np.linalg.norm(nodes[:, :, None] - x, axis=3).min(axis=(1, 2))
    within = np.linalg.norm(nodes[:, :, None] - nodes[:, None], axis=3) + np.diag(np.full(helpers + 1, np.inf))
    apart = np.minimum(apart, within.min(axis=(1, 2)))
    g, motions, u_h, _ = _v_system(x[:k], u[:, :k], anchors_h, anchors_v, z)
    rhs = np.einsum("bad,bmad->bam", g, motions)  # (B, d + 1, M)
    u_v = (np.linalg.pinv(g, rtol=LSTSQ_RTOL * (d + 1)) @ rhs).transpose(0, 2, 1)  # (B, M, d)
    misfit = np.abs(np.einsum("bad,bmad->bma", g, motions - u_v[:, :, None])).max(axis=(1, 2))
    groups: list[_Group | None] = []
    for i in range(b):
        score = None
        if apart[i] >= PREFERRED_SEPARATION and misfit[i] <= CONSTRAINT_ATOL:
            h_anchors = tuple(tuple(int(a) for a in row) for row in anchors_h[i])
            v_anchors = tuple(int(a) for a in anchors_v[i])
            score = state.independent_conditioning(
                [*zip(nodes[i, :helpers], h_anchors), (nodes[i, helpers], [*v_anchors, *range(len(x), len(x) + helpers)])]
            )
        groups.append(None if score is None else _Group(nodes[i, :helpers], u_h[i], h_anchors, nodes[i, helpers], u_v[i], v_anchors, score))
    return groups


def place_groups(x_n: np.ndarray, u_n: np.ndarray, rng: np.random.Generator) -> Placement:
    """Hierarchical groups (module docstring) until N_D = d(d+1)/2 + M. x_n (k, d), u_n (M, k, d),
    normalised. Raises DomainError ``no_solution`` when no try of a round gives a group."""
    k, d = x_n.shape
    state = Placement(x_n, u_n, target_zero_modes(d, len(u_n)))
    to_remove = state.n_d - state.target
    ahead: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []  # solved pair tries of the next rounds
    while state.n_d > state.target:
        best = None
        # Progress within the round: each try moves on by a shrinking step, short of the round's
        # end (a group removes at least one more degree of freedom).
        done, tries = 1 - (state.n_d - state.target) / to_remove, 0
        for helpers in HELPERS:
            check_budget()
            if helpers != HELPERS[0]:
                anchors_h, anchors_v, z, solved = _solved_rounds(x_n, u_n, k, helpers, rng, 1)[0]
            else:
                if not ahead:
                    ahead.extend(_solved_rounds(x_n, u_n, k, helpers, rng, min(LOOKAHEAD_ROUNDS, state.n_d - state.target)))
                anchors_h, anchors_v, z, solved = ahead.pop(0)
            check_budget()
            for group in _groups_at(state, k, anchors_h[solved], anchors_v[solved], z[solved]):
                if group is not None and (best is None or group.score > best.score):
                    best = group
            tries += len(z)
            report_progress(done + (1 - 1 / (tries + 1)) / to_remove, "tried groups of unspecified nodes")
            if best is not None:
                break
        if best is None or best.score <= RTOL:
            raise DomainError(
                "no_solution",
                f"no hierarchical group of unspecified nodes removes the remaining "
                f"{state.n_d - state.target} degrees of freedom ({GROUP_TRIES} seeded tries for each "
                f"of {len(HELPERS)} group sizes).",
            )
        first = len(state.positions)
        for p, m, a in zip(best.x_h, best.u_h, best.anchors_h):
            state.add(p, m, list(a))
        state.add(best.x_v, best.u_v, [*best.anchors_v, *range(first, len(state.positions))])
        report_progress(1 - (state.n_d - state.target) / to_remove, f"placed {len(state.positions) - k} nodes")
    return state
