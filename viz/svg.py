"""The SVG writer: a Scene as an SVG document (a string), numbers to 0.1 px.

Elements carry classes for machines: ``panel`` (g, id ``panel-<k>`` in panel order), ``node
specified|unspecified`` (circle), ``bar`` (line), ``arrow mode|target`` (polygon), ``solution``
(polyline or circle), ``marker source|target`` (polygon), ``label`` and ``caption`` (text),
``legend`` (g); nodes, arrows and markers name their node in ``data-node``, bars their index in
``data-edge``.
"""

from __future__ import annotations

from itertools import count
from xml.sax.saxutils import escape

import numpy as np

from zeromode.viz.layout import layout
from zeromode.viz.picture import Picture
from zeromode.viz.scene import Circle, Group, Line, Polygon, Polyline, Scene, Text
from zeromode.viz.style import FONT_SVG, WHITE


def picture_svg(picture: Picture, ids: str = "") -> str:
    """The picture laid out and written as an SVG document (``ids``: as scene_svg's)."""
    return scene_svg(layout(picture), ids)


def scene_svg(scene: Scene, ids: str = "") -> str:
    """The scene as an SVG document. ``ids`` prefixes every element id (panels, clip paths): an
    HTML page holding several pictures inline needs each clip-path id once in the page."""
    w, h = _f(scene.width), _f(scene.height)
    out = [
        (
            f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" '
            f'font-family="{FONT_SVG}">'
        ),
        f'<rect width="{w}" height="{h}" fill="{WHITE}"/>',
    ]
    clips = count()  # clip-path ids, unique in the document
    for shape in scene.shapes:
        _write(shape, out, clips, ids)
    out.append("</svg>")
    return "\n".join(out)


def _f(v: float) -> str:
    return f"{v:.1f}"


def _points(p: np.ndarray) -> str:
    return " ".join(f"{_f(a)},{_f(b)}" for a, b in p)


def _tags(cls: str | None, data=()) -> str:
    """The machine-readable attributes: class, then data-* in order."""
    attrs = ([f'class="{cls}"'] if cls else []) + [f'data-{key}="{value}"' for key, value in data]
    return "".join(a + " " for a in attrs)


def _outline(stroke: str | None, width: float) -> str:
    return f' stroke="{stroke}" stroke-width="{_f(width)}"' if stroke else ""


def _write(shape, out: list[str], clips, ids: str = "") -> None:
    if isinstance(shape, Group):
        attrs = _tags(shape.cls) + (f'id="{ids}{shape.id}" ' if shape.id else "")
        if shape.offset != (0.0, 0.0):
            attrs += f'transform="translate({_f(shape.offset[0])},{_f(shape.offset[1])})" '
        if shape.clip is not None:
            k = next(clips)
            x, y, w, h = (_f(v) for v in shape.clip)
            out.append(f'<clipPath id="{ids}clip-{k}"><rect x="{x}" y="{y}" width="{w}" height="{h}"/></clipPath>')
            attrs += f'clip-path="url(#{ids}clip-{k})" '
        out.append(f"<g {attrs.rstrip()}>" if attrs else "<g>")
        for child in shape.shapes:
            _write(child, out, clips, ids)
        out.append("</g>")
    elif isinstance(shape, Line):
        (x1, y1), (x2, y2) = shape.ends
        out.append(
            f'<line {_tags(shape.cls, shape.data)}x1="{_f(x1)}" y1="{_f(y1)}" x2="{_f(x2)}" y2="{_f(y2)}"'
            f'{_outline(shape.stroke, shape.width)} stroke-linecap="round"/>'
        )
    elif isinstance(shape, Polyline):
        out.append(
            f'<polyline {_tags(shape.cls, shape.data)}points="{_points(shape.points)}" fill="none"'
            f'{_outline(shape.stroke, shape.width)} stroke-linejoin="round" stroke-linecap="round"/>'
        )
    elif isinstance(shape, Polygon):
        opacity = f' fill-opacity="{shape.opacity:g}"' if shape.opacity < 1 else ""
        out.append(
            f'<polygon {_tags(shape.cls, shape.data)}points="{_points(shape.points)}" fill="{shape.fill or "none"}"'
            f'{opacity}{_outline(shape.stroke, shape.width)}/>'
        )
    elif isinstance(shape, Circle):
        cx, cy = shape.centre
        out.append(
            f'<circle {_tags(shape.cls, shape.data)}cx="{_f(cx)}" cy="{_f(cy)}" r="{_f(shape.radius)}" '
            f'fill="{shape.fill}"{_outline(shape.stroke, shape.width)}/>'
        )
    elif isinstance(shape, Text):
        x, y = shape.at
        anchor = ' text-anchor="middle"' if shape.anchor == "middle" else ""
        out.append(
            f'<text {_tags(shape.cls)}x="{_f(x)}" y="{_f(y)}"{anchor} font-size="{shape.size:g}" '
            f'fill="{shape.fill}">{escape(shape.text)}</text>'
        )
    else:
        raise TypeError(f"no SVG for {type(shape).__name__}")
