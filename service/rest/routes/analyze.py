"""POST /v1/analyze — counts and bases of a frame's zero modes and self-stresses."""

from __future__ import annotations

from fastapi import APIRouter

from zeromode.operations import endpoints
from zeromode.service.wire.schemas.analyze import AnalyzeRequest, AnalyzeResponse
from zeromode.service.wire.schemas.common import ERROR_RESPONSES

router = APIRouter(prefix="/v1", tags=["analysis"])


@router.post("/analyze", response_model=AnalyzeResponse, responses=ERROR_RESPONSES)
def post_analyze(request: AnalyzeRequest) -> dict:
    """Rank of the compatibility matrix, zero modes, rigid motions and self-stresses of a frame."""
    return endpoints.analyze(request).body
