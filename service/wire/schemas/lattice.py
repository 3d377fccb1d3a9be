"""POST /v1/design/auxetic."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field, FiniteFloat

from zeromode.service.wire.schemas.certify import CertifyResponse
from zeromode.service.wire.schemas.common import AnalysisCounts, Points, RequestModel, ResultFrame
from zeromode.service.wire.schemas.design import DesignRefineOptions
from zeromode.service.wire.schemas.tolerance import ToleranceOptions, ToleranceReportModel


class AuxeticRequest(RequestModel):
    dim: Literal[2, 3] = Field(default=2, description="2: a sheet of n_x × n_y modules; 3: a chain of blocks.")
    cells: list[int] = Field(
        default=[4, 4],
        min_length=1,
        max_length=2,
        description="2D: [n_x, n_y] modules (n_x·n_y ≤ 2500); 3D: [n] blocks (n ≤ 64).",
    )
    poisson_ratio: FiniteFloat = Field(
        default=-1.0,
        description="Linear Poisson ratio ν = −ε_y/ε_x of the designed mode (negative: auxetic).",
    )
    cell: list[FiniteFloat] | None = Field(
        default=None,
        description="Module half-sizes: 2D [w, h] (default [1, 1]); 3D [w, h, l] (default [1, 1, 1]).",
    )
    strain: FiniteFloat | None = Field(
        default=None,
        ge=1e-4,
        lt=0.9,
        description=(
            "Axial strain ε_x of the expanded (+) and contracted (−) finite states; both must lie in the "
            "usable strain range (`report.strain_range`), else 422 `strain_out_of_range` naming it. "
            "Default: ±0.1 clipped to the range."
        ),
    )
    seed: int = Field(default=0, ge=0)
    tolerance: ToleranceOptions | None = Field(
        default=None, description="Report in `report.tolerance` how precisely the design must be built (as /v1/design)."
    )
    refine: DesignRefineOptions | None = Field(
        default=None,
        description=(
            "Refine for finite-motion fidelity (as /v1/design's options.refine): the unspecified nodes move so that "
            "the specified ones (sheet corners; chain ports and apexes) reach a·(their mode) along one motion. "
            "`frame` and `modes` stay the linear lattice; the result is in `report.refinement`. A refinement with "
            "more bar equations than unknowns (sheets, whose self-stresses repeat bars) is 422 `too_few_unknowns`."
        ),
    )
    certify: bool = Field(
        default=False,
        description=(
            "Embed SDP certificates (as /v1/certify) in report.certificate; the optimal-stiffness margin when its "
            "LMI is at most 48, else the uniform margin."
        ),
    )
    finite_strain: FiniteStrainOptions | None = Field(
        default=None,
        description=(
            "2D only: hold the secant Poisson ratio within `tolerance` of `poisson_ratio` over `strain_range` "
            "(a module chosen on one module — a trammel, a Cardan trammel for ν = −1, or the best of them refined by "
            "IPOPT — then tiled and verified on the full sheet; report.finite_strain). "
            "The states are at the ends of the range (`strain` is unused). Out of reach: 422 "
            "`finite_strain_unreachable` with the best figures in detail.best."
        ),
    )


class FiniteStrainOptions(RequestModel):
    strain_range: list[FiniteFloat] = Field(
        min_length=2, max_length=2, description="[ε_lo, ε_hi] (ε_lo < 0 < ε_hi) over which the secant ν is held."
    )
    tolerance: FiniteFloat = Field(default=0.02, gt=0, le=1, description="Largest |ν_secant − poisson_ratio| allowed.")


class FiniteStrainReport(BaseModel):
    strain_range: list[float] = Field(description="The range asked for.")
    tolerance: float
    strains: list[float] = Field(description="ε_x at which the full sheet was verified.")
    secant_poisson_ratios: list[float] = Field(description="Secant ν measured on the full sheet at each of them.")
    max_deviation: float = Field(description="max |ν_secant − poisson_ratio| over them (≤ tolerance).")
    max_relative_bar_error: float = Field(description="Largest relative bar-length change over them.")
    module: dict = Field(
        description=(
            "The module chosen: family 'trammel' (parameter: its stretch s), 'cardan' (ν = −1 exactly; parameter: "
            "c/(w + h²/w)) or 'refined' (IPOPT's refinement of the best member; parameter null), and its coordinates "
            "after the cell's (w, h): the trammel's (c, e)."
        )
    )


class LatticeState(BaseModel):
    name: Literal["expanded", "contracted"]
    positions: Points
    poisson_ratio: float = Field(description="Secant Poisson ratio of this state relative to the reference.")
    strain: float = Field(
        description="Its axial strain ε_x (2D: the requested one, exact; 3D: of the traced configuration nearest it)."
    )


class RangeEndModel(BaseModel):
    strain: float = Field(description="ε_x at this end of the range.")
    reason: Literal["singular_point", "node_proximity", "bar_crossing", "strain_extremum", "search_limit"] = Field(
        description=(
            "singular_point: the compatibility matrix loses rank; node_proximity: two nodes without a bar come "
            "closer than `proximity_fraction` of the shortest bar; bar_crossing (2D): a node passes through a bar; "
            "strain_extremum (3D): ε_x turns back along the motion; search_limit: |ε_x| reached the largest strain examined."
        )
    )
    detail: str = Field(description="What happens there, in one sentence.")


class StrainRangeModel(BaseModel):
    lower: RangeEndModel
    upper: RangeEndModel
    proximity_fraction: float = Field(description="Closest approach allowed, as a fraction of the shortest bar.")
    shortest_bar: float


class AuxeticReport(BaseModel):
    analysis: AnalysisCounts
    boundary: dict[str, list[int]] = Field(description="Node sets whose mean positions define the strains.")
    mode_residual: float
    max_relative_bar_error: float = Field(description="Largest relative bar-length change over the states.")
    strain_range: StrainRangeModel = Field(
        description="The usable strain range [lower, upper] ∋ 0 over which the exact finite motion stays regular and physical."
    )
    min_node_distance: float = Field(
        description="Closest pair of nodes without a bar over the states, relative to the shortest bar (≥ proximity_fraction)."
    )
    timings_ms: dict[str, float]
    tolerance: ToleranceReportModel | None = Field(default=None, description="Fabrication tolerances when asked.")
    refinement: dict | None = Field(default=None, description="The /v1/refine result when `refine` was asked.")
    refined_poisson_ratio: float | None = Field(
        default=None, description="Linear ν of the refined frame's mode (null if it has not exactly one nontrivial mode)."
    )
    certificate: CertifyResponse | None = Field(default=None, description="SDP certificates when `certify`.")
    finite_strain: FiniteStrainReport | None = Field(default=None, description="When `finite_strain` was asked.")


class AuxeticResponse(BaseModel):
    frame: ResultFrame
    modes: list[Points] = Field(description="The single nontrivial zero mode (N×d).")
    poisson_ratio: float = Field(
        description="ν = −ε_y/ε_x of the mode: ε is the rate of change of the distance between the mean "
        "positions of opposite boundary sets (pulled along x). Negative means auxetic."
    )
    states: list[LatticeState]
    report: AuxeticReport
