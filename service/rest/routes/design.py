"""POST /v1/solution-space, /v1/design and /v1/design/two-configuration — the analytic
quadric construction; parse → call the operation → serialise."""

from __future__ import annotations

from fastapi import APIRouter

from zeromode.operations import endpoints
from zeromode.service.wire.schemas.common import ERROR_RESPONSES
from zeromode.service.wire.schemas.design import (
    DesignRequest,
    DesignResponse,
    SolutionSpaceRequest,
    SolutionSpaceResponse,
    TwoConfigurationRequest,
    TwoConfigurationResponse,
)

router = APIRouter(prefix="/v1", tags=["design"])


@router.post("/solution-space", response_model=SolutionSpaceResponse, responses=ERROR_RESPONSES)
def post_solution_space(request: SolutionSpaceRequest) -> dict:
    """All (x_U, u_U) of one unspecified node joined to every specified node (Ã, W̃, Q)."""
    return endpoints.solution_space(request).body


@router.post("/design", response_model=DesignResponse, responses=ERROR_RESPONSES)
def post_design(request: DesignRequest) -> dict:
    """Inverse design by judicious constraint placement: the requested motions become the only
    non-rigid zero modes of the returned frame (verified before it is returned); optionally
    refined (report.refinement) and certified (report.certificate) in the same call."""
    return endpoints.design(request).body


@router.post("/design/two-configuration", response_model=TwoConfigurationResponse, responses=ERROR_RESPONSES)
def post_two_configuration(request: TwoConfigurationRequest) -> dict:
    """A frame whose specified nodes can sit at `initial` and at `final` with every bar keeping
    its length (the midpoint frame's designed flex, by the averaging principle); whether one
    continuous motion joins the two configurations is traced and reported."""
    return endpoints.two_configuration(request).body
