"""POST /v1/design/multistable: rods and springs whose given conformations are energy minima."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field

from zeromode.service.wire.schemas.common import (
    AnalysisCounts,
    Points,
    RequestModel,
    ResultFrame,
    SpecifiedPoints,
)


class MultistableOptions(RequestModel):
    barrier: float | None = Field(
        default=None,
        gt=0,
        description="Smallest energy barrier between neighbouring minima (energy units: max_stiffness × length²); "
        "default half the largest barrier the springs can make.",
    )
    max_stiffness: float = Field(default=1.0, gt=0, description="Largest spring stiffness k_max.")
    seed: int = Field(default=0, ge=0, description="Seed for the node placement and the relaxations: same request, same answer.")
    bifurcation: int | None = Field(
        default=None, ge=0, le=2,
        description="Index of a conformation where the motion is to branch (three 2D conformations): the rods' "
        "configuration space has a bifurcation there, the motion takes the branch through the other conformations, "
        "which alone become the springs' minima.",
    )


class MultistableRequest(RequestModel):
    dim: Literal[2, 3]
    conformations: list[SpecifiedPoints] = Field(
        min_length=2, max_length=3,
        description="2 or 3 conformations of the k specified nodes (each k×d, k ≥ d + 1), in the order the motion visits them.",
    )
    options: MultistableOptions = Field(default_factory=MultistableOptions)


class SpringsModel(BaseModel):
    pairs: list[tuple[int, int]] = Field(description="S springs [i, j]; never a rod of the frame.")
    stiffness: list[float] = Field(description="k_s > 0, at most max_stiffness.")
    rest_length: list[float] = Field(description="L_s: E = Σ k_s (|x_i − x_j| − L_s)² / 2.")


class LandscapeModel(BaseModel):
    arclength: list[float] = Field(description="s along the motion (Euclidean arc length in R^{dN}), 0 at the first conformation.")
    energy: list[float] = Field(description="E(s) of the springs at each sample (every rod at its length).")
    conformation_samples: list[int] = Field(description="The sample index of each conformation.")
    positions: list[list[list[float]]] = Field(
        description="Every node (N × d) at each sample: the motion itself, each conformation (up to a rigid motion) at its sample."
    )


class MinimumModel(BaseModel):
    index: int = Field(description="Which conformation.")
    arclength: float
    energy: float
    slope: float = Field(description="E′(s) along the motion (0 up to round-off).")
    curvature: float = Field(description="E″(s) along the motion, from the motion's tangent and curvature (> 0: a strict minimum).")
    barrier_before: float | None = Field(description="Highest sampled E between the previous minimum and this one, minus E here.")
    barrier_after: float | None = Field(description="Highest sampled E between this minimum and the next, minus E here.")
    hessian_min_eigenvalue: float = Field(
        description="Smallest eigenvalue, modulo rigid motions, of the Hessian of the full energy with the rods as stiff "
        "springs (rod_stiffness_ratio × max_stiffness) at its relaxed minimum: > 0 means positive definite."
    )
    relaxed_shift: float = Field(description="How far that relaxation moved the conformation (over RMS radius · √N).")
    worst_landing: float = Field(
        description="Largest distance (over RMS radius · √N, modulo rigid motions) between the relaxed minimum and the "
        "end of a relaxation from a seeded perturbation."
    )


class BranchFollowedModel(BaseModel):
    reach: tuple[float, float] = Field(
        description="Path parameters reached either way from the branch point (RMS node displacement over its RMS radius)."
    )
    max_relative_bar_error: float = Field(description="Largest relative change of a rod's length along the continuation.")
    separation: float = Field(
        description="Smallest distance (modulo rigid motions) of its end configurations from the other branch's traced "
        "configurations, over their distance from the branch point: > 0, a curve of its own."
    )


class BifurcationModel(BaseModel):
    index: int = Field(description="The conformation where the motion branches (not a minimum: two first-order modes).")
    arclength: float = Field(
        description="Its s along the motion, on the landscape's scale (0 at the first minimum); a branch point at the "
        "first or last conformation lies beyond the landscape's samples, which span the minima and a margin."
    )
    energy: float = Field(description="The springs' energy there (neither constrained nor a minimum).")
    rank: int = Field(description="Rank of C there: one below the rods' count (one self-stress).")
    sigma_kept: float = Field(description="Smallest kept singular value of C over the largest (normalised positions).")
    sigma_dropped: float = Field(description="The singular value lost at the branch point, over the largest (round-off).")
    stress: list[float] = Field(description="The self-stress ω (Cᵀω = 0, unit norm, per rod in frame order).")
    form: tuple[float, float, float] = Field(
        description="(A, B, D) of Q(a, b) = A a² + 2B ab + D b², the second-order condition Σ ω_e |Δu_e|² = 0 "
        "on u = a u₁ + b u₂ (u₁, u₂ the orthonormal nontrivial modes): indefinite, B² > AD."
    )
    taken_tangent: Points = Field(
        description="Unit tangent (in R^{dN}, ⟂ rigid motions) of the branch the motion takes at conformations[index], "
        "signed towards the next conformation (away from the previous one at the last)."
    )
    other_tangent: Points = Field(description="Unit tangent of the other branch (sign immaterial).")
    angle_degrees: float = Field(description="Angle between the two tangents as lines, in (0, 90].")
    dyad: tuple[int, int] = Field(description="The branching dyad's nodes (q, p): p's rods are parallel at the branch point.")
    kind: Literal["stretched", "folded"] = Field(
        description="stretched: p between q and its other node (their distance largest there); folded: p beyond q (smallest)."
    )
    taken_branch: BranchFollowedModel = Field(description="The branch the motion takes, traced through every conformation.")
    other_branch: BranchFollowedModel = Field(description="The other branch, followed a quarter of the way to the nearest conformation.")


class MultistableReport(BaseModel):
    construction: str = Field(description="How the linkage was built.")
    analysis: AnalysisCounts = Field(description="Counts of the rods in the first conformation.")
    unspecified_nodes: int
    rods: int
    springs: int
    parameters: list[float] = Field(description="Path parameter τ of each conformation on the traced motion (increasing).")
    epsilons: list[float] = Field(description="Finite-motion fidelity of each conformation on the traced motion (all nodes).")
    gap: float = Field(description="Smallest σ_r/σ_max of C along the motion; one nontrivial zero mode at every sample.")
    max_length_mismatch: float = Field(description="Largest relative difference of a rod's length between conformations.")
    barrier: float = Field(description="The barrier asked for (or its default).")
    max_stiffness: float
    rod_stiffness_ratio: float = Field(description="K / max_stiffness of the rods as stiff springs in the verification.")
    relaxations: int = Field(description="Seeded relaxations per minimum.")
    timings_ms: dict[str, float]


class MultistableResponse(BaseModel):
    frame: ResultFrame = Field(description="The rods in the first conformation; the first k nodes are its specified nodes exactly.")
    conformations: list[Points] = Field(description="Every node in each conformation (C × N × d); the first k rows exact.")
    springs: SpringsModel
    landscape: LandscapeModel
    minima: list[MinimumModel]
    bifurcation: BifurcationModel | None = Field(
        default=None, description="The branch point when options.bifurcation asked for one (then minima omit it)."
    )
    report: MultistableReport
