"""POST /v1/plot — pictures in the paper's visual language (SVG)."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import Response

from zeromode.service.convert import frame_from_model
from zeromode.service.schemas.common import ERROR_RESPONSES
from zeromode.service.schemas.plot import PlotRequest
from zeromode.solver.plot import figure_svg

router = APIRouter(prefix="/v1", tags=["plot"])


@router.post(
    "/plot",
    response_class=Response,
    responses={200: {"content": {"image/svg+xml": {}}, "description": "An SVG document."}, **ERROR_RESPONSES},
)
def post_plot(request: PlotRequest) -> Response:
    """Draw a frame: specified nodes red, unspecified blue, bars grey, requested motions as hollow
    green arrows, zero modes as solid green arrows, optionally the solution space (light blue),
    further configurations side by side and source/target markers.  3D frames are shown in a
    fixed orthographic view with depth cues."""
    svg = figure_svg(
        frame_from_model(request.frame),
        modes=request.modes,
        targets=request.targets,
        solution_space=request.solution_space,
        configurations=request.configurations,
        labels=request.labels,
        source=request.source,
        target_nodes=request.target_nodes,
        title=request.title,
        seed=request.seed,
    )
    return Response(content=svg, media_type="image/svg+xml")
