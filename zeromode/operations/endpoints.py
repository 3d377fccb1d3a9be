"""The one pipeline behind the three doors: each endpoint's operation on its validated request
(zeromode.service.wire.schemas), returning the solver's result and the endpoint's body
(``Outcome``). The REST routes (parse → call → serialise), the job engine's tasks
(``OPERATIONS``), the CLI and the library's functions (``zeromode.analyze``, …) call these same
functions, so every door answers the same.

A domain failure is raised as the solver raises it (a DomainError with ``code``); where the
endpoint's 422 carries the best result found (a singular or unreachable motion, a failed
refinement, an inaccurate allosteric design, an unreachable finite strain), the exception
carries its body too (zeromode.service.wire.errors.with_best).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel

from zeromode.operations.documents import (
    MAP,
    allosteric_arguments,
    auxetic_arguments,
    design_arguments,
    is_map_request,
    kind,
    multistable_arguments,
    sequential_arguments,
    validated,
)
from zeromode.operations.prechecks import motion_frame
from zeromode.service.wire.convert import frame_from_model, module_from_model
from zeromode.service.wire.errors import with_best
from zeromode.service.wire.responses import (
    allosteric_body,
    analyze_body,
    auxetic_body,
    certificate_body,
    design_body,
    elastic_allosteric_body,
    inaccurate_design_best,
    json_safe,
    map_response_body,
    motion_body,
    multistable_body,
    network_allosteric_body,
    refinement_body,
    sequential_body,
    sequential_refusal_best,
    solution_space_body,
    two_configuration_body,
)
from zeromode.service.wire.schemas.allostery import (
    AllostericRequest,
    AllostericResponse,
    NetworkAllostericAnswer,
    NetworkAllostericRequest,
)
from zeromode.service.wire.schemas.analyze import AnalyzeRequest, AnalyzeResponse
from zeromode.service.wire.schemas.certify import CertifyRequest, CertifyResponse
from zeromode.service.wire.schemas.design import (
    DesignRequest,
    DesignResponse,
    SolutionSpaceRequest,
    SolutionSpaceResponse,
    TwoConfigurationRequest,
    TwoConfigurationResponse,
)
from zeromode.service.wire.schemas.lattice import AuxeticRequest, AuxeticResponse
from zeromode.service.wire.schemas.motion import (
    MotionRequest,
    MotionResponse,
    RefineRequest,
    RefineResponse,
)
from zeromode.service.wire.schemas.multistable import MultistableRequest, MultistableResponse
from zeromode.service.wire.schemas.sequential import (
    MapRequest,
    MapResponse,
    SequentialRequest,
    SequentialResponse,
)
from zeromode.service.wire.settings import current_settings
from zeromode.solver.applications.allostery import InaccurateDesign, design_allosteric
from zeromode.solver.applications.elastic_allostery import (
    MAX_STIFFNESS,
    RatioOutOfReach,
    tune_elastic,
)
from zeromode.solver.applications.finite_strain import FiniteStrainUnreachable
from zeromode.solver.applications.network_allostery import tune_network
from zeromode.solver.certificates.fabrication import tolerance_report
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.motion.boundary_strain import path_strains
from zeromode.solver.motion.finite_motion import (
    CURVE_SAMPLES,
    SingularPath,
    fidelity_curve,
    linear_target,
    trace_motion,
)
from zeromode.solver.motion.periodic import trace_motion_through_cell
from zeromode.solver.motion.refine import RefinementFailed
from zeromode.solver.motion.target import MotionTarget, TargetUnreachable, aim_motion
from zeromode.solver.progress import progress_stage


@dataclass(frozen=True)
class Outcome:
    """What an operation found: the solver's result and the endpoint's response body."""

    solution: Any
    body: dict


def _ms_since(t0: float) -> dict[str, float]:
    """``timings_ms`` of an operation timed as one stage: its wall time in ms."""
    return {"total": 1e3 * (time.perf_counter() - t0)}


# ----------------------------------------------------------------------------- analysis


def analyze(r: AnalyzeRequest) -> Outcome:
    """POST /v1/analyze: the rank of the compatibility matrix C (paper, Eq. 3), its zero modes
    (C u = 0), rigid motions and self-stresses (Cᵀ s = 0)."""
    from zeromode.solver.analysis.rigidity import analyze as analyze_frame

    t0 = time.perf_counter()
    o = r.options
    with progress_stage(0.0, 1.0, "analysis", detail=True):
        result = analyze_frame(
            frame_from_model(r.frame), rtol=o.rtol, method=o.method, bases=o.bases,
            basis_limit=current_settings().max_basis_numbers, gap_rtol=o.gap_rtol,
        )
    return Outcome(result, analyze_body(result, _ms_since(t0)))


# ----------------------------------------------------------------------------- design


def solution_space(r: SolutionSpaceRequest) -> Outcome:
    """POST /v1/solution-space: Ã, W̃ and the quadric Q of one unspecified node (Eqs. 4–6)."""
    from zeromode.solver.construction.solution_space import seeded_samples
    from zeromode.solver.construction.solution_space import solution_space as space_of

    space = space_of(r.positions, r.motions, dim=r.dim)
    return Outcome(space, solution_space_body(space, seeded_samples(space, r.samples, r.seed)))


def design(r: DesignRequest) -> Outcome:
    """POST /v1/design: judicious constraint placement (Eqs. 4–7), then the stages the options
    ask for (solver.pipeline.design_pipeline: refine, certify, tolerance)."""
    from zeromode.solver.pipeline import design_pipeline

    result = design_pipeline(**design_arguments(r))
    return Outcome(result, design_body(result, result.timings_ms))


def two_configuration(r: TwoConfigurationRequest) -> Outcome:
    """POST /v1/design/two-configuration: the midpoint frame designed with the flex
    (y_S − x_S)/2 keeps every bar length at x_S and y_S (the averaging principle)."""
    from zeromode.solver.construction.two_configuration import design_two_configurations

    t0 = time.perf_counter()
    result = design_two_configurations(r.initial, r.final, dim=r.dim, seed=r.options.seed)
    return Outcome(result, two_configuration_body(result, _ms_since(t0)))


def multistable(r: MultistableRequest) -> Outcome:
    """POST /v1/design/multistable: a one-freedom linkage through the 2 or 3 conformations
    (verified by continuation), springs making each a strict minimum of the elastic energy
    along its motion with barriers between neighbours, every minimum verified by the full
    energy's Hessian and seeded relaxations (solver.multistable); NoPath and a branched
    design's NoBifurcation carry the best attempt's figures."""
    from zeromode.solver.multistable.bifurcation import NoBifurcation
    from zeromode.solver.multistable.design import design_multistable
    from zeromode.solver.multistable.linkage import NoPath

    t0 = time.perf_counter()
    try:
        result = design_multistable(**multistable_arguments(r))
    except (NoBifurcation, NoPath) as exc:
        raise with_best(exc, json_safe(exc.best)) from None
    return Outcome(result, multistable_body(result, _ms_since(t0)))


def auxetic(r: AuxeticRequest) -> Outcome:
    """POST /v1/design/auxetic: a lattice of coupled modules of Poisson ratio ν (Fig. 5a), with
    the stages it asks for (solver.pipeline.auxetic_pipeline). FiniteStrainUnreachable carries
    the best strains found."""
    from zeromode.solver.pipeline import auxetic_pipeline

    t0 = time.perf_counter()
    try:
        result = auxetic_pipeline(**auxetic_arguments(r))
    except FiniteStrainUnreachable as exc:
        raise with_best(exc, json_safe(exc.best)) from None
    return Outcome(result, auxetic_body(result, _ms_since(t0)))


def allosteric(r: AllostericRequest) -> Outcome:
    """POST /v1/design/allosteric: source and target sites joined by relay modules (Fig. 5b),
    its fabrication tolerances when asked. InaccurateDesign carries the best figures found."""
    t0 = time.perf_counter()
    share = 1.0 if r.options.tolerance is None else 0.1  # the tolerances take the rest (0.3–5 s against 0.05–0.2)
    try:
        with progress_stage(0.0, share, "design"):
            result = design_allosteric(**allosteric_arguments(r))
    except InaccurateDesign as exc:
        raise with_best(exc, inaccurate_design_best(exc)) from None
    tolerance = None
    if (o := r.options.tolerance) is not None:
        with progress_stage(share, 1.0, "tolerances"):
            tolerance = tolerance_report(
                result.design.frame, result.design.modes, source=result.source, target=result.target,
                seed=r.options.seed, **o.model_dump(),
            )
    return Outcome(result, allosteric_body(result, _ms_since(t0), tolerance))


def network_allosteric(r: NetworkAllostericRequest) -> Outcome:
    """POST /v1/design/allosteric/network: the smallest change found that makes a given network
    respond exactly — as one mechanism (bars removed, nodes added on solution spaces; the
    default) or, with options.response "elastic", as a spring network relaxing under the
    imposed source strain (bars removed, one stiffness changed). A ratio out of the elastic
    edit's reach is refused with the best figures found."""
    given = Frame.build(r.frame.positions, r.frame.edges, dim=r.frame.dim)
    o = r.options
    if o.response == "elastic":
        if r.strain_ratio is None or r.source_motion is not None or r.target_motion is not None:
            raise InvalidInput(
                "invalid_response", "the elastic response model takes strain_ratio for a source and a target pair, "
                "not motions.",
            )
        try:
            result = tune_elastic(
                given, r.source, r.target, r.strain_ratio, stiffness=o.stiffness,
                max_stiffness=MAX_STIFFNESS if o.max_stiffness is None else o.max_stiffness,
            )
        except RatioOutOfReach as exc:
            raise with_best(exc, json_safe(exc.best)) from None
        return Outcome(result, elastic_allosteric_body(result, given.edges))
    if o.stiffness is not None or o.max_stiffness is not None:
        raise InvalidInput(
            "invalid_options", "stiffness and max_stiffness belong to the elastic response model "
            "(options.response \"elastic\"); a mechanism holds whatever the stiffnesses.",
        )
    result = tune_network(
        given, r.source, r.target, source_motion=r.source_motion, target_motion=r.target_motion,
        strain_ratio=r.strain_ratio, seed=r.options.seed,
    )
    return Outcome(result, network_allosteric_body(result, given.edges))


def respond(doc: dict) -> tuple[dict, BaseModel]:
    """Design a request document as its endpoint does, every option included: (the response
    body, the validated request). The one place documents (plot, export, the CLI) are designed."""
    for fields, model, operation in (
        (("source", "target"), AllostericRequest, allosteric),
        (("cells",), AuxeticRequest, auxetic),
        (("poisson_ratio",), AuxeticRequest, auxetic),
        (("positions", "motions"), DesignRequest, design),
        (("conformations",), MultistableRequest, multistable),
        (("features",), SequentialRequest, sequential),
        (("frame", "input_pair", "output_pair"), MapRequest, module_map),
    ):
        if all(f in doc for f in fields):
            r = validated(doc, model)
            return operation(r).body, r
    raise InvalidInput(
        "invalid_document",
        "the document is neither a body with a frame nor a request or response of /v1/design, "
        "/v1/design/auxetic, /v1/design/allosteric, /v1/design/multistable, /v1/design/sequential "
        "or /v1/map.",
    )


def map_answer(doc) -> dict | None:
    """A document as a /v1/map answer: itself (documents.MAP), a /v1/map request answered as the
    route answers it (respond), else None."""
    if not isinstance(doc, dict):
        return None
    if kind(doc) == MAP:
        return doc
    return respond(doc)[0] if is_map_request(doc) else None


# ----------------------------------------------------------------------------- beyond the linear design


def motion(r: MotionRequest) -> Outcome:
    """POST /v1/motion: predictor–corrector continuation along a zero mode (Eq. 1 at finite
    amplitude), through one cell of a tiled lattice, or aimed at a target. A singular point
    (with on_singularity "error") raises SingularPath, an unreachable target TargetUnreachable,
    each carrying the path's body up to where it stopped."""
    t0 = time.perf_counter()
    frame = motion_frame(r)
    # The linear target of the ε curve, refused (or its mode found) before any tracing.
    linear = None if r.epsilon_curve is None else linear_target(frame, r.epsilon_curve.amplitude, r.epsilon_curve.motion, r.mode)

    def body(path, aimed=None) -> dict:
        strains = None if r.boundary is None else path_strains(frame.positions, path.positions, r.boundary)
        spec = list(frame.specified)
        curve = None if linear is None else fidelity_curve(path, spec, frame.positions[spec], *linear, CURVE_SAMPLES)
        return motion_body(path, _ms_since(t0), strains, aimed, curve)

    steps = r.model_dump(include={"mode", "max_step", "direction", "max_steps"})
    aimed = None
    if r.target is not None:
        target = MotionTarget(**r.target.model_dump(exclude={"nodes"}), nodes=tuple(r.target.nodes or ()),
                              boundary=r.boundary)
        try:
            aimed = aim_motion(frame, target, periodic=r.boundary is not None, **steps)
        except TargetUnreachable as exc:
            raise with_best(exc, body(exc.best.path, exc.best)) from None
        path = aimed.path
    else:
        # A lattice (its boundary given) is followed through one cell when it is tiled, checked on the frame.
        trace = trace_motion if r.boundary is None else trace_motion_through_cell
        path = trace(frame, amplitude=r.amplitude, **steps)
    answer = body(path, aimed)
    if path.singularities and r.on_singularity == "error":
        raise with_best(SingularPath(path), answer)
    return Outcome(path, answer)


def refine(r: RefineRequest) -> Outcome:
    """POST /v1/refine: casadi + IPOPT move the unspecified nodes to minimise the finite-motion
    infidelity ε(a). RefinementFailed carries the best refinement's body."""
    from zeromode.solver.motion.refine import refine as refine_frame

    try:
        result = refine_frame(
            frame_from_model(r.frame), motion_s=r.motion, amplitude=r.amplitude, targets=r.targets,
            **r.options.model_dump(include={"K", "tol", "max_iter", "max_time_s", "stay_on_solution_space"}),
        )
    except RefinementFailed as exc:
        raise with_best(exc, refinement_body(exc.best)) from None
    return Outcome(result, refinement_body(result))


def certify(r: CertifyRequest) -> Outcome:
    """POST /v1/certify: self-stresses with their evidence, prestress stability by an SDP over
    the stresses, and the rigidity margin beyond rigid motions and the designed ``modes``."""
    from zeromode.solver.certificates.prestress import certify as certify_frame

    o = r.options
    result = certify_frame(frame_from_model(r.frame), r.modes, solver=o.solver, stiffness=o.stiffness,
                           max_iters=o.max_iters)
    return Outcome(result, certificate_body(result))


# ----------------------------------------------------------------------------- modules as maps


def module_map(r: MapRequest) -> Outcome:
    """POST /v1/map: a module's map d_out = f(d_in) from its finite motion (solver.sequential:
    samples, usable range between folds, fixed points, f and f′ exactly at ``at``)."""
    from zeromode.solver.sequential.module_map import module_map as map_of

    t0 = time.perf_counter()
    with progress_stage(0.0, 1.0, "module map"):
        result = map_of(module_from_model(r))
    return Outcome(result, {**map_response_body(result, r.at), "timings_ms": _ms_since(t0)})


def sequential(r: SequentialRequest) -> Outcome:
    """POST /v1/design/sequential: a module designed for the features (IPOPT, verified by
    continuation) and, with ``chain``, its chain verified against the map's iterates, or with
    ``soliton``, the soliton chain with its springs, drive and wall (solver.sequential.soliton); a
    refusal carries its best figures (``feature_out_of_reach``, ``chain_mismatch``,
    ``soliton_not_verified``)."""
    from zeromode.solver.sequential.chain import design_sequential
    from zeromode.solver.sequential.soliton import design_soliton

    t0 = time.perf_counter()
    a = sequential_arguments(r)
    try:
        with progress_stage(0.0, 1.0, "sequential design"):
            if r.soliton is not None:
                result = design_soliton(a["points"], a["start"], a["reach"], r.soliton.n_modules, r.soliton.stiffness)
            else:
                result = design_sequential(**a)
    except DomainError as exc:
        best = sequential_refusal_best(exc)
        if best is None:
            raise
        raise with_best(exc, best) from None
    return Outcome(result, sequential_body(result, _ms_since(t0)))


# ----------------------------------------------------------------------------- the registry


@dataclass(frozen=True)
class Operation:
    """An endpoint's operation with its request and response models."""

    run: Callable[[Any], Outcome]
    request_model: type[BaseModel]
    response_model: type[BaseModel]


# Every POST endpoint that answers a JSON body computed by an operation, declared once.
OPERATIONS: dict[str, Operation] = {
    "/v1/analyze": Operation(analyze, AnalyzeRequest, AnalyzeResponse),
    "/v1/solution-space": Operation(solution_space, SolutionSpaceRequest, SolutionSpaceResponse),
    "/v1/design": Operation(design, DesignRequest, DesignResponse),
    "/v1/design/two-configuration": Operation(two_configuration, TwoConfigurationRequest, TwoConfigurationResponse),
    "/v1/design/multistable": Operation(multistable, MultistableRequest, MultistableResponse),
    "/v1/design/auxetic": Operation(auxetic, AuxeticRequest, AuxeticResponse),
    "/v1/design/allosteric": Operation(allosteric, AllostericRequest, AllostericResponse),
    "/v1/design/allosteric/network": Operation(network_allosteric, NetworkAllostericRequest, NetworkAllostericAnswer),
    "/v1/motion": Operation(motion, MotionRequest, MotionResponse),
    "/v1/refine": Operation(refine, RefineRequest, RefineResponse),
    "/v1/certify": Operation(certify, CertifyRequest, CertifyResponse),
    "/v1/map": Operation(module_map, MapRequest, MapResponse),
    "/v1/design/sequential": Operation(sequential, SequentialRequest, SequentialResponse),
}


def wire_body(endpoint: str, body: dict) -> dict:
    """``body`` as the endpoint's response model sends it (absent optional fields as null)."""
    return OPERATIONS[endpoint].response_model.model_validate(body).model_dump(mode="json")
