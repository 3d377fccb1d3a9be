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
of GROUP_TRIES tries. The helpers' free positions are what let V's over-determined system close.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np

from zeromode.solver.budget import check_budget
from zeromode.solver.errors import DomainError
from zeromode.solver.placement import MAX_RADIUS, PREFERRED_SEPARATION, Placement, target_zero_modes
from zeromode.solver.progress import report_progress
from zeromode.solver.rank import RTOL
from zeromode.solver.tolerances import CONSTRAINT_ATOL, PLACEMENT_RTOL

# Seeded starts per group; the best conditioned solution among them is placed.
GROUP_TRIES = 24
# Helpers per group: one (a pair) first, two when no pair is found.
HELPERS = (1, 2)
# Gauss–Newton: steps, and the residual (normalised units) at which a pair is solved.
NEWTON_STEPS = 40
NEWTON_ATOL = 1e-13
# Finite-difference step of the Jacobian (normalised units, 2d ≤ 6 unknowns).
JACOBIAN_STEP = 1e-7


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


def _motions_of_helper(x: np.ndarray, u: np.ndarray, anchors, x_u: np.ndarray) -> np.ndarray | None:
    """u_U^(i) (M, d) from the d bars to ``anchors``: (x_b − x_U)·u_U = (x_b − x_U)·u_b^(i)."""
    g = x[list(anchors)] - x_u  # (d, d)
    if np.linalg.cond(g) > 1 / PLACEMENT_RTOL:
        return None
    rhs = np.einsum("bd,mbd->mb", g, u[:, list(anchors)])  # (M, d)
    return np.linalg.solve(g, rhs.T).T


def _v_system(x, u, anchors_h, anchors_v, z):
    """(G, motions of V's anchors (M, d + 1, d), helper motions (h, M, d)) at z, or None."""
    d = x.shape[1]
    h = len(anchors_h)
    x_h, x_v = z[: h * d].reshape(h, d), z[h * d :]
    u_h = [_motions_of_helper(x, u, a, p) for a, p in zip(anchors_h, x_h)]
    if any(m is None for m in u_h):
        return None
    g = np.vstack([x[list(anchors_v)], x_h]) - x_v  # (d + 1, d)
    motions = np.concatenate([u[:, list(anchors_v)], np.stack(u_h, axis=1)], axis=1)
    return g, motions, np.stack(u_h)


def _consistency(x, u, anchors_h, anchors_v, z) -> np.ndarray | None:
    """f(z) (M,): V's d + 1 bars consistent for every motion (module docstring)."""
    d = x.shape[1]
    system = _v_system(x, u, anchors_h, anchors_v, z)
    if system is None:
        return None
    g, motions, _ = system
    r = np.einsum("ad,mad->ma", g, motions)
    n = np.array([(-1) ** a * np.linalg.det(np.delete(g, a, axis=0)) for a in range(d + 1)])
    norm = np.linalg.norm(n)
    if norm == 0:
        return None
    # V on one of its anchors solves f = 0 trivially (a bar of zero length): dividing by the
    # product of the bar lengths (times their mean to the d-th power, to stay scale-free) moves
    # those roots away and leaves the others where they are.
    lengths = np.linalg.norm(g, axis=1)
    return (r @ n) / norm * lengths.mean() ** d / np.prod(lengths)


def _solve_group(x, u, anchors_h, anchors_v, z) -> np.ndarray | None:
    """Gauss–Newton with minimum-norm steps on f(z) = 0 (M equations, (h + 1)d unknowns)."""
    for _ in range(NEWTON_STEPS):
        f = _consistency(x, u, anchors_h, anchors_v, z)
        if f is None or not np.all(np.isfinite(f)):
            return None
        if np.linalg.norm(f) <= NEWTON_ATOL:
            return z
        jac = np.empty((len(f), len(z)))
        for j in range(len(z)):
            step = np.zeros(len(z))
            step[j] = JACOBIAN_STEP
            plus = _consistency(x, u, anchors_h, anchors_v, z + step)
            minus = _consistency(x, u, anchors_h, anchors_v, z - step)
            if plus is None or minus is None:
                return None
            jac[:, j] = (plus - minus) / (2 * JACOBIAN_STEP)
        z = z - np.linalg.lstsq(jac, f, rcond=None)[0]
        if np.linalg.norm(z) > MAX_RADIUS:
            return None
    return None


def _gain(state: Placement, position: np.ndarray, anchors) -> tuple[int, float]:
    """(rank the node's bars add, their smallest singular value over the largest): the rows of
    its bars on [N_old, its own coordinates], unit rows, as in Placement.best_in."""
    s = np.linalg.svd(state.bar_rows(position, anchors), compute_uv=False)
    return int(np.count_nonzero(s > PLACEMENT_RTOL * s[0])), float(s[-1] / s[0])


def _try_group(state: Placement, k: int, helpers: int, rng: np.random.Generator) -> _Group | None:
    """One seeded attempt: anchors, a start, Gauss–Newton, the bar checks and the rank gains."""
    d = state.d
    x = np.asarray(state.positions)
    u = np.asarray(state.motions).transpose(1, 0, 2)  # (M, N, d)
    # V's bars add a constraint only on motions of the anchors' union that the rigid and designed
    # motions leave free: the union must be as large as it can be, so the anchor sets are taken
    # in turn from one permutation of the specified nodes (disjoint while they last).
    order = np.concatenate([rng.permutation(k) for _ in range(helpers + 1)])
    anchors_h = tuple(tuple(sorted(order[j * d : (j + 1) * d].tolist())) for j in range(helpers))
    anchors_v = tuple(sorted(order[helpers * d : helpers * d + d + 1 - helpers].tolist()))
    if any(len(set(a)) < len(a) for a in (*anchors_h, anchors_v)):
        return None
    centres = [x[list(a)].mean(0) for a in (*anchors_h, anchors_v)]
    start = np.concatenate(centres) + rng.normal(0, 0.7, (helpers + 1) * d)
    z = _solve_group(x[:k], u[:, :k], anchors_h, anchors_v, start)
    if z is None:
        return None
    x_h, x_v = z[: helpers * d].reshape(helpers, d), z[helpers * d :]
    points = np.vstack([x, x_h])
    for i, p in enumerate([*x_h, x_v]):
        others = np.delete(np.vstack([points, x_v]), len(x) + i, axis=0)
        if np.min(np.linalg.norm(others - p, axis=1)) < PREFERRED_SEPARATION:
            return None
    g, motions, u_h = _v_system(x[:k], u[:, :k], anchors_h, anchors_v, z)
    rhs = np.einsum("ad,mad->ma", g, motions)
    u_v = np.linalg.lstsq(g, rhs.T, rcond=None)[0].T  # (M, d)
    if not np.abs(np.einsum("ad,mad->ma", g, motions - u_v[:, None])).max() <= CONSTRAINT_ATOL:
        return None
    trial = copy.deepcopy(state)
    score = np.inf
    for p, m, a in zip(x_h, u_h, anchors_h):
        gain, cond = _gain(trial, p, a)
        if gain != d:
            return None
        trial.add(p, m, list(a))
        score = min(score, cond)
    gain, cond = _gain(trial, x_v, [*anchors_v, *range(len(x), len(x) + helpers)])
    if gain != d + 1:
        return None
    return _Group(x_h, u_h, anchors_h, x_v, u_v, anchors_v, min(score, cond))


def place_groups(x_n: np.ndarray, u_n: np.ndarray, rng: np.random.Generator) -> Placement:
    """Hierarchical groups (module docstring) until N_D = d(d+1)/2 + M. x_n (k, d), u_n (M, k, d),
    normalised. Raises DomainError ``no_solution`` when no try of a round gives a group."""
    k, d = x_n.shape
    state = Placement(x_n, u_n, target_zero_modes(d, len(u_n)))
    to_remove = state.n_d - state.target
    while state.n_d > state.target:
        best = None
        # Progress within the round: each try moves on by a shrinking step, short of the round's
        # end (a group removes at least one more degree of freedom).
        done, tries = 1 - (state.n_d - state.target) / to_remove, 0
        for helpers in HELPERS:
            for _ in range(GROUP_TRIES):
                check_budget()
                group = _try_group(state, k, helpers, rng)
                tries += 1
                report_progress(done + (1 - 1 / (tries + 1)) / to_remove, "tried a group of unspecified nodes")
                if group is not None and (best is None or group.score > best.score):
                    best = group
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
