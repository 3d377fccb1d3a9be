"""POST /v1/certify — self-stress, prestress-stability and rigidity-margin certificates."""

from __future__ import annotations

from fastapi import APIRouter

from zeromode.service.convert import frame_from_model
from zeromode.service.responses import certificate_body
from zeromode.service.schemas.certify import CertifyRequest, CertifyResponse
from zeromode.service.schemas.common import ERROR_RESPONSES
from zeromode.solver.certificates.prestress import certify

router = APIRouter(prefix="/v1", tags=["certificates"])


@router.post("/certify", response_model=CertifyResponse, responses=ERROR_RESPONSES)
def post_certify(request: CertifyRequest) -> dict:
    """Self-stresses with their singular-value evidence; prestress stability decided by an SDP
    for any number of flexes and stresses, with its margin and certifying stress; the rigidity
    margin of the frame's motions beyond rigid motions and the designed `modes`, for uniform
    and SDP-optimal bar stiffness. Failures: 422 `certificate_failed` (no solver verified a
    solution; the message lists each solver's status), `too_expensive` (an LMI beyond the size
    limit, or the time budget spent), `invalid_modes`."""
    frame = frame_from_model(request.frame)
    opts = request.options
    return certificate_body(certify(
        frame, request.modes, solver=opts.solver, stiffness=opts.stiffness, max_iters=opts.max_iters
    ))
