"""PNG and PDF: a Scene drawn with matplotlib (Agg for PNG, its PDF backend for PDF).

Why matplotlib, and not cairosvg on the SVG (measured on this project's busy 2-core machine,
medians of 5, 1.5 px per SVG px):
- availability, the deciding reason: PNG must work after a plain ``pip install`` (issue 17).
  cairosvg reaches the system library libcairo through cairocffi's dlopen; pip cannot install
  it, and python:*-slim images, macOS and Windows lack it. matplotlib's wheels carry all they
  need (Agg, FreeType, the DejaVu fonts).
- speed: equal on small frames (outward_2d, 49 shapes: 89 ms against cairosvg's 74 ms), faster
  on large ones (4 × 4 sheet, 632 shapes: 169 against 227 ms; cube with its sphere, 1165: 160
  against 420 ms; two-mode 3D design, 2549: 176 against 702 ms; 12 × 12 sheet, 4880: 416
  against 1043 ms). Its import costs more (0.6–1.0 s against 0.2–0.4 s), paid only when a PNG
  or PDF is written: import this module only then (the CLI does; nothing imports it eagerly).
- the pictures are the same: cairosvg's rendering of the SVG and this PNG differ by 0.4–1.8
  grey levels per pixel on average and put ink on the same pixels (intersection over union
  0.92–0.97; tests/test_plot.py checks it); matplotlib also writes PDF for papers and the
  animations issue 17 asks for.

Shapes are drawn in the scene's order, consecutive shapes of one kind as one collection (one
draw call for a lattice's thousand bars), in a figure of width × height points whose data
units are SVG pixels, so stroke widths and font sizes mean the same in both writers.
"""

from __future__ import annotations

import io
import math
from itertools import groupby
from pathlib import Path

import numpy as np
from matplotlib.collections import EllipseCollection, LineCollection, PolyCollection
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from zeromode.viz.scene import Circle, Group, Line, Polygon, Polyline, Scene, Text
from zeromode.viz.style import FONT_RASTER, WHITE

FORMATS = ("png", "pdf")
POINTS_PER_INCH = 72.0


def raster_bytes(scene: Scene, fmt: str = "png", scale: float = 1.5) -> bytes:
    """The scene as a PNG (``scale`` pixels per SVG pixel) or a PDF (vector; its page is rounded
    up to whole pixels of ``scale`` as the PNG's is)."""
    if fmt not in FORMATS:
        raise ValueError(f"format must be one of {FORMATS}, got {fmt!r}")
    fig, ax = scene_figure(scene, scale)
    draw_shapes(ax, scene.shapes)
    buffer = io.BytesIO()
    fig.savefig(buffer, format=fmt, dpi=POINTS_PER_INCH * scale, facecolor=WHITE)
    return buffer.getvalue()


def scene_figure(scene: Scene, scale: float):
    """(figure, axes) of the scene's page: data units are SVG pixels, y down, no axes drawn."""
    # The page the SVG declares (its sizes are written to 0.1 px: a height of 344.50000000000006
    # is "344.5" there), in whole output pixels (the last one partly blank), so that no rounding
    # squeezes the page and the PNG is the SVG's size.
    width, height = (math.ceil(round(v, 1) * scale) / scale for v in (scene.width, scene.height))
    fig = Figure(figsize=(width / POINTS_PER_INCH, height / POINTS_PER_INCH), facecolor=WHITE)
    ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))
    ax.set_xlim(0.0, width)
    ax.set_ylim(height, 0.0)  # y down, as in SVG
    ax.set_axis_off()
    return fig, ax


def draw_scene(ax, scene: Scene) -> list:
    """The scene on ``ax``, one panel of a larger figure: data units are SVG pixels, y down, equal
    aspect, no axes drawn; returns the artists (draw_shapes)."""
    ax.set_xlim(0.0, scene.width)
    ax.set_ylim(scene.height, 0.0)
    ax.set_aspect("equal")
    ax.set_axis_off()
    return draw_shapes(ax, scene.shapes)


def draw_shapes(ax, shapes, z0: int = 0) -> list:
    """Draw shapes in order on the axes (zorder from z0 up); returns the artists. A run whose
    shapes share the first word of their ``cls`` (``bar``, ``node``, ``marker``, …) carries it
    as its gid: matplotlib's SVG names the group so."""
    flat = list(_flatten(shapes, np.zeros(2), None))
    drawn = []
    for z, ((kind, offset, clip), run) in enumerate(
        groupby(flat, key=lambda item: (type(item[0]), tuple(item[1]), item[2])), start=z0
    ):
        run_shapes = [shape for shape, _, _ in run]
        artists = _draw(ax, kind, run_shapes, np.asarray(offset))
        names = {(shape.cls or " ").split(" ")[0] for shape in run_shapes}
        for artist in artists:
            if len(names) == 1 and names != {""}:
                artist.set_gid(next(iter(names)))
            artist.set_zorder(z)
            if clip is not None:
                x, y, w, h = clip
                artist.set_clip_path(Rectangle((x, y), w, h, transform=ax.transData))
        drawn += artists
    return drawn


def write_raster(scene: Scene, path: str | Path, scale: float = 1.5) -> None:
    """Write the scene to ``path``, PNG or PDF by its suffix."""
    Path(path).write_bytes(raster_bytes(scene, Path(path).suffix.lstrip(".").lower(), scale))


def _flatten(shapes, offset: np.ndarray, clip):
    """(shape, offset, clip) of every leaf in painting order; a group adds its offset and clip."""
    for shape in shapes:
        if isinstance(shape, Group):
            yield from _flatten(shape.shapes, offset + shape.offset, shape.clip if shape.clip else clip)
        else:
            yield shape, offset, clip


def _rgba(colour: str | None, alpha: float = 1.0):
    return (0.0, 0.0, 0.0, 0.0) if colour is None else to_rgba(colour, alpha)


def _draw(ax, kind, shapes: list, offset: np.ndarray) -> list:
    """Artists drawing a run of shapes of one kind, shifted by offset."""
    if kind is Line or kind is Polyline:
        paths = [(s.ends if kind is Line else s.points) + offset for s in shapes]
        lines = LineCollection(
            paths, colors=[s.stroke for s in shapes], linewidths=[s.width for s in shapes],
            capstyle="round", joinstyle="round",
        )
        return [ax.add_collection(lines, autolim=False)]
    if kind is Polygon:
        polys = PolyCollection(
            [s.points + offset for s in shapes], closed=True, joinstyle="miter",
            facecolors=[_rgba(s.fill, s.opacity) for s in shapes],
            edgecolors=[_rgba(s.stroke) for s in shapes],
            linewidths=[s.width if s.stroke else 0.0 for s in shapes],
        )
        return [ax.add_collection(polys, autolim=False)]
    if kind is Circle:
        diameters = [2 * s.radius for s in shapes]
        circles = EllipseCollection(
            diameters, diameters, np.zeros(len(shapes)), units="xy",
            offsets=np.array([s.centre for s in shapes]) + offset, offset_transform=ax.transData,
            facecolors=[s.fill for s in shapes], edgecolors=[_rgba(s.stroke) for s in shapes],
            linewidths=[s.width if s.stroke else 0.0 for s in shapes],
        )
        return [ax.add_collection(circles, autolim=False)]
    if kind is Text:
        return [
            ax.text(*(s.at + offset), s.text, fontsize=s.size, color=s.fill, family=FONT_RASTER,
                    ha="center" if s.anchor == "middle" else "left", va="baseline")
            for s in shapes
        ]
    raise TypeError(f"no raster drawing for {kind.__name__}")
