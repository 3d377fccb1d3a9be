"""Nonlinear refinement of unspecified node positions for finite-motion fidelity (casadi + IPOPT).

The quadric construction places the unspecified nodes so that u_S is an exact *infinitesimal*
zero mode; along a finite motion the specified nodes drift (finite_motion.fidelity measures
by how much).  Refinement moves the unspecified nodes so that the mechanism carries the
specified nodes to x_S + Δ_S along a continuous path, Δ_S = a·u_S.

Nonlinear program (normalised coordinates: frame centred and divided by its RMS radius r):
    unknowns   x_U                 reference positions of the unspecified nodes (N_U × d);
               X_1 … X_{K−1}        intermediate configurations (N × d each);
               X_{K,U}             the unspecified nodes of the final configuration
               (X_0 = (x_S, x_U) and X_{K,S} = x_S + Δ_S are constants, which fixes the
               rigid-motion gauge at both ends);
    equalities |X_{j,i} − X_{j,k}|² = |X_{0,i} − X_{0,k}|²  for every bar (i, k), j = 1 … K
               (every configuration has the reference bar lengths);
    separation |X_i − X_j| ≥ MIN_SEPARATION·(closest such pair in the design) at both ends, for
               every pair without a bar that has an unspecified node (merged nodes make a
               degenerate frame);
    objective  (1/(K·N)) Σ_j ‖X_j − ((1 − j/K)·X_0 + (j/K)·X_K)‖²  +  μ‖x_U − x_U⁰‖²/N_U
               — departure from the straight path (for the specified nodes that is the
               straight route x_S + (j/K)·Δ_S); it also fixes the gauge of the intermediate
               configurations.  The small μ picks, among equally straight solutions, the
               one nearest the design.
    option     stay_on_solution_space: also keep u_S an exact zero mode at the reference, i.e.
               C(X_0)·(u_S, u_U) = 0 with u_U (N_U × d) extra unknowns — every x_U stays on
               the solution space of the paper's quadric (Eq. 6) for u_S.
casadi builds the problem symbolically, so IPOPT gets the exact gradient, Jacobian and Hessian
of the Lagrangian.  IPOPT starts from the linear motion X_j = X_0 + (j/K)·α·u (u the frame's
nontrivial mode, α fitted to Δ_S).

After IPOPT the result is re-verified through independent routes: the rigidity analysis at the
refined reference X_0 and at X_K (no new self-stress, exactly one nontrivial zero mode at both)
and ε after refinement measured by continuation (finite_motion.motion_fidelity) from the
refined reference — not from IPOPT's own configurations.  The target counts as reached when
ε after ≤ max(1e-6, 100·tol); otherwise IPOPT's configurations were not one continuous motion
(they straddle two branches of the configuration space) and the solve is retried once with 2K.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from zeromode.solver.analysis.normalisation import Normalisation, rms_radius
from zeromode.solver.analysis.rigidity import Analysis, analyze
from zeromode.solver.budget import check_budget, remaining
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.motion.finite_motion import (
    CURVE_SAMPLES,
    FidelityCurve,
    MotionPath,
    _kabsch,
    bar_lengths,
    fidelity_curve,
    kabsch_distance,
    motion_fidelity,
    relative_bar_error,
    target_displacement,
)
from zeromode.solver.progress import progress_heartbeat, progress_stage, report_progress
from zeromode.solver.tolerances import IPOPT_TOL, REACHED_EPS, REPORT_MIN_TIME_S

# Weight of ‖x_U − x_U⁰‖² relative to the straight-path term (see the module docstring).
DESIGN_WEIGHT = 1e-3
# Unspecified nodes keep at least this fraction of the design's closest node distance.
MIN_SEPARATION = 0.25
# The target counts as reached when ε after ≤ max(REACHED_EPS, REACHED_PER_TOL·tol).
REACHED_PER_TOL = 100.0
# A refinement that misses the target for lack of intermediate configurations is retried once
# with 2K of them, up to this many.
MAX_K = 64
# IPOPT unknowns are capped so one refinement stays within a request's time budget.
MAX_UNKNOWNS = 20_000
IPOPT_SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")
# Progress of one attempt: the NLP built at NLP_SHARE[0], IPOPT's iterations up to NLP_SHARE[1],
# then the re-verification (analyses, the refined frame's finite motion).
NLP_SHARE = (0.1, 0.7)
# Clock scale of the NLP's construction and derivation for progress_heartbeat (progress only):
# about a second for the benchmark designs, far more near MAX_UNKNOWNS.
NLP_EXPECTED_S = 1.0


@dataclass(frozen=True, eq=False)
class Refinement:
    """The result of refine(): a frame whose finite motion follows the target.

    Attributes
    ----------
    frame : Frame
        The refined frame (or, after a failure, the best frame found: the refined one if its ε
        is smaller than the original's, else the original, with epsilon_after = epsilon_before).
    displacement : np.ndarray
        Δ_S (k × d), the specified nodes' target displacement.
    amplitude : float
        Its relative amplitude a.
    epsilon_before, epsilon_after : float
        Finite-motion fidelity ε of the original and of the refined frame.
    ipopt_status : str
        IPOPT's status ("not_needed" when it was not run).
    iterations : int
        IPOPT's iteration count (0 when IPOPT stopped before iterating, or was not run: a target
        that is a rigid motion of x_S is reached by the frame as it is, ε = 0).
    K : int
        The steps of the discretised path.
    attempts : int
        How many IPOPT runs were made.
    time_ms, ipopt_time_ms : float
        Wall time of the refinement and of IPOPT in it.
    path : np.ndarray
        (K+1, N, d): IPOPT's last iterate X_0 … X_K in the frame's coordinates, kept for
        diagnosis after a failure too.
    max_relative_bar_error : float
        The largest relative change of a bar's length along ``path``.
    analysis_reference, analysis_end : Analysis or None
        The analyses of the path's first and last configurations.
    ok : bool
        Whether the refinement succeeded (re-verified).
    message : str
        One sentence on the outcome.
    mode : np.ndarray or None
        (N, d): the refined frame's nontrivial zero mode at its reference, None when it has not
        exactly one.
    curve_before, curve_after : FidelityCurve or None
        ε(b) at CURVE_SAMPLES amplitudes b in (0, a] on the paths that measured epsilon_before
        and epsilon_after (their last values are those two numbers; curve_after is curve_before
        when the original frame is kept); None for a rigid target (no path is traced).
    """

    frame: Frame
    displacement: np.ndarray
    amplitude: float
    epsilon_before: float
    epsilon_after: float
    ipopt_status: str
    iterations: int
    K: int
    attempts: int
    time_ms: float
    ipopt_time_ms: float
    path: np.ndarray
    max_relative_bar_error: float
    analysis_reference: Analysis | None
    analysis_end: Analysis | None
    ok: bool
    message: str
    mode: np.ndarray | None = None
    curve_before: FidelityCurve | None = None
    curve_after: FidelityCurve | None = None


class RefinementFailed(DomainError):
    """IPOPT did not converge, or its result failed re-verification; ``best`` holds the best
    result found (see Refinement.frame)."""

    def __init__(self, best: Refinement):
        super().__init__("refinement_failed", best.message)
        self.best = best


def _single_mode(analysis: Analysis) -> bool:
    return analysis.nontrivial_zero_modes == 1


def nlp_counts(n: int, d: int, n_unspecified: int, n_bars: int, K: int, stay: bool) -> tuple[int, int]:
    """(equalities, unknowns) of the NLP (module docstring): K·N_B bar equations (+ N_B for
    C(X_0)·u = 0) against N_U·d + (K − 1)·N·d + N_U·d coordinates (+ N_U·d mode rates).  IPOPT
    refuses a problem with more equalities than unknowns whatever their redundancy."""
    equalities = K * n_bars + (n_bars if stay else 0)
    unknowns = (2 + int(stay)) * n_unspecified * d + (K - 1) * n * d
    return equalities, unknowns


def check_problem_size(frame: Frame, K: int, stay_on_solution_space: bool = False) -> None:
    """refine's refusals from the frame's sizes alone (nlp_counts), before any analysis:
    InvalidInput ``nothing_to_refine`` (no unspecified node) or ``invalid_option`` (K < 1),
    DomainError ``too_expensive`` (more than MAX_UNKNOWNS unknowns) or ``too_few_unknowns``
    (more bar equations than unknowns: IPOPT cannot start)."""
    n_unspecified = frame.n_nodes - len(frame.specified)
    if n_unspecified == 0:
        raise InvalidInput("nothing_to_refine", "the frame has no unspecified node to move.")
    if K < 1:
        raise InvalidInput("invalid_option", "K must be at least 1.")
    n_bars = frame.n_edges
    equalities, unknowns = nlp_counts(frame.n_nodes, frame.dim, n_unspecified, n_bars, K, stay_on_solution_space)
    if unknowns > MAX_UNKNOWNS:
        raise DomainError(
            "too_expensive",
            f"the refinement would have {unknowns} unknowns (limit {MAX_UNKNOWNS}); lower K or use a smaller frame.",
        )
    if equalities > unknowns:
        raise DomainError(
            "too_few_unknowns",
            f"the refinement would have {equalities} bar equations for {unknowns} unknowns (K = {K}): the "
            f"frame has too few free coordinates for this target — its {n_bars} bars outnumber what its "
            f"{n_unspecified} unspecified nodes can satisfy along a path (redundant bars, i.e. "
            "self-stresses, count too); ask for a design with more unspecified nodes or fewer "
            "redundant bars.",
        )


def refinement_target(frame: Frame, motion_s, amplitude, targets, K: int, stay_on_solution_space: bool):
    """refine's refusals before any analysis: Δ_S and a (target_displacement), once the
    problem's sizes are accepted (check_problem_size)."""
    delta, a = target_displacement(frame, motion_s, amplitude, targets)
    check_problem_size(frame, K, stay_on_solution_space)
    return delta, a


def _rigid_target(frame: Frame, delta: np.ndarray, a: float, analysis: Analysis | None, t_start: float) -> Refinement:
    """x_S + Δ_S is a rigid motion of x_S: the frame reaches it unchanged (ε = 0); the path is
    the reference and the whole frame moved by that rigid motion."""
    spec = list(frame.specified)
    x_s = frame.positions[spec]
    _, _, rotation = _kabsch(x_s, x_s + delta)
    moved = (frame.positions - x_s.mean(axis=0)) @ rotation + (x_s + delta).mean(axis=0)
    mode = None
    if analysis is not None and analysis.modes is not None and _single_mode(analysis):
        mode = analysis.modes[0]
    return Refinement(
        frame=frame, displacement=delta, amplitude=a, epsilon_before=0.0, epsilon_after=0.0,
        ipopt_status="not_needed", iterations=0, K=1, attempts=0,
        time_ms=1e3 * (time.perf_counter() - t_start), ipopt_time_ms=0.0,
        path=np.stack([frame.positions, moved]),
        max_relative_bar_error=relative_bar_error(moved, frame.edges, bar_lengths(frame.positions, frame.edges)),
        analysis_reference=analysis, analysis_end=None, ok=True,
        message="the target is a rigid motion of the specified nodes: the frame reaches it as it is (ε = 0).",
        mode=mode,
    )


def refine(
    frame: Frame,
    motion_s=None,
    amplitude: float | None = 0.1,
    targets=None,
    K: int = 8,
    tol: float = IPOPT_TOL,
    max_iter: int = 500,
    max_time_s: float = 5.0,
    stay_on_solution_space: bool = False,
    analysis: Analysis | None = None,
) -> Refinement:
    """Move the unspecified nodes so that the finite motion carries x_S to x_S + Δ_S.

    frame: a frame with specified nodes and exactly one nontrivial zero mode (a linear design).
    motion_s/amplitude or targets: the target, see target_displacement().
    K: number of configurations after the reference (≥ 1); if IPOPT's configurations straddle
    two branches (the refined motion misses the target), the solve is retried once with 2K
    (≤ MAX_K).  tol, max_iter, max_time_s: IPOPT's tol, max_iter and max_cpu_time (per solve).
    analysis: the frame's analysis with bases, when the caller already has it (the pipeline
    passes the design's), so the reference is not analysed twice.
    Returns a Refinement with ``ok`` True; raises RefinementFailed (code ``refinement_failed``,
    with the best result) otherwise.
    """
    t_start = time.perf_counter()
    delta, a = refinement_target(frame, motion_s, amplitude, targets, K, stay_on_solution_space)
    spec = np.asarray(frame.specified, dtype=int)
    if kabsch_distance(frame.positions[spec] + delta, frame.positions[spec]) <= REACHED_EPS * np.linalg.norm(delta):
        return _rigid_target(frame, delta, a, analysis, t_start)
    with progress_stage(0.0, 0.1, "analysing the design", detail=True):
        before = analysis if analysis is not None else analyze(frame)
    if not _single_mode(before):
        raise DomainError(
            "not_single_mode",
            f"refinement follows one nontrivial zero mode; the frame has {before.nontrivial_zero_modes}.",
        )
    with progress_stage(0.1, 0.3, "the design's finite motion"):
        fid_before, path_before = motion_fidelity(frame, delta)

    # IPOPT's K configurations can straddle two branches of the configuration space (the
    # refined motion then misses the target); a finer path (2K) usually stays on one.
    # Progress: the first solve [0.3, 0.9], a retry [0.9, 1].
    attempts = []
    for k_try, share in zip((K, 2 * K), ((0.3, 0.9), (0.9, 1.0))):
        with progress_stage(*share, f"IPOPT with K = {k_try}"):
            attempt = _attempt(
                frame, before, delta, k_try, tol, max_iter, max_time_s, stay_on_solution_space
            )
        attempts.append(attempt)
        if not attempt.problems or not attempt.discontinuous or 2 * k_try > MAX_K:
            break
    best = min(attempts, key=lambda t: (bool(t.problems), t.eps_after))
    ok = not best.problems
    # A finite eps_after (so a traced best.motion) whenever the refined frame is kept.
    keep_refined = best.eps_after < fid_before.epsilon or ok
    # ε(b) for b in (0, a] on the paths already traced (their last values are ε before and after).
    x_s = frame.positions[spec]
    curve_before = fidelity_curve(path_before, spec, x_s, delta, a, CURVE_SAMPLES)
    curve_after = fidelity_curve(best.motion, spec, x_s, delta, a, CURVE_SAMPLES) if keep_refined else curve_before
    report_progress(1.0, "refined")
    result = Refinement(
        frame=best.refined if keep_refined else frame,
        displacement=delta,
        amplitude=a,
        epsilon_before=fid_before.epsilon,
        epsilon_after=float(best.eps_after) if keep_refined else fid_before.epsilon,
        ipopt_status=best.status,
        iterations=best.iterations,
        K=best.K,
        attempts=len(attempts),
        time_ms=1e3 * (time.perf_counter() - t_start),
        ipopt_time_ms=sum(t.ipopt_ms for t in attempts),
        path=best.path,
        max_relative_bar_error=best.bar_error,
        analysis_reference=best.an_ref if keep_refined else before,
        analysis_end=best.an_end if keep_refined else None,
        ok=ok,
        message="refinement succeeded."
        if ok
        else "refinement failed: " + "; ".join(best.problems) + ".",
        mode=best.mode if keep_refined else None,
        curve_before=curve_before,
        curve_after=curve_after,
    )
    if not ok:
        raise RefinementFailed(result)
    return result


@dataclass(eq=False)
class _Attempt:
    """One IPOPT solve with its re-verification (see refine)."""

    K: int
    status: str
    iterations: int
    ipopt_ms: float
    path: np.ndarray
    bar_error: float
    refined: Frame
    an_ref: Analysis | None
    an_end: Analysis | None
    eps_after: float
    problems: list[str]
    discontinuous: bool
    mode: np.ndarray | None
    motion: MotionPath | None  # the refined frame's traced motion that measured eps_after


def _attempt(
    frame, before, delta, K, tol, max_iter, max_time_s, stay_on_solution_space
) -> _Attempt:
    spec = np.asarray(frame.specified, dtype=int)
    unspec = np.setdiff1d(np.arange(frame.n_nodes), spec)
    n, d = frame.n_nodes, frame.dim
    t_build = time.perf_counter()
    norm = Normalisation.of(frame.positions)
    x0 = norm.positions_in(frame.positions)
    target = x0[spec] + delta / norm.length
    building = NLP_SHARE[0] / 2  # the NLP's expressions, then casadi's derivatives (nlpsol)
    with progress_stage(0.0, building, "the NLP"), progress_heartbeat(NLP_EXPECTED_S, "building"):
        nlp, x_init, lbg, ubg, unpack = _build_nlp(
            x0, frame.edges, spec, unspec, target, K, before.modes[0], stay_on_solution_space
        )
    check_budget()
    # max_time_s covers the NLP's construction too, and the request's budget bounds both.
    left = float(max_time_s) - (time.perf_counter() - t_build)
    budget = remaining()
    left = left if budget is None else min(left, budget)
    if left <= 0:
        raise DomainError(
            "too_expensive",
            f"building the refinement's NLP (K = {K}, {frame.n_nodes} nodes) took the whole time limit "
            f"of {max_time_s:g} s; lower K or raise max_time_s.",
        )
    iterations_report = _IterationReport(nlp["x"].numel(), nlp["g"].numel(), max_iter, left)
    # casadi releases the GIL while it derives the NLP's functions: the heartbeat runs.
    with progress_stage(building, NLP_SHARE[0], "the NLP's derivatives"), progress_heartbeat(NLP_EXPECTED_S, "casadi"):
        solver = ipopt_solver("refine", nlp, tol, max_iter, left, iterations_report)
    t_ipopt = time.perf_counter()
    with progress_stage(*NLP_SHARE, "IPOPT"):
        sol = solver(x0=x_init, lbg=lbg, ubg=ubg)
    ipopt_ms = 1e3 * (time.perf_counter() - t_ipopt)
    stats = solver.stats()
    status = str(stats.get("return_status", "unknown"))
    # IPOPT leaves iter_count unset (any integer) when it refuses a problem before iterating.
    iterations = int(stats.get("iter_count", 0))
    iterations = iterations if 0 <= iterations <= int(max_iter) else 0
    configs = unpack(np.asarray(sol["x"]).ravel())  # (K+1, N, d) normalised
    path = norm.positions_out(configs)
    # The ends' specified rows are constants of the NLP: restore them without round-off.
    path[0, spec] = frame.positions[spec]
    path[-1, spec] = frame.positions[spec] + delta
    lengths = bar_lengths(path[0], frame.edges)
    bar_error = max(relative_bar_error(p, frame.edges, lengths) for p in path[1:])

    problems = []
    if status not in IPOPT_SUCCESS:
        problems.append(f"IPOPT stopped with status {status} after {iterations} iterations")
    refined = frame
    an_ref = an_end = None
    eps_after = np.inf
    motion = None
    try:
        refined = Frame.build(path[0], frame.edges, frame.specified, dim=d)
        # Counts decide the re-verification; the reference's bases give the refined mode.
        with progress_stage(NLP_SHARE[1], 0.75, "analysing the refined frame", detail=True):
            an_ref = analyze(refined)
        with progress_stage(0.75, 0.8, "analysing its far end", detail=True):
            an_end = analyze(Frame.build(path[-1], frame.edges, frame.specified, dim=d), bases=False)
    except DomainError as exc:  # a diverged iterate, or two joined nodes collapsed onto each other
        problems.append(f"the refined frame is invalid ({exc.message})")
    if an_ref is not None and an_end is not None:
        for name, an in (("reference", an_ref), ("final configuration", an_end)):
            if an.self_stresses > before.self_stresses:
                problems.append(f"the refined {name} has {an.self_stresses} self-stress(es)")
            if not _single_mode(an):
                problems.append(
                    f"the refined {name} has {an.nontrivial_zero_modes} nontrivial zero modes"
                )
        if _single_mode(an_ref):
            # How far to look: IPOPT's path length in the tracer's units (RMS node
            # displacement over the RMS radius), with a margin.
            steps = np.linalg.norm(np.diff(path, axis=0), axis=(1, 2))
            horizon = 1.5 * float(np.sum(steps)) / (np.sqrt(n) * (rms_radius(path[0]) or 1.0))
            try:
                with progress_stage(0.8, 1.0, "the refined frame's finite motion"):
                    fid_after, motion = motion_fidelity(refined, delta, horizon=horizon)
                eps_after = fid_after.epsilon
            except DomainError as exc:
                problems.append(f"the refined frame's motion could not be traced ({exc.message})")
    # IPOPT's configurations may jump between branches of the configuration space; then the
    # refined frame's own motion does not reach the target and ε after stays large.
    reach = max(REACHED_EPS, REACHED_PER_TOL * tol)
    discontinuous = not problems and eps_after > reach
    if discontinuous:
        problems.append(
            f"the refined frame's motion passes the target at ε = {eps_after:.3g} (> {reach:.3g}) "
            f"with K = {K}: IPOPT's configurations are not joined by one continuous motion"
        )
    return _Attempt(
        K,
        status,
        iterations,
        ipopt_ms,
        path,
        bar_error,
        refined,
        an_ref,
        an_end,
        eps_after,
        problems,
        discontinuous,
        an_ref.modes[0] if an_ref is not None and _single_mode(an_ref) else None,
        motion,
    )


def ipopt_solver(name: str, nlp: dict, tol: float, max_iter: int, left: float, callback: ca.Callback | None = None):
    """casadi's IPOPT solver for ``nlp`` with exact derivatives, silent, stopped after
    ``max_iter`` iterations or ``left`` seconds (CPU and wall); ``callback`` sees each iteration.
    The adaptive barrier update: inequalities inactive at the solution (separations) cost fewer
    iterations (it halves the median count on the refinement benchmark's designs)."""
    options = {
        "print_time": False,
        "error_on_fail": False,
        "ipopt.print_level": 0,
        "ipopt.sb": "yes",
        "ipopt.mu_strategy": "adaptive",
        "ipopt.tol": tol,
        "ipopt.max_iter": int(max_iter),
        "ipopt.max_cpu_time": left,
        "ipopt.max_wall_time": left,
    }
    if callback is not None:
        options["iteration_callback"] = callback
    return ca.nlpsol(name, "ipopt", nlp, options)


class _IterationReport(ca.Callback):
    """IPOPT's iteration callback: after iteration i, report max(i / max_iter, t / time_limit)
    (both bound the solve, both grow; t from IPOPT's first callback, at its starting point), so
    a slow solve reports each iteration and a long one moves with the clock.  Receives nlpsol's
    outputs (x, f, g, multipliers) and ignores them."""

    def __init__(self, nx: int, ng: int, max_iter: int, time_limit: float):
        ca.Callback.__init__(self)
        self._sizes = {"x": nx, "lam_x": nx, "g": ng, "lam_g": ng, "f": 1}
        self._max_iter, self._time_limit = max(int(max_iter), 1), max(float(time_limit), REPORT_MIN_TIME_S)
        self._count, self._t0 = 0, None
        self.construct("refine_progress", {})

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "ret"

    def get_sparsity_in(self, i):
        n = self._sizes.get(ca.nlpsol_out(i))
        return ca.Sparsity(0, 0) if n is None else ca.Sparsity.dense(n)

    def eval(self, arg):
        self._count += 1
        self._t0 = self._t0 or time.perf_counter()
        elapsed = time.perf_counter() - self._t0
        report_progress(max(self._count / self._max_iter, elapsed / self._time_limit), "IPOPT iterations")
        return [0]


def _build_nlp(x0, edges, spec, unspec, target, K, mode, stay_on_solution_space):
    """The NLP of the module docstring, over flat unknowns w = (x_U, X_1 … X_{K−1}, X_{K,U}
    [, u_U]); ``mode`` (N × d) is the frame's nontrivial zero mode, which gives the initial
    guess.  Returns (nlp dict, initial w, unpack: w ↦ (K+1, N, d) configurations)."""
    n, d = x0.shape
    nu = len(unspec)
    w_xu = ca.SX.sym("x_U", nu, d)
    w_mid = [ca.SX.sym(f"X_{j}", n, d) for j in range(1, K)]
    w_end = ca.SX.sym("X_K_U", nu, d)

    def assemble(fixed_rows, rows_u):
        m = ca.SX.zeros(n, d)
        for row, i in enumerate(spec):
            m[int(i), :] = fixed_rows[row, :]
        for row, i in enumerate(unspec):
            m[int(i), :] = rows_u[row, :]
        return m

    x_ref = assemble(ca.DM(x0[spec]), w_xu)
    x_end = assemble(ca.DM(target), w_end)
    configs = [x_ref, *w_mid, x_end]
    e0, e1 = [int(i) for i in edges[:, 0]], [int(i) for i in edges[:, 1]]

    def squared_lengths(m):
        diff = m[e0, :] - m[e1, :]
        return ca.sum2(diff * diff)

    ref_len = squared_lengths(x_ref)
    g = [squared_lengths(m) - ref_len for m in configs[1:]]
    equalities = K * len(edges)
    # Both ends keep every unspecified node MIN_SEPARATION·(the design's closest such pair)
    # away from every node it has no bar to: merging two such nodes satisfies the bars cheaply
    # but leaves a degenerate frame (a self-stress and an extra mode).  A bar shrinking to zero
    # is caught by the re-verification instead.
    moving = {int(i) for i in unspec}
    joined = {(min(i, j), max(i, j)) for i, j in zip(e0, e1)}
    pairs = [
        (i, j)
        for i in range(n)
        for j in range(i + 1, n)
        if (i in moving or j in moving) and (i, j) not in joined
    ]
    p0, p1 = [i for i, _ in pairs], [j for _, j in pairs]
    closest = float(np.min(np.sum((x0[p0] - x0[p1]) ** 2, axis=1))) if pairs else 0.0
    for m in (x_ref, x_end):
        diff = m[p0, :] - m[p1, :]
        g.append(ca.sum2(diff * diff) - MIN_SEPARATION**2 * closest)
    objective = 0
    for j in range(1, K):
        s = j / K
        dev = configs[j] - ((1 - s) * x_ref + s * x_end)
        objective += ca.sumsqr(dev)
    objective = objective / (K * n) + DESIGN_WEIGHT * ca.sumsqr(w_xu - ca.DM(x0[unspec])) / nu
    variables = [ca.vec(w_xu), *[ca.vec(m) for m in w_mid], ca.vec(w_end)]
    # Linear initial guess: the mode scaled so that its specified rows fit Δ_S (least squares).
    delta = target - x0[spec]
    linear_motion = float(np.sum(mode[spec] * delta) / np.sum(mode[spec] ** 2)) * mode
    init = [x0[unspec].ravel(order="F")]
    for j in range(1, K):
        init.append((x0 + (j / K) * linear_motion).ravel(order="F"))
    init.append((x0 + linear_motion)[unspec].ravel(order="F"))
    if stay_on_solution_space:
        # u_S = Δ_S up to scale (the zero-mode condition is homogeneous), u_U from the mode.
        w_uu = ca.SX.sym("u_U", nu, d)
        u_all = assemble(ca.DM(delta), w_uu)
        g.append(ca.sum2((x_ref[e0, :] - x_ref[e1, :]) * (u_all[e0, :] - u_all[e1, :])))
        variables.append(ca.vec(w_uu))
        init.append(linear_motion[unspec].ravel(order="F"))
    nlp = {"x": ca.vertcat(*variables), "f": objective, "g": ca.vertcat(*g)}
    lbg = np.zeros(nlp["g"].shape[0])
    ubg = np.zeros(nlp["g"].shape[0])
    ubg[equalities : equalities + 2 * len(pairs)] = np.inf
    flat_configs = ca.Function("configs", [nlp["x"]], [ca.vertcat(*[ca.vec(m) for m in configs])])

    def unpack(w: np.ndarray) -> np.ndarray:
        flat = np.asarray(flat_configs(w)).ravel()
        return flat.reshape(K + 1, d, n).transpose(0, 2, 1)

    return nlp, np.concatenate(init), lbg, ubg, unpack
