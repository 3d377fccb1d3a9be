"""A finite motion as an animation: animated SVG, GIF (matplotlib.animation, Pillow writer) and,
where ffmpeg is installed, MP4.

Every configuration is first aligned to the reference (solver.finite_motion.align_to: the rigid
motion that carries it nearest the reference is removed), so the frame moves and does not drift
or spin. The page is fixed for the whole motion: one scale and one window hold every
configuration. Behind the moving frame each node's trajectory is drawn, coloured by progress
from blue (start of the path) to yellow (end), as in the supplement's figures; the frame itself
keeps the paper's colours (specified nodes red, unspecified blue, bars grey, source and target
markers). 3D frames are seen in the pictures' orthographic view, with the depth cues of the
reference configuration.

Playback runs along the path and back (a ping-pong loop): ``frames`` configurations picked
evenly from the path (both ends included) give 2·frames − 2 animation frames.
"""

from __future__ import annotations

import shutil
import tempfile
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path

import numpy as np

from zeromode.solver.frame import Frame
from zeromode.solver.motion.finite_motion import align_to
from zeromode.viz.geometry import project, typical_gap, view_basis
from zeromode.viz.layout import bar_shapes, marker_shapes, node_shapes
from zeromode.viz.scene import Circle, Group, Line, Polygon, Polyline, Scene, Text
from zeromode.viz.style import (
    LEGEND_INK,
    LEGEND_PX,
    MIN_WIDTH_PX,
    PAD_PX,
    PANEL_PX,
    TITLE_INK,
    TITLE_PX,
    VIEW_3D,
    progress_colour,
)
from zeromode.viz.svg import _f, _outline, _points, _tags, scene_svg

# Each trajectory is drawn as this many polylines, each in the progress colour of its middle.
PROGRESS_BINS = 24
DEFAULT_FRAMES, DEFAULT_FPS = 40, 20.0
LEGEND_H = 34.0


@dataclass(frozen=True, eq=False)
class Animation:
    """A laid-out finite motion: the still background (title, trajectories, legend) and, for
    each animation frame, the moving shapes (bars, nodes, markers) — the same shapes in the same
    order in every frame, only their geometry changes. fps: frames per second."""

    background: Scene
    frames: tuple[tuple, ...]
    fps: float

    @property
    def seconds(self) -> float:
        return len(self.frames) / self.fps


def playback(count: int, frames: int = DEFAULT_FRAMES) -> np.ndarray:
    """Indices into a path of ``count`` configurations: ``frames`` of them evenly spread (ends
    included; all when there are fewer), then back again without repeating the ends."""
    picked = np.unique(np.round(np.linspace(0, count - 1, max(min(frames, count), 1))).astype(int))
    return np.concatenate([picked, picked[-2:0:-1]]) if len(picked) > 1 else picked


def motion_animation(
    frame: Frame,
    path,
    *,
    source=(),
    target=(),
    frames: int = DEFAULT_FRAMES,
    fps: float = DEFAULT_FPS,
    view: tuple[float, float] = VIEW_3D,
    title: str | None = None,
) -> Animation:
    """Lay out the finite motion ``path`` (T, N, d) of ``frame`` (see the module docstring)."""
    x = frame.positions
    configs = np.stack([align_to(np.asarray(c, dtype=float), x) for c in path])
    n_nodes, d = x.shape
    basis = view_basis(*view) if d == 3 else None
    unit = float(np.max(np.abs(configs))) or 1.0
    screen = np.stack([project(c / unit, basis)[0] for c in configs])  # (T, N, 2)
    _, depth = project(x / unit, basis)
    fade = (depth - depth.min()) / (np.ptp(depth) or 1.0) if basis is not None else np.zeros(n_nodes)
    lo, hi = screen.reshape(-1, 2).min(axis=0), screen.reshape(-1, 2).max(axis=0)
    extent = float(np.max(hi - lo)) or 1.0
    px = PANEL_PX / extent
    top = 40.0 if title else 10.0
    width = max((hi - lo)[0] * px + 2 * PAD_PX, MIN_WIDTH_PX)
    body_h = (hi - lo)[1] * px + 2 * PAD_PX
    left = (width - (hi - lo)[0] * px) / 2

    def to_px(p: np.ndarray) -> np.ndarray:
        return np.column_stack([left + (p[:, 0] - lo[0]) * px, top + PAD_PX + (hi[1] - p[:, 1]) * px])

    # Sizes follow the pictures' rules (viz.layout): nodes a fraction of the bar length, never so
    # big that near neighbours merge; bars and trajectories thinner than the nodes.
    ref = screen[int(np.argmin([np.linalg.norm(c - x) for c in configs]))]
    e = frame.edges
    bar_px = float(np.median(np.linalg.norm(ref[e[:, 0]] - ref[e[:, 1]], axis=1))) * px if len(e) else PANEL_PX / 4
    gap_px = typical_gap(ref) * px if n_nodes > 1 else PANEL_PX
    radius = float(np.clip(min(0.11 * bar_px, 0.32 * gap_px), 1.0, 6.5))
    bar_w = float(np.clip(0.42 * radius, 0.45, 2.4))
    is_spec = np.zeros(n_nodes, bool)
    is_spec[list(frame.specified)] = True

    shapes: list = []
    if title:
        shapes.append(Text(np.array([width / 2, 24.0]), title, TITLE_PX, TITLE_INK, "middle"))
    shapes.append(Group(tuple(_trajectories(screen, to_px, 0.45 * bar_w + 0.5)), cls="trajectories"))
    shapes.append(_legend(width, top + body_h + 4.0))
    background = Scene(width, top + body_h + LEGEND_H, tuple(shapes))
    moving = []
    for k in playback(len(configs), frames):
        p = to_px(screen[k])
        moving.append(tuple(
            bar_shapes(p, e, fade, bar_w) + node_shapes(p, is_spec, fade, radius)
            + marker_shapes(p, tuple(source), tuple(target), fade, radius)
        ))
    return Animation(background, tuple(moving), float(fps))


def _trajectories(screen: np.ndarray, to_px, width: float) -> list:
    """Each node's path (screen (T, N, 2)) as PROGRESS_BINS polylines coloured by progress."""
    count = len(screen)
    if count < 2:
        return []
    edges = np.unique(np.round(np.linspace(0, count - 1, min(PROGRESS_BINS, count - 1) + 1)).astype(int))
    out = []
    for a, b in pairwise(edges):
        colour = progress_colour(0.5 * (a + b) / (count - 1))
        out += [Polyline(to_px(screen[a : b + 1, i]), colour, width, "trajectory") for i in range(screen.shape[1])]
    return out


def _legend(width: float, y: float) -> Group:
    """"trajectory: start ▭▭▭▭ end", the progress ramp of the trajectories, centred at height y."""
    strip, cells = 120.0, 12
    x0 = (width - strip) / 2
    label = "trajectory: start"  # right-aligned before the strip (12 px text averages 6.6 px a character)
    shapes: list = [Text(np.array([x0 - 8 - 6.6 * len(label), y + 14]), label, LEGEND_PX, LEGEND_INK)]
    for c in range(cells):
        a = x0 + strip * c / cells
        box = np.array([[a, y + 4], [a + strip / cells + 0.5, y + 4], [a + strip / cells + 0.5, y + 16], [a, y + 16]])
        shapes.append(Polygon(box, progress_colour((c + 0.5) / cells)))
    shapes.append(Text(np.array([x0 + strip + 8, y + 14]), "end", LEGEND_PX, LEGEND_INK))
    return Group(tuple(shapes), cls="legend")


# ----------------------------------------------------------------------------- writers


def animation_svg(animation: Animation) -> str:
    """An SVG document that plays the motion by itself (SMIL ``<animate>``, linear between
    frames, looping): the background as still shapes, then every moving shape once, each
    geometric attribute animated through its values in the frames (len(frames) + 1 values:
    the loop closes on the first frame)."""
    still = scene_svg(animation.background)
    seconds = f"{animation.seconds:g}s"
    out = [still[: still.rindex("</svg>")], '<g class="motion">']
    for k, shape in enumerate(animation.frames[0]):
        track = [f[k] for f in animation.frames] + [animation.frames[0][k]]
        out.append(_animated(shape, track, seconds))
    out.append("</g>\n</svg>")
    return "\n".join(out)


def _animate(attribute: str, values, seconds: str) -> str:
    return (
        f'<animate attributeName="{attribute}" values="{";".join(values)}" dur="{seconds}" '
        'repeatCount="indefinite"/>'
    )


def _animated(shape, track: list, seconds: str) -> str:
    """One moving shape as an SVG element whose geometry follows ``track`` (its shapes, one per frame)."""
    if isinstance(shape, Line):
        attrs = {name: [_f(s.ends[r, c]) for s in track] for name, (r, c) in
                 (("x1", (0, 0)), ("y1", (0, 1)), ("x2", (1, 0)), ("y2", (1, 1)))}
        first = " ".join(f'{name}="{values[0]}"' for name, values in attrs.items())
        return (
            f'<line {_tags(shape.cls, shape.data)}{first}{_outline(shape.stroke, shape.width)} stroke-linecap="round">'
            + "".join(_animate(name, values, seconds) for name, values in attrs.items()) + "</line>"
        )
    if isinstance(shape, Circle):
        cx, cy = [_f(s.centre[0]) for s in track], [_f(s.centre[1]) for s in track]
        return (
            f'<circle {_tags(shape.cls, shape.data)}cx="{cx[0]}" cy="{cy[0]}" r="{_f(shape.radius)}" '
            f'fill="{shape.fill}"{_outline(shape.stroke, shape.width)}>'
            + _animate("cx", cx, seconds) + _animate("cy", cy, seconds) + "</circle>"
        )
    if isinstance(shape, Polygon):
        points = [_points(s.points) for s in track]
        return (
            f'<polygon {_tags(shape.cls, shape.data)}points="{points[0]}" fill="{shape.fill or "none"}"'
            f'{_outline(shape.stroke, shape.width)}>' + _animate("points", points, seconds) + "</polygon>"
        )
    raise TypeError(f"no animated SVG for {type(shape).__name__}")


def video_formats() -> tuple[str, ...]:
    """The video formats this machine writes: GIF always (Pillow), MP4 when ffmpeg is on PATH."""
    return ("gif", "mp4") if shutil.which("ffmpeg") else ("gif",)


def animation_video(animation: Animation, fmt: str = "gif", scale: float = 1.0) -> bytes:
    """The animation as a GIF (matplotlib.animation.PillowWriter) or an MP4 (FFMpegWriter, only
    where ffmpeg is installed: see video_formats), ``scale`` pixels per SVG pixel."""
    from matplotlib.animation import FFMpegWriter, FuncAnimation, PillowWriter

    from zeromode.viz.raster import POINTS_PER_INCH, draw_shapes, scene_figure

    if fmt not in video_formats():
        raise ValueError(f"cannot write {fmt!r} here; formats: {video_formats()}")
    fig, ax = scene_figure(animation.background, scale)
    draw_shapes(ax, animation.background.shapes)
    z0 = len(animation.background.shapes) * 100  # moving shapes paint over the still ones
    moving: list = []

    def show(k: int) -> list:
        for artist in moving:
            artist.remove()
        moving[:] = draw_shapes(ax, animation.frames[k], z0)
        return moving

    player = FuncAnimation(fig, show, frames=len(animation.frames), blit=False, repeat=False)
    writer = PillowWriter(fps=animation.fps) if fmt == "gif" else FFMpegWriter(fps=animation.fps)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / f"motion.{fmt}"
        player.save(out, writer=writer, dpi=POINTS_PER_INCH * scale)
        return out.read_bytes()
