"""POST /v1/plot: a frame, its modes and the requested motions as an SVG picture."""

from __future__ import annotations

from pydantic import BaseModel, Field

from zeromode.service.schemas.common import FrameModel, Points

MAX_PLOT_MODES = 16
MAX_CONFIGURATIONS = 8


class PlotRequest(BaseModel):
    frame: FrameModel
    modes: list[Points] | None = Field(
        default=None,
        max_length=MAX_PLOT_MODES,
        description="Zero modes to draw as solid green arrows, each N×d (light to dark green for several).",
    )
    targets: list[Points] | None = Field(
        default=None,
        max_length=MAX_PLOT_MODES,
        description=(
            "Requested motions u_S to draw as hollow green arrows, each k×d with one row per "
            "specified node in the order of frame.specified."
        ),
    )
    solution_space: bool = Field(
        default=False,
        description=(
            "Also draw the solution space of an unspecified node joined to every specified node, "
            "one per requested motion (targets, or else the modes' rows on the specified nodes): "
            "a curve for a conic, a wireframe for a quadric surface in 3D, dots otherwise."
        ),
    )
    configurations: list[Points] | None = Field(
        default=None,
        max_length=MAX_CONFIGURATIONS,
        description="Further positions of the same frame (N×d each), e.g. expanded and contracted states, drawn side by side.",
    )
    labels: list[str] | None = Field(
        default=None,
        max_length=1 + MAX_CONFIGURATIONS,
        description="Panel captions: the frame first, then one per configuration.",
    )
    source: list[int] = Field(default_factory=list, description="Source nodes (allosteric frames), marked with a purple square.")
    target_nodes: list[int] = Field(
        default_factory=list, description="Target nodes (allosteric frames), marked with an orange diamond."
    )
    title: str | None = Field(default=None, max_length=200, description="A title above the picture.")
    seed: int = Field(default=0, ge=0, description="Seed for sampled solution spaces: same request, same picture.")
