"""POST /v1/design/allosteric."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field, FiniteFloat

from zeromode.service.schemas.common import (
    AnalysisCounts,
    Points,
    RequestModel,
    ResultFrame,
    SpecifiedPoints,
)
from zeromode.service.schemas.tolerance import ToleranceOptions, ToleranceReportModel


class Site(RequestModel):
    positions: SpecifiedPoints = Field(min_length=1)
    motion: SpecifiedPoints = Field(min_length=1)


class AllostericOptions(RequestModel):
    seed: int = Field(default=0, ge=0)
    relay_spacing: FiniteFloat | None = Field(
        default=None, gt=0, description="Spacing of relay nodes between the sites (default: twice the site size)."
    )
    tolerance: ToleranceOptions | None = Field(
        default=None, description="Report in `report.tolerance` how precisely the design must be built (as /v1/design)."
    )


class AllostericRequest(RequestModel):
    dim: Literal[2, 3]
    source: Site = Field(description="Driven site: positions and motion (k_src×d each).")
    target: Site = Field(description="Distal site: positions and prescribed motion (k_tgt×d each).")
    options: AllostericOptions = Field(default_factory=AllostericOptions)


class AllostericReport(BaseModel):
    analysis: AnalysisCounts
    source: list[int] = Field(description="Frame indices of the source nodes.")
    target: list[int] = Field(description="Frame indices of the target nodes.")
    relays: list[int] = Field(description="Frame indices of the relay nodes laid between the sites.")
    achieved_target_motion: Points = Field(
        description="Target rows of the response to the source motion, solved from the frame's zero modes."
    )
    target_error: float = Field(description="‖achieved − prescribed‖ / ‖prescribed‖ (linear order).")
    distance: float = Field(description="Distance between the site centroids.")
    unspecified_nodes: int
    bars: int
    mode_residual: float
    timings_ms: dict[str, float]
    tolerance: ToleranceReportModel | None = Field(default=None, description="Fabrication tolerances when asked.")


class AllostericResponse(BaseModel):
    frame: ResultFrame
    modes: list[Points] = Field(description="The single nontrivial zero mode (N×d); source rows = source motion.")
    report: AllostericReport
