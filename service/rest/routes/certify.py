"""POST /v1/certify — self-stress, prestress-stability and rigidity-margin certificates."""

from __future__ import annotations

from fastapi import APIRouter

from zeromode.operations import endpoints
from zeromode.service.wire.schemas.certify import CertifyRequest, CertifyResponse
from zeromode.service.wire.schemas.common import ERROR_RESPONSES

router = APIRouter(prefix="/v1", tags=["certificates"])


@router.post("/certify", response_model=CertifyResponse, responses=ERROR_RESPONSES)
def post_certify(request: CertifyRequest) -> dict:
    """Self-stresses with their singular-value evidence; prestress stability decided by an SDP
    for any number of flexes and stresses, with its margin and certifying stress; the rigidity
    margin of the frame's motions beyond rigid motions and the designed `modes`, for uniform
    and SDP-optimal bar stiffness. Failures: 422 `certificate_failed` (no solver verified a
    solution; the message lists each solver's status), `too_expensive` (an LMI beyond the size
    limit, or the time budget spent), `invalid_modes`."""
    return endpoints.certify(request).body
