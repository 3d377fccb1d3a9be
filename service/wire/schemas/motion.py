"""POST /v1/motion (finite motion along a zero mode) and POST /v1/refine (IPOPT refinement)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, Field, model_validator

from zeromode.service.wire.schemas.common import (
    AnalysisCounts,
    ErrorDetail,
    FrameModel,
    Points,
    RequestModel,
    ResultFrame,
)
from zeromode.service.wire.schemas.limits import AtMost, limit_text
from zeromode.solver.analysis.rigidity import DENSE_MAX_DOF
from zeromode.solver.motion.finite_motion import CURVE_SAMPLES
from zeromode.solver.tolerances import IPOPT_TOL

FIDELITY = (
    "Finite-motion fidelity ε(a) = min over path points X(τ) and proper rigid motions R of "
    "‖R·X_S(τ) − (x_S + Δ_S)‖ / ‖Δ_S‖ (Kabsch alignment), Δ_S the target displacement."
)


CURVE = (
    f"ε(b) at m = {CURVE_SAMPLES} amplitudes b_j = (j/m)·a, j = 1 … m, for the targets x_S + (j/m)·Δ_S on the ray "
    "to the target: the same minimum over the same traced path as ε itself (polished on the "
    "constraint manifold, not between straight chords), so the last value is ε(a)."
)


class EpsilonCurveOption(RequestModel):
    amplitude: float = Field(
        gt=0,
        le=10,
        description=(
            "a: the linear target of the specified nodes x_S + Δ_S, Δ_S = a·(r_S/ρ_u)·u_S as /v1/refine's "
            "`motion` and `amplitude` (r_S the RMS radius of x_S, ρ_u the RMS of u_S)."
        ),
    )
    motion: Points | None = Field(
        default=None,
        description=(
            "u_S (k×d, rows in the order of frame.specified); default: those rows of `mode`, or of the "
            "frame's single nontrivial zero mode that the motion follows."
        ),
    )


class EpsilonCurveModel(BaseModel):
    amplitudes: list[float] = Field(description=f"b_1 < … < b_{CURVE_SAMPLES} = a.")
    epsilon: list[float] = Field(description="ε(b_j) along `path`. " + CURVE)
    parameter: list[float] = Field(description="The path parameter where each minimum is attained.")
    at_end: list[bool] = Field(
        description="The minimum sits at an end of `path` (a longer path might come closer: raise `amplitude`)."
    )


class RefineEpsilonCurve(BaseModel):
    amplitudes: list[float] = Field(description=f"b_1 < … < b_{CURVE_SAMPLES} = a.")
    before: list[float] = Field(
        description="ε(b_j) of the input frame, on the path that measured `epsilon_before` (its last value). " + CURVE
    )
    after: list[float] = Field(
        description=(
            "ε(b_j) of the refined frame, on the path that measured `epsilon_after` (its last value); "
            "`before` again when the input frame is kept."
        )
    )


class MotionTargetModel(RequestModel):
    kind: Literal["distance", "angle", "strain", "fraction"] = Field(
        description=(
            "'distance': |x_j − x_i| between `nodes` [i, j] (the frame's length unit); 'angle': the angle "
            "at node j between the arms to i and k, `nodes` [i, j, k], in radians — in 2D signed "
            "(counter-clockwise from arm i to arm k positive) and followed continuously along the "
            "path (its value in (−π, π] at the input frame, then unwrapped: a full turn adds 2π), "
            "in 3D unsigned in (0, π); 'strain': ε_x or ε_y (`axis`) of a lattice as in `strains` "
            "(needs `boundary`); 'fraction': f in [−1, 1], f ≠ 0, of the usable range of the "
            "motion in the direction sign(f) of the mode, in path parameter (the range ends at "
            "the first singular point, where two nodes without a bar come closer than 0.1 of the "
            "shortest bar, or at parameter 10)."
        )
    )
    value: float = Field(description="The target value of the quantity.")
    nodes: list[int] | None = Field(default=None, description="Node indices: [i, j] (distance) or [i, j, k] (angle at j).")
    axis: Literal["x", "y"] | None = Field(default=None, description="'strain': which strain, ε_x or ε_y.")


class MotionRequest(RequestModel):
    frame: FrameModel
    mode: Points | None = Field(
        default=None,
        description=(
            "N×d zero mode to follow (any scale; its rigid part is ignored). Default: the frame's "
            "single nontrivial zero mode, with its largest entry positive (entries within 1e-8 of "
            "it tie, the first deciding); 422 `ambiguous_mode` if "
            "the frame has several, `no_motion` if none."
        ),
    )
    amplitude: float = Field(
        default=0.2,
        gt=0,
        le=10,
        description=(
            "How far to follow the motion in each direction: pseudo-arclength in units of RMS node "
            "displacement over the frame's RMS radius (to first order the nodes move by "
            "amplitude·r·û, û the mode scaled to unit RMS node displacement). Not with `target`."
        ),
    )
    max_step: float = Field(
        default=0.02,
        gt=0,
        le=1,
        description="Largest continuation step, in the units of `amplitude`.",
    )
    max_steps: int = Field(
        default=5000,
        ge=1,
        le=20000,
        description="Step budget per direction (422 `step_limit` past it).",
    )
    direction: Literal["both", "forward", "backward"] = Field(
        default="both", description="Follow +mode, −mode, or both."
    )
    on_singularity: Literal["error", "report"] = Field(
        default="error",
        description=(
            "What to do when a singular point (extra zero modes: a branch point, or the frame "
            "locks) stops the path before the amplitude: 'error' answers 422 `singular_path` with "
            "the path up to it in detail.best; 'report' answers 200 with status 'singular_path'."
        ),
    )
    boundary: dict[Literal["left", "right", "bottom", "top"], list[int]] | None = Field(
        default=None,
        description=(
            "Node sets of a lattice (as /v1/design/auxetic's report.boundary): when given, the response "
            "reports the strain (ε_x, ε_y) and the secant Poisson ratio of every configuration, and a "
            "frame tiled by translations is followed through one cell and checked on the whole frame "
            "(method 'periodic'; the frame's own continuation where the check fails)."
        ),
    )
    target: MotionTargetModel | None = Field(
        default=None,
        description=(
            "Instead of `amplitude`: continue the motion until a quantity reaches this value and end "
            "exactly there (Newton on the bar constraints plus the target equation: the quantity "
            "within 1e-10 of the value — relative for a distance — and every bar within 1e-10 of its length). "
            "The path then holds the input frame and the configurations towards the target, the "
            "last one (`target.index`) on it; with direction 'both' the nearer landing (smaller "
            "|parameter|) is kept. The search goes up to path parameter 10. Unreachable: 422 "
            "`target_past_turning_point` (the quantity's derivative along the path changes sign "
            "first), `target_past_singular_point`, or `target_out_of_range` (beyond the search, or "
            "the quantity moves away in the only direction asked), whatever `on_singularity`, "
            "with the path traced and `target.reached` the nearest value found in detail.best; "
            "a malformed target (nodes out of range or repeated, coincident nodes, a strain "
            "without `boundary`) 422 `invalid_target`."
        ),
    )

    epsilon_curve: EpsilonCurveOption | None = Field(
        default=None,
        description=(
            "Also answer the finite-motion fidelity along the path for the specified nodes' linear "
            "target (`epsilon_curve` in the response; 422 `too_few_specified` below 2 specified nodes). "
            + FIDELITY
        ),
    )

    @model_validator(mode="after")
    def amplitude_or_target(self):
        if self.target is not None and "amplitude" in self.model_fields_set:
            raise ValueError("give `amplitude` or `target`, not both")
        return self


class SingularityModel(BaseModel):
    step: int = Field(description="Index in `path` of the singular configuration.")
    parameter: float = Field(description="Its path parameter.")
    extra_zero_modes: int = Field(description="Zero modes of C there beyond those along the path.")
    sigma: float = Field(description="σ/σ_max of the singular value that vanished (the evidence).")
    kind: Literal["rank_drop", "stalled"] = Field(
        description="'rank_drop': located where C loses rank; 'stalled': the corrector failed at the smallest step."
    )


class TargetReport(BaseModel):
    kind: Literal["distance", "angle", "strain", "fraction"]
    value: float = Field(description="The target asked.")
    reached: float = Field(
        description=(
            "The quantity at the last configuration (the unwrapped angle; for a fraction, its "
            "parameter over the range's end); in a 422's detail.best the nearest value found."
        )
    )
    error: float = Field(description="|reached − value|.")
    index: int = Field(description="Index in `path` of the configuration on the target.")
    parameter: float = Field(description="Its path parameter.")
    range_end: float | None = Field(
        default=None, description="'fraction': the path parameter where the usable range ends in that direction."
    )
    range_end_reason: Literal["singular_point", "node_proximity", "search_limit"] | None = Field(
        default=None, description="'fraction': what ends the usable range there."
    )


class MotionResponse(BaseModel):
    path: list[Points] = Field(
        description=(
            "Configurations (N×d each) ordered by `parameter`, each aligned to the input frame: "
            "the proper rigid motion that minimises the sum of squared node distances to it "
            "(Kabsch) is removed, so panels of a motion can be drawn without rotating. The "
            "input configuration itself is returned unchanged at `reference_index`."
        )
    )
    parameter: list[float] = Field(
        description="Path parameter of each configuration (0 at the input frame)."
    )
    reference_index: int = Field(description="Index of the input configuration in `path`.")
    max_relative_bar_error: float = Field(
        description="max over the path and the bars of | |x_i − x_j| − l | / l (≤ 1e-9)."
    )
    singularities: list[SingularityModel] = Field(
        description="Singular points met (at most one per direction)."
    )
    singular_start: SingularityModel | None = Field(
        default=None,
        description=(
            "The input frame itself as a singular point (step `reference_index`, parameter 0): C "
            "has more zero modes there than just off it along the path — the path starts at a "
            "branch point (two zero modes crossing, a flattened linkage; a `mode` must then be "
            "given). It does not end the path; null otherwise."
        ),
    )
    target: TargetReport | None = Field(default=None, description="With `target`: where the path ended.")
    status: Literal["ok", "singular_path"]
    steps: int = Field(description="Number of continuation steps taken (len(path) − 1).")
    method: Literal["dense", "sparse", "periodic"] = Field(
        description=(
            f"Linear algebra of the continuation: dense LU up to {DENSE_MAX_DOF} degrees of freedom, "
            "sparse LU of the bordered Jacobian above (periodic: one cell's motion, tiled and "
            "checked on the frame)."
        )
    )
    timings_ms: dict[str, float]
    strains: list[list[float]] | None = Field(
        default=None,
        description=(
            "With `boundary`: (ε_x, ε_y) of each configuration, the change of the extent between the mean "
            "positions of the opposite boundary sets relative to the input frame's."
        ),
    )
    poisson_ratio: list[float | None] | None = Field(
        default=None, description="With `boundary`: secant ν = −ε_y/ε_x of each configuration (null at ε_x = 0)."
    )
    epsilon_curve: EpsilonCurveModel | None = Field(
        default=None, description="With the request's `epsilon_curve`: ε along `path` for its linear target."
    )


class RefineOptions(RequestModel):
    K: int = Field(
        default=8,
        ge=1,
        le=64,
        description=(
            "Configurations after the reference along the path; retried once with 2K (≤ 64) if "
            "they straddle two branches of the configuration space."
        ),
    )
    tol: float = Field(default=IPOPT_TOL, gt=0, lt=1, description="IPOPT tol.")
    max_iter: int = Field(default=500, ge=1, le=10000, description="IPOPT max_iter.")
    max_time_s: Annotated[float, AtMost("time_budget_s")] = Field(
        default=5.0,
        gt=0,
        description=f"IPOPT max_cpu_time and max_wall_time, {limit_text('time_budget_s')}.",
    )
    stay_on_solution_space: bool = Field(
        default=False,
        description=(
            "Also keep u_S an exact infinitesimal zero mode of the refined reference frame (every "
            "unspecified node stays on the solution-space quadric for u_S)."
        ),
    )


class RefineRequest(RequestModel):
    frame: FrameModel = Field(
        description="A frame with specified nodes and one nontrivial zero mode."
    )
    motion: Points | None = Field(
        default=None,
        description="u_S (k×d, rows in the order of frame.specified): the direction of the target motion.",
    )
    targets: Points | None = Field(
        default=None,
        description="Final positions of the specified nodes (k×d), instead of motion + amplitude.",
    )
    amplitude: float = Field(
        default=0.1,
        gt=0,
        le=10,
        description=(
            "a: with `motion`, the specified nodes are displaced by Δ_S = a·(r_S/ρ_u)·u_S — an RMS "
            "displacement of a times the RMS radius r_S of the specified positions (ρ_u is the RMS "
            "of u_S). Ignored with `targets`."
        ),
    )
    options: RefineOptions = Field(default_factory=RefineOptions)

    @model_validator(mode="after")
    def one_target(self):
        if (self.motion is None) == (self.targets is None):
            raise ValueError("give exactly one of `motion` (with `amplitude`) or `targets`")
        return self


class RefineResponse(BaseModel):
    frame: ResultFrame = Field(description="The refined frame (specified nodes unchanged).")
    displacement: Points = Field(
        description="Δ_S, the target displacement of the specified nodes (k×d)."
    )
    amplitude: float = Field(description="a (RMS of Δ_S over the RMS radius of x_S).")
    epsilon_before: float = Field(description="ε of the input frame. " + FIDELITY)
    epsilon_after: float = Field(
        description="ε of the refined frame, measured by continuation from it (independently of IPOPT)."
    )
    modes: list[Points] | None = Field(
        default=None,
        description="The refined frame's nontrivial zero mode (N×d) at its reference; null when it has not exactly one.",
    )
    ipopt_status: str = Field(
        description="IPOPT's return status; 'not_needed' when the target is a rigid motion of x_S (ε = 0 without IPOPT)."
    )
    iterations: int = Field(description="IPOPT iterations (of the solve reported); 0 when IPOPT did not iterate.")
    K: int = Field(description="Configurations after the reference in the solve reported.")
    attempts: int = Field(
        description="IPOPT solves: 2 when the first path straddled two branches and was redone with 2K."
    )
    time_ms: float = Field(
        description="Whole refinement, including both ε measurements and the re-verification."
    )
    ipopt_time_ms: float = Field(description="IPOPT alone (all attempts).")
    path: list[Points] = Field(
        description="IPOPT's K+1 configurations, the refined reference first."
    )
    max_relative_bar_error: float = Field(
        description="Largest relative bar-length error along `path`."
    )
    analysis_reference: AnalysisCounts | None = Field(
        description="Rigidity analysis of the refined frame."
    )
    analysis_end: AnalysisCounts | None = Field(
        description="Rigidity analysis of the final configuration."
    )
    status: Literal["ok", "refinement_failed"]
    message: str
    epsilon_curve: RefineEpsilonCurve | None = Field(
        default=None,
        description="ε(b) for b in (0, a] before and after; null when no path is traced (a rigid target).",
    )


class MotionErrorDetail(ErrorDetail):
    best: MotionResponse | RefineResponse | None = Field(
        default=None,
        description="For `singular_path` and `refinement_failed`: the best result found.",
    )


class MotionErrorResponse(BaseModel):
    detail: MotionErrorDetail
