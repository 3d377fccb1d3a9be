"""Allostery inside a given spring network, elastic response model: the fewest bar changes that
make the network's linear response give exactly the requested strain ratio (pruning's contract,
Rocks et al., PNAS 114, 2520 (2017), ended exact).

Model. The bars are springs of stiffness k_b (1 unless stated): K = Qᵀ diag(k) Q, Q = diag(1/ℓ) C
(analysis/bond_green.py). The source pair's strain ε_S is imposed and the network relaxes to the
least elastic energy, min ½ uᵀKu subject to q_Sᵀu = ε_S ℓ_S, so u ∝ K⁺ q_S and

    η = ε_T / ε_S = ρ G_TS / G_SS,   ρ = ℓ_S / ℓ_T,   G_pq = q_pᵀ K⁺ q_q,

with ε_p = (x_i − x_j)·(u_i − u_j)/|x_i − x_j|² — the definition of benchmarks/pruning.py. The
answer holds for the stated stiffnesses (unlike network_allostery's mechanism, which holds
whatever they are), so the report states dη/dk of the tuned bar: how precisely it must be made.

Edit. Changing bar b's stiffness by δ is K + δ q_b q_bᵀ, and by Sherman–Morrison (bond_green, SM)

    η_b(δ) = ρ (G_TS + δ a_b) / (G_SS + δ c_b),  a_b = G_TS G_bb − G_Tb G_bS,  c_b = G_SS G_bb − G_bS²,

a ratio of affine functions of δ, without a pole while k_b + δ ≥ 0 (G_SS + δ c_b = (1 + δ G_bb) G'_SS
> 0), so η_b(δ) = η* has the closed form δ = (r G_SS − G_TS)/(a_b − r c_b), r = η*/ρ, and

    dη/dk = ρ (a_b G_SS − c_b G_TS) / (G_SS + δ c_b)².

Before the first removal and after each, every bar's δ is solved; a bar lands when its new
stiffness k_b + δ lies in [0, k_max·k_b] (k = 0: removed) and the change passes ``_stiff_enough``:
1 + δ G_bb > FLOPPY_RTOL (no new zero mode, pruning's guard) and the Rayleigh bound on the softest
mode after it, 2(1 + δ G_bb)/G_bb, not below the floor of the verification (a change that must
fail it is not tried). The first step with a landing bar ends the search: its bars
are tried least sensitive first (smallest k_b |dη/dk|, the change of η per error of the new
stiffness in units of the bar's given one — a bar's thickness is made to an absolute tolerance,
whatever thickness is asked) and the first that passes ``verify`` is the
answer — fewest changes: the removals so far plus one changed stiffness. Otherwise the bar whose
removal brings η nearest η* goes (pruning's ranking: the same δ = −k_b formula over the bars whose
removal passes ``_stiff_enough``), until no removal brings η nearer, which is a 422 with the best
verified figures found (``_best_figures``). One sparse factorisation serves the whole search (SpringNetwork: Woodbury
updates), the G_bb from the maintained redundancies D_b = 1 − k_b G_bb.

Verification, by another route than the search's: K assembled afresh from the positions and the
edited stiffnesses, the constrained problem solved by sparse LU of the bordered system
    [K  q_S  R; q_Sᵀ 0 0; Rᵀ 0 0] [u; λ; μ] = [0; ℓ_S; 0]     (R: the rigid motions, u ⟂ R),
η measured from u; the softest nontrivial eigenvalue of K (eigen.smallest_eigenpairs on R^⊥) must
stay above SOFTEST_MODE_RTOL of the given network's.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from functools import partial

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from zeromode.solver.analysis.bond_green import SpringNetwork, check_pair, pair_row
from zeromode.solver.analysis.eigen import smallest_eigenpairs
from zeromode.solver.analysis.normalisation import rms_radius
from zeromode.solver.analysis.rigidity import analyze, rigid_motions
from zeromode.solver.budget import check_budget
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.tolerances import FLOPPY_RTOL, SOFTEST_MODE_RTOL, TARGET_ERROR_MAX

# The tuned bar's stiffness may be set anywhere in [0, MAX_STIFFNESS·k_b]: ten times a bar's own
# stiffness is what one can make from the same material (thicker bar), 0 is a removal.
MAX_STIFFNESS = 10.0
# Landing bars verified at one step before the search moves on (least sensitive first).
MAX_VERIFIED = 4
# A verification slightly outside TARGET_ERROR_MAX (round-off of the search's Woodbury solves
# on a sensitive bar) is corrected by this many Newton steps on k, each verified afresh.
NEWTON_STEPS = 2


@dataclass(frozen=True, eq=False)
class ElasticAllostery:
    """Allostery in a given elastic network by editing its springs: the edited network and its
    figures.

    Attributes
    ----------
    frame : Frame
        The given positions with the kept bars (given order).
    stiffness : np.ndarray
        (N_B′,): the kept bars' stiffnesses, the tuned one changed.
    source_pair, target_pair : tuple of int
        The node pairs whose strains ε_S and ε_T are coupled.
    ratio : float
        η*, the strain ratio ε_T/ε_S asked for.
    initial_ratio : float
        η of the given network.
    strain_ratio : float
        η of the edited network, from the verification (bordered LU).
    ratio_error : float
        ``|η − η*| / max(1, |η*|)``.
    removed_edges : tuple of int
        Indices into the given edges, in removal order.
    tuned_edge : int or None
        The given edge whose stiffness changed (None when removals alone land).
    tuned_stiffness : tuple of float or None
        (given, new) stiffness of the tuned edge.
    sensitivity : float or None
        dη/dk of the tuned bar at its new stiffness (None without one).
    response : np.ndarray
        (N, d): the relaxed motion for ε_S = 1, ⟂ rigid motions.
    softest_mode : float
        λ_min of the edited stiffness matrix K over λ_min of the given one.
    max_stiffness : float
        The bound asked for: the tuned bar's new stiffness lies in [0, max_stiffness·k_b].
    timings_ms : dict
        Wall time of each step.
    """

    frame: Frame
    stiffness: np.ndarray
    source_pair: tuple[int, int]
    target_pair: tuple[int, int]
    ratio: float
    initial_ratio: float
    strain_ratio: float
    ratio_error: float
    removed_edges: tuple[int, ...]
    tuned_edge: int | None
    tuned_stiffness: tuple[float, float] | None
    sensitivity: float | None
    response: np.ndarray
    softest_mode: float
    max_stiffness: float
    timings_ms: dict

    @property
    def scaled_sensitivity(self) -> float | None:
        """k_b dη/dk of the tuned bar, k_b its given stiffness: η's change per error of the new
        stiffness in units of the given one."""
        return None if self.tuned_stiffness is None else self.tuned_stiffness[0] * self.sensitivity

    @property
    def changes(self) -> int:
        """Bars removed plus the one whose stiffness changed."""
        return len(self.removed_edges) + (self.tuned_edge is not None)


class RatioOutOfReach(DomainError):
    """No edit found reaches η*: ``best`` holds the nearest η found and the edit that gives it."""

    def __init__(self, message: str, best: dict):
        super().__init__("ratio_out_of_reach", message)
        self.best = best


@dataclass(frozen=True)
class Verified:
    """The independent route's figures: η, the relaxed motion u (N, d) for ε_S = 1 (⟂ rigid
    motions), the bordered system's relative residual."""

    strain_ratio: float
    response: np.ndarray
    residual: float


def stiffness_matrix(positions: np.ndarray, edges: np.ndarray, stiffness: np.ndarray) -> sp.csc_matrix:
    """K (dN × dN) = Σ_b k_b (e_i − e_j)(e_i − e_j)ᵀ ⊗ n_b n_bᵀ, n_b the unit vector of bar b,
    assembled from the node blocks (not through Q)."""
    n, d = positions.shape
    i, j = edges[:, 0], edges[:, 1]
    unit = positions[i] - positions[j]
    unit /= np.linalg.norm(unit, axis=1, keepdims=True)
    block = stiffness[:, None, None] * unit[:, :, None] * unit[:, None, :]  # (N_B, d, d)
    a, b = np.meshgrid(np.arange(d), np.arange(d), indexing="ij")
    rows, cols, vals = [], [], []
    for p, q, sign in ((i, i, 1.0), (j, j, 1.0), (i, j, -1.0), (j, i, -1.0)):
        rows.append((d * p[:, None, None] + a).ravel())
        cols.append((d * q[:, None, None] + b).ravel())
        vals.append(sign * block.ravel())
    return sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(d * n, d * n))


def verify(positions, edges, stiffness, source_pair, target_pair) -> Verified:
    """η of the network (positions (N, d) centred, edges (N_B, 2), stiffness (N_B,)) by the
    bordered system of the module docstring, solved by sparse LU."""
    n, d = positions.shape
    rows = []
    for i, j in (source_pair, target_pair):
        e = positions[i] - positions[j]
        q = np.zeros((n, d))
        q[i], q[j] = e / np.linalg.norm(e), -e / np.linalg.norm(e)
        rows.append((q.ravel(), float(np.linalg.norm(e))))
    (q_s, l_s), (q_t, l_t) = rows
    border = sp.csc_matrix(np.column_stack([q_s, rigid_motions(positions)]))
    system = sp.bmat([[stiffness_matrix(positions, edges, stiffness), border], [border.T, None]], format="csc")
    rhs = np.zeros(system.shape[0])
    rhs[d * n] = l_s  # ε_S = 1
    try:
        solution = spla.splu(system).solve(rhs)
    except RuntimeError:  # exactly singular: a zero mode the source strain does not fix
        return Verified(float("nan"), np.zeros((n, d)), float("inf"))
    u = solution[: d * n]
    residual = float(np.linalg.norm(system @ solution - rhs) / np.linalg.norm(rhs))
    return Verified(float((q_t @ u / l_t) / (q_s @ u / l_s)), u.reshape(n, d), residual)


def softest_mode(positions, edges, stiffness) -> float:
    """λ_min of K compressed to the complement of the rigid motions (Lanczos, eigen.py)."""
    k = stiffness_matrix(positions, edges, stiffness)
    values = smallest_eigenpairs(k, 1, deflate=rigid_motions(positions)).values
    return float(values[0]) if values.size else float("inf")  # no motion but rigid ones


def _stiffness(frame: Frame, stiffness) -> np.ndarray:
    if stiffness is None:
        return np.ones(frame.n_edges)
    k = np.asarray(stiffness, dtype=float)
    if k.shape != (frame.n_edges,) or not np.all(np.isfinite(k)) or np.any(k <= 0):
        raise InvalidInput(
            "invalid_stiffness", f"stiffness must be {frame.n_edges} finite positive numbers, one per bar."
        )
    return k


@dataclass(frozen=True)
class _Edit:
    """Bars removed (given edge indices, in order), then at most one bar ``edge`` set to
    ``stiffness`` (0: removed too), dη/dk there ``sensitivity``."""

    removed: tuple[int, ...]
    edge: int | None = None
    stiffness: float | None = None
    sensitivity: float | None = None

    def stiffnesses(self, given: np.ndarray) -> np.ndarray:
        k = given.copy()
        k[list(self.removed)] = 0.0
        if self.edge is not None:
            k[self.edge] = self.stiffness
        return k


@dataclass(frozen=True)
class _Problem:
    """What every check of an edit needs: the frame, its normalised positions, the given
    stiffnesses, the pairs, η*, the softest-mode floor, k_max and the given network's figures."""

    frame: Frame
    x: np.ndarray
    k: np.ndarray
    source: tuple[int, int]
    target: tuple[int, int]
    ratio: float
    floor: float
    max_stiffness: float
    given: Verified
    given_softest: float

    def check(self, edit: _Edit) -> tuple[Verified, np.ndarray]:
        k = edit.stiffnesses(self.k)
        keep = k > 0
        return verify(self.x, self.frame.edges[keep], k[keep], self.source, self.target), k

    def error(self, eta: float) -> float:
        return abs(eta - self.ratio) / max(1.0, abs(self.ratio))


def tune_elastic(
    frame: Frame,
    source_pair,
    target_pair,
    strain_ratio: float,
    stiffness=None,
    max_stiffness: float = MAX_STIFFNESS,
) -> ElasticAllostery:
    """The fewest changes (removals, then one stiffness) giving η = ``strain_ratio`` exactly.

    frame: a rigid frame (no nontrivial zero mode); source_pair, target_pair: node pairs;
    stiffness (N_B,) positive, default ones; max_stiffness: the tuned bar's new stiffness lies in
    [0, max_stiffness·k_b]. See the module docstring for the search and the verification.
    Raises InvalidInput (invalid_pair, invalid_stiffness, invalid_target), DomainError
    floppy_network (the frame has a nontrivial zero mode), RatioOutOfReach (ratio_out_of_reach).
    """
    started = time.perf_counter()
    s_pair = check_pair(frame, source_pair, "source_pair")
    t_pair = check_pair(frame, target_pair, "target_pair")
    if not np.isfinite(strain_ratio):
        raise InvalidInput("invalid_target", "strain_ratio must be finite.")
    if not (np.isfinite(max_stiffness) and max_stiffness >= 1.0):
        raise InvalidInput("invalid_target", "max_stiffness must be finite and at least 1 (the bar's own stiffness).")
    k_given = _stiffness(frame, stiffness)
    if analyze(frame, method="sparse", bases=False).nontrivial_zero_modes:
        raise DomainError(
            "floppy_network", "the frame has nontrivial zero modes, so its elastic response is not unique."
        )
    x = frame.normalised_positions()  # η is scale-free; this keeps K well scaled
    edges = frame.edges
    lowest = softest_mode(x, edges, k_given)
    problem = _Problem(
        frame, x, k_given, s_pair, t_pair, float(strain_ratio), SOFTEST_MODE_RTOL * lowest, float(max_stiffness),
        verify(x, edges, k_given, s_pair, t_pair), lowest,
    )
    net = SpringNetwork(x, edges, k_given)
    q, k = net.q, net.k
    q_s, l_s = pair_row(x, s_pair)
    q_t, l_t = pair_row(x, t_pair)
    rho, target = l_s / l_t, problem.ratio
    r = target / rho

    removed: list[int] = []
    near: list[tuple[float, _Edit]] = []  # edits met, with |η − η*| from the search
    while True:
        check_budget()
        u_s, u_t = net.solve(q_s), net.solve(q_t)
        g_s, g_t = q @ u_s, q @ u_t  # G_bS, G_bT for every bar
        g_ss, g_ts = float(q_s @ u_s), float(q_t @ u_s)
        eta = rho * g_ts / g_ss
        near.append((abs(eta - target), _Edit(tuple(removed))))
        if problem.error(eta) <= TARGET_ERROR_MAX and (answer := _verified(problem, near[-1][1])):
            return _done(answer, started)
        g_bb = (1.0 - net.redundancy) / k
        a = g_ts * g_bb - g_t * g_s
        c = g_ss * g_bb - g_s**2

        stiff_enough = partial(_stiff_enough, net.alive, g_bb, problem.floor)
        with np.errstate(divide="ignore", invalid="ignore"):
            delta = (r * g_ss - g_ts) / (a - r * c)
            new_k = k + delta
            lands = stiff_enough(delta) & np.isfinite(delta) & (new_k >= 0) & (new_k <= max_stiffness * k)
            slope = rho * (a * g_ss - c * g_ts) / (g_ss + delta * c) ** 2  # dη/dk at k + δ
        bars = np.flatnonzero(lands)
        for b in bars[np.argsort(np.abs(k[bars] * slope[bars]))][:MAX_VERIFIED]:
            edit = _Edit(tuple(removed), int(b), float(new_k[b]), float(slope[b]))
            if answer := _verified(problem, edit):
                return _done(answer, started)
        for new in (np.zeros_like(k), max_stiffness * k):  # η_b is monotone in k_b: its nearest is an end
            with np.errstate(divide="ignore", invalid="ignore"):
                eta_b = np.where(stiff_enough(new - k), rho * (g_ts + (new - k) * a) / (g_ss + (new - k) * c), np.nan)
            if not np.all(np.isnan(eta_b)):
                b = int(np.nanargmin(np.abs(eta_b - target)))
                near.append((abs(eta_b[b] - target), _Edit(tuple(removed), b, float(new[b]))))
        candidates = np.flatnonzero(stiff_enough(-k))
        if candidates.size == 0:
            break
        eta_b = rho * (g_ts - k[candidates] * a[candidates]) / (g_ss - k[candidates] * c[candidates])
        score = np.abs(eta_b - target)
        if not score.min() < abs(eta - target):
            break
        bar = int(candidates[np.argmin(score)])
        if net.remove(bar):
            removed.append(bar)
    best = _best_figures(problem, near)
    raise RatioOutOfReach(
        f"no removal of bars that keeps the network stiff, followed by one stiffness in [0, {max_stiffness:g}·k], "
        f"reaches η = {target:g}; the nearest found is η = {best['strain_ratio']:.6g}.",
        {**best, "ratio": target, "initial_ratio": problem.given.strain_ratio,
         "timings_ms": {"total": 1e3 * (time.perf_counter() - started)}},
    )


def _stiff_enough(alive: np.ndarray, g_bb: np.ndarray, floor: float, delta: np.ndarray) -> np.ndarray:
    """Bars (N_B,) whose stiffness may change by ``delta``: 1 + δ G_bb, the share of a force
    dipole on b's ends the network carries after the change, stays above FLOPPY_RTOL, and the
    softest mode, at most 2(1 + δ G_bb)/G_bb after it (Rayleigh quotient of K⁺q_b, ‖q_b‖² = 2),
    can stay above ``floor``."""
    share = 1.0 + delta * g_bb
    return alive & (share > FLOPPY_RTOL) & (2.0 * share >= floor * g_bb)


def _verified(problem: _Problem, edit: _Edit) -> ElasticAllostery | None:
    """``edit`` as an ElasticAllostery if the independent route confirms η* to TARGET_ERROR_MAX
    and the softest mode stays above the floor, else None. A near miss is corrected by Newton
    steps on the tuned stiffness (dη/dk from the search), each verified afresh."""
    for step in range(NEWTON_STEPS + 1):
        check, k = problem.check(edit)
        error = problem.error(check.strain_ratio)
        if not check.residual <= TARGET_ERROR_MAX:
            return None
        if error <= TARGET_ERROR_MAX:
            break
        if edit.edge is None or step == NEWTON_STEPS or not edit.sensitivity:
            return None
        corrected = edit.stiffness - (check.strain_ratio - problem.ratio) / edit.sensitivity
        if not 0.0 <= corrected <= problem.max_stiffness * problem.k[edit.edge]:
            return None
        edit = replace(edit, stiffness=corrected)
    keep = k > 0
    lowest = softest_mode(problem.x, problem.frame.edges[keep], k[keep])
    if not lowest >= problem.floor:
        return None
    tuned = edit.edge is not None and edit.stiffness > 0
    frame = problem.frame
    return ElasticAllostery(
        frame=Frame.build(frame.positions, frame.edges[keep], frame.specified, frame.dim),
        stiffness=k[keep],
        source_pair=problem.source,
        target_pair=problem.target,
        ratio=problem.ratio,
        initial_ratio=problem.given.strain_ratio,
        strain_ratio=check.strain_ratio,
        ratio_error=float(error),
        removed_edges=edit.removed + ((edit.edge,) if edit.edge is not None and not tuned else ()),
        tuned_edge=edit.edge if tuned else None,
        tuned_stiffness=(float(problem.k[edit.edge]), float(edit.stiffness)) if tuned else None,
        sensitivity=edit.sensitivity if tuned else None,
        response=check.response * rms_radius(frame.positions),  # u scales with the positions
        softest_mode=lowest / problem.given_softest,
        max_stiffness=problem.max_stiffness,
        timings_ms={},
    )


def _best_figures(problem: _Problem, near: list[tuple[float, _Edit]]) -> dict:
    """The nearest to η* of the edits met whose network stays stiff, verified as an answer is.

    Removals only soften (K' ≼ K), so along the greedy path the softest mode falls: the last
    path state above the floor is found by bisection, and the edits met up to it are verified
    nearest first (η afresh, the softest mode), at most 2·MAX_VERIFIED; that state otherwise.
    """
    def stiff(edit: _Edit) -> bool:
        k = edit.stiffnesses(problem.k)
        return softest_mode(problem.x, problem.frame.edges[k > 0], k[k > 0]) >= problem.floor

    path = [edit for _, edit in near if edit.edge is None]  # the states after 0, 1, 2, … removals
    lo, hi = 0, len(path) - 1  # path[0] is the given network, above the floor
    while lo < hi:
        mid = (lo + hi + 1) // 2
        lo, hi = (mid, hi) if stiff(path[mid]) else (lo, mid - 1)
    last = len(path[lo].removed)
    edit, check = path[lo], problem.check(path[lo])[0]
    met = sorted((item for item in near if len(item[1].removed) <= last), key=lambda item: item[0])
    for _, candidate in met[: 2 * MAX_VERIFIED]:
        verified = problem.check(candidate)[0]
        if candidate is path[lo] or (verified.residual <= TARGET_ERROR_MAX and stiff(candidate)):
            edit, check = candidate, verified
            break
    removal = edit.edge is not None and edit.stiffness == 0
    return {
        "strain_ratio": check.strain_ratio,
        "ratio_error": problem.error(check.strain_ratio),
        "removed_edges": list(edit.removed) + ([edit.edge] if removal else []),
        "tuned_edge": None if edit.edge is None or removal else edit.edge,
        "tuned_stiffness": None if edit.edge is None or removal else [float(problem.k[edit.edge]), float(edit.stiffness)],
    }


def _done(answer: ElasticAllostery, started: float) -> ElasticAllostery:
    return replace(answer, timings_ms={"total": 1e3 * (time.perf_counter() - started)})
