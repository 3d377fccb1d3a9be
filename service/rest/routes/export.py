"""POST /v1/export — a design, lattice, allosteric or multistable design, chain, module map, motion or refinement as
a file for ParaView, a graph library, a laser cutter, a 3D printer or a talk; parse → write → serialise."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import Response

from zeromode.export import FORMATS
from zeromode.operations.exporting import export_file
from zeromode.service.wire.schemas.common import ERROR_RESPONSES
from zeromode.service.wire.schemas.export import ExportFormatInfo, ExportRequest
from zeromode.viz.animation import video_formats

router = APIRouter(prefix="/v1", tags=["export"])


@router.post(
    "/export",
    response_class=Response,
    responses={
        200: {
            "content": {fmt.media_type: {} for fmt in FORMATS.values()},
            "description": "The file, with a Content-Disposition naming it.",
        },
        **ERROR_RESPONSES,
    },
)
def post_export(request: ExportRequest) -> Response:
    """Write a document (a response of /v1/design, /v1/design/auxetic, /v1/design/allosteric,
    /v1/design/multistable or /v1/refine, a request of the first four — designed first — a
    /v1/design/sequential response, a /v1/map response or request — its module, or with map_csv,
    map_svg or map_png its sampled map or the module beside its chart — or a /v1/motion response
    with its `frame`), or a frame with
    modes, a path and springs, in `format` (springs always as springs, never as rods): VTK or XDMF for ParaView (meshio),
    GraphML or node-link JSON (networkx), a DXF or SVG cut file, STL plates or a CSV kit list in mm,
    or the finite motion as an animated SVG, GIF or MP4 (traced first when the document has no
    path)."""
    content, media_type, filename = export_file(request)
    return Response(
        content=content, media_type=media_type, headers={"content-disposition": f'attachment; filename="{filename}"'}
    )


@router.get("/export/formats", response_model=list[ExportFormatInfo])
def get_export_formats() -> list[dict]:
    """Every export format: media type, file suffix, whether it shows a finite motion, whether
    this service can write it (mp4 needs ffmpeg), and whether it writes a module's map."""
    videos = video_formats()
    return [
        {"name": name, "media_type": f.media_type, "suffix": f.suffix, "motion": f.motion,
         "available": name != "mp4" or "mp4" in videos, "description": f.description, "map": f.map}
        for name, f in FORMATS.items()
    ]
