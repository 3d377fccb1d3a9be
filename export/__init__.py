"""zeromode.export — designs leave zeromode in the formats of the tools they go to.

Each format is written with its field's own library (imported only when that format is asked
for), from one neutral Takeaway (takeaway.py):

  vtk, xdmf              ParaView, through meshio (meshes.py); springs are a cell kind of their own
  graphml, node_link_json  graph libraries, through networkx (graphs.py)
  dxf, cut_svg, stl, kit_csv  fabrication in mm: ezdxf, its SVG backend, meshio (fabrication.py)
  svg_animation, gif, mp4  the finite motion as an animation (zeromode.viz.animation; mp4 only
                         where ffmpeg is installed)
  map_csv, map_svg, map_png  a module's map (a /v1/map answer): its samples, or the module beside
                         its chart (maps.py)
"""

from __future__ import annotations

from dataclasses import dataclass

from zeromode.export.fabrication import Fabrication
from zeromode.export.takeaway import Takeaway
from zeromode.solver.errors import DomainError, InvalidInput


@dataclass(frozen=True)
class Format:
    """An export format: its media type, file suffix, whether it shows a finite motion (then
    the Takeaway needs a path), what it is for, and whether it writes a module's map (only a
    /v1/map answer has one) rather than a frame."""

    media_type: str
    suffix: str
    motion: bool
    description: str
    map: bool = False


FORMATS = {
    "vtk": Format("application/xml", ".vtu", False, "VTK unstructured grid for ParaView (meshio): bars and springs as lines told apart by cell data kind, roles, sites, zero modes and conformations as point data"),
    "xdmf": Format("application/xml", ".xdmf", True, "XDMF time series for ParaView (meshio): the finite motion as point displacements"),
    "graphml": Format("application/graphml+xml", ".graphml", False, "GraphML (networkx): positions, roles, modes, bar lengths and springs (edge kind, rest length, stiffness) as attributes"),
    "node_link_json": Format("application/json", ".json", False, "networkx node-link JSON: positions, roles, modes, bar lengths and springs (edge kind, rest length, stiffness) as attributes"),
    "dxf": Format("image/vnd.dxf", ".dxf", False, "DXF cut file in mm (ezdxf): each bar a link with pin holes, laid flat and labelled; springs on layer SPRING at their rest length"),
    "cut_svg": Format("image/svg+xml", ".svg", False, "the DXF cut file as a plain SVG in mm (no legend)"),
    "stl": Format("model/stl", ".stl", False, "the links as printable plates (binary STL, meshio)"),
    "kit_csv": Format("text/csv", ".csv", False, "parts list of a strut-and-hub kit: bars with lengths in the frame's units and in mm, springs with rest lengths and stiffness"),
    "svg_animation": Format("image/svg+xml", ".svg", True, "the finite motion as an animated SVG (SMIL)"),
    "gif": Format("image/gif", ".gif", True, "the finite motion as a GIF (matplotlib, Pillow)"),
    "mp4": Format("video/mp4", ".mp4", True, "the finite motion as an MP4 (matplotlib, ffmpeg; only where ffmpeg is installed)"),
    "map_csv": Format("text/csv", ".csv", False, "a /v1/map answer's sampled map: d_in, f(d_in) and f′(d_in) at each sample of the usable range", map=True),
    "map_svg": Format("image/svg+xml", ".svg", False, "a /v1/map answer as a picture (matplotlib): the module, its pairs marked, beside f with the diagonal, usable range, fixed points and folds", map=True),
    "map_png": Format("image/png", ".png", False, "the map_svg picture as a PNG", map=True),
}


@dataclass(frozen=True)
class AnimationOptions:
    """frames: configurations picked from the path (the animation plays them there and back);
    fps; scale: GIF/MP4 pixels per SVG pixel; title above the picture."""

    frames: int = 40
    fps: float = 20.0
    scale: float = 1.0
    title: str | None = None


def check_writable(fmt: str) -> None:
    """Whether this machine can write ``fmt``, asked before any work: InvalidInput for an unknown
    format, DomainError ``unavailable_format`` (with what to install) for MP4 without ffmpeg."""
    if fmt not in FORMATS:
        raise InvalidInput("invalid_format", f"format must be one of {', '.join(FORMATS)}; got {fmt!r}.")
    if fmt == "mp4":
        from zeromode.viz.animation import video_formats

        if fmt not in video_formats():
            raise DomainError(
                "unavailable_format",
                "MP4 needs ffmpeg, which is not on this machine's PATH (install it, e.g. apt-get install "
                "ffmpeg); gif and svg_animation need nothing more.",
            )


def export_bytes(
    takeaway: Takeaway, fmt: str, fab: Fabrication | None = None, animation: AnimationOptions | None = None
) -> bytes:
    """The takeaway written in format ``fmt`` (a key of FORMATS), with the given part sizes and
    playback (defaults when None). Raises as check_writable, and InvalidInput for a motion format
    without a path."""
    fab = fab or Fabrication()
    animation = animation or AnimationOptions()
    check_writable(fmt)
    if FORMATS[fmt].motion and takeaway.path is None:
        raise InvalidInput("no_motion", f"the {fmt} format shows a finite motion; the export has no path.")
    if fmt in ("vtk", "xdmf"):
        from zeromode.export import meshes

        return (meshes.vtu_bytes if fmt == "vtk" else meshes.xdmf_bytes)(takeaway)
    if fmt in ("graphml", "node_link_json"):
        from zeromode.export import graphs

        return (graphs.graphml_bytes if fmt == "graphml" else graphs.node_link_bytes)(takeaway)
    if fmt in ("dxf", "cut_svg", "stl", "kit_csv"):
        from zeromode.export import fabrication

        writer = {"dxf": fabrication.dxf_bytes, "cut_svg": fabrication.cut_svg_bytes,
                  "stl": fabrication.stl_bytes, "kit_csv": fabrication.kit_csv_bytes}[fmt]
        return writer(takeaway, fab)
    if fmt in ("map_csv", "map_svg", "map_png"):
        from zeromode.export import maps

        return maps.map_csv_bytes(takeaway) if fmt == "map_csv" else maps.map_picture_bytes(takeaway, fmt[4:])
    from zeromode.viz.animation import animation_svg, animation_video, motion_animation

    movie = motion_animation(
        takeaway.frame, takeaway.path, source=takeaway.source, target=takeaway.target,
        frames=animation.frames, fps=animation.fps, title=animation.title,
    )
    if fmt == "svg_animation":
        return animation_svg(movie).encode()
    return animation_video(movie, fmt, animation.scale)
