"""POST /v1/design/multistable — rods and springs whose conformations are energy minima;
parse → call the operation → serialise."""

from __future__ import annotations

from fastapi import APIRouter

from zeromode.operations import endpoints
from zeromode.service.wire.schemas.common import ERROR_RESPONSES
from zeromode.service.wire.schemas.multistable import MultistableRequest, MultistableResponse

router = APIRouter(prefix="/v1", tags=["design"])


@router.post("/design/multistable", response_model=MultistableResponse, responses=ERROR_RESPONSES)
def post_multistable(request: MultistableRequest) -> dict:
    """A one-degree-of-freedom linkage of rods whose finite motion passes through the 2 or 3
    conformations in order (verified by continuation), with springs making each a strict local
    minimum of the elastic energy along the motion and barriers of at least `options.barrier`
    between neighbours; every minimum verified by the Hessian of the full energy and by seeded
    relaxations before the answer is returned (otherwise 422 with the best figures)."""
    return endpoints.multistable(request).body
