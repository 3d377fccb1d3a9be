"""POST /v1/solution-space, /v1/design and /v1/design/two-configuration — the analytic
quadric construction; parse → call the solver → serialise."""

from __future__ import annotations

import time

from fastapi import APIRouter

from zeromode.service.documents import design_arguments
from zeromode.service.responses import design_body, solution_space_body, two_configuration_body
from zeromode.service.schemas.common import ERROR_RESPONSES
from zeromode.service.schemas.design import (
    DesignRequest,
    DesignResponse,
    SolutionSpaceRequest,
    SolutionSpaceResponse,
    TwoConfigurationRequest,
    TwoConfigurationResponse,
)
from zeromode.solver.construction.solution_space import seeded_samples, solution_space
from zeromode.solver.construction.two_configuration import design_two_configurations
from zeromode.solver.pipeline import design_pipeline

router = APIRouter(prefix="/v1", tags=["design"])


@router.post("/solution-space", response_model=SolutionSpaceResponse, responses=ERROR_RESPONSES)
def post_solution_space(request: SolutionSpaceRequest) -> dict:
    """All (x_U, u_U) of one unspecified node joined to every specified node (Ã, W̃, Q)."""
    space = solution_space(request.positions, request.motions, dim=request.dim)
    return solution_space_body(space, seeded_samples(space, request.samples, request.seed))


@router.post("/design", response_model=DesignResponse, responses=ERROR_RESPONSES)
def post_design(request: DesignRequest) -> dict:
    """Inverse design by judicious constraint placement: the requested motions become the only
    non-rigid zero modes of the returned frame (verified before it is returned); optionally
    refined (report.refinement) and certified (report.certificate) in the same call."""
    result = design_pipeline(**design_arguments(request))
    return design_body(result, result.timings_ms)


@router.post("/design/two-configuration", response_model=TwoConfigurationResponse, responses=ERROR_RESPONSES)
def post_two_configuration(request: TwoConfigurationRequest) -> dict:
    """A frame whose specified nodes can sit at `initial` and at `final` with every bar keeping
    its length (the midpoint frame's designed flex, by the averaging principle); whether one
    continuous motion joins the two configurations is traced and reported."""
    t0 = time.perf_counter()
    result = design_two_configurations(request.initial, request.final, dim=request.dim, seed=request.options.seed)
    return two_configuration_body(result, {"total": 1e3 * (time.perf_counter() - t0)})
