"""Finite motion of a frame along a zero mode, and the finite-motion fidelity ε(a).

The quadric construction of the paper is exact to linear order only: a nontrivial zero mode
u ∈ N(C) is an infinitesimal motion (Supplementary, "Edge Constraint Satisfaction": u ∈ N(C)
is necessary but not sufficient for a finite deformation).  This module follows the actual,
nonlinear motion and measures how far the specified nodes drift from the user's target.

Finite motion (pseudo-arclength predictor–corrector continuation).
    The configurations reachable from the reference x keep every bar length,
        g_e(X) = ½(|X_i − X_j|² − l_e²) = 0   for every bar e = (i, j),
    whose Jacobian is the compatibility matrix C(X) (paper Eq. 3).  All work is done on the
    normalised configuration (centred, divided by the RMS radius r), so steps, tolerances and
    rank decisions are scale-free.  At an accepted point X_k with tangent t_k (unit, dN):
      * nontrivial zero modes M_k = N(C(X_k)) ⊖ rigid motions (rank decided by rank.RTOL);
        t_k = the projection of t_{k−1} (at the start: of the requested mode) onto span M_k;
        B_k = an orthonormal basis of the rest of N(C(X_k)): the rigid motions and, if there
        are several nontrivial modes, the ones ⟂ t_k.
      * predictor P = X_k + h·√N·t_k (h in units of RMS node displacement / r);
      * corrector: Newton (Gauss–Newton when the frame has self-stresses) on
            g(Y) = 0,  t_kᵀ(Y − P) = 0,  B_kᵀ(Y − P) = 0,
        i.e. the rigid-motion gauge and the other mode directions are fixed out per step.
      * the step is accepted if Newton converges fast and t turns by less than MAX_TURN;
        h grows after easy steps, halves after hard ones, up to ``max_step``.
    The path parameter τ is the accumulated pseudo-arclength in units of RMS node displacement
    over the frame's RMS radius: to first order X(τ) = x + τ·r·û with û the mode scaled to unit
    RMS node displacement.

Singular points.
    Where the configuration space is not a smooth curve (a branch point, or a point where the
    frame locks), C(X) loses rank: extra zero modes appear.  Along each step the determinant of
    the square corrector Jacobian
        J(Y) = [C_R(Y); t_kᵀ; B_kᵀ]      (C_R: rank C(X_k) independent rows of C, pivoted QR)
    is continuous and nonzero away from such points and changes sign through a simple one
    (Allgower & Georg, "Numerical Continuation Methods", §8.1).  A sign change is located by
    bisection on the step length, and confirmed by counting the zero modes of C there with the
    relative threshold SINGULAR_RTOL (a branch point is located to about √ε ≈ 1e-8).
    A confirmed point ends the path in that direction and is reported; it is never stepped over.
    A step that cannot be completed even at MIN_STEP is reported as a "stalled" singularity.

Finite-motion fidelity (the definition used by /v1/motion, /v1/refine and /v1/design).
    For a target displacement a·u_S of the specified nodes S,
        ε(a) = min over path points X(τ) and proper rigid motions R of
               ‖R·X_S(τ) − (x_S + a·u_S)‖ / ‖a·u_S‖            (Frobenius norms, k×d)
    with the inner minimum by Kabsch alignment (rotation + translation, det R = +1) and the
    outer one over the path samples, polished between the neighbours of the best sample on
    the constraint manifold itself (the corrector), so no interpolation error enters ε.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from scipy.optimize import minimize_scalar

from zeromode.solver.budget import check_budget
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame, check_positions
from zeromode.solver.normalisation import Normalisation
from zeromode.solver.rank import RTOL, complement_within, decide_rank
from zeromode.solver.rigidity import rigid_motions
from zeromode.solver.tolerances import GIVEN_MODE_RTOL

# Continuation runs on a dense C (full SVD per step); at 600 degrees of freedom a step costs
# about 0.1 s, beyond that a path would not fit in a request's time budget.
MAX_DOF = 600
# Newton stops when every bar is within this relative length error (the API promises ≤ 1e-9).
NEWTON_RTOL = 1e-12
NEWTON_MAX_ITER = 12
# A step is accepted only if the tangent turns by less than this (radians) ...
MAX_TURN = 0.15
# ... and it is halved down to this before the continuation gives up ("stalled").
MIN_STEP = 1e-9
# Zero modes at a located singular point are counted with this relative threshold: a branch
# point can be located only to about √(machine ε) ≈ 1e-8, and σ vanishes linearly there.
SINGULAR_RTOL = 1e-6
BISECTION_STEPS = 60


@dataclass(frozen=True)
class Singularity:
    """A point of the path where C loses rank: ``extra_zero_modes`` more zero modes than at the
    start of the step.  ``step`` indexes ``MotionPath.positions``; ``sigma`` is σ/σ_max of the
    singular value that vanished (evidence of the decision); ``kind`` is "rank_drop" (located
    and confirmed) or "stalled" (the corrector failed at MIN_STEP)."""

    step: int
    parameter: float
    extra_zero_modes: int
    sigma: float
    kind: str


@dataclass(frozen=True, eq=False)
class MotionPath:
    """A traced finite motion.

    positions: (P, N, d) configurations in the frame's coordinates, ordered by ``parameter``
    (P,), strictly increasing, 0 at the reference configuration (index ``reference_index``).
    """

    positions: np.ndarray
    parameter: np.ndarray
    reference_index: int
    max_relative_bar_error: float
    singularities: tuple[Singularity, ...]
    edges: np.ndarray

    @property
    def status(self) -> str:
        return "singular_path" if self.singularities else "ok"


class SingularPath(DomainError):
    """The continuation met a singular point before the requested amplitude; ``best`` is the
    path traced up to it (as valid as any path: every bar keeps its length)."""

    def __init__(self, path: MotionPath):
        first = path.singularities[0]
        what = (
            f"{first.extra_zero_modes} extra zero mode(s) appear"
            if first.kind == "rank_drop"
            else "the corrector cannot continue even with the smallest step"
        )
        super().__init__(
            "singular_path",
            f"the motion meets a singular point at parameter {first.parameter:.6g} "
            f"(path index {first.step}): {what}.",
        )
        self.best = path


# ----------------------------------------------------------------------------------------------
# Bar constraints on a normalised configuration


def bar_lengths(positions: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """|x_i − x_j| for every bar, shape (N_B,)."""
    return np.linalg.norm(positions[edges[:, 0]] - positions[edges[:, 1]], axis=1)


def relative_bar_error(positions: np.ndarray, edges: np.ndarray, lengths: np.ndarray) -> float:
    """max_e | |X_i − X_j| − l_e | / l_e for one configuration (0 for a frame with no bars)."""
    if len(edges) == 0:
        return 0.0
    return float(np.max(np.abs(bar_lengths(positions, edges) - lengths) / lengths))


class _Constraints:
    """g(X) = ½(|X_i − X_j|² − l_e²) and its Jacobian C(X) for a fixed bar set (normalised)."""

    def __init__(self, edges: np.ndarray, reference: np.ndarray):
        self.edges = edges
        self.lengths = bar_lengths(reference, edges)
        self.n, self.d = reference.shape
        # Signed incidence E (N_B × N): +1 at i, −1 at j, so E·X stacks the bar vectors.
        self.incidence = np.zeros((len(edges), self.n))
        self.incidence[np.arange(len(edges)), edges[:, 0]] = 1.0
        self.incidence[np.arange(len(edges)), edges[:, 1]] = -1.0

    def residual(self, x: np.ndarray) -> np.ndarray:
        diff = x[self.edges[:, 0]] - x[self.edges[:, 1]]
        return 0.5 * (np.sum(diff * diff, axis=1) - self.lengths**2)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """C(X) dense, row e = E_e ⊗ (X_i − X_j): rigidity.compatibility_matrix without the sparse
        assembly, which would dominate the cost of a continuation step on small frames."""
        diff = self.incidence @ x
        return (self.incidence[:, :, None] * diff[:, None, :]).reshape(len(self.edges), -1)

    def error(self, x: np.ndarray) -> float:
        return relative_bar_error(x, self.edges, self.lengths)


@dataclass(frozen=True, eq=False)
class _Point:
    """An accepted point: configuration (N, d), unit tangent t (dN), the complement basis B
    (dN × (z − 1)), the rows R of C kept for the determinant test, its sign and the counts."""

    x: np.ndarray
    t: np.ndarray
    b: np.ndarray
    rows: np.ndarray
    zero_modes: int
    rank: int
    sign: float


def _zero_modes(c: np.ndarray, x: np.ndarray):
    """N(C) (dN × z), the rigid motions R (dN × ρ), the nontrivial modes N(C) ⊖ R and rank C,
    for C = C(x) dense and x normalised (full SVD; the rank decided by rank.decide_rank)."""
    ndof = c.shape[1]
    if c.shape[0]:
        _, s, vt = np.linalg.svd(c, full_matrices=True)
        rank, _ = decide_rank(s, RTOL)
    else:
        vt, rank = np.eye(ndof), 0
    null = vt[rank:].T
    rigid = rigid_motions(x, RTOL)
    return null, rigid, complement_within(null, rigid), rank


def _local_frame(cons: _Constraints, x: np.ndarray, direction: np.ndarray, c=None):
    """Zero modes of C(x): the unit tangent (projection of ``direction`` onto the nontrivial
    modes), the complement B, the pivot rows of C and the rank; None if no nontrivial mode has
    a component along ``direction``."""
    c = cons.jacobian(x) if c is None else c
    ndof = c.shape[1]
    _, rigid, modes, rank = _zero_modes(c, x)
    t = modes @ (modes.T @ direction)
    norm = np.linalg.norm(t)
    if modes.shape[1] == 0 or norm <= 1e-8 * np.linalg.norm(direction):
        return None
    t /= norm
    others = complement_within(modes, t[:, None])
    b = np.column_stack([rigid, others])
    if rank == c.shape[0]:
        rows = np.arange(rank)
    else:  # self-stresses: keep rank C independent rows (pivoted QR of Cᵀ)
        _, _, piv = sla.qr(c.T, mode="economic", pivoting=True)
        rows = np.sort(piv[:rank])
    return t, b, rows, ndof - rank, rank


def _det_sign(c: np.ndarray, rows: np.ndarray, t: np.ndarray, b: np.ndarray) -> float:
    sign, _ = np.linalg.slogdet(np.vstack([c[rows], t[None, :], b.T]))
    return float(sign)


def _solve(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Newton step: LU when the system is square and regular, least squares otherwise (a frame
    with self-stresses has redundant bar rows; the system is consistent at a solution)."""
    if matrix.shape[0] == matrix.shape[1]:
        try:
            return np.linalg.solve(matrix, rhs)
        except np.linalg.LinAlgError:
            pass
    return np.linalg.lstsq(matrix, rhs, rcond=None)[0]


def _correct(
    cons: _Constraints, pred: np.ndarray, t: np.ndarray, b: np.ndarray, start=None, tight=False
):
    """Newton on g(Y) = 0, tᵀ(Y − P) = 0, Bᵀ(Y − P) = 0 from ``start`` (default the predictor P).

    Converged when every bar is within NEWTON_RTOL of its length.  With ``tight`` Newton then
    goes on while its steps still shrink, because next to a singular point a bar error of δ²
    leaves a position error of δ along the soft direction.  Returns (Y, iterations) or None."""
    y = pred.copy() if start is None else start.copy()
    fixed = np.column_stack([t, b])
    last = np.inf
    for it in range(1, NEWTON_MAX_ITER + 1):
        c = cons.jacobian(y)
        f = np.concatenate([cons.residual(y), fixed.T @ (y - pred).ravel()])
        step = _solve(np.vstack([c, fixed.T]), -f)
        size = float(np.max(np.abs(step)))
        if cons.error(y) <= NEWTON_RTOL and (not tight or size >= 0.5 * last or size <= 1e-15):
            return y, it - 1
        y = y + step.reshape(y.shape)
        if not np.all(np.isfinite(y)):
            return None
        last = size
    return (y, NEWTON_MAX_ITER) if cons.error(y) <= NEWTON_RTOL else None


def _zero_modes_at(cons: _Constraints, x: np.ndarray, rtol: float) -> tuple[int, np.ndarray]:
    s = np.linalg.svd(cons.jacobian(x), compute_uv=False) if len(cons.edges) else np.zeros(0)
    rank, _ = decide_rank(s, rtol)
    return cons.n * cons.d - rank, s


def _trace_one_way(cons, start: _Point, amplitude, max_step, max_steps):
    """Continue from ``start`` to parameter ``amplitude``.

    Returns (configurations after the start, their parameters, singularity or None) with the
    singularity's ``step`` counted from the start (1 = first new point)."""
    sqrt_n = np.sqrt(cons.n)
    point, tau, h = start, 0.0, min(max_step, amplitude)
    xs, taus = [], []
    for _ in range(max_steps):
        check_budget()
        if tau >= amplitude * (1 - 1e-12):
            return xs, taus, None
        h = min(h, amplitude - tau)
        accepted = None
        while h >= MIN_STEP:
            got = _correct(
                cons, point.x + h * sqrt_n * point.t.reshape(point.x.shape), point.t, point.b
            )
            if got is not None:
                y, iters = got
                c = cons.jacobian(y)
                local = _local_frame(cons, y, point.t, c)
                if local is not None and float(local[0] @ point.t) >= np.cos(MAX_TURN):
                    accepted = (y, iters, c, local)
                    break
                if (
                    local is None
                ):  # no nontrivial mode continues t here: can only be a singular point
                    accepted = (y, iters, c, None)
                    break
            h *= 0.5
        if accepted is None:
            n_zero, s = _zero_modes_at(cons, point.x, SINGULAR_RTOL)
            sig = _vanishing_sigma(s, point.rank)
            return (
                xs,
                taus,
                Singularity(len(xs), tau, max(n_zero - point.zero_modes, 0), sig, "stalled"),
            )
        y, iters, c, local = accepted
        crossed = local is None or _det_sign(c, point.rows, point.t, point.b) != point.sign
        if local is not None and local[3] > point.zero_modes:
            crossed = True  # landed on the singular point itself
        if crossed:
            found = _locate(cons, point, h, y)
            if found is not None:
                y_star, s_star, extra, sig = found
                xs.append(y_star)
                taus.append(tau + s_star)
                return xs, taus, Singularity(len(xs), tau + s_star, extra, sig, "rank_drop")
            if local is None:
                h *= 0.5
                continue
        t, b, rows, zero_modes, rank = local
        sign = _det_sign(c, rows, t, b)
        point = _Point(y, t, b, rows, zero_modes, rank, sign)
        tau += h
        xs.append(y)
        taus.append(tau)
        if iters <= 3:
            h = min(1.5 * h, max_step)
    raise DomainError(
        "step_limit",
        f"the continuation used its {max_steps} steps and reached parameter {tau:.6g} of {amplitude:.6g}; "
        "raise max_steps or max_step.",
    )


def _vanishing_sigma(s: np.ndarray, rank: int) -> float:
    """σ_rank/σ_max: the relative size of the last singular value that was nonzero at the start."""
    if rank == 0 or s.size == 0 or s[0] == 0:
        return 0.0
    return float(s[rank - 1] / s[0])


def _locate(cons, point: _Point, h: float, y_end: np.ndarray):
    """Bisect the step length s ∈ (0, h) on the sign of det J (fixed t, B, rows of the step)
    and confirm a rank drop of C there.  Returns (Y*, s*, extra zero modes, σ/σ_max) or None.

    Next to a branch point the corrector is ill-conditioned (two branches lie within O(|s − s*|)
    of each other), so the bracket may wobble by ~√ε; the point with the smallest vanishing
    singular value seen during the bisection is the one reported."""
    sqrt_n = np.sqrt(cons.n)

    def measured(s_val, y):
        n_zero, sv = _zero_modes_at(cons, y, SINGULAR_RTOL)
        return (_vanishing_sigma(sv, point.rank), n_zero - point.zero_modes, s_val, y)

    best = measured(h, y_end)
    lo, y_lo, hi = 0.0, point.x, h
    for _ in range(BISECTION_STEPS):
        if hi - lo <= 1e-15 * max(h, 1.0) or best[0] <= 1e-3 * SINGULAR_RTOL:
            break
        mid = 0.5 * (lo + hi)
        pred = point.x + mid * sqrt_n * point.t.reshape(point.x.shape)
        # Warm start from our own branch, so Newton does not hop onto the crossing one.
        warm = y_lo + (mid - lo) * sqrt_n * point.t.reshape(point.x.shape)
        got = _correct(cons, pred, point.t, point.b, start=warm, tight=True)
        if got is None:
            break
        y = got[0]
        best = min(best, measured(mid, y), key=lambda m: m[0])
        if _det_sign(cons.jacobian(y), point.rows, point.t, point.b) == point.sign:
            lo, y_lo = mid, y
        else:
            hi = mid
    sigma, extra, s_star, y_star = best
    if extra <= 0:
        return None
    return y_star, s_star, extra, sigma


# ----------------------------------------------------------------------------------------------
# Public API


def _start_direction(frame: Frame, x: np.ndarray, cons: _Constraints, mode) -> np.ndarray:
    """The unit starting tangent (dN) in normalised coordinates; DomainError if there is none."""
    n = x.shape[0]
    null, _, modes, _ = _zero_modes(cons.jacobian(x), x)
    if mode is None:
        if modes.shape[1] == 0:
            raise DomainError("no_motion", "the frame has no nontrivial zero mode: it cannot move.")
        if modes.shape[1] > 1:
            raise DomainError(
                "ambiguous_mode",
                f"the frame has {modes.shape[1]} nontrivial zero modes; give `mode` to choose the motion.",
            )
        u = modes[:, 0]
        # Deterministic sign: the largest entry positive (ties: the first).
        return u * (1.0 if u[np.argmax(np.abs(u))] > 0 else -1.0)
    u = check_positions(mode, frame.dim, name="mode")
    if u.shape[0] != n:
        raise InvalidInput(
            "invalid_shape", f"mode must have one row per node ({n}), got {u.shape[0]}."
        )
    u = u.ravel()
    norm = np.linalg.norm(u)
    if norm == 0:
        raise InvalidInput("invalid_mode", "mode is zero.")
    leak = np.linalg.norm(u - null @ (null.T @ u)) / norm
    if not leak <= GIVEN_MODE_RTOL:  # also catches NaN
        raise DomainError(
            "not_a_zero_mode",
            f"mode is not a zero mode of the frame: |C·u| leaves N(C) by {leak:.2e} of |u|.",
        )
    t = modes @ (modes.T @ u)
    if np.linalg.norm(t) <= GIVEN_MODE_RTOL * norm:
        raise DomainError("rigid_mode", "mode is a rigid motion of the frame; it deforms nothing.")
    return t / np.linalg.norm(t)


def trace_motion(
    frame: Frame,
    mode=None,
    amplitude: float = 0.2,
    max_step: float = 0.02,
    direction: str = "both",
    max_steps: int = 5000,
) -> MotionPath:
    """Follow the finite motion of ``frame`` along ``mode`` to parameter ±``amplitude``.

    mode: (N, d) zero mode to follow (any scale); default the frame's single nontrivial mode
    (DomainError ``ambiguous_mode`` if there are several, ``no_motion`` if none).
    amplitude, max_step: in units of RMS node displacement over the frame's RMS radius.
    direction: "forward" (along +mode), "backward" or "both".
    Singular points stop the path in their direction and are listed in ``singularities``
    (``status`` "singular_path"); the path up to them is returned.
    """
    if direction not in ("both", "forward", "backward"):
        raise InvalidInput(
            "invalid_direction", "direction must be 'both', 'forward' or 'backward'."
        )
    if not (np.isfinite(amplitude) and amplitude > 0 and np.isfinite(max_step) and max_step > 0):
        raise InvalidInput("invalid_amplitude", "amplitude and max_step must be positive numbers.")
    ndof = frame.dim * frame.n_nodes
    if ndof > MAX_DOF:
        raise DomainError(
            "too_expensive",
            f"finite motion is traced for frames of up to {MAX_DOF} degrees of freedom (d·N); this one has {ndof}.",
        )
    norm = Normalisation.of(frame.positions)
    x0 = norm.positions_in(frame.positions)
    cons = _Constraints(frame.edges, x0)
    t0 = _start_direction(frame, x0, cons, mode)

    branches = {}
    for sign, name in ((1.0, "forward"), (-1.0, "backward")):
        if direction not in (name, "both"):
            continue
        local = _local_frame(cons, x0, sign * t0)
        t, b, rows, zero_modes, rank = local
        start = _Point(x0, t, b, rows, zero_modes, rank, _det_sign(cons.jacobian(x0), rows, t, b))
        branches[name] = _trace_one_way(cons, start, amplitude, max_step, max_steps)

    back_x, back_tau, back_sing = branches.get("backward", ([], [], None))
    fwd_x, fwd_tau, fwd_sing = branches.get("forward", ([], [], None))
    configs = back_x[::-1] + [x0] + fwd_x
    params = [-p for p in back_tau[::-1]] + [0.0] + fwd_tau
    ref = len(back_x)
    singularities = []
    if back_sing is not None:
        singularities.append(
            Singularity(
                ref - back_sing.step,
                -back_sing.parameter,
                back_sing.extra_zero_modes,
                back_sing.sigma,
                back_sing.kind,
            )
        )
    if fwd_sing is not None:
        singularities.append(
            Singularity(
                ref + fwd_sing.step,
                fwd_sing.parameter,
                fwd_sing.extra_zero_modes,
                fwd_sing.sigma,
                fwd_sing.kind,
            )
        )
    positions = norm.positions_out(np.stack(configs))
    lengths = bar_lengths(frame.positions, frame.edges)
    error = max(relative_bar_error(p, frame.edges, lengths) for p in positions)
    return MotionPath(
        positions=positions,
        parameter=np.asarray(params),
        reference_index=ref,
        max_relative_bar_error=error,
        singularities=tuple(singularities),
        edges=frame.edges,
    )


def kabsch_distance(moving: np.ndarray, target: np.ndarray) -> float:
    """min over proper rigid motions R (rotation, det +1, and translation) of ‖R·moving − target‖_F.

    moving, target: (k, d).  Kabsch: centre both, SVD of the covariance, flip the last axis if
    the optimal orthogonal map would be a reflection.  The residual is formed explicitly (not
    from the singular values) so that distances near 1e-12 of the size keep their digits.
    """
    p = moving - moving.mean(axis=0)
    q = target - target.mean(axis=0)
    u, _, vt = np.linalg.svd(p.T @ q)
    flip = np.ones(p.shape[1])
    flip[-1] = np.sign(np.linalg.det(u @ vt)) or 1.0
    rotation = (u * flip) @ vt  # maps row vectors: p @ rotation ≈ q
    return float(np.linalg.norm(p @ rotation - q))


@dataclass(frozen=True)
class Fidelity:
    """ε(a) and where on the path it is attained; ``at_end`` means the minimum sits at an end of
    the path, so a longer path might do better (or the path ended at a singular point)."""

    epsilon: float
    parameter: float
    at_end: bool


def fidelity(path: MotionPath, specified, x_s, u_s, a: float) -> Fidelity:
    """ε(a) = min_τ min_R ‖R·X_S(τ) − (x_S + a·u_S)‖ / ‖a·u_S‖ over a traced path.

    specified: indices S (k); x_s, u_s: (k, d); a > 0.  The outer minimum is taken over the
    samples, then polished on the constraint manifold itself: between the neighbours of the
    best sample, the configuration at pseudo-arclength s from it is computed by the corrector
    (exact bar lengths) and the distance minimised over s — no interpolation error.
    """
    spec = np.asarray(specified, dtype=int)
    x_s = np.asarray(x_s, dtype=float)
    u_s = np.asarray(u_s, dtype=float)
    target = x_s + a * u_s
    scale = np.linalg.norm(a * u_s)
    if scale == 0:
        raise InvalidInput("invalid_motion", "the target displacement a·u_S is zero.")
    dist = np.array([kabsch_distance(p[spec], target) for p in path.positions])
    best = int(np.argmin(dist))
    tau, value = float(path.parameter[best]), float(dist[best])
    if len(dist) >= 2:
        polished = _polish(path, best, lambda y: kabsch_distance(y[spec], target))
        if polished is not None and polished[1] < value:
            tau, value = polished
    return Fidelity(value / scale, tau, best in (0, len(dist) - 1))


def _polish(path: MotionPath, k: int, distance):
    """Minimise ``distance`` (of a configuration in the path's coordinates) over the curve
    between samples k−1 and k+1; (parameter, distance) or None if the corrector fails."""
    ref = path.positions[path.reference_index]
    norm = Normalisation.of(ref)
    cons = _Constraints(path.edges, norm.positions_in(ref))
    xs = norm.positions_in(path.positions)
    lo, hi = max(k - 1, 0), min(k + 1, len(xs) - 1)
    local = _local_frame(cons, xs[k], (xs[hi] - xs[lo]).ravel())
    if local is None:
        return None
    t, b = local[0], local[1]
    sqrt_n = np.sqrt(cons.n)
    # Pseudo-arclength offsets of the neighbours along t (the path parameter's own units).
    bounds = [float(t @ (xs[j] - xs[k]).ravel()) / sqrt_n for j in (lo, hi)]
    fallback = distance(path.positions[k])

    def along(s: float) -> float:
        got = _correct(cons, xs[k] + s * sqrt_n * t.reshape(xs[k].shape), t, b, tight=True)
        return fallback if got is None else distance(norm.positions_out(got[0]))

    res = minimize_scalar(along, bounds=bounds, method="bounded", options={"xatol": 1e-12})
    return float(path.parameter[k] + res.x), float(res.fun)


def motion_fidelity(frame: Frame, displacement_s: np.ndarray, horizon: float = 0.0, max_step: float = 0.02):
    """ε of a frame with one nontrivial mode for the target x_S + Δ_S: (Fidelity, MotionPath),
    with a = 1 and u_S = Δ_S in the definition of ε.

    The mode is traced both ways up to the parameter max(3·τ_lin, ``horizon``, 0.05), τ_lin
    the linear estimate of where the target is reached, doubling (≤ 3 times) while the closest
    point is an end of the path and no singular point was met.  The distance to the target
    need not fall monotonically along the motion, hence the margin and ``horizon`` (refine()
    passes the length of IPOPT's path).
    """
    spec = np.asarray(frame.specified, dtype=int)
    x_s = frame.positions[spec]
    norm = Normalisation.of(frame.positions)
    x0 = norm.positions_in(frame.positions)
    u = _start_direction(frame, x0, _Constraints(frame.edges, x0), None).reshape(x0.shape)
    # Linear estimate: X_S(τ) ≈ x_S + τ·r·√N·u_S (u unit in dN), fitted to Δ_S in least squares.
    along = norm.length * np.sqrt(frame.n_nodes) * u[spec]
    tau_lin = abs(float(np.sum(along * displacement_s) / max(np.sum(along * along), 1e-300)))
    amplitude = max(3 * tau_lin, horizon, 0.05)
    step = min(max_step, amplitude / 10)
    for _ in range(4):
        path = trace_motion(frame, amplitude=amplitude, max_step=step, direction="both")
        fid = fidelity(path, spec, x_s, displacement_s, 1.0)
        if not fid.at_end or path.singularities:
            break
        amplitude *= 2
    return fid, path
