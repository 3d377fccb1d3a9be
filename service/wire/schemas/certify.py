"""POST /v1/certify: self-stress, prestress-stability and rigidity-margin certificates."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, Field

from zeromode.service.wire.schemas.common import AnalysisCounts, FrameModel, Points, RequestModel
from zeromode.service.wire.schemas.limits import Limited
from zeromode.solver.certificates.prestress import (
    MAX_DOF,
    OPTIMAL_MAX_DIM,
    SDP_MAX_DIM,
)
from zeromode.solver.certificates.stiffness import GAP_RTOL
from zeromode.solver.tolerances import GIVEN_MODE_RTOL, PRESTRESS_TOL


class CertifyOptions(RequestModel):
    solver: Literal["clarabel", "scs"] = Field(
        default="clarabel",
        description="SDP solver tried first (through cvxpy); the other one is the fallback.",
    )
    stiffness: bool = Field(
        default=True,
        description=(
            "Also compute the optimal-stiffness rigidity margin. Its LMI has size p = dN − ρ − M: "
            f"up to {SDP_MAX_DIM} it is solved as an SDP (Clarabel or SCS), up to {OPTIMAL_MAX_DIM} by "
            "an interior-point method on the LMI reduced by the frame's reflection symmetries (a spectral bundle "
            "method when the reduced blocks stay large), all with a verified "
            f"bracket; beyond {OPTIMAL_MAX_DIM} the request is refused (422 too_expensive) before any "
            f"analysis. false gives the uniform margin alone, for frames up to {MAX_DOF} degrees "
            "of freedom."
        ),
    )
    max_iters: int | None = Field(
        default=None,
        ge=1,
        le=100_000,
        description="Cap on each solver's iterations (default: the solver's own).",
    )


class CertifyRequest(RequestModel):
    frame: FrameModel
    modes: Annotated[list[Points], Limited("max_motions")] = Field(
        default_factory=list,
        description=(
            "Designed modes, each N×d (e.g. the modes of a /v1/design answer): zero modes of the "
            f"frame (‖C m‖ ≤ {GIVEN_MODE_RTOL:g}·‖C‖_F‖m‖), independent modulo rigid motions. The "
            "rigidity margin isolates the frame's other motions from them."
        ),
    )
    options: CertifyOptions = Field(default_factory=CertifyOptions)


class SolverRunModel(BaseModel):
    solver: Literal["clarabel", "scs", "interior_point", "spectral_bundle"]
    status: str = Field(
        description=(
            "cvxpy status (optimal, optimal_inaccurate, user_limit, solver_error, ...); "
            "'<status>_unverified' when the verified bounds did not decide the question; for "
            f"interior_point and spectral_bundle 'optimal' (relative bracket ≤ {GAP_RTOL:g}) or 'gap_not_closed' (its "
            "time ran out: the bracket is still verified, only wider)."
        )
    )
    time_ms: float = Field(description="Wall time of this attempt, including modelling in cvxpy.")


class SdpModel(BaseModel):
    """How an SDP was solved: the accepted attempt and every attempt in order."""

    solver: Literal["clarabel", "scs", "interior_point", "spectral_bundle"] = Field(
        description="Solver of the accepted attempt (interior_point or spectral_bundle: the optimal margin beyond the SDP size)."
    )
    status: str = Field(
        description="Its status: optimal or optimal_inaccurate (cvxpy); optimal or gap_not_closed (interior_point, spectral_bundle)."
    )
    time_ms: float = Field(description="Wall time of the accepted attempt.")
    size: int = Field(
        description=(
            "Number of variables: the stresses that matter to the prestress SDP (at most "
            "f(f+1)/2, however many self-stresses), or the bars of the stiffness allocation."
        )
    )
    attempts: list[SolverRunModel] = Field(description="Every attempt, the accepted one last.")


class SingularValueEvidence(BaseModel):
    smallest_nonzero: float = Field(
        description="σ_r: smallest nonzero singular value of the scale-normalised C."
    )
    largest_zero: float = Field(
        description="σ_{r+1}: largest singular value counted as zero (0 when there is none)."
    )


class SelfStressModel(BaseModel):
    count: int = Field(description="Number of independent self-stresses, N_B − rank C.")
    basis: list[list[float]] = Field(
        description="Orthonormal basis of the self-stresses ω (Cᵀω = 0), N_B numbers each."
    )
    basis_included: bool = Field(description="False when the basis was too large to return.")
    singular_values: SingularValueEvidence
    equilibrium_residual: float = Field(
        description="max over the basis of ‖Cᵀω‖ / ‖C‖_F on the scale-normalised frame."
    )


class PrestressModel(BaseModel):
    prestress_stable: bool = Field(
        description=(
            "True when one self-stress ω has stress energy Σ ω_ij ‖q_i − q_j‖² > 0 on every "
            "nontrivial infinitesimal flex q (Connelly–Whiteley); decided for any number of "
            "flexes and stresses."
        )
    )
    decided_by: Literal["infinitesimal_rigidity", "no_self_stress", "sdp"] = Field(
        description=(
            "infinitesimal_rigidity: no nontrivial flex (stable, no margin); no_self_stress: "
            "flexes but no stress (not stable); sdp: max t s.t. Σ c_k G_k ⪰ t·I, ‖c‖ ≤ 1."
        )
    )
    flexes: int = Field(description="f, the number of nontrivial infinitesimal flexes (LMI size).")
    stresses: int = Field(description="s, the number of independent self-stresses (SDP variables).")
    margin: float | None = Field(
        description=(
            "t*: the smallest stress energy over unit flexes (⟂ rigid motions) of the best unit "
            "stress; a verified lower bound, attained by `stress`. Null when f = 0."
        )
    )
    margin_upper_bound: float | None = Field(
        description="Verified upper bound on t* from the dual SDP solution. Null when f = 0."
    )
    stress: list[float] | None = Field(
        description="The certifying self-stress (unit norm, ω_e > 0 is tension) when stable via the SDP."
    )
    threshold: float = Field(
        description=f"t* ≤ threshold ({PRESTRESS_TOL:g}) counts as zero, i.e. not prestress stable."
    )
    sdp: SdpModel | None = Field(description="Solver record; null when no SDP was needed.")


class RigidityMarginModel(BaseModel):
    designed_modes: int = Field(description="M, the number of designed modes given.")
    complement_dim: int = Field(
        description="p = dN − ρ − M, the dimension of the motions the margin is taken over."
    )
    undesigned_zero_modes: int = Field(
        description="Nontrivial zero modes not among the designed ones; any makes every margin 0."
    )
    uniform: float | None = Field(
        description=(
            "λ_min(Pᵀ Cᵀ C P) with every bar stiffness 1, C of the scale-normalised frame (RMS "
            "radius 1), P an orthonormal basis of the complement of rigid motions ⊕ designed "
            "modes. Null when p = 0."
        )
    )
    optimal: float | None = Field(
        description=(
            "max over k ≥ 0, Σ k = N_B of λ_min(Pᵀ Cᵀ diag(k) C P), attained by `stiffness` "
            "(verified). Null when options.stiffness is false."
        )
    )
    optimal_upper_bound: float | None = Field(
        description="Verified upper bound on the optimal margin from the dual SDP solution."
    )
    gain: float | None = Field(
        description="optimal / uniform (null when uniform is 0 or not computed)."
    )
    stiffness: list[float] | None = Field(
        description="The optimal bar stiffnesses k (N_B, Σ = N_B), in edge order."
    )
    sdp: SdpModel | None = Field(description="Solver record; null when no SDP was run.")


class CertifyResponse(BaseModel):
    """The certificates of one frame (also embedded in /v1/design reports with options.certify)."""

    analysis: AnalysisCounts
    self_stress: SelfStressModel
    prestress: PrestressModel
    rigidity_margin: RigidityMarginModel
    timings_ms: dict[str, float] = Field(
        description="analysis, prestress, rigidity_margin and total wall times."
    )
