"""Design of a module whose map has a requested feature (arXiv 1906.08400's module design).

A feature is a set of map points (x_j, y_j[, s_j]): f(x_j) = y_j and, where given, f′(x_j) = s_j.
    fixed point d* with slope s:    (d*, d*, s)
    period-2 cycle d₁ ↔ d₂:         (d₁, d₂), (d₂, d₁)
    range [a, b] onto [c, e]:       (a, c), (b, e)
Several features may be combined (a deployable module: an unstable and a stable fixed point).

The NLP (casadi, IPOPT with exact derivatives), on K configurations X¹…X^K (N × d each) of one
module (the same bars; X¹ is the designed module's reference):

    minimise   Σ_j ‖X^j − S^j‖² / r²                                   (stay near the start)
    subject to |X^j_a − X^j_b|² = x_j²,  |X^j_c − X^j_e|² = y_j²        (the map points)
               |X^j_p − X^j_q|² = |X¹_p − X¹_q|²  for every bar, j ≥ 2  (one module)
               f′(X^j) = s_j  where given
               |X¹_p − X¹_q| ≥ MIN_BAR_FRACTION·(the start's shortest bar)   (no collapsed bar)
               |X^j_i − x̄| ≤ reach·r                                    (the module's extent)
               ‖X^k − X^j‖ ≤ BRANCH_JUMP·r·√N for neighbours in d_in       (one branch)

with intermediate configurations (d_in fixed between neighbouring x_j and one step beyond the
outermost, d_out free) so that neighbours are close: the points then lie on one branch of the
motion, not on a mirror one, and no fold comes within a step of them.

S^j the start module's sample nearest x_j, x̄ and r its centroid and RMS radius.  The slope is
the tangent formula of module_map: v solves AᵀA v = Aᵀ[0; d_in; 0] with A = [C(X); ∇½d_in²;
rigid motions at X] (least squares, exact for a one-mode module), f′ = ∇d_out·v.

IPOPT's answer is not trusted: the designed module's map is computed by continuation
(module_map) and evaluated exactly at every x_j, which must all lie in its usable range (one
branch, no fold between them); f(x_j) must meet y_j and f′(x_j) meet s_j within MAP_RTOL.
Otherwise ``feature_out_of_reach`` with the best figures.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import casadi as ca
import numpy as np

from zeromode.solver.analysis.normalisation import rms_radius
from zeromode.solver.budget import check_budget, remaining
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.progress import progress_heartbeat, progress_stage
from zeromode.solver.sequential.module_map import Module, ModuleMap, module_map, two_triangle_module
from zeromode.solver.tolerances import DISTINCT_RTOL, MAP_IPOPT_TOL, MAP_RTOL

# The designed module stays within this many RMS radii of the start's centroid (its extent).
REACH = 3.0
# No bar shorter than this fraction of the start's shortest bar (a collapsed triangle would
# add a zero mode).
MIN_BAR_FRACTION = 0.2
# Neighbouring configurations of the NLP's ladder (sorted by d_in) have inputs at most
# BRANCH_STEP RMS radii apart and lie within BRANCH_JUMP RMS radii (RMS node distance) of each
# other: the designed points lie on one branch of the motion (a jump to a mirror branch moves
# nodes by far more; near a fold a small change of d_in moves them several times as far).
BRANCH_STEP = 0.05
BRANCH_JUMP = 0.2
# Most configurations in the NLP (each N × d unknowns with its symbolic slope): the ladder of
# inputs spanning 10 RMS radii.
MAX_LADDER = 200
# Largest start module designed (nodes): the slope's expression solves a symbolic (dN)² system
# per configuration (the two-triangle module has 5 nodes).
DESIGN_MAX_NODES = 16
# IPOPT's iteration cap (its tolerance: tolerances.MAP_IPOPT_TOL).
IPOPT_MAX_ITER = 400
# ... and its time limit (CPU and wall; the request's budget if shorter): a design takes ~1 s.
IPOPT_MAX_S = 60.0
# ... and at least this (IPOPT refuses a limit of 0: a budget that ends between check_budget and
# IPOPT's start is overrun by this at most, then refused by check_budget after it).
IPOPT_MIN_S = 0.01
# Progress shares of a design and IPOPT's expected time for its heartbeat (measured on the
# deployable pair of fixed points, wall at load 8: the start's map 0.9–1.2 s, the NLP's
# construction 0.5 s and IPOPT 0.6–0.9 s, the designed module's map 1.1–1.3 s).
START_MAP_SHARE = 0.3
IPOPT_SHARE = 0.65
IPOPT_EXPECTED_S = 1.0


@dataclass(frozen=True)
class MapPoint:
    """f(d_in) = d_out and, unless None, f′(d_in) = slope."""

    d_in: float
    d_out: float
    slope: float | None = None


def fixed_point(d: float, slope: float) -> tuple[MapPoint, ...]:
    """A fixed point d* = f(d*) with f′(d*) = slope (stable iff |slope| < 1)."""
    return (MapPoint(d, d, slope),)


def period_two(d1: float, d2: float) -> tuple[MapPoint, ...]:
    """A period-2 cycle: f(d₁) = d₂, f(d₂) = d₁."""
    return (MapPoint(d1, d2), MapPoint(d2, d1))


def range_onto(source, target) -> tuple[MapPoint, ...]:
    """The interval source = (a, b) mapped onto target = (c, e): f(a) = c, f(b) = e."""
    return (MapPoint(source[0], target[0]), MapPoint(source[1], target[1]))


@dataclass(frozen=True, eq=False)
class ModuleDesign:
    """A designed module and the figures of its verification.

    configurations: (K, N, d) IPOPT's configurations (X¹ the module's reference);
    map: the designed module's map by continuation (None where it could not be computed);
    achieved: (K,) f(x_j) and slopes: (K,) f′(x_j), exact (NaN where x_j is off the range);
    deviation: max over points of |f(x_j) − y_j|/y_j and |f′(x_j) − s_j|/max(1, |s_j|)."""

    module: Module
    points: tuple[MapPoint, ...]
    configurations: np.ndarray
    map: ModuleMap | None
    achieved: np.ndarray
    slopes: np.ndarray
    deviation: float
    solver_status: str


class FeatureOutOfReach(DomainError):
    """The feature was not met within MAP_RTOL; ``best`` is the design with its figures."""

    def __init__(self, message: str, best: ModuleDesign):
        super().__init__("feature_out_of_reach", message)
        self.best = best


def check_points(points) -> tuple[MapPoint, ...]:
    """The map points as positive finite distances and finite slopes, distinct inputs (f is a
    function); InvalidInput ``invalid_feature`` otherwise."""
    points = tuple(points)
    if not points:
        raise InvalidInput("invalid_feature", "a feature needs at least one map point.")
    for p in points:
        values = [p.d_in, p.d_out] + ([] if p.slope is None else [p.slope])
        if not all(np.isfinite(v) for v in values) or not (p.d_in > 0 and p.d_out > 0):
            raise InvalidInput("invalid_feature", "map points need positive finite distances and finite slopes.")
    ins = np.array([p.d_in for p in points])
    gaps = np.abs(ins[:, None] - ins[None, :])[~np.eye(len(ins), dtype=bool)]
    if np.any(gaps <= DISTINCT_RTOL * ins.max()):
        raise InvalidInput("invalid_feature", "two map points have the same input distance (a period-2 cycle needs d₁ ≠ d₂).")
    return points


def _slope_expression(module: Module, x) -> ca.SX:
    """f′ at the configuration x (N × d casadi SX) by the tangent formula (module docstring)."""
    edges = module.frame.edges
    n, dim = module.frame.positions.shape
    (a, b), (c, e) = module.input_pair, module.output_pair

    def pair_row(i, j):
        row = ca.SX.zeros(1, n * dim)
        diff = x[i, :] - x[j, :]
        row[0, i * dim:(i + 1) * dim] = diff
        row[0, j * dim:(j + 1) * dim] = -diff
        return row

    rows = [pair_row(int(i), int(j)) for i, j in edges] + [pair_row(a, b)]
    centre = ca.sum1(x) / n
    for axis in range(dim):
        t = np.zeros((n, dim))
        t[:, axis] = 1.0
        rows.append(ca.SX(t.reshape(1, -1)))
    for p in range(dim):
        for q in range(p + 1, dim):
            r = ca.SX.zeros(n, dim)
            r[:, p] = -(x[:, q] - centre[q])
            r[:, q] = x[:, p] - centre[p]
            rows.append(ca.reshape(r.T, 1, n * dim))
    big = ca.vertcat(*rows)
    rhs = ca.SX.zeros(big.shape[0], 1)
    rhs[len(edges)] = ca.norm_2((x[a, :] - x[b, :]).T)
    v = ca.reshape(ca.solve(big.T @ big, big.T @ rhs), dim, n).T
    out = (x[c, :] - x[e, :]).T
    return ca.dot(out, (v[c, :] - v[e, :]).T) / ca.norm_2(out)


def check_design(points, start: Module | None = None, reach: float = REACH) -> tuple[tuple[MapPoint, ...], Module]:
    """What design_module refuses before any work (milliseconds; POST /v1/jobs refuses it at
    submit too): the points (check_points); ``too_expensive`` for a start of more than
    DESIGN_MAX_NODES nodes or a ladder of more than MAX_LADDER configurations;
    ``invalid_reach``; ``feature_out_of_reach`` for a distance beyond 2·reach·r (no two nodes
    within reach·r of the centre are farther apart).  Returns (points, start), the start
    defaulting to the two-triangle module."""
    points = check_points(points)
    start = two_triangle_module() if start is None else start
    if start.frame.n_nodes > DESIGN_MAX_NODES:
        raise DomainError("too_expensive", f"modules of up to {DESIGN_MAX_NODES} nodes are designed; the start has {start.frame.n_nodes}.")
    if not (np.isfinite(reach) and reach > 0):
        raise InvalidInput("invalid_reach", "reach must be a positive number.")
    r = rms_radius(start.frame.positions)
    widest = max(max(p.d_in, p.d_out) for p in points)
    if widest > 2 * reach * r:
        raise DomainError(
            "feature_out_of_reach",
            f"a distance of {widest:.6g} is out of reach: nodes within {reach:g} RMS radii ({reach * r:.6g}) of the "
            f"start's centre are at most {2 * reach * r:.6g} apart.",
        )
    if len(_ladder(points, r)) > MAX_LADDER:
        raise DomainError(
            "too_expensive",
            f"the features span more than {MAX_LADDER} configurations of the NLP's ladder (inputs {BRANCH_STEP:g} "
            "RMS radii apart): ask for closer input distances.",
        )
    return points, start


def design_module(points, start: Module | None = None, reach: float = REACH) -> ModuleDesign:
    """A module (``start``'s bars, default the two-triangle module) whose map meets ``points``
    (module docstring); refusals before any work as check_design's, FeatureOutOfReach with the
    best figures if the points are not met.  Progress: the start's map, IPOPT (a heartbeat: one
    opaque call, under the time budget left), the designed module's map."""
    points, start = check_design(points, start, reach)
    ref = start.frame.positions
    n, dim = ref.shape
    edges = start.frame.edges
    r, centre = rms_radius(ref), ref.mean(axis=0)
    with progress_stage(0.0, START_MAP_SHARE, "the start's map"):
        start_map = module_map(start)
    ladder = _ladder(points, r)
    seeds = [start_map.positions[int(np.argmin(np.abs(start_map.d_in - x)))] for x, _ in ladder]
    xs = [ca.SX.sym(f"x{j}", n, dim) for j in range(len(ladder))]
    (a, b), (c, e) = start.input_pair, start.output_pair

    def sq(x, i, j):
        return ca.sumsqr(x[i, :] - x[j, :])

    g, lo, hi = [], [], []

    def add(expr, low, high):
        g.append(expr)
        lo.append(low)
        hi.append(high)

    for x, (d_in, p) in zip(xs, ladder):
        add((sq(x, a, b) - d_in**2) / r**2, 0.0, 0.0)
        if p is not None:
            add((sq(x, c, e) - p.d_out**2) / r**2, 0.0, 0.0)
        if p is not None and p.slope is not None:
            add(_slope_expression(start, x) - p.slope, 0.0, 0.0)
        for i in range(n):
            add(ca.sumsqr(x[i, :] - centre.reshape(1, -1)) / r**2, -np.inf, reach**2)
    shortest = float(np.min(np.linalg.norm(ref[edges[:, 0]] - ref[edges[:, 1]], axis=1)))
    for i, j in edges:
        add(sq(xs[0], i, j) / r**2, (MIN_BAR_FRACTION * shortest / r) ** 2, np.inf)
        for x in xs[1:]:
            add((sq(x, i, j) - sq(xs[0], i, j)) / r**2, 0.0, 0.0)
    order = sorted(range(len(ladder)), key=lambda j: ladder[j][0])
    for j, k in itertools.pairwise(order):
        add(ca.sumsqr(xs[k] - xs[j]) / (n * r**2), -np.inf, BRANCH_JUMP**2)
    w = ca.vertcat(*[ca.reshape(x.T, -1, 1) for x in xs])
    objective = sum(ca.sumsqr(x - s) for x, s in zip(xs, seeds)) / r**2
    check_budget()  # spent already (the start's map): too_expensive before IPOPT
    budget = remaining()
    left = IPOPT_MAX_S if budget is None else min(IPOPT_MAX_S, max(budget, IPOPT_MIN_S))
    # IPOPT's default (monotone) barrier update: refine.ipopt_solver's adaptive one misses the
    # deployable pair of fixed points (measured), so the options are this NLP's own.
    options = {"ipopt.tol": MAP_IPOPT_TOL, "ipopt.max_iter": IPOPT_MAX_ITER, "ipopt.max_cpu_time": left,
               "ipopt.max_wall_time": left, "ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": False}
    solver = ca.nlpsol("module_design", "ipopt", {"x": w, "f": objective, "g": ca.vertcat(*g)}, options)
    with progress_stage(START_MAP_SHARE, IPOPT_SHARE, "IPOPT"), progress_heartbeat(IPOPT_EXPECTED_S, "solving"):
        got = solver(x0=np.concatenate([s.ravel() for s in seeds]), lbg=lo, ubg=hi)
    status = solver.stats()["return_status"]
    check_budget()  # IPOPT stopped at the budget's end: too_expensive, not a verdict on the feature
    configurations = np.asarray(got["x"]).reshape(len(ladder), n, dim)
    with progress_stage(IPOPT_SHARE, 1.0, "verification"):
        return _verified(start, points, configurations[: len(points)], status, reach)


def _ladder(points: tuple[MapPoint, ...], r: float) -> list[tuple[float, MapPoint | None]]:
    """The NLP's configurations: (d_in, its map point) for every point, in the order given, then
    (d_in, None) for the intermediate ones between neighbouring inputs, at most BRANCH_STEP·r
    apart in d_in, and one BRANCH_STEP·r beyond each end (so no fold comes within that of a
    requested input: the usable range holds them all with a margin)."""
    ladder: list[tuple[float, MapPoint | None]] = [(p.d_in, p) for p in points]
    ins = sorted(p.d_in for p in points)
    margin = min(BRANCH_STEP * r, 0.5 * ins[0])
    ins = [ins[0] - margin] + ins + [ins[-1] + margin]
    for k, (lo, hi) in enumerate(itertools.pairwise(ins)):
        steps = int(np.ceil((hi - lo) / (BRANCH_STEP * r)))
        inner = np.linspace(lo, hi, steps + 1)[1:-1]
        ends = [lo] if k == 0 else [hi] if k == len(ins) - 2 else []
        ladder += [(float(x), None) for x in np.concatenate([inner, ends])]
    return ladder


def _verified(start: Module, points, configurations: np.ndarray, status: str, reach: float) -> ModuleDesign:
    """The design at IPOPT's X¹, its map by continuation and the exact figures at every point;
    FeatureOutOfReach unless every point is met within MAP_RTOL on one branch, the module within
    ``reach`` and no bar shorter than MIN_BAR_FRACTION of the start's shortest."""
    k = len(points)
    achieved, slopes = np.full(k, np.nan), np.full(k, np.nan)
    try:
        frame = Frame.build(configurations[0], start.frame.edges)
        module = Module(frame, start.input_pair, start.output_pair)
        the_map = module_map(module)
    except DomainError as exc:
        best = ModuleDesign(start, points, configurations, None, achieved, slopes, np.inf, status)
        raise FeatureOutOfReach(f"IPOPT ended with {status}, and the module it gives has no map: {exc.message}", best) from None
    x = np.array([p.d_in for p in points])
    ref = start.frame.positions
    centre, r = ref.mean(axis=0), rms_radius(ref)
    extent = float(np.max(np.linalg.norm(configurations - centre, axis=-1))) / r
    e = start.frame.edges
    shortest = np.min(np.linalg.norm(ref[e[:, 0]] - ref[e[:, 1]], axis=1))
    bar = float(np.min(np.linalg.norm(configurations[0][e[:, 0]] - configurations[0][e[:, 1]], axis=1)) / shortest)
    inside = (x >= the_map.range[0]) & (x <= the_map.range[1])
    if np.any(inside):
        achieved[inside], slopes[inside] = the_map.evaluate(x[inside])
    deviation = 0.0
    for j, p in enumerate(points):
        deviation = max(deviation, abs(achieved[j] - p.d_out) / p.d_out)
        if p.slope is not None:
            deviation = max(deviation, abs(slopes[j] - p.slope) / max(1.0, abs(p.slope)))
    design = ModuleDesign(module, points, configurations, the_map, achieved, slopes, float(deviation), status)
    if not (extent <= reach * (1 + MAP_RTOL) and bar >= MIN_BAR_FRACTION * (1 - MAP_RTOL)):
        raise FeatureOutOfReach(
            f"IPOPT ended with {status}; the best module reaches {extent:.4g} RMS radii from the start's centre "
            f"(at most {reach:g}) with its shortest bar {bar:.4g} of the start's (at least {MIN_BAR_FRACTION:g}).",
            design)
    if not np.all(inside):
        lo, hi = the_map.range
        raise FeatureOutOfReach(
            f"IPOPT ended with {status}; the designed module's usable range [{lo:.6g}, {hi:.6g}] (one branch "
            "between folds) does not hold every requested input distance.", design)
    if not deviation <= MAP_RTOL:
        raise FeatureOutOfReach(
            f"IPOPT ended with {status}; the best module meets the feature only to {deviation:.2e} "
            f"(relative), not {MAP_RTOL:g}.", design)
    return design
