"""POST /v1/solution-space and POST /v1/design."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, Field

from zeromode.service.wire.schemas.certify import CertifyResponse
from zeromode.service.wire.schemas.common import (
    AnalysisCounts,
    Points,
    RequestModel,
    ResultFrame,
    SpecifiedPoints,
)
from zeromode.service.wire.schemas.limits import AtMost, Limited, limit_text
from zeromode.service.wire.schemas.tolerance import ToleranceOptions, ToleranceReportModel
from zeromode.solver.tolerances import IPOPT_TOL


class SolutionSpaceRequest(RequestModel):
    dim: Literal[2, 3]
    positions: SpecifiedPoints = Field(min_length=1, description="x_S, k×d.")
    motions: SpecifiedPoints = Field(min_length=1, description="u_S, k×d.")
    samples: Annotated[int, AtMost("max_samples")] = Field(
        default=8, ge=0, description=f"How many real solutions to return, {limit_text('max_samples')}."
    )
    seed: int = Field(default=0, ge=0, description="Seed for the sampling lines.")


class SolutionSample(BaseModel):
    position: list[float] = Field(description="x_U")
    motion: list[float] = Field(description="u_U")


class SolutionSpaceResponse(BaseModel):
    nullity: int = Field(description="m = dim N(Ã)")
    dimension: int = Field(description="m − 1, the dimension of the solution set")
    kind: Literal["points", "conic", "quadric_surface", "quadric_hypersurface"]
    basis: list[list[float]] = Field(description="W̃ = [w_1 … w_m, ṽ*], (2d+1)×(m+1), rows (x_U, u_U, c).")
    quadric: list[list[float]] = Field(description="Q, symmetric (m+1)×(m+1), α̃ᵀQα̃ = 0.")
    samples: list[SolutionSample] = Field(description="Real solutions, each verified against all k bars.")
    max_constraint_residual: float = Field(
        description="Largest |(x_Si − x_U)·(u_Si − u_U)| over the samples, on the normalised problem."
    )


class DesignRefineOptions(RequestModel):
    """Run the nonlinear stage (casadi/IPOPT, as POST /v1/refine) on the linear design."""

    amplitude: float = Field(
        default=0.1, gt=0, le=1, description="Target displacement a·u_S, a relative to the specified nodes' RMS size."
    )
    K: int = Field(default=8, ge=1, le=64, description="Intermediate configurations in the NLP.")
    tol: float = Field(default=IPOPT_TOL, gt=0, lt=1, description="IPOPT tolerance.")
    max_time_s: float = Field(default=5.0, gt=0, le=60, description="IPOPT CPU time limit per solve.")


class DesignOptions(RequestModel):
    seed: int = Field(default=0, ge=0, description="Seed for candidate sampling: same request, same answer.")
    n_unspecified: int | None = Field(
        default=None, ge=0, le=64, description="Use exactly this many unspecified nodes (default: as few as possible)."
    )
    certify: bool = Field(
        default=False,
        description=(
            "Embed SDP certificates (self-stress, prestress stability, rigidity margins) in "
            "report.certificate; the optimal-stiffness SDP runs when the design has at most 48 "
            "suppressed motions, otherwise the uniform margin is reported."
        ),
    )
    refine: DesignRefineOptions | None = Field(
        default=None,
        description=(
            "Refine for finite-motion fidelity in the same call (one motion only). `frame` and "
            "`modes` stay the exact linear design; the refined frame, ε before/after and IPOPT's "
            "status are in `report.refinement` (status 'refinement_failed' with the best result "
            "when IPOPT fails)."
        ),
    )
    tolerance: ToleranceOptions | None = Field(
        default=None,
        description=(
            "Report in `report.tolerance` how precisely the design must be built: the bar-length and "
            "pin-position errors that keep the designed motion and the rigidity margin within the "
            "budget, by linearisation, each checked by a seeded Monte Carlo of perturbed frames."
        ),
    )


class DesignRequest(RequestModel):
    dim: Literal[2, 3]
    positions: SpecifiedPoints = Field(min_length=1, description="x_S, k×d.")
    motions: Annotated[list[SpecifiedPoints], Limited("max_motions")] = Field(
        min_length=1, description=f"M target motions, each k×d; M {limit_text('max_motions')}."
    )
    options: DesignOptions = Field(default_factory=DesignOptions)


class DesignReport(BaseModel):
    analysis: AnalysisCounts
    target_zero_modes: int = Field(description="d(d+1)/2 + M")
    unspecified_nodes: int
    bars: int
    anchor_sets: list[list[int]] = Field(
        description="For each unspecified node, the specified nodes it is joined to (its solution space)."
    )
    conditioning: float = Field(description="Smallest nonzero singular value of the scale-normalised C.")
    mode_residual: float = Field(description="max_i ‖C u_i‖ / (‖C‖_F ‖u_i‖) on the normalised frame.")
    timings_ms: dict[str, float]
    certificate: CertifyResponse | None = Field(
        default=None, description="SDP certificates (as POST /v1/certify) when options.certify."
    )
    refinement: dict | None = Field(default=None, description="The /v1/refine result when options.refine.")
    tolerance: ToleranceReportModel | None = Field(
        default=None, description="Fabrication tolerances when options.tolerance."
    )


class DesignResponse(BaseModel):
    frame: ResultFrame
    modes: list[Points] = Field(description="M full zero modes, N×d; rows 0..k−1 equal the requested motions.")
    report: DesignReport


class TwoConfigurationRequest(RequestModel):
    dim: Literal[2, 3]
    initial: SpecifiedPoints = Field(min_length=1, description="x_S, k×d: first configuration.")
    final: SpecifiedPoints = Field(min_length=1, description="y_S, k×d: second configuration.")
    options: DesignOptions = Field(default_factory=DesignOptions, description="Only `seed` is used.")


class TwoConfigurationReport(BaseModel):
    analysis: AnalysisCounts = Field(description="Counts of the frame in its first configuration.")
    unspecified_nodes: int
    bars: int
    max_length_mismatch: float = Field(description="max over bars of |l(final) − l(initial)| / l(initial).")
    epsilon: float | None = Field(
        description="Finite-motion fidelity of the traced motion from the first configuration to y_S (None if not traced)."
    )
    path: str = Field(description="Whether one continuous motion joins the configurations, in one sentence.")
    timings_ms: dict[str, float]


class TwoConfigurationResponse(BaseModel):
    frame: ResultFrame = Field(description="The frame in its first configuration; the first k nodes are at x_S exactly.")
    final_positions: Points = Field(description="N×d second configuration; the first k rows are y_S exactly.")
    report: TwoConfigurationReport
