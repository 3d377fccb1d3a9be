"""POST /v1/plot — pictures in the paper's visual language (SVG); parse → draw → serialise."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import Response

from zeromode.operations.plotting import picture_from_request
from zeromode.service.wire.schemas.common import ERROR_RESPONSES
from zeromode.service.wire.schemas.plot import PlotRequest
from zeromode.viz.svg import picture_svg

router = APIRouter(prefix="/v1", tags=["plot"])


@router.post(
    "/plot",
    response_class=Response,
    responses={200: {"content": {"image/svg+xml": {}}, "description": "An SVG document."}, **ERROR_RESPONSES},
)
def post_plot(request: PlotRequest) -> Response:
    """Draw a frame: specified nodes red, unspecified blue, bars grey, requested motions as hollow
    green arrows, zero modes as solid green arrows, optionally the solution space (light blue),
    further configurations beside it with labels and captions, and source/target markers.  3D
    frames are shown in a fixed orthographic view with depth cues."""
    return Response(content=picture_svg(picture_from_request(request)), media_type="image/svg+xml")
