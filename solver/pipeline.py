"""The user's pipeline: analytic design → optional refinement → optional certificates.

This is the one place that chains the stages. Routes, jobs, the CLI and the library call
``design_pipeline``; nothing else decides which stages a request needs or how large they are.

Stages (each only when asked: model no more than the scene needs):
  1. design      the quadric construction of the paper (Eqs. 4–7; design.design), verified by
                 one full rigidity analysis of the designed frame;
  2. refine      casadi/IPOPT refinement of the unspecified nodes for finite-motion fidelity
                 (refine.refine), which reuses the design's analysis as its reference and
                 analyses the refined frame once (plus a counts-only check of its far end);
  3. certify     self-stress, prestress stability and rigidity margin of the linear design
                 (certificates.certify), which reuses the design's analysis.
  4. tolerance   how precisely the linear design must be built: linear sensitivities to bar
                 length and pin position errors checked by a seeded Monte Carlo
                 (tolerance.tolerance_report).
So a design + refine + certify request runs the full analysis twice: the designed frame and the
refined frame.

Sizing: the stiffness-allocation SDP has a p × p LMI with p = dN − d(d+1)/2 − M (the motions
to suppress); past ``SDP_MAX_DIM`` the certificate keeps the uniform margin only.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np

from zeromode.solver.applications.finite_strain import (
    FiniteStrainSheet,
    check_finite_strain_request,
    finite_strain_sheet,
)
from zeromode.solver.applications.lattice import (
    Lattice,
    auxetic_chain_3d,
    auxetic_sheet,
    chain_couplings,
    chain_modules,
    chain_specified,
    check_sheet_strain,
    sheet_module_for,
)
from zeromode.solver.applications.sheet_module import sheet_edges, sheet_positions
from zeromode.solver.certificates.fabrication import (
    ToleranceReport,
    check_tolerance_request,
    tolerance_report,
)
from zeromode.solver.certificates.prestress import SDP_MAX_DIM, Certificate, certify, check_size
from zeromode.solver.construction.coupling import merged_frame
from zeromode.solver.construction.design import Design, design, design_targets
from zeromode.solver.errors import InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.motion.boundary_strain import poisson_ratio
from zeromode.solver.motion.refine import Refinement, RefinementFailed, check_problem_size, refine
from zeromode.solver.progress import progress_stage
from zeromode.solver.tolerances import IPOPT_TOL

# Estimated cost of the stages in seconds, for progress: each stage that runs gets its share of
# the whole (_shares).  Measured with the default options (Fig. 3c square, cube, 2 × 2 to 40 × 40
# sheets, 8-block chain): a design 0.01–0.02 s, a sheet 0.1–0.2 s, a chain or a finite-strain
# sheet 4–8 s (continuations, scans), refinement 2.5–4 s, certificates 0.05–1.3 s, tolerances
# (default 64 samples) 0.3–5 s.
STAGE_COSTS_S = {"design": 0.02, "sheet": 0.2, "traced lattice": 5.0, "refine": 3.0, "certify": 0.5, "tolerance": 3.0}


def _shares(first: str, refine_stage, certify_stage: bool, tolerance_stage) -> dict[str, tuple[float, float]]:
    """The progress_stage of each stage that runs ("design" from STAGE_COSTS_S[first], then the
    ones asked for, in order): consecutive intervals of [0, 1] as long as their costs."""
    asked = {"refine": refine_stage is not None, "certify": certify_stage, "tolerance": tolerance_stage is not None}
    stages = ["design", *(name for name, run in asked.items() if run)]
    weights = [STAGE_COSTS_S[first if name == "design" else name] for name in stages]
    ends = np.cumsum([0.0, *weights]) / sum(weights)
    return {name: (float(ends[i]), float(ends[i + 1])) for i, name in enumerate(stages)}


@dataclass(frozen=True)
class RefineStage:
    """Options of the refinement stage, passed to refine.refine under these names: the relative
    amplitude a, K configurations, IPOPT's tolerance and time limit per solve."""

    amplitude: float = 0.1
    K: int = 8
    tol: float = IPOPT_TOL
    max_time_s: float = 5.0


@dataclass(frozen=True)
class ToleranceStage:
    """Options of the tolerance stage, passed to tolerance.tolerance_report under these names: the
    relative change tolerated and the Monte Carlo's sample count."""

    budget: float = 0.01
    samples: int = 64


@dataclass(frozen=True, eq=False)
class PipelineResult:
    """What the design pipeline produced (design, then the stages asked for).

    Attributes
    ----------
    design : Design
        The verified linear design (its frame and modes are the contract's answer).
    refinement : Refinement or None
        The refined frame, or after a failure the best one found (``ok`` False), or None when
        not asked.
    certificate : Certificate or None
        The certificates of the linear design, or None.
    timings_ms : dict
        Wall time of each stage that ran and the total.
    tolerance : ToleranceReport or None
        The fabrication tolerances of the linear design, or None.
    """

    design: Design
    refinement: Refinement | None
    certificate: Certificate | None
    timings_ms: dict[str, float]
    tolerance: ToleranceReport | None = None


def stiffness_sdp_fits(frame: Frame, zero_modes: int) -> bool:
    """True when the stiffness-allocation LMI (p × p, p = dN − d(d+1)/2 − M, ``zero_modes`` =
    d(d+1)/2 + M) is within SDP_MAX_DIM.  The large-LMI routes (certificates/stiffness.py) reach
    p = OPTIMAL_MAX_DIM but take 26–40 s at p = 2478 (20 × 20 sheet, interior point) and 41 s
    for the 64-block chain (spectral bundle)
    (docs/benchmarks/certificates.md): past a pipeline stage's budget, so the pipeline keeps the
    LMI cap and /v1/certify serves the larger margins."""
    return frame.dim * frame.n_nodes - zero_modes <= SDP_MAX_DIM


def check_design_request(
    positions,
    motions,
    *,
    dim: int | None = None,
    seed: int = 0,
    n_unspecified: int | None = None,
    refine_stage: RefineStage | None = None,
    certify_stage: bool = False,
    tolerance_stage: ToleranceStage | None = None,
) -> None:
    """design_pipeline's refusals before any stage runs (design_pipeline's arguments): a
    refinement of more than one motion (InvalidInput ``invalid_options``), then design's
    (design_targets).  The refine, certify and tolerance stages' sizes depend on the designed
    frame: they are decided when it exists."""
    if refine_stage is not None and len(motions) != 1:
        raise InvalidInput(
            "invalid_options", "refinement follows one motion; give a single motion."
        )
    design_targets(positions, motions, dim, n_unspecified)


def design_pipeline(
    positions,
    motions,
    *,
    dim: int | None = None,
    seed: int = 0,
    n_unspecified: int | None = None,
    refine_stage: RefineStage | None = None,
    certify_stage: bool = False,
    tolerance_stage: ToleranceStage | None = None,
) -> PipelineResult:
    """Design, then (if asked) refine and certify; see the module docstring.

    positions: x_S (k, d); motions: M motions, each (k, d). refine_stage follows one motion
    (M = 1). Raises the DomainErrors of the stages it runs (a failed refinement is not an
    error: its best result is returned with ``ok`` False).
    """
    check_design_request(positions, motions, dim=dim, n_unspecified=n_unspecified, refine_stage=refine_stage)
    share = _shares("design", refine_stage, certify_stage, tolerance_stage)
    t0 = time.perf_counter()
    with progress_stage(*share["design"], "design"):
        result = design(positions, motions, dim=dim, seed=seed, n_unspecified=n_unspecified)
    timings = {"design": 1e3 * (time.perf_counter() - t0)}
    refined = None
    if refine_stage is not None:
        t1 = time.perf_counter()
        with progress_stage(*share["refine"], "refinement"):
            try:
                refined = refine(
                    result.frame,
                    motion_s=np.asarray(motions[0], dtype=float),
                    analysis=result.analysis,
                    **asdict(refine_stage),
                )
            except RefinementFailed as exc:
                refined = exc.best
        timings["refine"] = 1e3 * (time.perf_counter() - t1)
    certificate = None
    if certify_stage:
        t2 = time.perf_counter()
        with progress_stage(*share["certify"], "certificates"):
            certificate = certify(
                result.frame,
                list(result.modes),
                stiffness=stiffness_sdp_fits(result.frame, result.target_zero_modes),
                analysis=result.analysis,
            )
        timings["certify"] = 1e3 * (time.perf_counter() - t2)
    tolerance = None
    if tolerance_stage is not None:
        t3 = time.perf_counter()
        with progress_stage(*share["tolerance"], "tolerances"):
            tolerance = tolerance_report(result.frame, result.modes, seed=seed, **asdict(tolerance_stage))
        timings["tolerance"] = 1e3 * (time.perf_counter() - t3)
    timings["total"] = 1e3 * (time.perf_counter() - t0)
    return PipelineResult(result, refined, certificate, timings, tolerance)


@dataclass(frozen=True, eq=False)
class AuxeticResult:
    """What the auxetic pipeline produced.

    Attributes
    ----------
    lattice : Lattice
        The verified lattice, with its usable strain range and finite states.
    refinement : Refinement or None
        Its refinement, or None when not asked.
    refined_poisson_ratio : float or None
        The refined frame's linear Poisson ratio (None when not refined or when the refined
        frame has not exactly one nontrivial mode).
    certificate : Certificate or None
        The lattice's certificates, or None.
    timings_ms : dict
        Wall time of each stage that ran and the total.
    tolerance : ToleranceReport or None
        The fabrication tolerances, or None.
    finite_strain : FiniteStrainSheet or None
        The sheet designed for a secant Poisson ratio at a finite strain, or None.
    """

    lattice: Lattice
    refinement: Refinement | None
    refined_poisson_ratio: float | None
    certificate: Certificate | None
    timings_ms: dict[str, float]
    tolerance: ToleranceReport | None = None
    finite_strain: FiniteStrainSheet | None = None


def check_auxetic_request(
    dim: int,
    cells,
    *,
    poisson: float,
    cell=None,
    strain: float | None = None,
    refine_stage: RefineStage | None = None,
    certify_stage: bool = False,
    tolerance_stage: ToleranceStage | None = None,
    finite_strain: tuple[float, float, float] | None = None,
    seed: int = 0,
) -> None:
    """auxetic_pipeline's refusals before the lattice is built (auxetic_pipeline's arguments),
    in its order: finite_strain on a 3D chain, then the lattice's own (finite-strain sheet:
    check_finite_strain_request; sheet: sheet_module_for, then check_sheet_strain — one
    module's scan, kept for the run; chain: chain_couplings), then the stages' sizes on the
    lattice's frame at rest (refine.check_problem_size, certificates.check_size,
    tolerance.check_tolerance_request; a chain's frame needs its block designed, kept for the
    run).  Not decided here: a chain's strain (its range is a continuation of the whole chain),
    a finite-strain sheet's stages (its module is chosen by the design), and what only the
    analysis shows (the lattice's single mode).  ``seed``: the chain's block design."""
    if finite_strain is not None:
        if dim != 2:
            raise InvalidInput("invalid_options", "finite_strain holds the secant ratio of 2D sheets only.")
        check_finite_strain_request(*cells, finite_strain[:2], finite_strain[2], tuple(cell or (1.0, 1.0)))
        return
    stages = refine_stage is not None or certify_stage or tolerance_stage is not None
    if dim != 2:
        n, block = cells[0], tuple(cell or (1.0, 1.0, 1.0))
        if not stages:
            chain_couplings(n, poisson, block)
            return
        # The chain's nodes and bars (one block designed), its ports and apexes specified.
        frame, _ = merged_frame(*chain_modules(n, poisson, block, seed), chain_specified(n))
    else:
        module, _ = sheet_module_for(*cells, poisson, tuple(cell or (1.0, 1.0)))
        check_sheet_strain(*cells, poisson, tuple(cell or (1.0, 1.0)), strain)
        if not stages:
            return
        # The sheet's nodes and bars at rest, its corner grid specified as the refinement drives it.
        n_corners = (cells[0] + 1) * (cells[1] + 1)
        frame = Frame.build(
            sheet_positions(module, *cells, module.reference), sheet_edges(module, *cells), range(n_corners)
        )
    if refine_stage is not None:
        check_problem_size(frame, refine_stage.K)
    if certify_stage:
        check_size(frame, 1, stiffness_sdp_fits(frame, frame.dim * (frame.dim + 1) // 2 + 1))
    if tolerance_stage is not None:
        check_tolerance_request(frame, tolerance_stage.budget, tolerance_stage.samples)


def auxetic_pipeline(
    dim: int,
    cells,
    *,
    poisson: float,
    cell=None,
    strain: float | None = None,
    seed: int = 0,
    refine_stage: RefineStage | None = None,
    certify_stage: bool = False,
    tolerance_stage: ToleranceStage | None = None,
    finite_strain: tuple[float, float, float] | None = None,
) -> AuxeticResult:
    """A 2D sheet (cells (n_x, n_y), cell (w, h)) or 3D chain (cells (n,), cell (w, h, l)), then
    (if asked) the stages of design_pipeline on it: refinement of the unspecified nodes with the
    specified ones (sheet corners, chain ports and apexes) driven along the lattice's mode,
    certificates and tolerances of the linear lattice.  Raises the DomainErrors of the stages
    it runs (a refinement whose problem has more equations than unknowns is refused by refine).
    finite_strain (ε_lo, ε_hi, tolerance): a 2D sheet whose secant ν stays within the tolerance
    of ``poisson`` over [ε_lo, ε_hi] (finite_strain.finite_strain_sheet; its states at the ends,
    ``strain`` unused)."""
    traced = finite_strain is not None or dim != 2
    share = _shares("traced lattice" if traced else "sheet", refine_stage, certify_stage, tolerance_stage)
    held = None
    with progress_stage(*share["design"], "lattice"):
        # A sheet's strain is checked by its module's scan (kept for the run): its reports.
        with progress_stage(0.0, 0.3, "checks", detail=True):
            check_auxetic_request(
                dim, cells, poisson=poisson, cell=cell, strain=strain, refine_stage=refine_stage,
                certify_stage=certify_stage, tolerance_stage=tolerance_stage, finite_strain=finite_strain,
            )
        t0 = time.perf_counter()
        with progress_stage(0.3, 1.0):
            if finite_strain is not None:
                held = finite_strain_sheet(
                    *cells, poisson=poisson, strain_range=finite_strain[:2], tolerance=finite_strain[2],
                    cell=tuple(cell or (1.0, 1.0)),
                )
                lat = held.lattice
            elif dim == 2:
                lat = auxetic_sheet(*cells, poisson=poisson, cell=tuple(cell or (1.0, 1.0)), strain=strain)
            else:
                lat = auxetic_chain_3d(
                    cells[0], poisson=poisson, block=tuple(cell or (1.0, 1.0, 1.0)), strain=strain, seed=seed
                )
    timings = {"design": 1e3 * (time.perf_counter() - t0)}
    refined, refined_nu = None, None
    if refine_stage is not None:
        t1 = time.perf_counter()
        frame = Frame.build(lat.frame.positions, lat.frame.edges, lat.driven, dim=lat.frame.dim)
        with progress_stage(*share["refine"], "refinement"):
            try:
                refined = refine(frame, motion_s=lat.mode[lat.driven], **asdict(refine_stage))
            except RefinementFailed as exc:
                refined = exc.best
        if refined.mode is not None:
            sets = {k: np.asarray(v) for k, v in lat.boundary.items()}
            refined_nu = poisson_ratio(refined.frame.positions, refined.mode, sets)
        timings["refine"] = 1e3 * (time.perf_counter() - t1)
    certificate = None
    if certify_stage:
        t2 = time.perf_counter()
        zero_modes = lat.frame.dim * (lat.frame.dim + 1) // 2 + 1
        with progress_stage(*share["certify"], "certificates"):
            certificate = certify(
                lat.frame, [lat.mode], stiffness=stiffness_sdp_fits(lat.frame, zero_modes), analysis=lat.analysis
            )
        timings["certify"] = 1e3 * (time.perf_counter() - t2)
    tolerance = None
    if tolerance_stage is not None:
        t3 = time.perf_counter()
        with progress_stage(*share["tolerance"], "tolerances"):
            tolerance = tolerance_report(lat.frame, [lat.mode], boundary=lat.boundary, seed=seed, **asdict(tolerance_stage))
        timings["tolerance"] = 1e3 * (time.perf_counter() - t3)
    timings["total"] = 1e3 * (time.perf_counter() - t0)
    return AuxeticResult(lat, refined, refined_nu, certificate, timings, tolerance, held)
