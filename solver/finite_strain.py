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
included) contains it.  Everything is computed on one module, so the cost of the design does not
grow with the number of cells.

The tiled sheet is then verified on its own: the rank analysis of the full frame (exactly one
nontrivial zero mode), and at VERIFY_SAMPLES strains across the range the sheet's positions
(tiled from the module's Newton-exact configuration) with every bar length recomputed, the
closest pair of nodes without a bar on the full sheet (k-d tree), and the secant ν measured from
the boundary means of the full sheet.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.lattice import (
    MAX_SHEET_CELLS,
    Lattice,
    boundary_strains,
    closest_unjoined,
    measured_lattice,
)
from zeromode.solver.progress import progress_stage, report_progress, report_steps
from zeromode.solver.rigidity import analyze
from zeromode.solver.sheet_module import (
    SymmetricModule,
    sheet_edges,
    sheet_positions,
    sheet_velocities,
    trammel_coordinates,
    trammel_module,
)
from zeromode.solver.strain_range import PROXIMITY_FRACTION, StrainRange, module_range, needed_reach

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
# The search compares candidates' ranges: their events are located to this strain (the chosen
# module's range is then scanned to round-off).
COVER_XTOL = 1e-5
# Modules whose nodes reach past this many neighbours (in x or y) at the reference are not
# considered: their axis nodes lie among the bars of modules three cells away, and the range
# scan (whose patch grows with the reach) would make the cost grow with the sheet up to that size.
MAX_REACH = 3
# Strain step of the deviation estimate on each candidate (Newton continuation of the module).
ESTIMATE_STEP = 0.01
# Strains at which the tiled sheet is verified (the ends of the requested range included).
VERIFY_SAMPLES = 9
# A bar of the verified sheet may change its length by at most this much (relative).
BAR_RTOL = 1e-9


@dataclass(frozen=True, eq=False)
class FiniteStrainSheet:
    """A sheet holding its secant ratio: the lattice (states at the ends of the requested range),
    the module chosen (stretch s, trammel sign, coordinates (c, e)), and the verification on the
    full sheet: strains (S,), secant ν (S,) measured there, max |ν_s − ν|, max bar error."""

    lattice: Lattice
    stretch: float
    sign: float
    coordinates: tuple[float, float]
    strains: np.ndarray
    secant_ratios: np.ndarray
    max_deviation: float
    max_relative_bar_error: float
    requested: tuple[float, float]
    tolerance: float


class FiniteStrainUnreachable(DomainError):
    """No module of the family holds ν within the tolerance over the range; ``best`` holds the
    best figures found: the smallest deviation over the requested range (with its usable range)
    and the widest usable range among members within the tolerance."""

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
    for ε_x over ``strain_range`` (lo < 0 < hi), see the module docstring.  Raises
    FiniteStrainUnreachable (422 with the best figures) when no member of the family does."""
    check_finite_strain_request(nx, ny, strain_range, tolerance, cell)
    lo, hi = (float(v) for v in strain_range)
    w, h = cell
    beta = -poisson

    # Copies farther than MAX_REACH cells are not watched by the scans (the cost stays that of
    # a (MAX_REACH + 1)² sheet); the full sheet's closest pairs are checked in _verified_sheet.
    scan_cells = (min(nx, MAX_REACH + 1), min(ny, MAX_REACH + 1))

    def member(stretch: float):
        c, e = trammel_coordinates(w, h, beta, float(stretch), SIGN)
        return trammel_module(w, h, c, e)

    def cover(module) -> float:
        """min(ε_max/hi, ε_min/lo) of the range scanned no further than [lo, hi] (1: contains it);
        0 for a module whose nodes reach past MAX_REACH neighbours at the reference."""
        shortest = float(np.sqrt(np.min(module.squared_lengths)))
        if max(needed_reach(module, module.reference, shortest, (MAX_REACH + 1,) * 2)) > MAX_REACH:
            return 0.0
        usable = module_range(module, scan_cells, limits=(lo, hi), xtol=COVER_XTOL).range
        return min(usable.upper.strain / hi, usable.lower.strain / lo)

    devs = []
    with progress_stage(0.0, 0.2, "the module family"):
        searched = report_steps(len(STRETCHES), "secant ratios of a member", step=0.05)
        for k, stretch in enumerate(STRETCHES):
            try:
                devs.append(_deviation(member(stretch), poisson, lo, hi))
            except (DomainError, np.linalg.LinAlgError):
                devs.append(np.inf)
            searched(k)
    devs = np.array(devs)
    if not np.isfinite(devs).any():
        raise FiniteStrainUnreachable(
            f"no trammel module of linear ratio {poisson:g} reaches both ends of [{lo:g}, {hi:g}].", {}
        )
    k_best = int(np.argmin(devs))
    best_dev = {"max_deviation": float(devs[k_best]), "stretch": float(STRETCHES[k_best])}
    within = np.flatnonzero(devs <= tolerance)
    covers = {}
    chosen = None
    # The smallest stretch first: the axis nodes sit nearest the module's centre there,
    # farthest from the neighbours' bars.
    for i, k in enumerate(within):
        with progress_stage(0.2 + 0.4 * i / len(within), 0.2 + 0.4 * (i + 1) / len(within), "a module's usable range", detail=True):
            covers[k] = cover(member(STRETCHES[k]))
        if covers[k] >= 1.0:
            chosen = float(STRETCHES[k])
            break
    # The usable window of s can fall between grid points (it is ±1.5 % of s wide for ν = −0.5
    # over ±10 % on a square cell, and the cover is rugged in s): maximise the cover around the
    # best grid points, best first.
    best_cover = max(covers.values(), default=-np.inf)
    report_progress(0.6, "scanned the modules within the tolerance")
    # Progress of the window searches: one report per cover evaluated (at most all of them).
    evaluated = report_steps(WINDOW_SEARCHES * WINDOW_EVALUATIONS, "searching between grid points", step=0.05)
    counted = iter(range(WINDOW_SEARCHES * WINDOW_EVALUATIONS))

    def window_cover(t: float) -> float:
        evaluated(next(counted, WINDOW_SEARCHES * WINDOW_EVALUATIONS - 1))
        return cover(member(t))

    with progress_stage(0.6, 0.75):
        for k in sorted(covers, key=covers.get, reverse=True)[:WINDOW_SEARCHES] if chosen is None else ():
            bounds = (STRETCHES[max(k - 1, 0)], STRETCHES[min(k + 1, len(STRETCHES) - 1)])
            found = minimize_scalar(
                lambda t: -window_cover(t), bounds=bounds, method="bounded",
                options={"xatol": WINDOW_XTOL * bounds[0], "maxiter": WINDOW_EVALUATIONS},
            )
            best_cover = max(best_cover, -found.fun)
            if -found.fun >= 1.0 and _deviation(member(found.x), poisson, lo, hi) <= tolerance:
                chosen = float(found.x)
                break
    if chosen is None:
        if not covers:
            why = f"the best secant deviation over the range is {best_dev['max_deviation']:.3g}"
        else:
            why = (
                f"every module within the tolerance collides or locks inside it; the best reaches "
                f"{best_cover:.3g} of the requested range"
            )
        raise FiniteStrainUnreachable(
            f"no module holds ν = {poisson:g} within ±{tolerance:g} over ε_x ∈ [{lo:g}, {hi:g}]: {why}.",
            {"best_deviation": best_dev, "best_cover": None if not covers else float(best_cover)},
        )
    module = member(chosen)
    s, sign = chosen, SIGN
    with progress_stage(0.75, 0.8, "the chosen module's usable range", detail=True):
        usable = module_range(module, scan_cells).range  # the whole usable range, for the report
    with progress_stage(0.8, 1.0, "the tiled sheet"):
        return _verified_sheet(module, nx, ny, poisson, (lo, hi), tolerance, usable, s, sign)


def _verified_sheet(module, nx, ny, poisson, requested, tolerance, usable: StrainRange, s, sign) -> FiniteStrainSheet:
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
    if deviation > tolerance or bar_error > BAR_RTOL or closest < PROXIMITY_FRACTION:
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
        stretch=s,
        sign=sign,
        coordinates=(float(q0[2]), float(q0[3])),
        strains=np.array([e for e, _ in ratios]),
        secant_ratios=secant,
        max_deviation=deviation,
        max_relative_bar_error=bar_error,
        requested=(lo, hi),
        tolerance=tolerance,
    )
