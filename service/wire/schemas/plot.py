"""POST /v1/plot: a frame, its modes and the requested motions as an SVG picture."""

from __future__ import annotations

from pydantic import Field, FiniteFloat

from zeromode.service.wire.schemas.common import FrameModel, Points, RequestModel
from zeromode.viz.style import VIEW_3D

MAX_PLOT_MODES = 16
MAX_CONFIGURATIONS = 8


class PlotRequest(RequestModel):
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
        description=(
            "Further positions of the same frame (N×d each), e.g. expanded and contracted states, drawn "
            "at one common scale in a row (or a column, for wide panels)."
        ),
    )
    labels: list[str] | None = Field(
        default=None,
        max_length=1 + MAX_CONFIGURATIONS,
        description="Text above each panel, in panel order (the frame's panel is number frame_panel).",
    )
    captions: list[str] | None = Field(
        default=None,
        max_length=1 + MAX_CONFIGURATIONS,
        description="Text below each panel, in panel order, e.g. the Poisson ratio of each state.",
    )
    frame_panel: int = Field(
        default=0,
        ge=0,
        le=MAX_CONFIGURATIONS,
        description=(
            "Where the frame's own panel (the one with arrows) goes among the panels: 0 first (default), "
            "1 after the first configuration, … — e.g. 1 puts the reference between a contracted and an "
            "expanded state."
        ),
    )
    arrow_nodes: list[int] | None = Field(
        default=None,
        description=(
            "Nodes that carry mode arrows. Default: every node, or for frames of more than 200 nodes "
            "the node nearest the centre of each cell of a 10-cell-wide grid over the frame."
        ),
    )
    source: list[int] = Field(default_factory=list, description="Source nodes (allosteric frames), marked with a purple square.")
    target_nodes: list[int] = Field(
        default_factory=list, description="Target nodes (allosteric frames), marked with an orange diamond."
    )
    view: tuple[FiniteFloat, FiniteFloat] = Field(
        default=VIEW_3D,
        description="3D frames: the orthographic view as [azimuth about z, elevation above the xy-plane] in degrees.",
    )
    title: str | None = Field(default=None, max_length=200, description="A title above the picture.")
    seed: int = Field(default=0, ge=0, description="Seed for sampled solution spaces: same request, same picture.")
