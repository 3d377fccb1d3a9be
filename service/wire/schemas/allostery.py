"""POST /v1/design/allosteric."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, Field, FiniteFloat

from zeromode.service.wire.schemas.common import (
    AnalysisCounts,
    FrameModel,
    Points,
    RequestModel,
    ResultFrame,
    SpecifiedPoints,
)
from zeromode.service.wire.schemas.limits import Limited
from zeromode.service.wire.schemas.tolerance import ToleranceOptions, ToleranceReportModel


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
    robustness: Literal["robust", "economy"] = Field(
        default="robust",
        description=(
            "robust: several relay chains are designed and the one with the smallest amplification "
            "(report.amplification) is returned; economy: the first chain that meets the floors, fewest "
            "nodes, whose amplification grows faster with the distance. Either answer states its amplification."
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
    gain_one: bool = Field(
        description=(
            "true: every relay port moves with the source's RMS motion whatever its size (relays of gain 1, "
            "robust chains); false: port motions grow with their size (constant strain, economy chains)."
        )
    )


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
    amplification: float = Field(
        description=(
            "A, the fabrication error a builder feels: move every node by ε·ℓ̄ (ℓ̄ the mean bar length) in an "
            "independent uniformly random direction; A is the RMS over those errors of the relative change of "
            "the target's whole response ‖δw_T‖/‖w_T‖, per ε, from the linearisation of C(x)u = 0: "
            "A = ‖J‖_F ℓ̄ / (√d ‖w_T‖), J = ∂w_T/∂x."
        )
    )
    amplification_worst: float = Field(
        description=(
            "The same ratio for the worst node errors of RMS size ε·ℓ̄: ‖J‖₂ ℓ̄ √N / ‖w_T‖, an upper bound of any "
            "such perturbation's relative change per ε (to first order)."
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


# ----------------------------------------------------------------------------- given network
SpecifiedNodes = Annotated[list[int], Limited("max_specified")]


class NetworkOptions(RequestModel):
    seed: int = Field(default=0, ge=0, description="Seed of the placement of added nodes.")


class NetworkAllostericRequest(RequestModel):
    """A given network and the response it must give: either the motions of both sites, or (for a
    source pair and a target pair) the strain ratio η* = ε_T/ε_S."""

    frame: FrameModel = Field(description="The given network; it must be rigid (no nontrivial zero mode).")
    source: SpecifiedNodes = Field(min_length=1, description="Source node indices in the frame.")
    target: SpecifiedNodes = Field(min_length=1, description="Target node indices in the frame.")
    source_motion: SpecifiedPoints | None = Field(
        default=None, description="Motion of the source nodes (one row per source node); with target_motion."
    )
    target_motion: SpecifiedPoints | None = Field(
        default=None, description="Prescribed motion of the target nodes (one row per target node)."
    )
    strain_ratio: FiniteFloat | None = Field(
        default=None,
        description=(
            "η* = ε_T/ε_S for a source pair and a target pair, ε_p = (x_i − x_j)·(u_i − u_j)/|x_i − x_j|² "
            "(instead of motions)."
        ),
    )
    options: NetworkOptions = Field(default_factory=NetworkOptions)


class NetworkAllostericReport(BaseModel):
    analysis: AnalysisCounts = Field(description="Counts of the modified frame: d(d+1)/2 + 1 zero modes.")
    source: list[int]
    target: list[int]
    source_motion: Points = Field(description="Source rows of the mode (the motion that drives the target).")
    achieved_target_motion: Points = Field(
        description="Target rows of the response to the source motion, solved from the modified frame."
    )
    target_error: float = Field(description="‖achieved − designed target motion‖ / ‖designed‖; at most 1e-9.")
    strain_ratio: float | None = Field(description="ε_T/ε_S of that response (pairs), else null.")
    removed_edges: list[int] = Field(description="Indices into the given frame's edges of the bars removed.")
    removed_bars: list[tuple[int, int]] = Field(description="Those bars as node pairs.")
    added_nodes: list[int] = Field(description="Frame indices of the nodes added (after the given ones).")
    added_edges: list[tuple[int, int]] = Field(description="Bars added, as frame node pairs.")
    moving: list[int] = Field(description="Given nodes that move relative to the rest of the network.")
    bonds_changed: int = Field(description="Bars removed plus bars added.")
    mode_residual: float
    timings_ms: dict[str, float]


class NetworkAllostericResponse(BaseModel):
    frame: ResultFrame = Field(
        description="The modified frame: the given nodes (same indices), then the added ones; kept bars, then added bars."
    )
    modes: list[Points] = Field(description="Its one nontrivial zero mode (N×d), zero on the unmoved network.")
    report: NetworkAllostericReport
