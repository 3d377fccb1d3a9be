"""POST /v1/map and POST /v1/design/sequential — modules as one-dimensional maps and their
chains (zeromode.solver.sequential); parse → call the solver → serialise."""

from __future__ import annotations

import time

from fastapi import APIRouter, Body
from fastapi.responses import JSONResponse

from zeromode.service.convert import feature_points, module_from_model
from zeromode.service.errors import error_body
from zeromode.service.responses import module_map_body, sequential_body, sequential_refusal_best
from zeromode.service.schemas.common import ERROR_RESPONSES
from zeromode.service.schemas.sequential import (
    SEQUENTIAL_EXAMPLES,
    MapRequest,
    MapResponse,
    SequentialRequest,
    SequentialResponse,
)
from zeromode.solver.errors import DomainError
from zeromode.solver.sequential.chain import design_sequential
from zeromode.solver.sequential.module_map import module_map

router = APIRouter(prefix="/v1", tags=["sequential"])


@router.post("/map", response_model=MapResponse, responses=ERROR_RESPONSES)
def post_map(request: MapRequest) -> dict:
    """The module's map d_out = f(d_in) from its finite motion: samples with f′, the usable range
    between folds, fixed points, and f, f′ exactly at the requested `at`."""
    t0 = time.perf_counter()
    body = module_map_body(module_map(module_from_model(request)), request.at)
    return {**body, "timings_ms": {"total": 1e3 * (time.perf_counter() - t0)}}


@router.post("/design/sequential", response_model=SequentialResponse, responses=ERROR_RESPONSES)
def post_sequential(request: SequentialRequest = Body(openapi_examples=SEQUENTIAL_EXAMPLES)):  # noqa: B008
    """A module whose map has the requested features (IPOPT on its node positions, verified by
    continuation to map_rtol) and, with `chain`, n copies chained and verified by continuation
    of the whole chain against the map's iterates. A feature out of reach answers 422
    `feature_out_of_reach` with the best figures in detail.best."""
    t0 = time.perf_counter()
    chain = request.chain
    try:
        result = design_sequential(
            feature_points(request.features),
            None if request.start is None else module_from_model(request.start),
            request.reach,
            None if chain is None else chain.n_modules,
            None if chain is None else chain.d0,
        )
    except DomainError as exc:
        best = sequential_refusal_best(exc)
        if best is None:
            raise
        return JSONResponse(status_code=422, content=error_body(exc.code, exc.message, best=best))
    return sequential_body(result, {"total": 1e3 * (time.perf_counter() - t0)})
