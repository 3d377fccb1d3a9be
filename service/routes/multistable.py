"""POST /v1/design/multistable — rods and springs whose conformations are energy minima;
parse → call the solver → serialise."""

from __future__ import annotations

import time

from fastapi import APIRouter

from zeromode.service.documents import multistable_arguments
from zeromode.service.responses import multistable_body
from zeromode.service.schemas.common import ERROR_RESPONSES
from zeromode.service.schemas.multistable import MultistableRequest, MultistableResponse
from zeromode.solver.multistable.design import design_multistable

router = APIRouter(prefix="/v1", tags=["design"])


@router.post("/design/multistable", response_model=MultistableResponse, responses=ERROR_RESPONSES)
def post_multistable(request: MultistableRequest) -> dict:
    """A one-degree-of-freedom linkage of rods whose finite motion passes through the 2 or 3
    conformations in order (verified by continuation), with springs making each a strict local
    minimum of the elastic energy along the motion and barriers of at least `options.barrier`
    between neighbours; every minimum verified by the Hessian of the full energy and by seeded
    relaxations before the answer is returned (otherwise 422 with the best figures)."""
    t0 = time.perf_counter()
    result = design_multistable(**multistable_arguments(request))
    return multistable_body(result, {"total": 1e3 * (time.perf_counter() - t0)})
