"""Certificates for a frame: self-stresses, prestress stability, rigidity margin of a design.

Definitions (vectors of motions are flattened row-major, node i at rows d·i … d·i+d−1):

Self-stress (paper, Eq. 3): ω ∈ R^{N_B} with Cᵀω = 0, i.e. Σ_j ω_ij (x_i − x_j) = 0 at every
    node. Its stress matrix Ω = Σ_e ω_e (e_i − e_j)(e_i − e_j)ᵀ (N × N) gives the stress energy
    E_ω(q) = Σ_e ω_e ‖q_i − q_j‖² = qᵀ(Ω ⊗ I_d)q of a motion q; ω_e > 0 is tension.
    Every rigid motion is in the kernel of Ω ⊗ I_d (translations because Ω1 = 0, rotations by
    the equilibrium equations), so E_ω is a form on the nontrivial flexes alone.

Prestress stability (Connelly & Whiteley 1996): a frame is prestress stable when one
    self-stress ω has E_ω(q) > 0 for every nontrivial infinitesimal flex q. With F (dN × f) an
    orthonormal basis of the nontrivial flexes (⟂ rigid motions) and ω_1 … ω_s an orthonormal
    basis of the self-stresses, G_k = Fᵀ(Ω_k ⊗ I_d)F (f × f) and the margin is the SDP

        t* = max { t : Σ_k c_k G_k ⪰ t·I_f, ‖c‖₂ ≤ 1 }            (primal, c ∈ R^s)
           = min { ‖(⟨G_k, Y⟩)_k‖₂ : Y ⪰ 0, tr Y = 1 }              (dual, Y ∈ S^f)

    t* ≥ 0 always (c = 0); the frame is prestress stable iff t* > 0, certified by the stress
    ω = Σ c_k ω_k (‖ω‖ = 1) and refuted by the dual Y, a positive semidefinite combination of
    flexes on which every stress energy vanishes. ω and −ω are both stresses, hence the ball.
    t* is invariant under rigid motions and scaling of the frame (stresses and flexes are).

Rigidity margin of a design (mode isolation): with bar stiffnesses k ≥ 0, Σ_e k_e = N_B, the
    stiffness matrix K(k) = Cᵀ diag(k) C; with P (dN × p) an orthonormal basis of the complement
    of (rigid motions ⊕ designed modes), p = dN − ρ − M,

        λ*(k) = λ_min(Pᵀ K(k) P),    λ* = max { λ : Σ_e k_e a_e a_eᵀ ⪰ λ·I_p, k ≥ 0, Σ k = N_B }
                                        = N_B · min { max_e a_eᵀ Y a_e : Y ⪰ 0, tr Y = 1 }

    where a_e = Pᵀc_e (c_e the row of bar e of C). C is that of the scale-normalised frame
    (centred, RMS radius 1), so margins are dimensionless; k_e weighs (ℓ_e δℓ_e)², i.e. a
    physical spring constant κ_e corresponds to k_e = κ_e / ℓ_e². The uniform allocation k = 1
    gives σ_min(CP)². An undesigned zero mode makes every λ*(k) zero.

Both SDPs are "maximise λ_min(Σ x_i A_i) over a convex set X" (an `LmiProgram`). Modelling
(the A_i, in numpy) is kept apart from solving (cvxpy; Clarabel by default, SCS as fallback).
Every solution is verified outside the solver: the lower bound is λ_min at the returned x
(projected onto X) and the upper bound is the dual objective at the returned Y (projected onto
{Y ⪰ 0, tr Y = 1}); both are exact bounds on the optimum whatever the solver's accuracy.

Size: the SDPs have one LMI of size f (prestress) or p (margin). Clarabel factorises a dense
block of size n(n+1)/2 for an n × n LMI, so its time grows like n⁶: SDP_MAX_DIM caps n.
Beyond it: the prestress SDP is reduced exactly to the stresses that matter (prestress_program:
m̃ ≤ f(f+1)/2 variables however many self-stresses), its LMI stays f × f and is refused past
SDP_MAX_DIM; the optimal-stiffness margin goes to the interior-point route of stiffness.py (up
to OPTIMAL_MAX_DIM: the LMI reduced by the frame's reflection symmetries to orbit variables and
one block per character, solved by a primal–dual method written for its rank-one terms; a
spectral bundle method when the blocks stay too large), with the same verified bracket; the
uniform margin is one shift-invert eigen-solve (eigen.py). Sizes are checked from the request
before any analysis (check_size).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from zeromode.solver.analysis.bordered import BorderedFactor
from zeromode.solver.analysis.eigen import nontrivial_zero_modes, smallest_eigenpairs
from zeromode.solver.analysis.rank import RTOL, nullspace, orthonormal_range
from zeromode.solver.analysis.rigidity import (
    DENSE_MAX_DOF,
    Analysis,
    analyze,
    compatibility_matrix,
    rigid_motions,
    zero_mode_residual,
)
from zeromode.solver.budget import check_budget, remaining
from zeromode.solver.certificates.stiffness import optimal_stiffness
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.progress import progress_heartbeat, progress_stage, report_progress
from zeromode.solver.tolerances import GIVEN_MODE_RTOL, MARGIN_GAP_RTOL, PRESTRESS_TOL, SCS_EPS

SOLVERS = ("clarabel", "scs")
# Largest LMI (f or p) handed to a solver. Measured with Clarabel on the shared 2-core machine:
# 1–4 s at n = 37, 3–7 s at n = 47, 10–20 s at n = 57 (growing like n⁶). Larger complements
# go to stiffness.py (interior point or spectral bundle), prestress LMIs beyond it are refused.
SDP_MAX_DIM = 48


def sdp_expected_s(n: int) -> float:
    """A solve's expected seconds for an n × n LMI (the figures above: ~2.5 s at n = 37, ∝ n⁶),
    for progress only (progress_heartbeat's clock scale)."""
    return max(2.5 * (n / 37) ** 6, 0.05)
# Largest frame certified (d·N): the analysis, the prestress projections and the uniform margin
# are sparse (a few seconds at dN = 15 000, the 50 × 50 auxetic sheet).
MAX_DOF = 60_000
# Largest complement p = dN − ρ − M for the optimal-stiffness margin (interior-point route:
# each iteration costs Σ_χ (m² p_χ + m p_χ² + p_χ³) for m bar orbits and blocks p_χ; the
# 20 × 20 auxetic sheet, p = 2478, reduces to 4 blocks of 620 and 800 orbits).
OPTIMAL_MAX_DIM = 2_500


# ----------------------------------------------------------------------------- modelling


@dataclass(frozen=True, eq=False)
class LmiProgram:
    """maximise λ subject to Σ_i x_i A_i ⪰ λ·I_n, x ∈ X.

    matrices: (m, n, n) symmetric A_i. domain: "ball" (‖x‖₂ ≤ 1) or "simplex"
    (x ≥ 0, Σ x = total). The dual is min { h_X(g(Y)) : Y ⪰ 0, tr Y = 1 } with
    g_i(Y) = ⟨A_i, Y⟩ and h_X the support function of X: ‖g‖₂ (ball), total·max g (simplex).
    """

    matrices: np.ndarray
    domain: str
    total: float = 1.0

    @property
    def size(self) -> int:
        return int(self.matrices.shape[1])

    def project(self, x: np.ndarray) -> np.ndarray:
        """A point of X from a solver's (possibly slightly infeasible) x."""
        if self.domain == "ball":
            norm = np.linalg.norm(x)
            # λ_min is homogeneous: a unit x gives the largest positive value along the ray.
            return x / norm if norm > 0 else x
        k = np.maximum(x, 0.0)
        return k * (self.total / k.sum()) if k.sum() > 0 else np.full_like(x, self.total / x.size)

    def lower_bound(self, x: np.ndarray) -> float:
        """λ_min(Σ x_i A_i) for x ∈ X: a value the program attains."""
        return float(np.linalg.eigvalsh(np.tensordot(x, self.matrices, axes=1))[0])

    def upper_bound(self, y: np.ndarray) -> float:
        """h_X(g(Y)) after projecting Y onto {Y ⪰ 0, tr Y = 1}: weak duality bounds λ* by it."""
        w, u = np.linalg.eigh((y + y.T) / 2)
        w = np.maximum(w, 0.0)
        if w.sum() <= 0:
            return np.inf
        y = (u * (w / w.sum())) @ u.T
        g = np.tensordot(self.matrices, y, axes=([1, 2], [0, 1]))
        return float(np.linalg.norm(g)) if self.domain == "ball" else float(self.total * g.max())


def stress_energy_forms(flexes: np.ndarray, stresses: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """G_k = Fᵀ(Ω_k ⊗ I_d)F, shape (s, f, f), from flexes (f, N, d) and stresses (s, N_B).

    Σ_e ω_e D_eᵀD_e with D_e = F_i − F_j (d × f): one pass over the bars, never dN × dN.
    """
    diff = flexes[:, edges[:, 0], :] - flexes[:, edges[:, 1], :]  # (f, N_B, d)
    per_bar = np.einsum("aeu,beu->eab", diff, diff)  # (N_B, f, f)
    return np.tensordot(stresses, per_bar, axes=1)


def bar_products(flexes: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """q^{ab}_e = (F_a,i − F_a,j)·(F_b,i − F_b,j) for a ≤ b, shape (N_B, f(f+1)/2), from flexes
    (f, N, d): the stress energy of stress ω on flexes a, b is ωᵀq^{ab}."""
    diff = flexes[:, edges[:, 0], :] - flexes[:, edges[:, 1], :]  # (f, N_B, d)
    a, b = np.triu_indices(len(flexes))
    return np.einsum("aed,aed->ea", diff[a], diff[b])


def stress_projection(q: np.ndarray, c, stresses: np.ndarray | None, null: np.ndarray) -> np.ndarray:
    """Π q: the projection of the columns of q (N_B × m) onto the self-stresses N(Cᵀ).

    With a stress basis S (s × N_B, orthonormal): S Sᵀ q. Without one (too large to keep): q − C y
    with CᵀC y = Cᵀq, y ⟂ N(C), solved with the bordered matrix [[CᵀC, W], [Wᵀ, 0]] (W = the
    orthonormal basis ``null`` of N(C), bordered.py), plus one refinement step on the residual
    Cᵀ(Π q) — which vanishes exactly for a projection."""
    if stresses is not None:
        return stresses.T @ (stresses @ q)
    gram = BorderedFactor(sp.csc_matrix(c.T @ c), null)
    projected = q - c @ gram.solve(c.T @ q)[0]
    return projected - c @ gram.solve(c.T @ projected)[0]


def prestress_program(flexes: np.ndarray, projected: np.ndarray, edges: np.ndarray):
    """The prestress-stability SDP over the flexes F (f, N, d) and an orthonormal basis S̃ of
    span{Π q^{ab}} (N_B × m̃, m̃ ≤ f(f+1)/2); returns (LmiProgram, S̃).

    Exact reduction: the energy form of a stress ω is G(ω)_ab = ωᵀq^{ab} = ωᵀΠq^{ab}, so the part
    of ω orthogonal to S̃ (still a stress) changes no G but spends norm; the optimum over the unit
    ball of stresses lies in S̃, and the dual objective ‖(⟨G_k, Y⟩)_k‖ over S̃ equals the one over
    any orthonormal stress basis (‖Π q(Y)‖ with Π q(Y) ∈ S̃). So the SDP has m̃ variables however
    many stresses the frame has."""
    basis = orthonormal_range(projected, RTOL)
    return LmiProgram(stress_energy_forms(flexes, basis.T, edges), "ball"), basis


def stiffness_program(a: np.ndarray) -> LmiProgram:
    """The stiffness-allocation SDP: A_e = a_e a_eᵀ for the rows a_e of CP (N_B × p), Σ k = N_B."""
    return LmiProgram(a[:, :, None] * a[:, None, :], "simplex", total=float(a.shape[0]))


# ----------------------------------------------------------------------------- solving


@dataclass(frozen=True)
class SolverRun:
    """One attempt: solver name, cvxpy status, wall time."""

    solver: str
    status: str
    time_ms: float


@dataclass(frozen=True, eq=False)
class LmiSolution:
    """A verified solution: x ∈ X with λ_min(Σ x_i A_i) = lower ≤ λ* ≤ upper.

    solver/status/time_ms describe the accepted attempt; attempts lists every attempt in order.
    """

    x: np.ndarray
    lower: float
    upper: float
    solver: str
    status: str
    time_ms: float
    attempts: tuple[SolverRun, ...]


def _solve_once(program: LmiProgram, solver: str, time_limit: float | None, max_iters: int | None):
    """One cvxpy solve; returns (x, Y, status) with x, Y None when the solver gave nothing."""
    # Imported here: cvxpy takes seconds to import, and only the SDP stage needs it, so service
    # workers that never certify start fast (model no more than the scene needs).
    import cvxpy as cp

    m, n, _ = program.matrices.shape
    x = cp.Variable(m, nonneg=program.domain == "simplex")
    lam = cp.Variable()
    coefficients = program.matrices.reshape(m, n * n).T  # column i = vec(A_i)
    lmi = cp.reshape(coefficients @ x, (n, n), order="F") - lam * np.eye(n) >> 0
    domain = cp.norm(x, 2) <= 1 if program.domain == "ball" else cp.sum(x) == program.total
    problem = cp.Problem(cp.Maximize(lam), [lmi, domain])
    if solver == "clarabel":
        name, limits = cp.CLARABEL, {"time_limit": time_limit, "max_iter": max_iters}
        options = {}
    else:
        name, limits = cp.SCS, {"time_limit_secs": time_limit, "max_iters": max_iters}
        options = {"eps_abs": SCS_EPS, "eps_rel": SCS_EPS}
    options.update({key: value for key, value in limits.items() if value is not None})
    try:
        with warnings.catch_warnings():
            # "Solution may be inaccurate": the caller verifies every solution itself.
            warnings.simplefilter("ignore", UserWarning)
            problem.solve(solver=name, **options)
    except cp.error.SolverError:
        return None, None, "solver_error"
    status = str(problem.status)
    if x.value is None or lmi.dual_value is None or not np.all(np.isfinite(x.value)):
        return None, None, status
    return np.asarray(x.value, dtype=float), np.asarray(lmi.dual_value, dtype=float), status


class CertificateFailed(DomainError):
    """``certificate_failed``: every attempt at an n × n LMI failed; ``attempts`` records them
    in order, ``best`` the widest verified bracket known when there is one."""

    def __init__(self, size: int, attempts: tuple[SolverRun, ...], best: tuple[float, float] | None = None):
        summary = "; ".join(f"{a.solver}: {a.status}" for a in attempts)
        bracket = "" if best is None else f"; best verified bracket [{best[0]:.6g}, {best[1]:.6g}]"
        super().__init__("certificate_failed",
                         f"no solver produced a verified certificate for the {size}×{size} SDP ({summary}){bracket}.")
        self.size, self.attempts = size, attempts


def solve_lmi(
    program: LmiProgram, solver: str = "clarabel", accept=None, max_iters: int | None = None
) -> LmiSolution:
    """Solve ``program`` with ``solver``, then the other solver if the first fails.

    An attempt fails when the solver returns no solution, a status other than optimal /
    optimal_inaccurate, or verified bounds that ``accept(lower, upper)`` rejects. Each attempt
    gets what is left of the request's time budget (budget.py); once that is spent:
    DomainError ``too_expensive``. When every attempt fails: ``certificate_failed`` naming each
    solver and its status.
    """
    if solver not in SOLVERS:
        raise InvalidInput(
            "invalid_solver", f"solver must be one of {', '.join(SOLVERS)}, got {solver!r}."
        )
    order = (solver,) + tuple(s for s in SOLVERS if s != solver)
    attempts = []
    for i, name in enumerate(order):
        check_budget()
        t0 = time.perf_counter()
        with (
            progress_stage(i / len(order), (i + 1) / len(order), f"{program.size}×{program.size} SDP with {name}"),
            progress_heartbeat(sdp_expected_s(program.size), "solving"),
        ):
            x, y, status = _solve_once(program, name, remaining(), max_iters)
        if x is not None:
            x = program.project(x)
            lower, upper = program.lower_bound(x), program.upper_bound(y)
            verified = np.isfinite(upper) and (accept is None or accept(lower, upper))
            if status in ("optimal", "optimal_inaccurate") and verified:
                run = SolverRun(name, status, 1e3 * (time.perf_counter() - t0))
                attempts.append(run)
                return LmiSolution(x, lower, upper, name, status, run.time_ms, tuple(attempts))
            if status in ("optimal", "optimal_inaccurate"):
                status = f"{status}_unverified"
        attempts.append(SolverRun(name, status, 1e3 * (time.perf_counter() - t0)))
    check_budget()  # a solver stopped by the time limit is a budget failure, not a math one
    raise CertificateFailed(program.size, tuple(attempts))


# ----------------------------------------------------------------------------- certificates


@dataclass(frozen=True, eq=False)
class SelfStressCertificate:
    """Count and orthonormal basis (s, N_B) of the self-stresses, with the rank evidence.

    smallest_nonzero / largest_zero: σ_r and σ_{r+1} of the scale-normalised C (0 if none).
    equilibrium_residual: max_k ‖Cᵀω_k‖ / ‖C‖_F over the basis (0 when there is none).
    """

    count: int
    basis: np.ndarray
    basis_included: bool
    smallest_nonzero: float
    largest_zero: float
    equilibrium_residual: float


@dataclass(frozen=True, eq=False)
class PrestressCertificate:
    """Prestress stability. decided_by: "infinitesimal_rigidity" (f = 0, stable, no margin),
    "no_self_stress" (f > 0, s = 0, not stable, margin 0) or "sdp".

    margin ≤ t* ≤ margin_upper_bound; stress: the certifying unit self-stress (N_B) when stable.
    """

    prestress_stable: bool
    decided_by: str
    flexes: int
    stresses: int
    margin: float | None
    margin_upper_bound: float | None
    stress: np.ndarray | None
    threshold: float
    sdp: LmiSolution | None


@dataclass(frozen=True, eq=False)
class RigidityMargin:
    """Mode isolation of a design: λ_min(Pᵀ K(k) P) for uniform and optimal k.

    optimal ≤ λ* ≤ optimal_upper_bound; stiffness: the optimal allocation (N_B, Σ = N_B);
    gain = optimal / uniform. uniform is None when the complement is empty (p = 0). With
    undesigned zero modes every margin is 0 and no SDP runs; the other optimal fields are None
    when the SDP did not run.
    """

    designed_modes: int
    complement_dim: int
    undesigned_zero_modes: int
    uniform: float | None
    optimal: float | None = None
    optimal_upper_bound: float | None = None
    gain: float | None = field(init=False, default=None)  # optimal / uniform, derived
    stiffness: np.ndarray | None = None
    sdp: LmiSolution | None = None

    def __post_init__(self) -> None:
        positive = self.uniform is not None and self.uniform > 0
        gain = self.optimal / self.uniform if self.optimal is not None and positive else None
        object.__setattr__(self, "gain", gain)


@dataclass(frozen=True, eq=False)
class Certificate:
    """The three certificates of one frame, its analysis, and timings in milliseconds.

    Attributes
    ----------
    analysis : Analysis
        The frame's analysis.
    self_stress : SelfStressCertificate
        The self-stress count and basis with their evidence (Cᵀ s = 0).
    prestress : PrestressCertificate
        Prestress stability: decided by infinitesimal rigidity, by the absence of self-stress,
        or by the SDP with its margin.
    rigidity_margin : RigidityMargin
        Mode isolation: λ_min(Pᵀ K(k) P) for uniform and optimal stiffnesses k.
    timings_ms : dict
        Wall time of each certificate.
    """

    analysis: Analysis
    self_stress: SelfStressCertificate
    prestress: PrestressCertificate
    rigidity_margin: RigidityMargin
    timings_ms: dict = field(default_factory=dict)


def self_stress_certificate(analysis: Analysis, c) -> SelfStressCertificate:
    """Self-stress count, basis and evidence from ``analysis`` and the normalised C (sparse)."""
    basis = analysis.stresses
    residual = 0.0
    if basis.size:
        residual = float(np.max(np.linalg.norm(c.T @ basis.T, axis=0)) / spla.norm(c))
    return SelfStressCertificate(
        count=analysis.self_stresses,
        basis=basis,
        basis_included=analysis.bases_included,
        smallest_nonzero=analysis.rank_gap.last_nonzero,
        largest_zero=analysis.rank_gap.first_zero,
        equilibrium_residual=residual,
    )


def prestress_certificate(
    analysis: Analysis, edges: np.ndarray, c, null, solver: str = "clarabel", **solve_options
) -> PrestressCertificate:
    """Decide prestress stability; run the SDP only when there are both flexes and stresses.

    c: the normalised C; null: a callable returning (rigid motions, nontrivial flexes) as
    orthonormal columns (computed only when the SDP runs)."""
    f, s = analysis.nontrivial_zero_modes, analysis.self_stresses
    if f == 0:
        return PrestressCertificate(
            True, "infinitesimal_rigidity", 0, s, None, None, None, PRESTRESS_TOL, None
        )
    if s == 0:
        return PrestressCertificate(
            False, "no_self_stress", f, 0, 0.0, 0.0, None, PRESTRESS_TOL, None
        )
    if f > SDP_MAX_DIM:
        raise DomainError(
            "too_expensive",
            f"the frame has {f} nontrivial flexes; the prestress SDP is limited to {SDP_MAX_DIM}.",
        )
    rigid, flexes = null()
    n, d = analysis.nodes, analysis.dim
    q = bar_products(flexes.T.reshape(f, n, d), edges)
    stresses = analysis.stresses if analysis.bases_included else None
    program, basis = prestress_program(
        flexes.T.reshape(f, n, d),
        stress_projection(q, c, stresses, np.column_stack([rigid, flexes])),
        edges,
    )
    # The bracket must fall on one side of the threshold, or the solve does not decide anything.
    solution = solve_lmi(
        program,
        solver,
        accept=lambda lo, up: lo > PRESTRESS_TOL or up <= PRESTRESS_TOL,
        **solve_options,
    )
    stable = solution.lower > PRESTRESS_TOL
    stress = basis @ solution.x if stable else None
    return PrestressCertificate(
        stable,
        "sdp",
        f,
        s,
        max(solution.lower, 0.0),
        solution.upper,
        stress,
        PRESTRESS_TOL,
        solution,
    )


def designed_mode_basis(frame: Frame, rigid: np.ndarray, modes) -> np.ndarray:
    """Orthonormal basis (dN × (ρ + M)) of rigid motions ⊕ designed modes, after validation.

    modes: M arrays of shape (N, d). Raises InvalidInput ``invalid_modes`` naming the first mode
    that has the wrong shape, is not a zero mode, or adds nothing to the earlier span.
    """
    n, d = frame.n_nodes, frame.dim
    span = rigid
    for i, mode in enumerate(modes):
        try:
            m = np.asarray(mode, dtype=float)
        except (TypeError, ValueError, OverflowError):  # ragged rows or non-numbers
            raise InvalidInput("invalid_modes", f"modes[{i}] must be an {n}×{d} array of numbers.") from None
        if m.shape != (n, d):
            raise InvalidInput("invalid_modes", f"modes[{i}] must be {n}×{d}, got shape {m.shape}.")
        if not np.all(np.isfinite(m)):
            raise InvalidInput("invalid_modes", f"modes[{i}] holds a number that is not finite.")
        v = m.ravel()
        norm = np.linalg.norm(v)
        if norm == 0:
            raise InvalidInput("invalid_modes", f"modes[{i}] is zero.")
        residual = zero_mode_residual(frame, m)
        if not residual <= GIVEN_MODE_RTOL:  # also catches NaN
            raise InvalidInput(
                "invalid_modes",
                f"modes[{i}] is not a zero mode of the frame: ‖C m‖/(‖C‖_F‖m‖) = {residual:.2e} > {GIVEN_MODE_RTOL:g}.",
            )
        outside = v - span @ (span.T @ v)
        if np.linalg.norm(outside) <= GIVEN_MODE_RTOL * norm:
            raise InvalidInput(
                "invalid_modes",
                f"modes[{i}] is a combination of the rigid motions and the modes before it.",
            )
        span = orthonormal_range(np.column_stack([span, outside]), RTOL)
    return span


def rigidity_margin(
    frame: Frame,
    analysis: Analysis,
    c,
    modes=(),
    stiffness: bool = True,
    solver: str = "clarabel",
    **solve_options,
) -> RigidityMargin:
    """Margin of the design (frame, designed modes) for uniform and, if asked, optimal stiffness."""
    n_dof = frame.dim * frame.n_nodes
    span = designed_mode_basis(frame, analysis.rigid_basis, modes)
    m = span.shape[1] - analysis.rigid_body_modes
    p = n_dof - span.shape[1]
    undesigned = max(analysis.nontrivial_zero_modes - m, 0)
    if p == 0:
        # Every motion is rigid or designed: there is nothing left to isolate.
        return RigidityMargin(m, 0, 0, None)
    if undesigned > 0:
        # An undesigned zero mode q has K(k)q = 0 for every k: all margins vanish, no SDP needed.
        zero = 0.0 if stiffness else None
        return RigidityMargin(m, p, undesigned, 0.0, optimal=zero, optimal_upper_bound=zero)
    if n_dof > DENSE_MAX_DOF:
        # λ_min of CᵀC on span^⊥ by shift-invert Lanczos; span ⊆ N(C) up to the given modes'
        # tolerance, so this is σ_{dN−ρ−M}(C)² (eigen.py: a Rayleigh quotient, residual ~1e-16).
        uniform = float(smallest_eigenpairs(sp.csc_matrix(c.T @ c), 1, deflate=span).values[0])
        if not stiffness:
            return RigidityMargin(m, p, 0, uniform)
        return _large_margin(frame, m, p, uniform, c, span)
    complement, _, _ = nullspace(span.T)
    a = c @ complement  # (N_B, p): rows a_e = Pᵀ c_e
    uniform = float(np.linalg.svd(a, compute_uv=False)[-1] ** 2) if a.shape[0] >= p else 0.0
    if not stiffness:
        return RigidityMargin(m, p, 0, uniform)
    if p > SDP_MAX_DIM:
        return _large_margin(frame, m, p, uniform, c, span)
    try:
        solution = solve_lmi(
            stiffness_program(a),
            solver,
            # k = 1 is feasible, so a verified optimum below the uniform margin is a failed solve.
            accept=lambda lo, up: (
                lo >= uniform * (1 - MARGIN_GAP_RTOL) and up - lo <= MARGIN_GAP_RTOL * up
            ),
            **solve_options,
        )
    except CertificateFailed as exc:
        # Neither conic solver's answer verified (an ill-conditioned allocation: a finite-strain
        # trammel sheet, 46 × 46): the interior-point route of stiffness.py, whose bracket is
        # verified on the frame itself, is the method's other way to the same optimum.
        margin = _large_margin(frame, m, p, uniform, c, span)
        attempts = exc.attempts + margin.sdp.attempts
        if margin.sdp.status != "optimal" or margin.optimal < uniform * (1 - MARGIN_GAP_RTOL):
            raise CertificateFailed(p, attempts, (margin.optimal, margin.optimal_upper_bound)) from exc
        return replace(margin, sdp=replace(margin.sdp, attempts=attempts))
    return RigidityMargin(m, p, 0, uniform, solution.lower, solution.upper, stiffness=solution.x, sdp=solution)


def _large_margin(frame: Frame, m: int, p: int, uniform: float, c, span) -> RigidityMargin:
    """The optimal margin of a complement beyond SDP_MAX_DIM: the interior-point route
    (stiffness.py, reduced by the symmetries of the normalised frame), its verified bracket
    recorded like an SDP solution (solver "interior_point", or "spectral_bundle" for a frame
    whose reduced blocks stay too large; status "optimal" or "gap_not_closed")."""
    result = optimal_stiffness(c, span, uniform, frame.normalised_positions(), frame.edges)
    run = SolverRun(result.method, result.status, result.time_ms)
    record = LmiSolution(
        result.stiffness, result.lower, result.upper, run.solver, run.status, run.time_ms, (run,)
    )
    return RigidityMargin(m, p, 0, uniform, result.lower, result.upper, stiffness=result.stiffness, sdp=record)


def check_size(frame: Frame, n_modes: int, stiffness: bool) -> None:
    """Refuse (DomainError ``too_expensive``) a request beyond the limits, from its sizes alone.

    dN > MAX_DOF, or with ``stiffness`` a complement p = dN − d(d+1)/2 − M beyond
    OPTIMAL_MAX_DIM (ρ = d(d+1)/2 unless the nodes are degenerate, so p is never
    underestimated by more than the few rigid motions a degenerate frame lacks)."""
    n_dof = frame.dim * frame.n_nodes
    if n_dof > MAX_DOF:
        raise DomainError(
            "too_expensive",
            f"certificates are computed for frames of up to {MAX_DOF} degrees of freedom (d·N); "
            f"this one has {n_dof}.",
        )
    p = n_dof - frame.dim * (frame.dim + 1) // 2 - n_modes
    if stiffness and p > OPTIMAL_MAX_DIM:
        raise DomainError(
            "too_expensive",
            f"the optimal-stiffness margin is computed for complements of up to {OPTIMAL_MAX_DIM} "
            f"motions (p = dN − ρ − M); this frame has p = {p}. With stiffness = false the "
            "uniform margin alone is computed, for frames up to "
            f"{MAX_DOF} degrees of freedom.",
        )


def check_certify_request(frame: Frame, modes, solver: str, stiffness: bool) -> None:
    """certify's refusals that need no analysis: InvalidInput ``invalid_solver``, DomainError
    ``too_expensive`` (check_size), InvalidInput ``invalid_modes`` (designed_mode_basis against
    the rigid motions of the frame's normalised positions, the analysis's rigid basis)."""
    if solver not in SOLVERS:
        raise InvalidInput(
            "invalid_solver", f"solver must be one of {', '.join(SOLVERS)}, got {solver!r}."
        )
    check_size(frame, len(modes), stiffness)
    designed_mode_basis(frame, rigid_motions(frame.normalised_positions(), RTOL), modes)


def certify(
    frame: Frame,
    modes=None,
    *,
    solver: str = "clarabel",
    stiffness: bool = True,
    max_iters: int | None = None,
    analysis: Analysis | None = None,
) -> Certificate:
    """Self-stress certificate, prestress stability and rigidity margin of ``frame``.

    modes: optional designed modes, each (N, d) (e.g. the ``modes`` of a /v1/design answer);
    they must be zero modes, independent modulo rigid motions. solver: "clarabel" or "scs"
    (the other one is the fallback). stiffness: also run the stiffness-allocation SDP.
    max_iters caps each solver attempt; the time budget of budget.py bounds the whole call.
    analysis: the frame's analysis with bases when the caller already has it (the pipeline
    passes the design's), so it is not recomputed.
    Raises InvalidInput (bad modes/solver), DomainError ``too_expensive`` / ``certificate_failed``.
    """
    t0 = time.perf_counter()
    check_certify_request(frame, modes or (), solver, stiffness)
    if analysis is None:
        with progress_stage(0.0, 0.2, "analysis", detail=True):
            analysis = analyze(frame)
    c = compatibility_matrix(frame.normalised_positions(), frame.edges)
    t1 = time.perf_counter()
    report_progress(0.2, "analysed the frame")
    certificate = self_stress_certificate(analysis, c)

    def null():
        """(rigid motions, nontrivial flexes) of the analysis, or from CᵀC when it kept none."""
        if analysis.bases_included:
            return analysis.rigid_basis, analysis.modes.reshape(len(analysis.modes), -1).T
        f = analysis.nontrivial_zero_modes
        return analysis.rigid_basis, nontrivial_zero_modes(c, analysis.rigid_basis, f)

    with progress_stage(0.2, 0.5, "prestress stability"):
        prestress = prestress_certificate(analysis, frame.edges, c, null, solver, max_iters=max_iters)
    t2 = time.perf_counter()
    with progress_stage(0.5, 1.0, "rigidity margin"):
        margin = rigidity_margin(
            frame, analysis, c, modes or (), stiffness, solver, max_iters=max_iters
        )
    t3 = time.perf_counter()
    return Certificate(
        analysis,
        certificate,
        prestress,
        margin,
        {
            "analysis": 1e3 * (t1 - t0),
            "prestress": 1e3 * (t2 - t1),
            "rigidity_margin": 1e3 * (t3 - t2),
            "total": 1e3 * (t3 - t0),
        },
    )
