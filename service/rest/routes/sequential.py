"""POST /v1/map and POST /v1/design/sequential — modules as one-dimensional maps and their
chains (zeromode.solver.sequential); parse → call the operation → serialise."""

from __future__ import annotations

from fastapi import APIRouter, Body

from zeromode.operations import endpoints
from zeromode.service.wire.schemas.common import ERROR_RESPONSES
from zeromode.service.wire.schemas.sequential import (
    SEQUENTIAL_EXAMPLES,
    MapRequest,
    MapResponse,
    SequentialRequest,
    SequentialResponse,
)

router = APIRouter(prefix="/v1", tags=["sequential"])


@router.post("/map", response_model=MapResponse, responses=ERROR_RESPONSES)
def post_map(request: MapRequest) -> dict:
    """The module's map d_out = f(d_in) from its finite motion: samples with f′, the usable range
    between folds, fixed points, and f, f′ exactly at the requested `at`."""
    return endpoints.module_map(request).body


@router.post("/design/sequential", response_model=SequentialResponse, responses=ERROR_RESPONSES)
def post_sequential(request: SequentialRequest = Body(openapi_examples=SEQUENTIAL_EXAMPLES)) -> dict:  # noqa: B008
    """A module whose map has the requested features (IPOPT on its node positions, verified by
    continuation to map_rtol) and, with `chain`, n copies chained and verified by continuation
    of the whole chain against the map's iterates. A feature out of reach answers 422
    `feature_out_of_reach` with the best figures in detail.best."""
    return endpoints.sequential(request).body
