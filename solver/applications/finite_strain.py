"""Auxetic sheets whose *secant* Poisson ratio is held over a strain range.

The two-node module (lattice.py, paper Fig. S1a) has its linear Poisson ratio −β fixed by its
one coordinate, c² = w² + βh², and nothing left to shape its finite motion: its secant ratio
drifts (−0.656 at ε_x = −5 %, −0.366 at +5 % for ν = −0.5).  The trammel module
(sheet_module.trammel_module: four unspecified nodes, two mirror pairs on the axes) moves its
corner on an ellipse, and its two coordinates (c, e) choose the ellipse: through the reference
corner p = (w, h), tangent there to the affine path (w(1 + ε), h(1 − νε)), with the conjugate
semi-diameter q = s·(w, βh) (sheet_module.trammel_coordinates).  Along the ellipse
    P(φ) = p cos φ + q sin φ,   a = w(cos φ + s sin φ),   b = h(cos φ + sβ sin φ),
so with ε = a/w − 1 the secant ratio is ν_s(ε) = −(b/h − 1)/ε = −β + O(ε/s²): the stretch s
trades the curvature of the path against the size of the module (large s puts the axis nodes
far out, where they meet the neighbours' bars).  The design is a search over the one-parameter
family (s > 0, and the two trammels ±, not mirror images of each other) — every member has
linear ratio exactly ν — for the member whose secant ratio stays within the tolerance over the
requested range [ε_lo, ε_hi] and whose usable range (strain_range.module_range: no singular
point, no node closer than PROXIMITY_FRACTION of the shortest bar, no bar crossing, neighbours
included) contains it.  For ν = −1 (within the tolerance) the Cardan trammels come first
(sheet_module.cardan_trammel, searched by c): their corner moves on a straight line through the
module's centre, a secant ratio of −1 to round-off over the whole motion.  When no member holds
the range, IPOPT refines the module with the best cover (refine_module: the module's orbit
coordinates and its configurations at samples of the range as unknowns, bars at their lengths,
secant ratios within t minimised, pairs of the module and its neighbours kept apart), after
Brent's searches between grid points (family members keep the linear ratio exactly ν, a refined
module only within the tolerance, so they come first); a refined module counts only once
its own continuation (_deviation) and usable range (module_range) hold the range.  Everything is
computed on one module, so the cost of the design does not grow with the number of cells.

The tiled sheet is then verified on its own: the rank analysis of the full frame (exactly one
nontrivial zero mode), and at VERIFY_SAMPLES strains across the range the sheet's positions
(tiled from the module's Newton-exact configuration) with every bar length recomputed, the
closest pair of nodes without a bar on the full sheet (k-d tree), and the secant ν measured from
the boundary means of the full sheet.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as ca
import numpy as np
from scipy.optimize import minimize_scalar

from zeromode.solver.analysis.rigidity import analyze
from zeromode.solver.applications.lattice import (
    MAX_SHEET_CELLS,
    Lattice,
    closest_unjoined,
    measured_lattice,
)
from zeromode.solver.applications.sheet_module import (
    SymmetricModule,
    cardan_trammel,
    sheet_edges,
    sheet_positions,
    sheet_velocities,
    trammel_coordinates,
    trammel_module,
)
from zeromode.solver.applications.strain_range import (
    Patch,
    StrainRange,
    module_range,
    needed_reach,
)
from zeromode.solver.budget import check_budget, remaining
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.motion.boundary_strain import boundary_strains
from zeromode.solver.motion.refine import ipopt_solver
from zeromode.solver.progress import progress_stage, report_steps
from zeromode.solver.tolerances import (
    BOX_SHRINK_RTOL,
    COVER_XTOL,
    IPOPT_TOL,
    MODULE_REFINE_REGULARISER,
    PROXIMITY_FRACTION,
    SAMPLE_ROUNDOFF,
    SHEET_BAR_RTOL,
)

# The stretches s searched (geometric grid: the deviation falls like 1/s², the size grows like s).
STRETCHES = np.geomspace(0.5, 20.0, 48)
# The trammel of sheet_module.trammel_coordinates with s₂ = +1: the other one (s₂ = −1) moves
# its corner on the same ellipse, so its secant ratio is the same; its ranges measured equal.
SIGN = 1.0
# Around the best grid stretch the window is found by Brent's bounded search on the cover, to
# this relative precision in s and within this many evaluations.
WINDOW_XTOL = 1e-3
WINDOW_EVALUATIONS = 16
WINDOW_SEARCHES = 3
# The Cardan trammels searched: c = f·(w + h²/w) for f on this grid (e = h + w(w − c)/h > 0).
CARDAN_FRACTIONS = np.linspace(0.05, 0.95, 19)
# Modules whose nodes reach past this many neighbours (in x or y) at the reference are not
# considered: their axis nodes lie among the bars of modules three cells away, and the range
# scan (whose patch grows with the reach) would make the cost grow with the sheet up to that size.
MAX_REACH = 3
# Strain step of the deviation estimate on each candidate (Newton continuation of the module).
ESTIMATE_STEP = 0.01
# Strains at which the tiled sheet is verified (the ends of the requested range included).
VERIFY_SAMPLES = 9
# IPOPT refinement of a module (refine_module): samples of the motion over the requested range,
# the weight of the reference's departure from the warm start (MODULE_REFINE_REGULARISER), IPOPT's
# tol (IPOPT_TOL) and iterations per solve, and the rounds of watched pairs.
REFINE_SAMPLES = 20
REFINE_MAX_ITER = 300
REFINE_ROUNDS = 4
# Weight of the separations' slacks (their shortfall, in squared fractions of the shortest bar)
# against t: a warm start that collides inside the range is a feasible start.
REFINE_SLACK_WEIGHT = 100.0
# The refined module's unspecified nodes stay within this many times the warm start's extent
# (per axis, along its motion), and within MAX_REACH neighbours.
BOX_GROWTH = 1.5
# IPOPT's time limit for a module's refinement, all rounds (the request's budget bounds it too).
REFINE_TIME_S = 3.0
# The NLP keeps watched pairs SEPARATION times the proximity threshold apart (a margin for the
# motion between samples); pairs are watched when they come within WATCH_DISTANCE shortest bars
# along the warm start's motion (and node–bar pairs when the node crosses the bar's line there).
SEPARATION = 1.05
WATCH_DISTANCE = 1.0


@dataclass(frozen=True, eq=False)
class FiniteStrainSheet:
    """A sheet holding its secant ratio: the lattice (states at the ends of the requested range),
    the module chosen (family "trammel" with parameter s, "cardan" with c/(w + h²/w), or
    "refined" by IPOPT with None; its orbit coordinates after (w, h)), and the verification on
    the full sheet: strains (S,), secant ν (S,) measured there, max |ν_s − ν|, max bar error."""

    lattice: Lattice
    family: str
    parameter: float | None
    coordinates: tuple[float, ...]
    strains: np.ndarray
    secant_ratios: np.ndarray
    max_deviation: float
    max_relative_bar_error: float
    requested: tuple[float, float]
    tolerance: float


class FiniteStrainUnreachable(DomainError):
    """No module holds ν within the tolerance over the range; ``best`` holds the best figures
    found: the smallest deviation over the requested range (family, parameter), the widest cover
    of the range among members within the tolerance, and IPOPT's refinement (its deviation,
    cover, status, coordinates) when it ran."""

    def __init__(self, message: str, best: dict):
        super().__init__("finite_strain_unreachable", message)
        self.best = best


def _deviation(module: SymmetricModule, nu: float, lo: float, hi: float) -> float:
    """max |ν_s(ε) − ν| over ε ∈ [lo, hi] in steps of ESTIMATE_STEP from 0 (inf if the module's
    curve does not reach an end)."""
    w, h = module.cell
    worst = 0.0
    for end in (hi, lo):
        q = module.reference
        steps = max(1, int(np.ceil(abs(end) / ESTIMATE_STEP)))
        for eps in np.linspace(0.0, end, steps + 1)[1:]:
            try:
                guess = q + (eps - (q[0] / w - 1.0)) * module.tangent(q)
            except np.linalg.LinAlgError:
                return np.inf
            q = module.configuration(eps, guess)
            if q is None:
                return np.inf
            worst = max(worst, abs(-(q[1] / h - 1.0) / eps - nu))
    return worst


def check_finite_strain_request(nx: int, ny: int, strain_range, tolerance: float, cell: tuple[float, float]) -> None:
    """finite_strain_sheet's refusals before any work: InvalidInput ``invalid_size``,
    ``invalid_strain_range`` (not lo < 0 < hi), ``invalid_tolerance``, ``invalid_cell``."""
    if nx < 1 or ny < 1 or nx * ny > MAX_SHEET_CELLS:
        raise InvalidInput("invalid_size", f"cells must be between 1 and {MAX_SHEET_CELLS} in all.")
    lo, hi = (float(v) for v in strain_range)
    if not (lo < 0 < hi):
        raise InvalidInput("invalid_strain_range", "strain_range must be [lo, hi] with lo < 0 < hi.")
    if not tolerance > 0:
        raise InvalidInput("invalid_tolerance", "tolerance must be positive.")
    w, h = cell
    if not (w > 0 and h > 0):
        raise InvalidInput("invalid_cell", "cell half-width and half-height must be positive.")


def finite_strain_sheet(
    nx: int,
    ny: int,
    poisson: float,
    strain_range: tuple[float, float],
    tolerance: float,
    cell: tuple[float, float] = (1.0, 1.0),
) -> FiniteStrainSheet:
    """An n_x × n_y sheet whose secant Poisson ratio stays within ``tolerance`` of ``poisson``
    for ε_x over ``strain_range`` (lo < 0 < hi), see the module docstring: the families searched
    (the trammel by its stretch s; the Cardan trammel by c when |ν + 1| ≤ tolerance), then, when
    no member holds the range, the IPOPT refinement of the best member.  Raises
    FiniteStrainUnreachable (422 with the best figures) when none does."""
    check_finite_strain_request(nx, ny, strain_range, tolerance, cell)
    lo, hi = (float(v) for v in strain_range)
    w, h = cell
    beta = -poisson

    # Copies farther than MAX_REACH cells are not watched by the scans (the cost stays that of
    # a (MAX_REACH + 1)² sheet); the full sheet's closest pairs are checked in _verified_sheet.
    # The scans watch the pairs of the n_x × n_y sheet itself (a narrow sheet has fewer).
    cells = (nx, ny)

    def cover(module) -> float:
        """min(ε_max/hi, ε_min/lo) of the range scanned no further than [lo, hi] (1: contains it,
        confirmed by a scan locating its events to round-off: an event located to COVER_XTOL
        can be dismissed, e.g. a node passing a bar's end); 0 for a module whose nodes reach past
        MAX_REACH neighbours at the reference."""
        shortest = float(np.sqrt(np.min(module.squared_lengths)))
        if max(needed_reach(module, module.reference, shortest, (MAX_REACH + 2,) * 2)) > MAX_REACH:
            return 0.0
        usable = module_range(module, cells, limits=(lo, hi), xtol=COVER_XTOL, max_reach=MAX_REACH).range
        if usable.contains(lo) and usable.contains(hi):  # confirmed with its events located to round-off
            usable = module_range(module, cells, limits=(lo, hi), max_reach=MAX_REACH).range
        if usable.lower.reason == usable.upper.reason == "search_limit":  # (the scan's ends carry round-off)
            return 1.0
        return min(usable.upper.strain / hi, usable.lower.strain / lo)

    def trammel(stretch: float):
        c, e = trammel_coordinates(w, h, beta, float(stretch), SIGN)
        return trammel_module(w, h, c, e)

    def cardan(fraction: float):
        return cardan_trammel(w, h, float(fraction) * (w + h * h / w))

    families = [("trammel", STRETCHES, trammel)]
    if abs(poisson + 1.0) <= tolerance:
        families.insert(0, ("cardan", CARDAN_FRACTIONS, cardan))
    # The families' grids first, then the searches between grid points, then IPOPT from the best
    # module found.  Members of a family keep the linear ratio exactly ν; a refined module trades
    # it within the tolerance, so the families come first.
    best_dev, best_cover, warm, chosen, refined = None, -np.inf, None, None, None
    searches = []
    share = 0.4 / len(families)
    for f, (family, grid, member) in enumerate(families):
        with progress_stage(f * share, (f + 1) * share, f"the {family} family"):
            found = _search_family(grid, member, cover, poisson, lo, hi, tolerance)
        searches.append((family, grid, member, found))
        if best_dev is None or found.best_deviation[0] < best_dev["max_deviation"]:
            best_dev = {"max_deviation": found.best_deviation[0], "family": family, "parameter": found.best_deviation[1]}
        if found.chosen is not None:
            chosen = (family, found.chosen, member(found.chosen))
            break
        if found.warm_start is not None and (found.best_cover > best_cover or warm is None):
            best_cover, warm = found.best_cover, found.warm_start

    if chosen is None and warm is not None:
        share = 0.35 / len(searches)
        for f, (family, grid, member, found) in enumerate(searches):
            with progress_stage(0.4 + f * share, 0.4 + (f + 1) * share, f"the {family} family between grid points"):
                t, cover_t, module_t = _search_windows(grid, member, found.covers, cover, poisson, lo, hi, tolerance)
            if t is not None:
                chosen = (family, t, member(t))
                break
            best_cover = max(best_cover, cover_t)
            warm = module_t if module_t is not None else warm
        if chosen is None:
            with progress_stage(0.75, 0.8, "IPOPT refinement of the best module"):
                refined = _refined(warm, cover, poisson, lo, hi, cells)
            if refined is not None and refined[1] <= tolerance and refined[2] >= 1.0:
                chosen = ("refined", None, refined[0].module)
    if chosen is None:
        if best_cover == -np.inf:
            why = f"the best secant deviation over the range is {best_dev['max_deviation']:.3g}"
        else:
            why = (
                f"every module within the tolerance collides or locks inside it; the best reaches "
                f"{best_cover:.3g} of the requested range"
            )
        best = {"best_deviation": best_dev, "best_cover": None if best_cover == -np.inf else float(best_cover)}
        if refined is not None:
            best["refinement"] = {
                "max_deviation": refined[1], "cover": refined[2], "ipopt_status": refined[0].status,
                "coordinates": refined[0].module.reference[2:].tolist(),
            }
            why += f"; IPOPT's refinement of the best module holds {refined[1]:.3g} over {refined[2]:.3g} of it"
        raise FiniteStrainUnreachable(
            f"no module holds ν = {poisson:g} within ±{tolerance:g} over ε_x ∈ [{lo:g}, {hi:g}]: {why}.", best
        )
    family, parameter, module = chosen
    with progress_stage(0.8, 0.85, "the chosen module's usable range", detail=True):
        usable = module_range(module, cells, max_reach=MAX_REACH).range  # the whole usable range, for the report
    with progress_stage(0.85, 1.0, "the tiled sheet"):
        return _verified_sheet(module, nx, ny, poisson, (lo, hi), tolerance, usable, family, parameter)


@dataclass(frozen=True)
class _FamilySearch:
    """What _search_family found on a grid: the chosen parameter (None: no member holds the
    range), the smallest deviation (value, parameter), the covers of the members within the
    tolerance (grid index → cover), the best of them (−inf: none) and the module to start IPOPT
    from (best cover within the tolerance, else the smallest deviation; None if no member
    reaches both ends)."""

    chosen: float | None
    best_deviation: tuple[float, float]
    covers: dict
    best_cover: float
    warm_start: SymmetricModule | None


def _search_family(grid: np.ndarray, member, cover, poisson: float, lo: float, hi: float, tolerance: float) -> _FamilySearch:
    """The member of a one-parameter family (``member(t)``, t over ``grid`` ascending) whose
    secant deviation is within the tolerance and whose usable range covers [lo, hi], on the
    grid: deviations, then covers of the members within the tolerance (smallest parameter
    first: for the trammel its axis nodes sit nearest the module's centre there, farthest from
    the neighbours' bars)."""
    devs = []
    with progress_stage(0.0, 0.3, "secant ratios"):
        searched = report_steps(len(grid), "secant ratios of a member", step=0.05)
        for k, t in enumerate(grid):
            try:
                devs.append(_deviation(member(t), poisson, lo, hi))
            except (DomainError, np.linalg.LinAlgError):
                devs.append(np.inf)
            searched(k)
    devs = np.array(devs)
    k_best = int(np.argmin(devs))
    best_dev = (float(devs[k_best]), float(grid[k_best]))
    if not np.isfinite(devs).any():
        return _FamilySearch(None, best_dev, {}, -np.inf, None)
    within = np.flatnonzero(devs <= tolerance)
    covers = {}
    for i, k in enumerate(within):
        with progress_stage(0.3 + 0.7 * i / len(within), 0.3 + 0.7 * (i + 1) / len(within), "a module's usable range", detail=True):
            covers[k] = cover(member(grid[k]))
        if covers[k] >= 1.0:
            return _FamilySearch(float(grid[k]), best_dev, covers, covers[k], None)
    best_cover = max(covers.values(), default=-np.inf)
    warm = member(grid[max(covers, key=covers.get)] if covers else grid[k_best])
    return _FamilySearch(None, best_dev, covers, best_cover, warm)


def _search_windows(grid, member, covers: dict, cover, poisson, lo, hi, tolerance):
    """Between grid points: the usable window of the parameter can fall between them (it is
    ±1.5 % of s wide for ν = −0.5 over ±10 % on a square cell, and the cover is rugged in s), so
    the cover is maximised by Brent's bounded search around the best grid points (``covers``),
    best first.  Returns (the parameter found or None, the best cover of a member within the
    tolerance, the module to start IPOPT from: the one with the best cover whatever its
    deviation — collision-free over the most of the range, IPOPT then lowers its deviation)."""
    best_cover, warm, warm_key = -np.inf, None, None
    evaluated = report_steps(WINDOW_SEARCHES * WINDOW_EVALUATIONS, "searching between grid points", step=0.05)
    counted = iter(range(WINDOW_SEARCHES * WINDOW_EVALUATIONS))

    def window_cover(t: float) -> float:
        evaluated(next(counted, WINDOW_SEARCHES * WINDOW_EVALUATIONS - 1))
        return cover(member(t))

    for k in sorted(covers, key=covers.get, reverse=True)[:WINDOW_SEARCHES]:
        bounds = (grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)])
        found = minimize_scalar(
            lambda t: -window_cover(t), bounds=bounds, method="bounded",
            options={"xatol": WINDOW_XTOL * bounds[0], "maxiter": WINDOW_EVALUATIONS},
        )
        deviation = _deviation(member(found.x), poisson, lo, hi)
        if deviation <= tolerance:
            best_cover = max(best_cover, -found.fun)
            if -found.fun >= 1.0:
                return float(found.x), best_cover, None
        if warm_key is None or (-found.fun, -deviation) > warm_key:
            warm, warm_key = member(found.x), (-found.fun, -deviation)
    return None, best_cover, warm


def _refined(warm: SymmetricModule, cover, poisson, lo, hi, cells):
    """refine_module from ``warm`` (REFINE_TIME_S at most): (refinement, its deviation by
    continuation, its cover), or None when IPOPT could not start."""
    result = refine_module(warm, poisson, lo, hi, cells, REFINE_TIME_S)
    if result is None:
        return None
    deviation = float(_deviation(result.module, poisson, lo, hi))
    return result, deviation, float(cover(result.module)) if np.isfinite(deviation) else 0.0


def _verified_sheet(module, nx, ny, poisson, requested, tolerance, usable: StrainRange, family: str, parameter) -> FiniteStrainSheet:
    """Tile ``module`` and verify the sheet on its own (module docstring); 422
    ``inaccurate_design`` if the full sheet misses what the module promised."""
    lo, hi = requested
    q0 = module.reference
    positions = sheet_positions(module, nx, ny, q0)
    frame = Frame.build(positions, sheet_edges(module, nx, ny))
    with progress_stage(0.0, 0.3, "analysis", detail=True):
        analysis = analyze(frame, bases=False)
    if analysis.nontrivial_zero_modes != 1:
        raise DomainError(
            "no_solution", f"the tiled sheet has {analysis.nontrivial_zero_modes} nontrivial modes, not 1."
        )
    n_corners = (nx + 1) * (ny + 1)
    grid = np.arange(n_corners).reshape(ny + 1, nx + 1)
    boundary = {"left": grid[:, 0], "right": grid[:, -1], "bottom": grid[0], "top": grid[-1]}
    mode = sheet_velocities(module, nx, ny, q0, module.tangent(q0))
    strains = np.linspace(lo, hi, VERIFY_SAMPLES)
    strains = strains[strains != 0.0]
    lengths = np.linalg.norm(positions[frame.edges[:, 0]] - positions[frame.edges[:, 1]], axis=1)
    ratios, bar_error, configs, closest = [], 0.0, {}, np.inf
    with progress_stage(0.3, 0.9, "its motion"):
        checked = report_steps(len(strains), "checked a configuration", step=0.05)
        for side in (strains[strains > 0], strains[strains < 0][::-1]):
            q, at = q0, 0.0
            for eps in side:  # outward from the reference, tangent predictor and Newton
                q = module.configuration(eps, q + (eps - at) * module.tangent(q))
                if q is None:
                    raise DomainError("no_solution", f"the module's motion does not reach ε_x = {eps:g}.")
                at, configs[eps] = eps, q
                x = sheet_positions(module, nx, ny, q)
                stretched = np.linalg.norm(x[frame.edges[:, 0]] - x[frame.edges[:, 1]], axis=1)
                bar_error = max(bar_error, float(np.max(np.abs(stretched / lengths - 1))))
                ex, ey = boundary_strains(positions, x - positions, boundary)
                ratios.append((eps, -ey / ex))
                closest = min(closest, closest_unjoined(x, frame.edges) / lengths.min())
                checked(len(configs) - 1)
    ratios.sort()
    secant = np.array([r for _, r in ratios])
    deviation = float(np.max(np.abs(secant - poisson)))
    if deviation > tolerance or bar_error > SHEET_BAR_RTOL or closest < PROXIMITY_FRACTION:
        raise DomainError(
            "inaccurate_design",
            f"the tiled sheet misses the module's figures: secant deviation {deviation:.3g} (tolerance {tolerance:g}), "
            f"bar error {bar_error:.3g}, closest nodes without a bar {closest:.3g} of the shortest bar "
            f"(at least {PROXIMITY_FRACTION:g}).",
        )
    states = {
        "expanded": sheet_positions(module, nx, ny, configs[max(configs)]),
        "contracted": sheet_positions(module, nx, ny, configs[min(configs)]),
    }
    with progress_stage(0.9, 1.0, "the states"):
        lattice = measured_lattice(frame, mode, analysis, boundary, states, usable, np.arange(n_corners))
    return FiniteStrainSheet(
        lattice=lattice,
        family=family,
        parameter=parameter,
        coordinates=tuple(float(v) for v in q0[2:]),
        strains=np.array([e for e, _ in ratios]),
        secant_ratios=secant,
        max_deviation=deviation,
        max_relative_bar_error=bar_error,
        requested=(lo, hi),
        tolerance=tolerance,
    )


# ----------------------------------------------------------------------------------------------
# IPOPT refinement of a module


@dataclass(frozen=True, eq=False)
class ModuleRefinement:
    """IPOPT's refined module and its figures: the module (reference q₀ refined), IPOPT's last
    status, iterations (all rounds) and rounds (refine_module), the sampled strains (K,), IPOPT's
    minimax deviation t over them (the deviation by continuation is _deviation's) and the sum of
    the separations' slacks (≈ 0: every watched pair kept apart at the samples)."""

    module: SymmetricModule
    status: str
    iterations: int
    rounds: int
    strains: np.ndarray
    sampled_deviation: float
    slack: float


def refinement_counts(module: SymmetricModule, samples: int) -> tuple[int, int]:
    """(equalities, unknowns) of refine_module's NLP: n_o bar orbits at each of K samples and the
    shortest bar's length against the n_q − 2 reference coordinates, n_q − 1 per sample (b and
    the orbit coordinates; a is the sample's strain) and t (the slacks come with their own
    inequalities)."""
    n_q, n_o = len(module.reference), len(module.bar_orbits)
    return samples * n_o + 1, (n_q - 2) + samples * (n_q - 1) + 1


def _violations(module: SymmetricModule, patch, configs: np.ndarray, reference: int, shortest: float, reach: float):
    """Over the configurations (S, n_q) of a motion in the order of their strains (the reference
    is configs[reference]): the patch's node pairs closer than ``reach``·ℓ_min at some
    configuration (P, 2), and its (node, bar) pairs whose node changes sides of the bar's line
    between consecutive configurations while between the bar's ends, with the side at the
    reference (C, 3: node, patch bar, sign ±1)."""
    x = np.stack([patch.positions(module, q) for q in configs])  # (S, M, 2)
    gap = np.min(np.linalg.norm(x[:, patch.pairs[:, 0]] - x[:, patch.pairs[:, 1]], axis=2), axis=0)
    pairs = patch.pairs[gap <= reach * shortest]
    p, b = patch.node_bar[:, 0], patch.node_bar[:, 1]
    qa, qb = x[:, patch.bars[b, 0]], x[:, patch.bars[b, 1]]
    along, rel = qb - qa, x[:, p] - qa
    area = along[..., 0] * rel[..., 1] - along[..., 1] * rel[..., 0]  # (S, C)
    t = np.sum(rel * along, axis=2) / np.sum(along * along, axis=2)
    inside = (t >= 0) & (t <= 1)
    flips = (np.sign(area[1:]) != np.sign(area[:-1])) & (inside[1:] | inside[:-1])
    crossed = np.flatnonzero(flips.any(axis=0))
    side = np.sign(area[reference, crossed])
    side[side == 0] = 1.0
    return pairs, np.column_stack([p[crossed], b[crossed], side]).astype(int)


def _motion_configs(module: SymmetricModule, strains: np.ndarray) -> np.ndarray | None:
    """q at each strain (S, n_q), by continuation from the reference outward (None if the
    module's motion does not reach one of them)."""
    out = {0.0: module.reference}
    for side in (strains[strains > 0], strains[strains < 0][::-1]):
        q, at = module.reference, 0.0
        for eps in side:
            try:
                q = module.configuration(eps, q + (eps - at) * module.tangent(q))
            except np.linalg.LinAlgError:
                return None
            if q is None:
                return None
            at, out[eps] = eps, q
    return np.array([out[e] for e in strains])


def refine_module(
    module: SymmetricModule, poisson: float, lo: float, hi: float, cells: tuple[int, int], max_time_s: float
) -> ModuleRefinement | None:
    """Refine the module's unspecified coordinates with IPOPT so that its symmetric motion holds
    the secant ratio ν over [lo, hi] without collisions (warm start: ``module`` itself).

    At K = REFINE_SAMPLES strains ε_k (evenly over [lo, hi], 0 left out) the unknowns are the
    configurations q_k = (w(1 + ε_k), b_k, orbit coordinates), the reference's orbit coordinates
    (a = w, b = h fixed: the cell), the deviation t and a slack s_j ≥ 0 per watched pair:
        minimise    t + REFINE_SLACK_WEIGHT·Σ s_j + MODULE_REFINE_REGULARISER·‖q₀ − q₀⁰‖²/‖q₀⁰‖²
        subject to  |X_i(q_k) − X_j(q_k)|² = |X_i(q₀) − X_j(q₀)|²   for every bar orbit, every k
                    |(b_k/h − 1)/ε_k + ν| ≤ t                        (secant ratio at each sample)
                    ℓ_*(q₀)² = ℓ_*⁰², ℓ_o(q₀)² ≥ ℓ_*⁰²               (the warm start's shortest
                                                                      bar orbit * stays shortest)
                    |X_p − X_q|²/ℓ_*⁰² ≥ (SEPARATION·PROXIMITY_FRACTION)² − s_j  at q₀ and every
                    q_k, for watched node pairs p, q without a bar,
                    σ·(X_r − X_q) × (X_p − X_q)/ℓ_*⁰² ≥ (SEPARATION·PROXIMITY_FRACTION)² − s_j
                    likewise for watched nodes p and bars (q, r), σ the side at the reference,
                    |x|, |y| of every unspecified node within the box (BOX_GROWTH times the warm
                    start's extent, no farther than MAX_REACH neighbours),
    pairs of the module and its neighbours (Patch).  The slacks make a warm start that collides
    a feasible start.  The mirror symmetry is built into the unknowns (sheet_module: X = B·q),
    so the corners stay on (±a, ±b) and every refined module tiles.  K·n_o + 1 equalities
    against (n_q − 2) + K(n_q − 1) + 1 unknowns besides the slacks (refinement_counts; n_o =
    n_q − 1, so never more).  Watched pairs are found by rounds (at most REFINE_ROUNDS): the node
    pairs within WATCH_DISTANCE·ℓ_min along the warm start's motion and its crossings first, then
    after each solve the pairs that come closer than the threshold or cross along the refined
    module's motion (traced by continuation every ESTIMATE_STEP) are added and IPOPT restarts
    from its solution.  The caller measures the refined module (_deviation, module_range).  None
    when the time left is too short to start or the warm start's motion does not reach the
    samples."""
    w, h = module.cell
    strains = np.linspace(lo, hi, REFINE_SAMPLES + 1)
    strains = strains[np.abs(strains) > SAMPLE_ROUNDOFF * (hi - lo)]
    equalities, unknowns = refinement_counts(module, len(strains))
    if equalities > unknowns:  # a module with more bar orbits than n_q − 1 has no motion to shape
        raise DomainError("too_few_unknowns", f"{module.name}: {equalities} equations for {unknowns} unknowns.")
    fine = np.concatenate([[0.0], np.arange(ESTIMATE_STEP, hi + SAMPLE_ROUNDOFF, ESTIMATE_STEP), -np.arange(ESTIMATE_STEP, -lo + SAMPLE_ROUNDOFF, ESTIMATE_STEP)])
    fine = np.unique(np.concatenate([fine, [lo, hi]]))
    start = _motion_configs(module, strains)
    watch = _motion_configs(module, fine)
    if start is None or watch is None:
        return None
    shortest = float(np.sqrt(np.min(module.squared_lengths)))
    # Every unspecified node stays inside the box the warm start's motion spans, grown by
    # BOX_GROWTH (per axis) and no farther than MAX_REACH neighbours: the copies that can touch
    # the module are those of the patch watched (needed_reach's rule for that box at the
    # smallest cell of the range).
    smallest = np.min(watch[:, :2], axis=0)
    widest = (2 * (MAX_REACH + 1) * smallest - PROXIMITY_FRACTION * shortest) / 2 * (1 - BOX_SHRINK_RTOL)
    box = np.minimum(BOX_GROWTH * np.max(np.abs(module.positions(watch)[:, 4:]), axis=(0, 1)), widest)
    reach = np.floor((2 * box + PROXIMITY_FRACTION * shortest) / (2 * smallest)).astype(int)
    patch = Patch.of(module, tuple(int(min(r, c - 1, MAX_REACH)) for r, c in zip(reach, cells)), cells)
    reference = int(np.flatnonzero(fine == 0.0)[0])
    pairs, crossings = _violations(module, patch, watch, reference, shortest, WATCH_DISTANCE)

    n_q = len(module.reference)
    x_init = np.concatenate([
        module.reference[2:], start[:, 1:].ravel(),
        [float(np.max(np.abs((start[:, 1] / h - 1) / strains + poisson)))],
    ])
    result, iterations = None, 0
    deadline = time.monotonic() + max_time_s
    for round_ in range(1, REFINE_ROUNDS + 1):
        nlp, lbg, ubg, lbx, slack_start = _module_nlp(module, patch, poisson, strains, pairs, crossings, x_init, box)
        check_budget()  # the NLP's construction counts against the request's budget and ours
        left = deadline - time.monotonic()
        left = left if remaining() is None else min(left, remaining())
        if left <= 0:
            break
        solver = ipopt_solver("finite_strain", nlp, IPOPT_TOL, REFINE_MAX_ITER, left)
        sol = solver(x0=np.concatenate([x_init, slack_start]), lbg=lbg, ubg=ubg, lbx=lbx)
        stats = solver.stats()
        solution = np.asarray(sol["x"]).ravel()
        x_init = solution[: len(x_init)]
        iterations += max(int(stats.get("iter_count", 0)), 0)
        refined = module.with_reference(np.concatenate([[w, h], x_init[: n_q - 2]]))
        result = ModuleRefinement(
            refined, str(stats.get("return_status")), iterations, round_, strains, float(x_init[-1]),
            float(np.sum(solution[len(x_init):])),
        )
        traced = _motion_configs(refined, fine)
        if traced is None:
            break
        new_pairs, new_crossings = _violations(
            refined, patch, traced, reference, float(np.sqrt(np.min(refined.squared_lengths))), PROXIMITY_FRACTION * SEPARATION
        )
        new_pairs = _new_rows(new_pairs, pairs)
        new_crossings = _new_rows(new_crossings, crossings, columns=2)
        if not len(new_pairs) and not len(new_crossings):
            break
        pairs, crossings = np.vstack([pairs, new_pairs]), np.vstack([crossings, new_crossings])
    return result


def _new_rows(rows: np.ndarray, known: np.ndarray, columns: int | None = None) -> np.ndarray:
    """The rows of ``rows`` whose first ``columns`` entries are not those of a row of ``known``."""
    k = slice(None, columns)
    seen = {tuple(r) for r in known[:, k].tolist()}
    keep = [i for i, r in enumerate(rows[:, k].tolist()) if tuple(r) not in seen]
    return rows[keep]


def _module_nlp(module: SymmetricModule, patch, poisson: float, strains: np.ndarray, pairs, crossings, start, box):
    """refine_module's NLP (its docstring) as casadi matrix expressions over w = (q₀'s orbit
    coordinates, q_1[1:] … q_K[1:], t, slacks): (nlp, lbg, ubg, lbx, the slacks' starting
    values — each pair's largest shortfall when the other unknowns are ``start``).  ``box`` (2,):
    the largest |x|, |y| of an unspecified node."""
    w, h = module.cell
    n_q, n_k = len(module.reference), len(strains)
    n_main, n_slack = len(start), len(pairs) + len(crossings)
    z = ca.SX.sym("w", n_main + n_slack)
    t = z[n_main - 1]
    slack = z[n_main:]
    z_ref = z[: n_q - 2]
    q_ref = ca.vertcat(w, h, z_ref)
    rest = ca.reshape(z[n_q - 2 : n_main - 1], n_q - 1, n_k)
    q_all = ca.horzcat(q_ref, ca.vertcat(ca.DM(w * (1 + strains)).T, rest))  # (n_q, K + 1): the reference, then the samples
    reps = module.bar_orbits
    scale = float(np.max(module.squared_lengths))

    def squared(ops_x, ops_y):
        """Σ over x, y of (D·q)² per row, for every column of q_all: (rows, K + 1)."""
        dx, dy = ca.mtimes(ca.DM(ops_x), q_all), ca.mtimes(ca.DM(ops_y), q_all)
        return dx * dx + dy * dy

    bx, by = module.basis[:, 0, :], module.basis[:, 1, :]
    lengths = squared(bx[reps[:, 0]] - bx[reps[:, 1]], by[reps[:, 0]] - by[reps[:, 1]]) / scale  # (n_o, K+1)
    g_bars = ca.vec(lengths[:, 1:] - ca.repmat(lengths[:, 0], 1, n_k))
    ratio = (ca.vec(rest[0, :]) / h - 1) / ca.DM(strains) + poisson
    g_nu = ca.vertcat(ratio + t, t - ratio)
    # The shortest bar orbit keeps its length ℓ_min and the others stay longer: the proximity
    # threshold PROXIMITY_FRACTION·ℓ_min is a constant of the NLP.
    shortest = int(np.argmin(module.squared_lengths))
    m = float(module.squared_lengths[shortest])
    g_short = lengths[:, 0] - m / scale
    # Patch positions are linear in q too: node n of the copy at offset o is B_n·q + 2o·(a, b).
    px = module.basis[patch.node, 0, :].copy()
    py = module.basis[patch.node, 1, :].copy()
    px[:, 0] += 2 * patch.offset[:, 0]
    py[:, 1] += 2 * patch.offset[:, 1]
    floor = (SEPARATION * PROXIMITY_FRACTION) ** 2 * m / scale
    gap = squared(px[pairs[:, 0]] - px[pairs[:, 1]], py[pairs[:, 0]] - py[pairs[:, 1]]) / scale - floor
    node, bar, side = crossings[:, 0], crossings[:, 1], crossings[:, 2].astype(float)
    qa, qb = patch.bars[bar, 0], patch.bars[bar, 1]
    ax, ay = ca.mtimes(ca.DM(px[qb] - px[qa]), q_all), ca.mtimes(ca.DM(py[qb] - py[qa]), q_all)
    rx, ry = ca.mtimes(ca.DM(px[node] - px[qa]), q_all), ca.mtimes(ca.DM(py[node] - py[qa]), q_all)
    area = ca.repmat(ca.DM(side), 1, n_k + 1) * (ax * ry - ay * rx) / scale - floor
    apart = ca.vertcat(gap, area)  # (pairs + crossings, K + 1), each ≥ −its slack
    g_apart = ca.vec(apart + ca.repmat(slack, 1, n_k + 1))
    z_start = module.reference[2:]
    objective = (
        t + REFINE_SLACK_WEIGHT * ca.sum1(slack)
        + MODULE_REFINE_REGULARISER * ca.sumsqr(z_ref - ca.DM(z_start)) / float(np.sum(z_start**2))
    )
    g_box = ca.vertcat(*[ca.vec(box[k] ** 2 - ca.mtimes(ca.DM(module.basis[4:, k, :]), q_all) ** 2) / scale for k in (0, 1)])
    g = ca.vertcat(g_bars, g_short[shortest], g_nu, g_short, g_apart, g_box)
    n_eq = g_bars.numel() + 1
    lbg = np.zeros(g.numel())
    ubg = np.concatenate([np.zeros(n_eq), np.full(g.numel() - n_eq, np.inf)])
    lbx = np.concatenate([np.full(n_main, -np.inf), np.zeros(n_slack)])
    # Slacks at the start: the largest shortfall of each pair over the samples (0 if none).
    values = np.asarray(ca.Function("apart", [z], [apart])(np.concatenate([start, np.zeros(n_slack)])))
    slack_start = np.maximum(-values.min(axis=1), 0.0) + IPOPT_TOL if n_slack else np.zeros(0)
    return {"x": z, "f": objective, "g": g}, lbg, ubg, lbx, slack_start
