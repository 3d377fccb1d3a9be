"""POST /v1/analyze — counts and bases of a frame's zero modes and self-stresses."""

from __future__ import annotations

import time

from fastapi import APIRouter

from zeromode.service.convert import frame_from_model
from zeromode.service.responses import analyze_body
from zeromode.service.schemas.analyze import AnalyzeRequest, AnalyzeResponse
from zeromode.service.schemas.common import ERROR_RESPONSES
from zeromode.service.settings import current_settings
from zeromode.solver.analysis.rigidity import analyze
from zeromode.solver.progress import progress_stage

router = APIRouter(prefix="/v1", tags=["analysis"])


@router.post("/analyze", response_model=AnalyzeResponse, responses=ERROR_RESPONSES)
def post_analyze(request: AnalyzeRequest) -> dict:
    """Rank of the compatibility matrix, zero modes, rigid motions and self-stresses of a frame."""
    t0 = time.perf_counter()
    frame = frame_from_model(request.frame)
    opts = request.options
    limit = current_settings().max_basis_numbers
    with progress_stage(0.0, 1.0, "analysis", detail=True):
        result = analyze(
            frame, rtol=opts.rtol, method=opts.method, bases=opts.bases, basis_limit=limit, gap_rtol=opts.gap_rtol
        )
    return analyze_body(result, {"total": 1e3 * (time.perf_counter() - t0)})
