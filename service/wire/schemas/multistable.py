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
    report: MultistableReport
