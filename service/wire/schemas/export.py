"""POST /v1/export: a document of another endpoint, or a frame with modes and a path, as a file."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, FiniteFloat

from zeromode.export import FORMATS
from zeromode.service.wire.schemas.common import FrameModel, Points, RequestModel
from zeromode.service.wire.schemas.multistable import SpringsModel
from zeromode.service.wire.schemas.tolerance import ToleranceOptions

ExportFormat = Literal[tuple(FORMATS)]  # the names of zeromode.export.FORMATS


class FabricationOptions(RequestModel):
    """Physical sizes of the cut and printed parts (dxf, cut_svg, stl, kit_csv), in millimetres."""

    mm_per_unit: float | None = Field(
        default=None, gt=0, description="Millimetres per unit of the frame's coordinates (default: the shortest bar is 5 link widths)."
    )
    pin_diameter_mm: float = Field(default=3.0, gt=0, le=1000, description="Diameter of the pin holes (add the clearance your machine needs).")
    link_width_mm: float = Field(default=8.0, gt=0, le=1000, description="Width of each link; its ends are half circles of this diameter.")
    thickness_mm: float = Field(default=3.0, gt=0, le=1000, description="Plate thickness of the printed links (stl).")
    sheet_width_mm: float = Field(default=300.0, gt=0, le=100000, description="Links are laid out in rows at most this wide.")
    gap_mm: float = Field(default=3.0, ge=0, le=1000, description="Space between parts and around the sheet.")


class AnimationOptions(RequestModel):
    """How the finite motion is played (svg_animation, gif, mp4)."""

    frames: int = Field(default=40, ge=2, le=200, description="Configurations picked evenly from the path; played there and back (2·frames − 2 animation frames).")
    fps: float = Field(default=20.0, gt=0, le=60, description="Animation frames per second.")
    scale: float = Field(default=1.0, gt=0, le=4, description="GIF/MP4 pixels per SVG pixel.")
    title: str | None = Field(default=None, max_length=200, description="A title above the picture.")


class MotionOptions(RequestModel):
    """The finite motion traced (as POST /v1/motion does) when a motion format is asked for and
    the document carries no path."""

    mode: int = Field(default=0, ge=0, description="Which of the modes to follow (index into modes).")
    amplitude: FiniteFloat = Field(default=0.3, gt=0, le=10, description="As POST /v1/motion: how far to follow the mode each way.")
    max_step: FiniteFloat = Field(default=0.02, gt=0, le=1, description="As POST /v1/motion.")


class ExportSprings(SpringsModel):
    """Springs given with a frame: a multistable response's ``springs``, an unknown field refused."""

    model_config = ConfigDict(extra="forbid")


class ExportRequest(RequestModel):
    format: ExportFormat = Field(description="The file to write (GET /v1/export/formats lists them).")
    document: dict | None = Field(
        default=None,
        description=(
            "A response of /v1/design, /v1/design/auxetic, /v1/design/allosteric, /v1/design/multistable "
            "(its springs exported as springs, its conformations as configurations), /v1/design/sequential "
            "(the chain, or the module without one; the motion formats play chain.path), /v1/map (the module, "
            "its pairs as source and target; map_csv, map_svg and map_png write its map) or /v1/refine (or a "
            "request of the first four or of /v1/map, designed first), or a /v1/motion response together with `frame`."
        ),
    )
    frame: FrameModel | None = Field(default=None, description="The frame, when no document gives it (or to go with a /v1/motion response).")
    modes: list[Points] | None = Field(default=None, description="Zero modes (each N×d); default: the document's.")
    path: list[Points] | None = Field(default=None, description="A finite motion (configurations, each N×d); default: the document's.")
    springs: ExportSprings | None = Field(
        default=None,
        description="Springs beside the frame's rods (pairs, stiffness, rest_length; never on a rod's pair); "
        "default: the document's (a multistable design's), else none.",
    )
    parameter: list[FiniteFloat] | None = Field(default=None, description="Path parameter of each configuration (default 0, 1, …).")
    fabrication: FabricationOptions = Field(default_factory=FabricationOptions)
    animation: AnimationOptions = Field(default_factory=AnimationOptions)
    motion: MotionOptions = Field(default_factory=MotionOptions)
    tolerance: ToleranceOptions | None = Field(
        default=None,
        description=(
            "Compute the fabrication tolerance report (as options.tolerance of /v1/design, seed 0) into the "
            "export's metadata; a document that carries report.tolerance passes it on without this."
        ),
    )


class ExportFormatInfo(BaseModel):
    name: str
    media_type: str
    suffix: str
    motion: bool = Field(description="The format shows a finite motion (traced when the document has none).")
    available: bool = Field(description="False for mp4 where ffmpeg is not installed.")
    description: str
    map: bool = Field(False, description="The format writes a module's map: only a /v1/map answer (or request) has one.")
