"""The fabrication tolerance report (options.tolerance of /v1/design): solver/certificates/fabrication.py."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, Field

from zeromode.service.wire.schemas.common import RequestModel

Quantity = Literal["mode", "poisson_ratio", "target_response", "rigidity_margin", "mode_stiffness"]
Error = Literal["bar_lengths", "pin_positions"]


class ToleranceOptions(RequestModel):
    """Report how precisely the design must be built (linear sensitivities checked by a seeded
    Monte Carlo of perturbed frames; its seed is the request's)."""

    budget: float = Field(
        default=0.01, gt=0, lt=1, description="The relative change tolerated in each quantity (0.01: 1 %)."
    )
    samples: int = Field(default=64, ge=2, le=1000, description="Perturbed frames per Monte Carlo check.")


class ToleranceEstimateModel(BaseModel):
    quantity: Quantity = Field(
        description=(
            "mode: how far the built frame is from moving the specified nodes as designed; poisson_ratio: "
            "a lattice's ν; target_response: an allosteric design's target motion; rigidity_margin: "
            "λ_min of CᵀC past the designed modes; mode_stiffness (frames with self-stresses): the designed "
            "modes' energy relative to the margin."
        )
    )
    error: Error = Field(
        description="bar_lengths: each length off by a fraction within ±ε; pin_positions: each coordinate within ±ε·mean bar length."
    )
    sensitivity: float = Field(description="Linear RMS relative change per unit ε (mean per ε² for mode_stiffness).")
    tolerance: float | None = Field(description="ε keeping the change at the budget (None: no first-order change).")
    tolerance_absolute: float | None = Field(description="pin_positions: the tolerance in the frame's units.")
    tested_error: float | None = Field(description="ε of the Monte Carlo (the tolerance, at most 0.1).")
    predicted: float | None = Field(description="The linear estimate of the statistic at tested_error.")
    monte_carlo: float | None = Field(description="The statistic over the perturbed frames at tested_error.")
    monte_carlo_p95: float | None = Field(description="95th percentile of the change over the perturbed frames.")
    agrees: bool | None = Field(description="predicted and monte_carlo within agreement_factor of each other.")
    failed: int = Field(description="Perturbed frames that could not be assembled.")
    statement: str = Field(description="The estimate in one sentence.")


class ToleranceReportModel(BaseModel):
    budget: float
    samples: int
    seed: int
    agreement_factor: float = Field(description="The linear estimate agrees when within this factor of the Monte Carlo.")
    mean_bar_length: float = Field(description="Pin tolerances are fractions of it (frame units).")
    self_stresses: int
    bar_lengths: float | None = Field(description="The tightest bar-length tolerance over the quantities (fraction).")
    pin_positions: float | None = Field(description="The tightest pin-position tolerance (fraction of the mean bar length).")
    summary: str = Field(description="What to build to, in one sentence.")
    disagreements: list[str] = Field(description="The estimates whose linearisation the Monte Carlo does not confirm.")
    estimates: list[ToleranceEstimateModel]
