"""POST /v1/analyze."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from zeromode.service.wire.schemas.common import AnalysisCounts, FrameModel, Points, RequestModel
from zeromode.solver.tolerances import RANK_RTOL


class AnalyzeOptions(RequestModel):
    rtol: float = Field(
        default=RANK_RTOL, gt=0, lt=1, description="Relative threshold: σ ≤ rtol·σ_max counts as zero."
    )
    method: Literal["auto", "dense", "sparse"] = Field(
        default="auto", description="Full SVD, sparse shift-invert subspace iteration, or by size."
    )
    bases: bool = Field(default=True, description="Return the mode and stress bases (if small enough).")
    gap_rtol: float | None = Field(
        default=None,
        ge=1e-12,
        lt=1,
        description=(
            "Converge rank_gap.last_nonzero to σ_r until rank_gap.last_nonzero_error ≤ gap_rtol (the sparse "
            "route widens σ_r's Ritz space, one shifted solve a step); 422 not_converged if it stays above."
        ),
    )


class AnalyzeRequest(RequestModel):
    frame: FrameModel
    options: AnalyzeOptions = Field(default_factory=AnalyzeOptions)


class AnalyzeResponse(AnalysisCounts):
    modes: list[Points] = Field(
        description="Orthonormal basis of the nontrivial zero modes, each N×d, ⟂ every rigid motion."
    )
    stresses: list[list[float]] = Field(description="Orthonormal basis of the self-stresses (N_B each).")
    method: str = Field(description="'dense' or 'sparse': which route decided the rank.")
    bases_included: bool = Field(
        description="False when the bases were too large to return (counts are exact regardless)."
    )
    timings_ms: dict[str, float]
