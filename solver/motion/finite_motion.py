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
    rank decisions are scale-free.  At an accepted point X_k:
      * W_k = [t_k, B_k] (dN × z) is an orthonormal basis of N(C(X_k)): t_k the unit tangent
        (the projection of t_{k−1} — at the start, of the requested mode — onto the nontrivial
        modes), B_k the rigid motions and, if there are several nontrivial modes, those ⟂ t_k;
      * predictor P = X_k + h·√N·t_k (h in units of RMS node displacement / r);
      * corrector: Newton's method on the square system
            F(Y) = [C_kᵀ g(Y); W_kᵀ(Y − P)] = 0,          C_k = C(X_k),
        whose Jacobian is the bordered matrix (bordered.py)
            M_k(Y) = [[C_kᵀ C(Y), W_k], [W_kᵀ, 0]].
        Near X_k, C_kᵀ g(Y) = 0 ⇔ g(Y) = 0 (g(Y) lies in the range of C, which meets
        N(C_kᵀ) = the self-stresses only at 0), so redundant bars (self-stresses) need no row
        selection; W_kᵀ(Y − P) = 0 fixes the arclength, the rigid-motion gauge and the other
        mode directions.  Every iteration refactorises M_k(Y) (a chord method that keeps
        M_k(X_k) contracts only like h/σ_r, and designed frames have σ_r/σ_max down to ~1e-4);
        the factorisation at the converged Y serves the tests below, so a step of m Newton
        iterations costs m + 1 factorisations.
      * the step is accepted if the corrector converges (every bar within NEWTON_RTOL of its
        length) and t turns by less than MAX_TURN; h grows after easy steps, halves after hard
        ones, up to ``max_step``.
    The null space at the new point comes from the same factorisation: M_k(Y)[v; μ] = [0; e_i]
    gives μ = 0 (multiply by W_kᵀ: C_k W_k = 0) and C(Y)v = 0, so z solves span N(C(Y)).
    At the reference, N(C) is the rigid motions and the nontrivial modes: from the SVD of C
    (dense route) or the smallest eigenvectors of CᵀC by shift-invert Lanczos (eigen.py), the
    count always from rigidity.analyze.
    The path parameter τ is the accumulated pseudo-arclength in units of RMS node displacement
    over the frame's RMS radius: to first order X(τ) = x + τ·r·û with û the mode scaled to unit
    RMS node displacement.  Returned configurations are aligned to the reference: the proper
    rigid motion minimising Σ_i |R X_i + b − x_i|² (Kabsch) is removed from each.

Singular points.
    Where the configuration space is not a smooth curve (a branch point, or a point where the
    frame locks), C(X) loses rank: extra zero modes appear.  With W_k spanning N(C_k),
        det M_k(X_k) = det(Σ²)·(−1)^z   (Σ the nonzero singular values of C_k),
    and along the step det M_k(Y) is continuous and nonzero until C(Y) loses rank on W_k^⊥,
    where it changes sign through a simple singular point (Allgower & Georg, "Numerical
    Continuation Methods", §8.1: the Galerkin factor C_kᵀ keeps the sign of the vanishing
    singular value, which CᵀC would square away).  A sign change, or a landing on the point
    itself (the smallest singular value of C(Y) on W_k^⊥, by inverse iteration with the same
    factorisation, below rank.RTOL), is located by bisection on the step length and confirmed
    by counting the zero modes of C there (rigidity.analyze with the relative threshold
    SINGULAR_RTOL: a branch point is located to about √ε ≈ 1e-8).  A confirmed point ends the
    path in that direction and is reported; it is never stepped over.  A step that cannot be
    completed even at CONTINUATION_MIN_STEP is reported as a "stalled" singularity.

Linear algebra.  Up to rigidity.DENSE_MAX_DOF degrees of freedom C is dense and M is factorised
by dense LU; above, C is sparse and M by a sparse LU of its pinned interior (bordered.py), so a
step costs a few sparse factorisations: frames of 10⁴ degrees of freedom and more.

Finite-motion fidelity (the definition used by /v1/motion, /v1/refine and /v1/design).
    For a target displacement a·u_S of the specified nodes S,
        ε(a) = min over path points X(τ) and proper rigid motions R of
               ‖R·X_S(τ) − (x_S + a·u_S)‖ / ‖a·u_S‖            (Frobenius norms, k×d)
    with the inner minimum by Kabsch alignment (rotation + translation, det R = +1) and the
    outer one over the path samples, polished between the neighbours of the best sample on
    the constraint manifold itself (the corrector), so no interpolation error enters ε.
    The curve b ↦ ε(b) over amplitudes b_j = (j/m)·a, j = 1 … m (fidelity_curve) is the same
    minimum on the same traced path for the targets x_S + (j/m)·Δ_S along the ray to x_S + Δ_S;
    its last value is ε(a) itself, bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla
from scipy.optimize import minimize_scalar

from zeromode.solver.analysis.bordered import BorderedFactor, pinned_coordinates
from zeromode.solver.analysis.eigen import nontrivial_zero_modes, smallest_eigenpairs
from zeromode.solver.analysis.normalisation import Normalisation, rms_radius
from zeromode.solver.analysis.rank import RTOL, complement_within, nullspace
from zeromode.solver.analysis.rigidity import (
    DENSE_MAX_DOF,
    analyze,
    compatibility_matrix,
    rigid_motions,
)
from zeromode.solver.budget import check_budget
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame, check_positions
from zeromode.solver.progress import progress_stage, report_progress
from zeromode.solver.tolerances import (
    AMPLITUDE_RTOL,
    BRACKET_ROUNDOFF,
    CONTINUATION_MIN_STEP,
    CURVE_MINIMUM_XATOL,
    GIVEN_MODE_RTOL,
    LOCATED_RTOL,
    MEASURED_WIDTH,
    NEWTON_RTOL,
    SIGN_TIE_RTOL,
    SINGULAR_RTOL,
    TANGENT_RTOL,
    TIGHT_STEP_ATOL,
)

# Largest frame traced (d·N). A sparse step costs a few factorisations of a dN × dN stiffness
# pattern: about 0.1 s each at dN = 15 000 (the 50 × 50 auxetic sheet), so a path of a few dozen
# steps fits a request's time budget up to a few 10⁴; beyond, the refusal comes before any work.
MAX_DOF = 60_000
# Nontrivial modes handled at once: each one is a column of the border W (a solve per factor).
MAX_MODES = 64
# Newton iterations of a corrector (to NEWTON_RTOL) before the step is refused.
NEWTON_MAX_ITER = 12
# Locating a singular point, Newton goes on while each correction is below this fraction of the
# previous one (rate 1/2 next to a singular root, where a bar error δ² leaves δ in position),
# for at most TIGHT_MAX_ITER iterations: 2⁻³⁰ takes δ from 1e-3 to round-off.
TIGHT_CONTRACTION = 0.75
TIGHT_MAX_ITER = 40
# A step converged in at most this many Newton steps is easy: the next one may be longer.
EASY_ITERATIONS = 3
# A correction larger than this (normalised units: a fraction of the RMS radius) has diverged.
MAX_CORRECTION = 0.5
# A step is accepted only if the tangent turns by less than this (radians); a refused step is
# halved down to CONTINUATION_MIN_STEP before the continuation gives up.
MAX_TURN = 0.15
# Steps of the Illinois bisection that locates a singular point (to LOCATED_RTOL).
BISECTION_STEPS = 60
# Inverse iterations for the smallest singular value of C(Y) on W^⊥ (evidence, not a decision:
# the count at a located point is always taken by rigidity.analyze).
INVERSE_ITERATIONS = 3
# Share of a motion's progress for the zero modes at the reference (an analysis and a null
# space: about a step's cost); the continuation reports the rest.
REFERENCE_SHARE = 0.05
# Relative accuracy of σ_max(C), the scale of the reported singular values, and of the
# vanishing singular value measured while locating a singular point (evidence, not decisions:
# a node collision makes dozens of singular values vanish together, and resolving that
# cluster to machine precision would cost minutes).
SIGMA_MAX_RTOL = 1e-2
SIGMA_RTOL = 1e-2
# Amplitudes of an ε curve (fidelity_curve) in (0, a]: enough for a chart's polyline to show
# how ε grows, while a refinement's two curves cost about 15 % of its time (each amplitude is a
# polished minimum, ~9 ms on the outward square: docs/designer.md).
CURVE_SAMPLES = 12


@dataclass(frozen=True)
class Singularity:
    """A point of the path where C loses rank: ``extra_zero_modes`` more zero modes than at the
    start of the step.  ``step`` indexes ``MotionPath.positions``; ``sigma`` is σ/σ_max of the
    singular value that vanished (evidence of the decision); ``kind`` is "rank_drop" (located
    and confirmed) or "stalled" (the corrector failed at CONTINUATION_MIN_STEP)."""

    step: int
    parameter: float
    extra_zero_modes: int
    sigma: float
    kind: str


@dataclass(frozen=True, eq=False)
class MotionPath:
    """A traced finite motion: configurations that keep every bar's length.

    Every configuration but the reference is aligned to it by the proper rigid motion that
    minimises the sum of squared node distances (Kabsch).

    Attributes
    ----------
    positions : np.ndarray
        (P, N, d) configurations in the frame's coordinates, ordered by ``parameter``.
    parameter : np.ndarray
        (P,), strictly increasing, 0 at the reference configuration.
    reference_index : int
        The reference's index in ``positions`` (the input positions exactly).
    max_relative_bar_error : float
        The largest relative change of a bar's length over the path.
    singularities : tuple of Singularity
        The singular points met, each ending the path on its side (a rank drop, or a corrector
        that cannot go on even with the smallest step); empty for status "ok".
    edges : np.ndarray
        (N_B, 2): the frame's bars.
    method : str
        "dense" or "sparse": the linear algebra the continuation used.
    singular_start : Singularity or None
        The reference itself as a singular point (``step`` = ``reference_index``, parameter
        0), when C has more zero modes there than just off it along the path (the path starts
        at a branch point: two zero modes crossing, a flattened linkage); None otherwise. It
        does not end the path and is not one of ``singularities``.
    """

    positions: np.ndarray
    parameter: np.ndarray
    reference_index: int
    max_relative_bar_error: float
    singularities: tuple[Singularity, ...]
    edges: np.ndarray
    method: str = "dense"
    singular_start: Singularity | None = None

    @property
    def status(self) -> str:
        """"singular_path" when a singular point ended the path, else "ok"."""
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


class BarConstraints:
    """g(X) = ½(|X_i − X_j|² − l_e²) and its Jacobian C(X) for a fixed bar set (normalised);
    C dense or sparse by ``method``; ``sigma_max`` = σ_max(C) at the reference, the scale of
    the relative singular values reported along the path.

    The continuation (``follow``) sees a constraint system only through this interface: the
    configuration x is an (n, d) array, ``rigid(x)`` the trivial motions, ``count`` and
    ``null_space`` the rank decisions. periodic.py subclasses it for one cell of a periodic
    frame, whose rows are its nodes and its lattice vectors.  ``measured_nodes`` is the number
    of nodes N whose RMS displacement the path parameter measures: a step of pseudo-arclength h
    moves x by h·√N along the unit tangent (N = n here; the cell's rows stand for the nodes of
    its whole patch).
    """

    def __init__(self, edges: np.ndarray, reference: np.ndarray, method: str):
        self.edges = edges
        self.lengths = bar_lengths(reference, edges)
        self.n, self.d = reference.shape
        self.measured_nodes = self.n
        self.method = method
        self.sigma_max = self.largest_singular_value(self.jacobian(reference))

    def residual(self, x: np.ndarray) -> np.ndarray:
        diff = x[self.edges[:, 0]] - x[self.edges[:, 1]]
        return 0.5 * (np.sum(diff * diff, axis=1) - self.lengths**2)

    def jacobian(self, x: np.ndarray):
        return compatibility_matrix(x, self.edges, dense=self.method == "dense")

    def error(self, x: np.ndarray) -> float:
        return relative_bar_error(x, self.edges, self.lengths)

    def largest_singular_value(self, c) -> float:
        if c.shape[0] == 0:
            return 1.0
        if self.method == "dense":
            return float(np.linalg.norm(c, 2))
        # Lanczos to 1 %: σ_max only scales the reported evidence, and lattices have clusters of
        # equal largest singular values that a tight tolerance would resolve for minutes.
        gram = spla.LinearOperator((c.shape[1],) * 2, matvec=lambda v: c.T @ (c @ v), dtype=float)
        start = np.random.default_rng(0).standard_normal(c.shape[1])
        return float(np.sqrt(spla.eigsh(gram, k=1, which="LA", tol=SIGMA_MAX_RTOL, v0=start)[0][0]))

    def galerkin(self, point: _Point, y: np.ndarray, c_y=None) -> BorderedFactor:
        """The factorised Jacobian M_k(Y) = [[C_kᵀ C(Y), W_k], [W_kᵀ, 0]] of the step from ``point``."""
        c_y = self.jacobian(y) if c_y is None else c_y
        return BorderedFactor(point.c.T @ c_y, point.w, point.pins)

    def rigid(self, x: np.ndarray) -> np.ndarray:
        """Orthonormal basis of the trivial motions of configuration x (dN × ρ)."""
        return rigid_motions(x, RTOL)

    def vanishing_sigma(self, x: np.ndarray, c, zero_modes: int) -> float:
        """σ_{dN−z}(C(x))/σ_max: the singular value that vanishes where C(x) has more than
        z = ``zero_modes`` zero modes (dense: SVD; sparse: the eigenvalue of CᵀC after the
        z − ρ nontrivial ones, ⟂ rigid motions, by eigen.py)."""
        rank = self.n * self.d - zero_modes
        if self.method == "dense":
            s = np.linalg.svd(c, compute_uv=False)
            return float(s[rank - 1]) / self.sigma_max if 0 < rank <= s.size else 0.0
        rigid = self.rigid(x)
        f = zero_modes - rigid.shape[1]
        values = smallest_eigenpairs((c.T @ c).tocsc(), f + 1, deflate=rigid, tol=SIGMA_RTOL**2).values
        return float(np.sqrt(max(values[f], 0.0))) / self.sigma_max

    def count(self, x: np.ndarray, rtol: float) -> tuple[int, int, float, float]:
        """(dim N(C(x)), nontrivial zero modes, σ_r/σ_max, σ_{r+1}/σ_max), the rank decided
        by rigidity.analyze with relative threshold ``rtol``."""
        analysis = analyze(Frame.build(x, self.edges), rtol=rtol, method=self.method, bases=False)
        sigma_max = self.largest_singular_value(self.jacobian(x))
        gap = analysis.rank_gap
        return (
            analysis.zero_modes,
            analysis.nontrivial_zero_modes,
            gap.last_nonzero / sigma_max,
            gap.first_zero / sigma_max,
        )

    def null_space(self, x: np.ndarray, nontrivial: int) -> np.ndarray:
        """Orthonormal basis of N(C(x)) (dN × z) with ``nontrivial`` zero modes beyond the
        rigid motions: the SVD of C (dense) or the smallest eigenvectors of CᵀC ⟂ rigid
        motions by shift-invert Lanczos (sparse, eigen.py)."""
        rigid = self.rigid(x)
        c = self.jacobian(x)
        if self.method == "dense":
            return nullspace(c, RTOL)[0] if c.shape[0] else np.eye(x.size)
        return np.column_stack([rigid, nontrivial_zero_modes(c, rigid, nontrivial)])


@dataclass(frozen=True, eq=False)
class _Point:
    """An accepted point: configuration x (N, d), W (dN × z) orthonormal basis of N(C(x)) with
    the unit tangent t in column 0, C(x), and the coordinates pinned to factorise M_k sparsely."""

    x: np.ndarray
    w: np.ndarray
    c: object

    @property
    def pins(self) -> np.ndarray:
        if "_pins" not in self.__dict__:  # once per point: every factorisation of its step shares W
            self.__dict__["_pins"] = pinned_coordinates(self.w)
        return self.__dict__["_pins"]

    @property
    def t(self) -> np.ndarray:
        return self.w[:, 0]

    @property
    def zero_modes(self) -> int:
        return self.w.shape[1]

    @property
    def regular_sign(self) -> int:
        """sign det M_k(X_k) = (−1)^z: the sign det M_k(Y) keeps until a singular point."""
        return -1 if self.zero_modes % 2 else 1


def _tangent_frame(cons, x: np.ndarray, null: np.ndarray, direction: np.ndarray):
    """W = [t, rigid motions, other nontrivial modes] from an orthonormal basis of N(C(x)): t is
    the unit projection of ``direction`` onto the nontrivial modes; None if it has none there."""
    rigid = cons.rigid(x)
    modes = complement_within(null, rigid)
    t = modes @ (modes.T @ direction)
    norm = np.linalg.norm(t)
    if modes.shape[1] == 0 or norm <= TANGENT_RTOL * np.linalg.norm(direction):
        return None
    t /= norm
    return np.column_stack([t, rigid, complement_within(modes, t[:, None])])


def _null_basis(factor: BorderedFactor) -> np.ndarray:
    """Orthonormal basis of N(C(Y)) from the factorised M_k(Y): the solutions of M[v; μ] = [0; e_i]."""
    v, _ = factor.solve(np.zeros((factor.n, factor.z)), np.eye(factor.z))
    return np.linalg.qr(v)[0]


def _soft_on_complement(cons: BarConstraints, factor: BorderedFactor, c_y) -> float:
    """σ/σ_max of the smallest singular value of C(Y) on W_k^⊥ (inverse iteration with the
    factorised M_k(Y)): small when Y is at, or close to, a point where C(Y) loses rank."""
    v = np.random.default_rng(0).standard_normal(factor.n)
    for _ in range(INVERSE_ITERATIONS):
        v, _ = factor.solve(v)
        v /= np.linalg.norm(v)
    return float(np.linalg.norm(c_y @ v)) / cons.sigma_max


def _correct(cons, point: _Point, pred, start=None, tight=False):
    """Newton's method on F(Y) = [C_kᵀ g(Y); W_kᵀ(Y − P)] from ``start`` (default the predictor P).

    Converged when every bar is within NEWTON_RTOL of its length.  With ``tight`` Newton then
    goes on while its steps still shrink, because next to a singular point a bar error of δ²
    leaves a position error of δ along the soft direction.  Returns (Y, Newton steps taken,
    M_k(Y) factorised — None when it is exactly singular —, C(Y)) or None."""
    y = pred.copy() if start is None else start.copy()
    gauge = point.w.T @ pred.ravel()
    last = np.inf
    max_iter = TIGHT_MAX_ITER if tight else NEWTON_MAX_ITER
    for it in range(max_iter + 1):
        c_y = cons.jacobian(y)
        converged = cons.error(y) <= NEWTON_RTOL
        try:
            factor = cons.galerkin(point, y, c_y)
        except np.linalg.LinAlgError:
            return (y, it, None, c_y) if converged else None
        if converged and (not tight or it == max_iter):
            return y, it, factor, c_y
        step = factor.solve(-(point.c.T @ cons.residual(y)), gauge - point.w.T @ y.ravel())[0]
        size = float(np.max(np.abs(step)))
        # At a singular root Newton converges linearly with rate 1/2: go on while it contracts.
        if converged and (size >= TIGHT_CONTRACTION * last or size <= TIGHT_STEP_ATOL):
            return y, it, factor, c_y
        if not size <= MAX_CORRECTION:  # diverging (also catches NaN)
            return None
        y = y + step.reshape(y.shape)
        last = size
    return None


def _trace_one_way(cons, start: _Point, amplitude, max_step, max_steps, stop=None, stop_bisections=0):
    """Continue from ``start`` to parameter ``amplitude``, or until ``stop(y)`` is true for a
    new configuration y (normalised; it is kept as the last one, its step first shortened
    towards where ``stop`` turns true by ``stop_bisections`` bisections: _shortened).

    Returns (configurations after the start, their parameters, singularity or None) with the
    singularity's ``step`` counted from the start (1 = first new point).  Progress is reported
    as τ/amplitude after every step, never decreasing; locating a singular point (a stage from
    there to the end of the direction) reports the share of its bisection steps taken."""
    sqrt_n = np.sqrt(cons.measured_nodes)
    point, tau, h = start, 0.0, min(max_step, amplitude)
    xs, taus = [], []
    done = 0.0

    def progress(fraction: float, message: str) -> None:
        nonlocal done
        done = max(done, fraction)
        report_progress(done, message)

    for _ in range(max_steps):
        check_budget()
        if tau >= amplitude * (1 - AMPLITUDE_RTOL):
            return xs, taus, None
        h = min(h, amplitude - tau)
        accepted = None
        while h >= CONTINUATION_MIN_STEP:
            got = _correct(cons, point, point.x + h * sqrt_n * point.t.reshape(point.x.shape))
            if got is not None:
                y, iters, f_y, c_y = got
                # f_y None: M_k(Y) is exactly singular, Y is on the singular point.
                w = None if f_y is None else _tangent_frame(cons, y, _null_basis(f_y), point.t)
                if w is None or float(w[:, 0] @ point.t) >= np.cos(MAX_TURN):
                    accepted = (y, iters, c_y, f_y, w)
                    break
            h *= 0.5
        if accepted is None:
            with progress_stage(done, 1.0, "counting zero modes where the corrector stalled"):
                extra, sigma = _extra_zero_modes(cons, point.x, point.zero_modes)
            return xs, taus, Singularity(len(xs), tau, max(extra, 0), sigma, "stalled")
        y, iters, c_y, f_y, w = accepted
        crossed = (
            w is None
            or f_y.sign != point.regular_sign
            or _soft_on_complement(cons, f_y, c_y) <= RTOL  # landed on the singular point itself
        )
        if crossed:
            with progress_stage(done, 1.0, "locating a singular point"):
                found = _locate(cons, point, h, y, f_y, c_y, report_progress)
            done = 1.0  # the stage reported the end of the direction
            if found is not None:
                y_star, s_star, extra, sigma = found
                xs.append(y_star)
                taus.append(tau + s_star)
                return xs, taus, Singularity(len(xs), tau + s_star, extra, sigma, "rank_drop")
            if w is None:
                h *= 0.5
                continue
        if stop is not None and stop(y):
            y, h = _shortened(cons, point, h, y, stop, stop_bisections)
            xs.append(y)
            taus.append(tau + h)
            return xs, taus, None
        point = _Point(y, w, c_y)
        tau += h
        xs.append(y)
        taus.append(tau)
        progress(tau / amplitude, "continuation")
        if iters <= EASY_ITERATIONS:
            h = min(1.5 * h, max_step)
    raise DomainError(
        "step_limit",
        f"the continuation used its {max_steps} steps and reached parameter {tau:.6g} of {amplitude:.6g}; "
        "raise max_steps or max_step.",
    )


def _shortened(cons, point: _Point, h: float, y: np.ndarray, stop, bisections: int):
    """The step of length h from ``point`` to y, where ``stop`` is true (and false at the
    point), shortened by bisection on its length to the shortest one found at whose end
    ``stop`` is still true: (that end, its length)."""
    sqrt_n = np.sqrt(cons.measured_nodes)
    lo, hi = 0.0, h
    for _ in range(bisections):
        mid = 0.5 * (lo + hi)
        got = _correct(cons, point, point.x + mid * sqrt_n * point.t.reshape(point.x.shape))
        if got is None:
            break
        if stop(got[0]):
            hi, y = mid, got[0]
        else:
            lo = mid
    return y, hi


def _extra_zero_modes(cons, x: np.ndarray, zero_modes: int) -> tuple[int, float]:
    """(zero modes of C(x) beyond ``zero_modes`` at SINGULAR_RTOL, σ/σ_max of the singular value
    that vanished — or of the smallest nonzero one when none did)."""
    count, _, last_nonzero, first_zero = cons.count(x, SINGULAR_RTOL)
    extra = count - zero_modes
    return extra, first_zero if extra > 0 else last_nonzero


def signed_determinant(factor: BorderedFactor, sign: int, reference: float) -> float:
    """sign·det M / exp(reference): det M relative to a reference |det| (log), oriented so that
    the regular side of a step (sign det = ``sign``) is positive."""
    return factor.sign * sign * float(np.exp(min(factor.logabsdet - reference, 700.0)))


def bracket_sign_change(evaluate, measure, h: float, d_end: float, state_end, report=None):
    """The point of smallest vanishing σ seen while bracketing the sign change of a continuous
    d(s) on (0, h], d(0) = 1 > 0 > d(h) = ``d_end``: the Illinois variant of regula falsi,
    with a bisection step whenever two steps did not halve the bracket (a node collision makes
    dozens of singular values vanish at once, det ∝ (s − s*)^m, where regula falsi crawls).

    evaluate(s, lo, state_lo) → (d(s), state) — d None where exactly singular — or None when
    the point cannot be computed; ``state_lo`` is the state at the bracket's regular end lo
    (None at s = 0), for warm starts on the caller's own branch. measure(state) → σ, called
    only once the bracket is within MEASURED_WIDTH of h (σ costs an eigen-solve on a large
    frame, the sign a factorisation). Stops once σ ≤ LOCATED_RTOL or the bracket is at
    round-off. Returns (σ, s, state). ``report(q)``, if given, is called after every step with q
    the share of BISECTION_STEPS taken (a step costs a corrector solve: progress for a caller)."""
    lo, hi, state_lo, state_hi, d_lo, d_hi = 0.0, h, None, state_end, 1.0, d_end
    stale = None  # the end kept twice in a row (Illinois: halve its value)
    widths = [h, h]  # the bracket two steps ago must have been at least twice as wide
    best = None
    for step in range(BISECTION_STEPS if d_hi < 0 else 0):
        if hi - lo <= BRACKET_ROUNDOFF * max(h, 1.0) or best is not None and best[0] <= LOCATED_RTOL:
            break
        check_budget()
        mid = (lo * d_hi - hi * d_lo) / (d_hi - d_lo) if d_lo > d_hi else lo
        if not lo + 0.01 * (hi - lo) <= mid <= hi - 0.01 * (hi - lo) or hi - lo > 0.5 * widths[0]:
            mid = 0.5 * (lo + hi)
        widths = [widths[1], hi - lo]
        got = evaluate(mid, lo, state_lo)
        if report is not None:
            report((step + 1) / BISECTION_STEPS)
        if got is None:
            break
        d, state = got
        if d is None:
            return 0.0, mid, state
        if hi - lo <= MEASURED_WIDTH * h:
            best = min(best or (np.inf,), (measure(state), mid, state), key=lambda m: m[0])
        if d > 0:
            lo, state_lo, d_lo = mid, state, d
            d_hi, stale = (0.5 * d_hi, "hi") if stale == "hi" else (d_hi, "hi")
        else:
            hi, state_hi, d_hi = mid, state, d
            d_lo, stale = (0.5 * d_lo, "lo") if stale == "lo" else (d_lo, "lo")
    return best if best is not None else (measure(state_hi), hi, state_hi)


def located_sigma(cons: BarConstraints, x: np.ndarray, c, factor, zero_modes: int) -> float:
    """σ/σ_max of the singular value that vanishes at a singular point, near x: the cheap
    indicator on W_k^⊥ (inverse iteration with the step's factorisation ``factor``, None where
    it is exactly singular) until it falls below SINGULAR_RTOL, then cons.vanishing_sigma (an
    eigen-solve at every bracketing step would dominate the cost on large frames)."""
    if factor is None:
        return 0.0
    soft = _soft_on_complement(cons, factor, c)
    return cons.vanishing_sigma(x, c, zero_modes) if soft <= SINGULAR_RTOL else soft


def _locate(cons, point: _Point, h: float, y_end: np.ndarray, f_end, c_end, report=None):
    """Locate the root s* ∈ (0, h] of det M_k(Y(s)) along the step and confirm a rank drop of C
    there.  Returns (Y*, s*, extra zero modes, σ/σ_max) or None.  ``report``: as
    bracket_sign_change's.

    det M_k(Y(s)) is smooth in s with a simple root at a simple singular point, so regula falsi
    brackets it in a handful of corrector solves (bracket_sign_change). Next to a branch point
    the corrector is ill-conditioned (two branches lie within O(|s − s*|) of each other), so
    the bracket may wobble by ~√ε; the point with the smallest vanishing singular value of C
    seen is the one confirmed and reported."""
    sqrt_n = np.sqrt(cons.measured_nodes)
    along = point.t.reshape(point.x.shape)
    reference = cons.galerkin(point, point.x, point.c).logabsdet

    def measure(state) -> float:
        y, f, c_y = state
        return located_sigma(cons, y, c_y, f, point.zero_modes)

    def evaluate(s, lo, state_lo):
        # Warm start from our own branch, so Newton does not hop onto the crossing one.
        warm = (point.x if state_lo is None else state_lo[0]) + (s - lo) * sqrt_n * along
        got = _correct(cons, point, point.x + s * sqrt_n * along, start=warm, tight=True)
        if got is None:
            return None
        y, _, f, c_y = got
        return (None if f is None else signed_determinant(f, point.regular_sign, reference)), (y, f, c_y)

    if f_end is None:  # the step ended exactly on the singular point
        s_star, y_star = h, y_end
    else:
        d_end = signed_determinant(f_end, point.regular_sign, reference)
        _, s_star, (y_star, _, _) = bracket_sign_change(evaluate, measure, h, d_end, (y_end, f_end, c_end), report)
    extra, sigma_star = _extra_zero_modes(cons, y_star, point.zero_modes)
    if extra <= 0:
        return None
    return y_star, s_star, extra, sigma_star


def regular_point(cons: BarConstraints, x: np.ndarray, direction: np.ndarray) -> _Point:
    """The accepted point of the continuation at the regular configuration x (normalised):
    W = [t, rigid motions, other modes] from N(C(x)), t the unit tangent nearest ``direction``
    (dN). DomainError ``no_motion`` if x has no nontrivial zero mode along ``direction``."""
    _, f, _, _ = cons.count(x, RTOL)
    w = _tangent_frame(cons, x, cons.null_space(x, f), direction)
    if w is None:
        raise DomainError("no_motion", "the configuration has no nontrivial zero mode along the path.")
    return _Point(x, w, cons.jacobian(x))


def curve_chart(cons: BarConstraints, x: np.ndarray, direction: np.ndarray):
    """s ↦ the configuration of ``cons`` at pseudo-arclength s from the regular configuration x
    (normalised) along its tangent nearest ``direction``, by the corrector of the continuation:
    a function (s, start) → (configuration or None), ``start`` a warm start (default the
    predictor)."""
    point = regular_point(cons, x, direction)
    return lambda s, start=None: chart_at(cons, point, s, start)


def chart_at(cons: BarConstraints, point: _Point, s: float, start=None):
    """The configuration at pseudo-arclength s from ``point`` along its tangent (the corrector,
    tight: W_kᵀ(Y − X_k − s·√N·t_k) = 0 with every bar kept), or None where it fails."""
    pred = point.x + s * np.sqrt(cons.measured_nodes) * point.t.reshape(point.x.shape)
    got = _correct(cons, point, pred, start=start, tight=True)
    return None if got is None else got[0]


def aimed_correction(cons: BarConstraints, point: _Point, start: np.ndarray, quantity, value: float, atol: float):
    """Newton's method on the augmented system of a step from ``point`` (X_k, W_k = [t_k, B_k])
    that ends where a quantity q reaches ``value``:

        F(Y) = [C_kᵀ g(Y);  q(Y) − value;  B_kᵀ(Y − X_k)] = 0,

    the continuation's corrector (module docstring) with the arclength row t_kᵀ(Y − P) = 0
    replaced by the target equation.  Its Jacobian is M_k(Y) with the row t_kᵀ replaced by
    ∇q(Y)ᵀ, solved by block elimination with the factorised M_k(Y): d₀ = the corrector's
    step with t_kᵀd₀ = 0, v = the solution of M_k(Y)[v; μ] = [0; e₁] (C(Y)v = 0 on the gauge),
    then d = d₀ + αv with ∇q·d = value − q(Y).  ``quantity(y)`` → (q, ∇q (n, d)) in the
    coordinates of ``cons``.  Returns Y once every bar is within NEWTON_RTOL of its length and
    |q − value| ≤ ``atol`` (Newton goes on while its steps shrink), or None (diverged, or
    ∇q·v = 0: a turning point of q)."""
    y = start.copy()
    b = point.w[:, 1:]
    gauge = b.T @ point.x.ravel()
    e1 = np.zeros(point.zero_modes)
    e1[0] = 1.0
    last = np.inf
    for _ in range(TIGHT_MAX_ITER):
        q, grad = quantity(y)
        converged = cons.error(y) <= NEWTON_RTOL and abs(q - value) <= atol
        try:
            factor = cons.galerkin(point, y)
        except np.linalg.LinAlgError:
            return y if converged else None
        d0, _ = factor.solve(-(point.c.T @ cons.residual(y)), np.concatenate([[0.0], gauge - b.T @ y.ravel()]))
        v, _ = factor.solve(np.zeros(factor.n), e1)
        slope = float(grad.ravel() @ v)
        if not abs(slope) > 0:
            return y if converged else None
        step = d0 + ((value - q) - float(grad.ravel() @ d0)) / slope * v
        size = float(np.max(np.abs(step)))
        if converged and (size >= TIGHT_CONTRACTION * last or size <= TIGHT_STEP_ATOL):
            return y
        if not size <= MAX_CORRECTION:  # diverging (also catches NaN)
            return None
        y = y + step.reshape(y.shape)
        last = size
    q, _ = quantity(y)
    return y if cons.error(y) <= NEWTON_RTOL and abs(q - value) <= atol else None


# ----------------------------------------------------------------------------------------------
# Public API


def _reference_null_space(cons: BarConstraints, x: np.ndarray, explicit_mode: bool):
    """Orthonormal bases of N(C(x)) (dN × z) and of its nontrivial part (dN × f), x normalised.

    Without ``explicit_mode`` a frame with f ≠ 1 is refused before any basis is computed
    (``no_motion`` / ``ambiguous_mode``)."""
    _, f, _, _ = cons.count(x, RTOL)
    if f == 0:
        raise DomainError("no_motion", "the frame has no nontrivial zero mode: it cannot move.")
    if f > 1 and not explicit_mode:
        raise DomainError(
            "ambiguous_mode",
            f"the frame has {f} nontrivial zero modes; give `mode` to choose the motion.",
        )
    if f > MAX_MODES:
        raise DomainError(
            "too_expensive",
            f"the frame has {f} nontrivial zero modes; motions are traced for up to {MAX_MODES}.",
        )
    null = cons.null_space(x, f)
    return null, complement_within(null, cons.rigid(x))


def given_mode(mode, n: int, d: int) -> np.ndarray:
    """A given mode as an (n, d) array of finite numbers (InvalidInput ``invalid_shape`` or
    ``not_finite`` naming it otherwise)."""
    u = check_positions(mode, d, name="mode")
    if u.shape[0] != n:
        raise InvalidInput("invalid_shape", f"mode must have one row per node ({n}), got {u.shape[0]}.")
    return u


def signed_mode(u: np.ndarray) -> np.ndarray:
    """u (any shape) signed so that its largest entry is positive; entries within SIGN_TIE_RTOL
    of the largest magnitude tie, and the first of them decides (a deterministic sign whatever
    the round-off of the computation that produced u)."""
    magnitude = np.abs(u).ravel()
    first = int(np.argmax(magnitude >= (1.0 - SIGN_TIE_RTOL) * magnitude.max()))
    return u if u.flat[first] > 0 else -u


def start_direction(cons: BarConstraints, x: np.ndarray, mode):
    """(unit starting tangent (dN), orthonormal basis of N(C(x))) in normalised coordinates;
    ``mode`` (n, d) or None (then the single nontrivial mode, signed by signed_mode).
    DomainError if there is no tangent."""
    n = x.shape[0]
    if mode is not None:
        u = given_mode(mode, n, x.shape[1])
    null, modes = _reference_null_space(cons, x, explicit_mode=mode is not None)
    if mode is None:
        return signed_mode(modes[:, 0]), null
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
    return t / np.linalg.norm(t), null


def follow(
    cons: BarConstraints,
    x0,
    t0,
    null,
    amplitude,
    max_step,
    direction,
    max_steps,
    stop=None,
    stop_bisections=0,
):
    """Continuation of the constraint system ``cons`` from x0 (normalised) along ±t0, with
    ``null`` an orthonormal basis of N(C(x0)): (configurations (normalised, ordered by
    parameter), parameters, index of x0, singular points (path indices)).  ``stop(y, sign)``,
    if given, ends a direction at the first new configuration y where it is true, its step
    shortened by ``stop_bisections`` bisections towards where it turns true.  Progress: one
    stage per direction."""
    c0 = cons.jacobian(x0)
    branches = {}
    ways = [(s, n) for s, n in ((1.0, "forward"), (-1.0, "backward")) if direction in (n, "both")]
    for k, (sign, name) in enumerate(ways):
        start = _Point(x0, _tangent_frame(cons, x0, null, sign * t0), c0)
        until = None if stop is None else (lambda y, sign=sign: stop(y, sign))
        with progress_stage(k / len(ways), (k + 1) / len(ways), f"continuation {name}"):
            branches[name] = _trace_one_way(cons, start, amplitude, max_step, max_steps, until, stop_bisections)
    back_x, back_tau, back_sing = branches.get("backward", ([], [], None))
    fwd_x, fwd_tau, fwd_sing = branches.get("forward", ([], [], None))
    ref = len(back_x)
    singularities = []
    for sing, sign in ((back_sing, -1), (fwd_sing, 1)):
        if sing is not None:
            singularities.append(
                Singularity(
                    ref + sign * sing.step,
                    sign * sing.parameter,
                    sing.extra_zero_modes,
                    sing.sigma,
                    sing.kind,
                )
            )
    configs = back_x[::-1] + [x0] + fwd_x
    params = np.asarray([-p for p in back_tau[::-1]] + [0.0] + fwd_tau)
    return configs, params, ref, tuple(singularities)


def check_trace_arguments(frame: Frame, amplitude: float, max_step: float, direction: str) -> None:
    """trace_motion's refusals before any work: InvalidInput ``invalid_direction`` or
    ``invalid_amplitude``, DomainError ``too_expensive`` above MAX_DOF degrees of freedom."""
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


def trace_motion(
    frame: Frame,
    mode=None,
    amplitude: float = 0.2,
    max_step: float = 0.02,
    direction: str = "both",
    max_steps: int = 5000,
    method: str = "auto",
    stop=None,
    stop_bisections: int = 0,
) -> MotionPath:
    """Follow the finite motion of ``frame`` along ``mode`` to parameter ±``amplitude``.

    mode: (N, d) zero mode to follow (any scale); default the frame's single nontrivial mode
    (DomainError ``ambiguous_mode`` if there are several, ``no_motion`` if none).
    amplitude, max_step: in units of RMS node displacement over the frame's RMS radius.
    direction: "forward" (along +mode), "backward" or "both".
    method: "dense", "sparse" or "auto" (dense up to rigidity.DENSE_MAX_DOF degrees of freedom).
    Singular points stop the path in their direction and are listed in ``singularities``
    (``status`` "singular_path"); the path up to them is returned.
    stop: optional ``stop(positions (N, d), sign)`` (sign +1 forward, −1 backward), called at
    every new configuration (unaligned, in the frame's coordinates); a direction ends at the
    first where it is true, that configuration kept, its step first shortened towards where
    ``stop`` turns true by ``stop_bisections`` bisections.
    A reference where C has more zero modes than just off it along the path (a branch point,
    reached only with a given ``mode``) is reported as ``singular_start``.
    Frames above MAX_DOF degrees of freedom are refused (``too_expensive``) before any work.
    """
    check_trace_arguments(frame, amplitude, max_step, direction)
    ndof = frame.dim * frame.n_nodes
    if method == "auto":
        method = "dense" if ndof <= DENSE_MAX_DOF else "sparse"
    if method not in ("dense", "sparse"):
        raise InvalidInput("invalid_method", "method must be 'auto', 'dense' or 'sparse'.")
    norm = Normalisation.of(frame.positions)
    x0 = norm.positions_in(frame.positions)
    with progress_stage(0.0, REFERENCE_SHARE, "zero modes at the reference"):
        cons = BarConstraints(frame.edges, x0, method)
        t0, null = start_direction(cons, x0, mode)
    until = None if stop is None else (lambda y, sign: stop(norm.positions_out(y), sign))
    with progress_stage(REFERENCE_SHARE, 1.0):
        configs, params, ref, singularities = follow(
            cons, x0, t0, null, amplitude, max_step, direction, max_steps, until, stop_bisections
        )
    positions = np.stack(
        [
            frame.positions if i == ref else align_to(norm.positions_out(y), frame.positions)
            for i, y in enumerate(configs)
        ]
    )
    lengths = bar_lengths(frame.positions, frame.edges)
    error = max(relative_bar_error(p, frame.edges, lengths) for p in positions)
    return MotionPath(
        positions=positions,
        parameter=np.asarray(params),
        reference_index=ref,
        max_relative_bar_error=error,
        singularities=singularities,
        edges=frame.edges,
        method=method,
        singular_start=_singular_start(cons, configs, ref, null.shape[1]),
    )


def _singular_start(cons: BarConstraints, configs, ref: int, zero_modes: int) -> Singularity | None:
    """The reference as a singular point of the path: C(x0) has ``zero_modes`` zero modes and its
    neighbours on the path fewer (counted at RTOL, as at the reference), so the path leaves a
    branch point. Only a reference with more than one nontrivial mode (more than ρ + 1 zero
    modes) can be one: elsewhere the continuation keeps a tangent in N(C) of that size. Counted on
    either side of the reference that the path has.
    σ is σ/σ_max of the singular value of C(x0) that vanishes there."""
    x0 = configs[ref]
    if zero_modes <= cons.rigid(x0).shape[1] + 1:
        return None
    along = [cons.count(configs[k], RTOL)[0] for k in (ref - 1, ref + 1) if 0 <= k < len(configs)]
    if not along or min(along) >= zero_modes:
        return None
    sigma = cons.vanishing_sigma(x0, cons.jacobian(x0), min(along))
    return Singularity(ref, 0.0, zero_modes - min(along), sigma, "rank_drop")


def _kabsch(moving: np.ndarray, target: np.ndarray):
    """(centred moving p, centred target q, rotation R) with p @ R ≈ q the best proper fit.

    Kabsch: SVD of the covariance pᵀq, the last axis flipped if the optimal orthogonal map
    would be a reflection (det R = +1)."""
    p = moving - moving.mean(axis=0)
    q = target - target.mean(axis=0)
    u, _, vt = np.linalg.svd(p.T @ q)
    flip = np.ones(p.shape[1])
    flip[-1] = np.sign(np.linalg.det(u @ vt)) or 1.0
    return p, q, (u * flip) @ vt  # maps row vectors: p @ rotation ≈ q


def align_to(moving: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """``moving`` (N, d) after the proper rigid motion that minimises its sum of squared node
    distances to ``reference`` (N, d): centroids matched, rotation by Kabsch."""
    p, _, rotation = _kabsch(moving, reference)
    return p @ rotation + reference.mean(axis=0)


def kabsch_distance(moving: np.ndarray, target: np.ndarray) -> float:
    """min over proper rigid motions R (rotation, det +1, and translation) of ‖R·moving − target‖_F.

    moving, target: (k, d). The residual is formed explicitly (not from the singular values) so
    that distances near 1e-12 of the size keep their digits.
    """
    return float(kabsch_distances(moving[None], target)[0])


def kabsch_distances(moving: np.ndarray, target: np.ndarray) -> np.ndarray:
    """kabsch_distance of every point set in ``moving`` (s, k, d) to ``target`` (k, d): (s,).

    The s Kabsch problems at once (one batched SVD of the covariances pᵀq, the last axis of
    each flipped where its best orthogonal map is a reflection)."""
    p = moving - moving.mean(axis=1, keepdims=True)
    q = target - target.mean(axis=0)
    u, _, vt = np.linalg.svd(np.einsum("ski,kj->sij", p, q))
    flip = np.ones(u.shape[:2])
    flip[:, -1] = np.where(np.linalg.det(u @ vt) < 0, -1.0, 1.0)
    rotation = (u * flip[:, None, :]) @ vt
    return np.linalg.norm(p @ rotation - q, axis=(1, 2))


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
    dist = kabsch_distances(path.positions[:, spec], target)
    best = int(np.argmin(dist))
    tau, value = float(path.parameter[best]), float(dist[best])
    if len(dist) >= 2:
        polished = curve_minimum(path, best, lambda y: kabsch_distance(y[spec], target))
        if polished is not None and polished[1] < value:
            tau, value = polished
    return Fidelity(value / scale, tau, best in (0, len(dist) - 1))


def curve_minimum(path: MotionPath, k: int, distance):
    """Minimise ``distance`` (of a configuration in the path's coordinates) over the curve
    between samples k−1 and k+1; (parameter, distance) or None if the corrector fails."""
    ref = path.positions[path.reference_index]
    norm = Normalisation.of(ref)
    method = path.method if path.method in ("dense", "sparse") else "dense" if ref.size <= DENSE_MAX_DOF else "sparse"
    cons = BarConstraints(path.edges, norm.positions_in(ref), method)
    xs = norm.positions_in(path.positions)
    lo, hi = max(k - 1, 0), min(k + 1, len(xs) - 1)
    null, _ = _reference_null_space(cons, xs[k], explicit_mode=True)
    w = _tangent_frame(cons, xs[k], null, (xs[hi] - xs[lo]).ravel())
    if w is None:
        return None
    point = _Point(xs[k], w, cons.jacobian(xs[k]))
    sqrt_n = np.sqrt(cons.measured_nodes)
    # Pseudo-arclength offsets of the neighbours along t (the path parameter's own units).
    bounds = [float(point.t @ (xs[j] - xs[k]).ravel()) / sqrt_n for j in (lo, hi)]
    fallback = distance(path.positions[k])

    def along(s: float) -> float:
        pred = xs[k] + s * sqrt_n * point.t.reshape(xs[k].shape)
        got = _correct(cons, point, pred, tight=True)
        return fallback if got is None else distance(norm.positions_out(got[0]))

    res = minimize_scalar(along, bounds=bounds, method="bounded", options={"xatol": CURVE_MINIMUM_XATOL})
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
    u = single_mode(frame)
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


def single_mode(frame: Frame) -> np.ndarray:
    """The frame's single nontrivial zero mode as trace_motion follows it by default: (N, d),
    unit in dN, signed by signed_mode (DomainError ``ambiguous_mode`` or ``no_motion``
    otherwise)."""
    x0 = Normalisation.of(frame.positions).positions_in(frame.positions)
    method = "dense" if frame.dim * frame.n_nodes <= DENSE_MAX_DOF else "sparse"
    return start_direction(BarConstraints(frame.edges, x0, method), x0, None)[0].reshape(x0.shape)


def target_displacement(frame: Frame, motion_s=None, amplitude=None, targets=None):
    """Δ_S (k × d) and the relative amplitude a of a target of the specified nodes.

    With ``motion_s`` (u_S, k × d) and ``amplitude`` a: Δ_S = a·(r_S/ρ_u)·u_S, where r_S is the
    RMS radius of the specified positions and ρ_u = √(mean_i |u_Si|²): a is the RMS displacement
    of the specified nodes relative to their RMS size (a = 0.2 moves them by 20 % of it).
    With ``targets`` (final positions, k × d): Δ_S = targets − x_S and a = ρ_Δ/r_S.
    """
    spec = list(frame.specified)
    if len(spec) < 2:
        raise InvalidInput(
            "too_few_specified",
            "a target of the specified nodes needs at least 2 of them (a rigid motion reaches any target of one).",
        )
    x_s = frame.positions[spec]
    r_s = rms_radius(x_s)
    k = len(spec)
    if (motion_s is None) == (targets is None):
        raise InvalidInput(
            "invalid_request", "give exactly one of `motion` (with `amplitude`) or `targets`."
        )
    if targets is not None:
        y = check_positions(targets, frame.dim, name="targets")
        if y.shape[0] != k:
            raise InvalidInput(
                "invalid_shape", f"targets must have one row per specified node ({k})."
            )
        delta = y - x_s
        rho = float(np.sqrt(np.mean(np.sum(delta**2, axis=1))))
        if rho == 0:
            raise InvalidInput(
                "invalid_motion", "targets equal the specified positions: nothing to reach."
            )
        return delta, rho / r_s
    u = check_positions(motion_s, frame.dim, name="motion")
    if u.shape[0] != k:
        raise InvalidInput("invalid_shape", f"motion must have one row per specified node ({k}).")
    rho = float(np.sqrt(np.mean(np.sum(u**2, axis=1))))
    if rho == 0:
        raise InvalidInput("invalid_motion", "motion is zero.")
    if amplitude is None or not np.isfinite(amplitude) or amplitude <= 0:
        raise InvalidInput("invalid_amplitude", "amplitude must be a positive number.")
    return float(amplitude) * (r_s / rho) * u, float(amplitude)


def linear_target(frame: Frame, amplitude: float, motion_s=None, mode=None):
    """(Δ_S, a) of the linear target x_S + a·(r_S/ρ_u)·u_S (target_displacement) of the frame's
    specified nodes S: u_S = ``motion_s`` (k, d), else rows S of ``mode`` (N, d), else of the
    frame's single nontrivial mode (single_mode: the one trace_motion follows by default)."""
    spec = list(frame.specified)
    if motion_s is None and len(spec) >= 2:  # fewer: target_displacement's refusal, before any work
        u = single_mode(frame) if mode is None else given_mode(mode, frame.n_nodes, frame.dim)
        motion_s = u[spec]
    return target_displacement(frame, motion_s, amplitude)


@dataclass(frozen=True, eq=False)
class FidelityCurve:
    """ε(b) along the ray of a target x_S + Δ_S of relative amplitude a, on one traced path.

    Attributes
    ----------
    amplitudes : np.ndarray
        (m,): b_j = (j/m)·a, j = 1 … m; the last is a.
    epsilon : np.ndarray
        (m,): ε(b_j) = fidelity of the target x_S + (j/m)·Δ_S (module docstring).
    parameter : np.ndarray
        (m,): the path parameter τ where each minimum is attained.
    at_end : np.ndarray
        (m,) bool: the minimum sits at an end of the path (a longer path might do better, or
        the path ended at a singular point there).
    """

    amplitudes: np.ndarray
    epsilon: np.ndarray
    parameter: np.ndarray
    at_end: np.ndarray


def fidelity_curve(path: MotionPath, specified, x_s, displacement_s, amplitude: float, samples: int) -> FidelityCurve:
    """ε at ``samples`` = m amplitudes evenly spaced in (0, a] for the target x_S + Δ_S.

    specified: indices S (k); x_s, displacement_s (Δ_S): (k, d); amplitude a > 0 labels Δ_S.
    ε(b_j) = fidelity(path, S, x_S, Δ_S, j/m): the minimum over the path's samples polished on
    the constraint manifold (curve_minimum), with u_S = Δ_S, so the last value (j = m) is the
    very number motion_fidelity reports for this path.  Costs m fidelity evaluations: m
    distances per sample of the path and m one-dimensional minimisations of a few tight
    corrector solves each.
    """
    if samples < 1:
        raise InvalidInput("invalid_option", "an ε curve needs at least one amplitude.")
    fractions = np.arange(1, samples + 1) / samples
    points = [fidelity(path, specified, x_s, displacement_s, float(s)) for s in fractions]
    return FidelityCurve(
        amplitudes=float(amplitude) * fractions,
        epsilon=np.array([p.epsilon for p in points]),
        parameter=np.array([p.parameter for p in points]),
        at_end=np.array([p.at_end for p in points], dtype=bool),
    )
