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
        default=None,
        gt=0,
        description=(
            "Size of the first relay ports next to each site, in the request's units (default: twice the "
            "larger site's RMS radius); the module length is proportional to it."
        ),
    )
    relay_growth: FiniteFloat | None = Field(
        default=None,
        ge=1,
        description=(
            "Ratio of consecutive relay sizes from each site towards the middle (default 2): a distance D "
            "then takes O(log D) modules; 1 lays equal relays (D / relay_spacing modules, refused as "
            "too_expensive past 400)."
        ),
    )
    tolerance: ToleranceOptions | None = Field(
        default=None, description="Report in `report.tolerance` how precisely the design must be built (as /v1/design)."
    )


class AllostericRequest(RequestModel):
    dim: Literal[2, 3]
    source: Site = Field(description="Driven site: positions and motion (k_src×d each).")
    target: Site = Field(description="Distal site: positions and prescribed motion (k_tgt×d each).")
    options: AllostericOptions = Field(default_factory=AllostericOptions)


class ChainModel(BaseModel):
    relay_spacing: float = Field(description="Size of the first relay ports, in the request's units.")
    relay_growth: float = Field(description="Ratio of consecutive relay sizes.")
    module_aspect: float = Field(description="Module length per smaller-port size.")
    seed: int = Field(description="Seed of the module placements.")


class AllostericReport(BaseModel):
    analysis: AnalysisCounts
    source: list[int] = Field(description="Frame indices of the source nodes.")
    target: list[int] = Field(description="Frame indices of the target nodes.")
    relays: list[int] = Field(description="Frame indices of the relay nodes laid between the sites.")
    achieved_target_motion: Points = Field(
        description="Target rows of the response to the source motion, solved from the frame's zero modes."
    )
    target_error: float = Field(
        description="‖achieved − prescribed‖ / ‖prescribed‖ (linear order); never above 1e-9 in a 200 answer."
    )
    gap: float = Field(
        description=(
            "σ_min/σ_max of the unit compatibility matrix diag(1/ℓ)·C beyond the designed zero modes: how far "
            "the softest other motion is from being a zero mode; never below 1e-6 in a 200 answer."
        )
    )
    sensitivity: float = Field(
        description=(
            "Largest relative change of the target site's change of shape (its response modulo rigid "
            "motions of the site) when the nodes move by `perturbation` site sizes (Euclidean norm over all "
            "nodes, worst direction), from the linearisation of C(x)u = 0."
        )
    )
    motion_sensitivity: float = Field(
        description=(
            "The same for the target's whole response, rigid part included; it grows with the distance "
            "(an angle error near the source moves the far end in proportion)."
        )
    )
    perturbation: float = Field(description="The stated relative perturbation of the sensitivities, in site sizes.")
    modules: int = Field(description="Modules in the chain from source to target (1: the sites joined directly).")
    chain: ChainModel = Field(description="The chain parameters that gave this design (after any alternatives).")
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
