"""Shared request/response models: Frame, rank gap, error body, the analysis counts."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, FiniteFloat

from zeromode.service.wire.schemas.limits import Limited, limit_text

Point = list[FiniteFloat]
Points = list[Point]
# k×d positions or motions of the specified nodes of a request.
SpecifiedPoints = Annotated[Points, Limited("max_specified")]


class RequestModel(BaseModel):
    """Base of every request model: an unknown field is refused (422 naming it), because a typo
    such as ``{"options": {"seeed": 3}}`` must not silently change the science."""

    model_config = ConfigDict(extra="forbid")


class ResultFrame(BaseModel):
    """A bar-and-joint frame. Node indices are 0-based; an edge and its reverse are the same edge.
    This is the frame a response carries: the service's own answer is not held to request limits."""

    dim: Literal[2, 3] = Field(description="Spatial dimension d.")
    positions: Points = Field(description="N×d node positions (row list).")
    edges: list[tuple[int, int]] = Field(default_factory=list, description="N_B bars [i, j], i ≠ j.")
    specified: list[int] = Field(
        default_factory=list, description="Indices of the specified nodes (default: none)."
    )


class FrameModel(ResultFrame, RequestModel):
    """A frame in a request: at most max_nodes nodes and max_edges bars (the serving app's
    settings); an unknown field is refused."""

    positions: Annotated[Points, Limited("max_nodes")] = Field(
        description=f"N×d node positions (row list), N {limit_text('max_nodes')}."
    )
    edges: Annotated[list[tuple[int, int]], Limited("max_edges")] = Field(
        default_factory=list, description=f"N_B bars [i, j], i ≠ j; N_B {limit_text('max_edges')}."
    )


class RankGapModel(BaseModel):
    last_nonzero: float = Field(
        description=(
            "σ_r of the scale-normalised C (0 when rank is 0): exact to round-off by the dense route; by the "
            "sparse route a Ritz value, never below σ_r, converged to σ_r when options.gap_rtol is given."
        )
    )
    first_zero: float = Field(description="σ_{r+1} of the scale-normalised C (0 when there is none).")
    last_nonzero_error: float = Field(
        description=(
            "A singular value of C lies within this relative distance of last_nonzero (the SVD's round-off; "
            "for a Ritz value the Weyl bound of its residual, 1 when it says nothing)."
        )
    )


class AnalysisCounts(BaseModel):
    """The /v1/analyze fields without the bases (embedded in design reports)."""

    nodes: int = Field(description="N")
    edges: int = Field(description="N_B")
    dim: int = Field(description="d")
    maxwell_count: int = Field(description="d·N − N_B")
    rank: int = Field(description="rank of the compatibility matrix C (N_B × dN)")
    zero_modes: int = Field(description="dim N(C) = d·N − rank")
    rigid_body_modes: int = Field(description="dimension of the rigid motions of this configuration")
    nontrivial_zero_modes: int = Field(description="zero_modes − rigid_body_modes")
    self_stresses: int = Field(description="N_B − rank")
    rank_gap: RankGapModel


class ErrorDetail(BaseModel):
    code: str = Field(description="Fixed snake_case error code.")
    message: str = Field(description="One human sentence naming the problem.")


class ErrorResponse(BaseModel):
    detail: ErrorDetail


ERROR_RESPONSES = {
    413: {"model": ErrorResponse, "description": "Request body too large."},
    422: {"model": ErrorResponse, "description": "Invalid request or domain failure (see code)."},
}
