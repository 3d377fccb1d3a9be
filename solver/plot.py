"""Pictures of frames in the paper's visual language, written as SVG by hand.

The colours follow the paper's figures (Figs. 1f, 2, 3, 5): specified nodes V_S red, unspecified
nodes V_U blue, bars grey, requested motions u_S as hollow green arrows, designed zero modes as
solid green arrows (light to dark green for several modes), and the solution space of an
unspecified node joined to every specified node (Eqs. 4–6) in light blue — a curve for a conic
(m = dim N(Ã) = 2), a wireframe for a quadric surface in 3D (m = 3), a point cloud for position
sets that fill a region, dots for isolated points (m ≤ 1).  With several motions the solution
spaces go from light to dark blue, as in the paper's Fig. 5.

3D frames are drawn in an orthographic view — by default azimuth −60°, elevation 25°: the
isometric view from the (1, −1, 1) octant turned by 15° and lowered by 10° — with depth cues:
farther nodes, bars and arrows are lighter and smaller.  Arrows share one length scale, so a
designed mode and the motion it was asked to realise coincide on the specified nodes; the
longest arrow is 20 % of the frame's size, capped at 1.2 typical gaps between the nodes that
carry arrows so that neighbouring arrows do not run into each other.

Several configurations of one frame (a lattice's contracted and expanded states, say) are drawn
at one common scale in a row, or in a column when the panels are wide, whichever picture is
nearer 4:3; a row is kept within about 1100 px so that its text stays legible page-wide.  Frames
of more than 200 nodes get larger panels, smaller nodes and thinner bars (nodes are kept below a
third of the gap to their nearest neighbour), and mode arrows on a spread subsample only — the
node nearest the centre of each cell of a 10-cell-wide grid — unless the caller names the nodes.

Everything here is numpy + string formatting: no plotting library, no web imports.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from xml.sax.saxutils import escape

import numpy as np
from scipy.spatial import cKDTree

from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame, check_positions
from zeromode.solver.solution_space import (
    CONSTRAINT_ATOL,
    SolutionSpace,
    real_roots_on_lines,
    solution_space,
)

SPECIFIED = ("#d7301f", "#8c1d12")  # fill, outline
UNSPECIFIED = ("#2c7fb8", "#1b4f72")
BAR = "#a3a3a3"
GREEN_LIGHT, GREEN_DARK, GREEN = "#74c476", "#1b7837", "#31a354"
BLUE_LIGHT, BLUE_DARK = "#9ecae1", "#3182bd"
SOURCE, TARGET = "#6a3d9a", "#ff7f00"

# Longest arrow as a fraction of the frame's size, and at most ARROW_GAPS typical gaps between
# the nodes that carry arrows: the median distance to the ARROW_NEIGHBOUR-th nearest of them
# (not the nearest: lattices have close pairs of nodes, whose arrows point apart).
ARROW_FRACTION, ARROW_GAPS, ARROW_NEIGHBOUR = 0.20, 1.2, 3
# The view of 3D frames: azimuth about z and elevation above the xy-plane, in degrees.
VIEW_3D = (-60.0, 25.0)
# How much lighter (mixed with white) and smaller the farthest element is than the nearest.
DEPTH_FADE, DEPTH_SHRINK = 0.45, 0.3
PANEL_PX, PAD_PX, GAP_PX, MIN_WIDTH_PX, ROW_PX = 440.0, 26.0, 18.0, 520.0, 1100.0
# Panels side by side or stacked, whichever picture's width : height is nearer ASPECT.
ASPECT = 4 / 3
# Frames with more nodes carry mode arrows on a spread subsample (ARROW_GRID cells across) and
# get panels up to BIG_PANEL times larger.
MAX_ARROW_NODES, ARROW_GRID, BIG_PANEL = 200, 10, 1.6
# Solution-space geometry is computed inside the nodes' bounding box (in view coordinates) grown
# by this fraction of its largest screen side on every side — larger than any panel, whose border
# then clips it — and, in depth, by DEPTH_GROWTH of it, so curves leave the picture sideways.
WINDOW_GROWTH, DEPTH_GROWTH = 0.6, 3.0


@dataclass(frozen=True, eq=False)
class Window:
    """The box lo ≤ axes·x ≤ hi: axes (d × d) orthonormal rows, the first two spanning the screen."""

    axes: np.ndarray
    lo: np.ndarray
    hi: np.ndarray

    @classmethod
    def around(cls, x: np.ndarray, axes: np.ndarray | None = None) -> Window:
        """The box around points x (n × d) grown by WINDOW_GROWTH (DEPTH_GROWTH in depth)."""
        axes = np.eye(x.shape[1]) if axes is None else axes
        y = x @ axes.T
        lo, hi = y.min(axis=0), y.max(axis=0)
        side = max(float(np.max((hi - lo)[:2])), float(np.max(np.abs(y)))) or 1.0
        grow = np.full(x.shape[1], WINDOW_GROWTH * side)
        grow[2:] = DEPTH_GROWTH * side
        return cls(axes, lo - grow, hi + grow)

    def contains(self, x: np.ndarray) -> np.ndarray:
        y = x @ self.axes.T
        return np.all((y >= self.lo) & (y <= self.hi), axis=1)

    @property
    def screen_size(self) -> float:
        return float(np.linalg.norm((self.hi - self.lo)[:2]))


@dataclass(frozen=True, eq=False)
class SolutionDrawing:
    """The positions x_U of one solution space, ready to draw (caller's coordinates, d columns).

    curves: ordered branches of a conic, each (n_i, d) with consecutive points close together;
    points: (n, d) isolated solutions (m ≤ 1) or a cloud on a quadric surface (m ≥ 3).
    Every point satisfies all k bar constraints (x_Si − x_U)·(u_Si − u_U) = 0 for some u_U.
    """

    kind: str
    curves: tuple[np.ndarray, ...]
    points: np.ndarray


def solution_drawing(
    positions, motions, window: Window | None = None, seed: int = 0, cloud: int = 700
) -> SolutionDrawing:
    """Trace the solution space of x_S, u_S (k × d each) inside the window (default: around x_S).

    A conic (m = 2) is traced exactly: a fan of lines through a point c of α-space is cut with
    the conic α̃ᵀQα̃ = 0; the larger root t(θ) of each line at angle θ ∈ [0, 2π) sweeps every
    point of the conic once (the line at θ + π is the line at θ reversed), and the sweep is
    refined by bisection until consecutive positions are close.  A quadric surface in 3D
    (m = 3) becomes a wireframe of such conics: its sections by horizontal planes z = h
    (parallels) and by vertical planes through its centre (meridians).  Position sets that
    fill a region (m = 3 in 2D, m ≥ 4) become a point cloud from ``SolutionSpace.sample``;
    isolated solutions (m ≤ 1) their points.  Raises DomainError ``no_solution`` when
    b ∉ R(Ã) (nothing to draw).
    """
    space = solution_space(positions, motions)
    if window is None:
        window = Window.around(space.positions)
    empty = np.zeros((0, space.dim))
    if space.nullity == 2:
        return SolutionDrawing(space.kind, _trace_conic(space, space.quadric_n, lambda s: s, window), empty)
    rng = np.random.default_rng(seed)
    x_u, _ = space.sample(4 * cloud if space.nullity > 2 else 8, rng)
    x_u = x_u[window.contains(x_u)]
    linear = space.w_tilde_n[: space.dim, : space.nullity]  # x'_U = P α + p0 (normalised)
    if space.nullity == 3 and space.dim == 3 and len(x_u) and np.linalg.cond(linear) < 1e8:
        return SolutionDrawing(space.kind, _wireframe(space, x_u, window), empty)
    return SolutionDrawing(space.kind, (), x_u[:cloud])


def _wireframe(space: SolutionSpace, cloud: np.ndarray, window: Window, parallels: int = 7, meridians: int = 8):
    """Plane sections of a quadric surface of positions (d = m = 3), each traced as a conic.

    A plane n·x = h of position space is, in α-space, the plane (Pᵀn)·α = (h − n·x0)/L − n·p0
    (x' = (x − x0)/L = Pα + p0 the normalised positions); with α = α0 + E s (E an orthonormal
    basis of that plane, α0 its point nearest the origin) the section is the conic
    s̃ᵀ(TᵀQT)s̃ = 0, T = [[E, α0], [0, 1]].  Parallels are spread over the cloud's height;
    meridians pass through the quadric's centre (the cloud's centroid when it has none).
    """
    m = space.nullity
    p, p0 = space.w_tilde_n[:3, :m], space.w_tilde_n[:3, m]
    q = space.quadric_n
    a, b = q[:m, :m], q[:m, m]
    centre = space.norm.positions_out(p @ np.linalg.solve(a, -b) + p0) if np.linalg.cond(a) < 1e8 else cloud.mean(axis=0)
    z_lo, z_hi = cloud[:, 2].min(), cloud[:, 2].max()
    planes = [(np.array([0.0, 0.0, 1.0]), z_lo + (z_hi - z_lo) * (i + 0.5) / parallels) for i in range(parallels)]
    for j in range(meridians):
        n = np.array([np.cos(np.pi * j / meridians), np.sin(np.pi * j / meridians), 0.0])
        planes.append((n, float(n @ centre)))
    curves: list[np.ndarray] = []
    for n, h in planes:
        # In normalised positions the plane is n·x' = (h − n·x0)/L; pulled back to α-space.
        nu = p.T @ n
        h_alpha = (h - n @ space.norm.x0) / space.norm.length - n @ p0
        alpha0 = nu * h_alpha / (nu @ nu)
        e = np.linalg.svd(nu[None, :])[2][1:].T  # m × 2, orthonormal, ⟂ ν
        t = np.zeros((m + 1, 3))
        t[:m, :2], t[:m, 2], t[m, 2] = e, alpha0, 1.0
        curves += _trace_conic(space, t.T @ q @ t, lambda s, e=e, a0=alpha0: a0 + s @ e.T, window)
    return tuple(curves)


def _trace_conic(space: SolutionSpace, conic: np.ndarray, to_alpha, window: Window):
    """Branches of a conic s̃ᵀ conic s̃ = 0 (s ∈ R², α = to_alpha(s)) inside the window, as ordered
    (n, d) polylines of positions; points failing the bar constraints are dropped."""
    scale = float(np.max(np.abs(conic))) or 1.0
    # The fan's centre must lie off the conic, or half the roots would sit at the centre itself.
    centre = next(
        (c for c in np.array([[0.0, 0.0], [0.31, 0.17], [-0.23, 0.41]])
         if abs(np.append(c, 1.0) @ conic @ np.append(c, 1.0)) > 1e-6 * scale),
        np.array([0.31, 0.17]),
    )
    step = window.screen_size / 320  # target spacing of consecutive points

    def evaluate(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        delta = np.column_stack([np.cos(np.pi * s), np.sin(np.pi * s)])
        t, ok = real_roots_on_lines(conic, np.broadcast_to(centre, delta.shape), delta)
        t_big = np.where(ok, t, -np.inf).max(axis=1)
        real = np.isfinite(t_big)
        x_u, u_u = space.points(to_alpha(centre + np.where(real, t_big, 0.0)[:, None] * delta))
        on = real & (np.max(np.abs(space.residuals(x_u, u_u)), axis=1) <= CONSTRAINT_ATOL)
        return x_u, on

    s = np.linspace(0.0, 2.0, 721)
    x, on = evaluate(s)
    for _ in range(40):
        inside = on & window.contains(x)
        gap = np.linalg.norm(np.diff(x, axis=0), axis=1)
        # Refine where the curve moves fast, and bisect towards tangencies (on/off boundaries),
        # where the arc must end on the tangent point to meet its partner arc.
        need = ((inside[:-1] | inside[1:]) & on[:-1] & on[1:] & (gap > step)) | (on[:-1] != on[1:])
        need &= np.diff(s) > 1e-12
        if not need.any():
            break
        mid = 0.5 * (s[:-1] + s[1:])[need]
        x_mid, on_mid = evaluate(mid)
        order = np.argsort(np.concatenate([s, mid]), kind="stable")
        s = np.concatenate([s, mid])[order]
        x = np.concatenate([x, x_mid])[order]
        on = np.concatenate([on, on_mid])[order]
    inside = on & window.contains(x)
    gap = np.r_[np.linalg.norm(np.diff(x, axis=0), axis=1), np.inf]
    pieces, run = [], [0] if inside[0] else []
    for i in range(1, len(s)):
        if inside[i] and inside[i - 1] and gap[i - 1] <= 4 * step:
            run.append(i)
            continue
        if len(run) > 1:
            pieces.append(x[run])
        run = [i] if inside[i] else []
    if len(run) > 1:
        pieces.append(x[run])
    return _stitch(pieces, 4 * step)


def _stitch(pieces: list[np.ndarray], tol: float) -> tuple[np.ndarray, ...]:
    """Join polylines whose ends meet (arcs of one branch split at a tangency or a sweep seam)."""
    pieces = list(pieces)
    i = 0
    while i < len(pieces):
        for j in range(i + 1, len(pieces)):
            joined = _join(pieces[i], pieces[j], tol)
            if joined is not None:
                pieces[i] = joined
                del pieces[j]
                break
        else:
            i += 1
    return tuple(pieces)


def _join(a: np.ndarray, b: np.ndarray, tol: float) -> np.ndarray | None:
    for a2, b2 in ((a, b), (a, b[::-1]), (a[::-1], b), (a[::-1], b[::-1])):
        if np.linalg.norm(a2[-1] - b2[0]) <= tol:
            return np.vstack([a2, b2])
    return None


# --------------------------------------------------------------------------------------------
# Projection and colour


def view_basis(azimuth: float, elevation: float) -> np.ndarray:
    """Rows: screen right, screen up, and the direction towards the viewer (3 × 3, orthonormal)."""
    a, e = np.radians(azimuth), np.radians(elevation)
    right = np.array([-np.sin(a), np.cos(a), 0.0])
    toward = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    return np.vstack([right, np.cross(toward, right), toward])


def _project(x: np.ndarray, basis: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Screen coordinates (n, 2) (y up) and depth (n,) (larger = farther; 0 in 2D)."""
    if basis is None:
        return x, np.zeros(len(x))
    return x @ basis[:2].T, -(x @ basis[2])


def _mix_white(colour: str, f: float) -> str:
    """colour mixed with a fraction f ∈ [0, 1] of white (in steps of 1/128: a few distinct strings)."""
    return _mixed(colour, round(128 * min(max(float(f), 0.0), 1.0)))


@lru_cache(maxsize=4096)
def _mixed(colour: str, step: int) -> str:
    rgb = [int(colour[i : i + 2], 16) for i in (1, 3, 5)]
    return "#" + "".join(f"{round(c + (255 - c) * step / 128):02x}" for c in rgb)


def _ramp(light: str, dark: str, n: int, single: str) -> list[str]:
    """n colours from light to dark (the paper's light/dark pairs); ``single`` when n = 1."""
    if n == 1:
        return [single]
    a = np.array([int(light[i : i + 2], 16) for i in (1, 3, 5)], dtype=float)
    b = np.array([int(dark[i : i + 2], 16) for i in (1, 3, 5)], dtype=float)
    return ["#" + "".join(f"{round(v):02x}" for v in a + (b - a) * k / (n - 1)) for k in range(n)]


def _f(v: float) -> str:
    return f"{v:.1f}"


def _points_attr(p: np.ndarray) -> str:
    return " ".join(f"{_f(a)},{_f(b)}" for a, b in p)


def _arrow_polygon(base: np.ndarray, vec: np.ndarray, shaft: float, head_w: float, head_l: float) -> np.ndarray:
    """The 7 corners of an arrow from base along vec (screen px): shaft half-width, head size."""
    length = float(np.hypot(*vec))
    e = vec / length
    n = np.array([-e[1], e[0]])
    head_l = min(head_l, 0.55 * length)
    neck = base + e * (length - head_l)
    return np.array([
        base + n * shaft, neck + n * shaft, neck + n * head_w, base + vec,
        neck - n * head_w, neck - n * shaft, base - n * shaft,
    ])


# --------------------------------------------------------------------------------------------
# Rendering


def render_svg(
    positions,
    edges,
    specified: Sequence[int] = (),
    modes=None,
    targets=None,
    solution: Sequence[SolutionDrawing] = (),
    configurations: Sequence = (),
    labels: Sequence[str] = (),
    source: Sequence[int] = (),
    target_nodes: Sequence[int] = (),
    title: str | None = None,
    view: tuple[float, float] = VIEW_3D,
    captions: Sequence[str] = (),
    frame_panel: int = 0,
    arrow_nodes: Sequence[int] | None = None,
) -> str:
    """The picture of a frame as an SVG document (a string).

    positions (N, d), edges (N_B, 2), specified: indices of V_S; modes (M, N, d) zero modes drawn
    as solid arrows on ``arrow_nodes`` (default: every node, or ``spread_subsample`` of a frame
    with more than MAX_ARROW_NODES nodes); targets (M', k, d) requested motions u_S drawn as
    hollow arrows, rows in the order of ``specified`` (a zero row draws nothing); solution: one
    SolutionDrawing per motion (light to dark blue); configurations: further (N, d) positions of
    the same bars, drawn without arrows at one common scale beside the frame, whose panel is
    number ``frame_panel`` (0: first) — in a row, or in a column when that makes the picture
    nearer to 4:3 (wide panels); labels / captions: text above / below each panel, in panel
    order; source / target_nodes: node indices marked with a purple square / an orange diamond
    (allosteric frames).  Inputs are trusted: ``figure_svg`` validates raw requests.

    Elements carry classes for machines: ``panel`` (g, id ``panel-<k>`` in panel order), ``node
    specified|unspecified`` (circle), ``bar`` (line), ``arrow mode|target`` (polygon),
    ``solution`` (polyline or circle), ``marker source|target`` (polygon), ``label`` and
    ``caption`` (text), ``legend`` (anything in the legend); nodes, arrows and markers name their
    node in ``data-node``, bars their index in ``data-edge``.
    """
    x = np.asarray(positions, dtype=float)
    n_nodes, d = x.shape
    e = np.asarray(edges, dtype=int).reshape(-1, 2)
    spec = np.asarray(specified, dtype=int)
    is_spec = np.zeros(n_nodes, bool)
    is_spec[spec] = True
    modes = np.zeros((0, n_nodes, d)) if modes is None else np.asarray(modes, dtype=float)
    targets = np.zeros((0, len(spec), d)) if targets is None else np.asarray(targets, dtype=float)
    basis = view_basis(*view) if d == 3 else None

    # One map from data to screen for every panel: unit-scaled first so that no coordinate can
    # overflow, then projected; arrows share one length scale.
    panels = [np.asarray(c, dtype=float) for c in configurations]
    panels.insert(frame_panel, x)
    unit = max(float(np.max(np.abs(p))) for p in panels) or 1.0
    screen = [_project(p / unit, basis) for p in panels]
    main = screen[frame_panel][0]
    # Unit-scaled coordinates are O(1): a smaller size means a single point (or one spot).
    size = max(float(np.max(np.ptp(s, axis=0))) for s, _ in screen)
    size = size if size > 1e-9 else 1.0
    bar_len = float(np.median(np.linalg.norm(x[e[:, 0]] / unit - x[e[:, 1]] / unit, axis=1))) if len(e) else size
    if arrow_nodes is None:
        arrow_nodes = np.arange(n_nodes) if n_nodes <= MAX_ARROW_NODES else spread_subsample(main)
    arrow_nodes = np.asarray(arrow_nodes, dtype=int)
    arrows = np.concatenate([modes[:, arrow_nodes].reshape(-1, d), targets.reshape(-1, d)])
    amax = float(np.max(np.abs(arrows), initial=0.0)) or 1.0  # arrows have their own units
    longest = float(np.max(np.linalg.norm(arrows / amax, axis=1), initial=0.0))
    # Neighbouring arrows should not run into each other: the cap is measured between the nodes
    # that carry arrows (a subsample of a big lattice is sparser than its bars), in space, where
    # the arrows are (a projection brings nodes at different depths together).
    spacing = _typical_gap(x[arrow_nodes] / unit, ARROW_NEIGHBOUR) if len(arrow_nodes) > 1 else bar_len
    arrow_len = min(ARROW_FRACTION * size, ARROW_GAPS * spacing) if longest > 0 else 0.0
    arrow_scale = arrow_len / longest / amax if longest > 0 else 0.0
    mode_vec = [_project(m * arrow_scale, basis)[0][arrow_nodes] for m in modes]
    target_vec = [_project(t * arrow_scale, basis)[0] for t in targets]
    depth_all = np.concatenate([dp for _, dp in screen])
    d_lo, d_span = float(depth_all.min()), float(np.ptp(depth_all)) or 1.0

    # Panel boxes in screen-data units (nodes, plus arrow tips for the frame's panel).
    boxes = []
    for k, (s, _) in enumerate(screen):
        tips = [s[arrow_nodes] + v for v in mode_vec] + [s[spec] + v for v in target_vec]
        allp = np.concatenate([s] + (tips if k == frame_panel else []))
        boxes.append((allp.min(axis=0), allp.max(axis=0)))
    extent = max(max(float(np.max(hi - lo)) for lo, hi in boxes), 0.3 * size)
    # A flat frame (collinear nodes, a single node) still gets a panel of sensible proportions.
    boxes = [(np.minimum(lo, 0.5 * (lo + hi) - 0.15 * extent), np.maximum(hi, 0.5 * (lo + hi) + 0.15 * extent))
             for lo, hi in boxes]
    top = 40.0 if title else 10.0
    label_h = 20.0 if any(labels) else 0.0
    caption_h = 18.0 if any(captions) else 0.0
    n_panels = len(panels)
    spans = np.array([hi - lo for lo, hi in boxes])  # (panels, 2) in screen-data units

    def sizes(px: float):
        """Panel widths and heights in pixels, and the (width, height) of a row and of a column."""
        w, h = spans[:, 0] * px + 2 * PAD_PX, spans[:, 1] * px + 2 * PAD_PX
        row = (w.sum() + GAP_PX * (n_panels - 1), h.max() + label_h + caption_h)
        col = (w.max(), h.sum() + n_panels * (label_h + caption_h) + GAP_PX * (n_panels - 1))
        return w, h, row, col

    # Big frames get bigger panels (up to BIG_PANEL times) so that their bars stay apart.
    big = float(np.clip(np.sqrt(n_nodes / MAX_ARROW_NODES), 1.0, BIG_PANEL))
    px = PANEL_PX * big / extent  # pixels per unit
    _, _, (row_w, row_h), (col_w, col_h) = sizes(px)
    column = n_panels > 1 and abs(np.log(col_w / col_h / ASPECT)) < abs(np.log(row_w / row_h / ASPECT))
    if not column:
        # A row is at most ROW_PX (times big) wide: its text must stay legible when the whole
        # picture is shown page-wide.
        px = min(px, (ROW_PX * big - 2 * PAD_PX * n_panels - GAP_PX * (n_panels - 1)) / float(spans[:, 0].sum()))
    widths, heights, (row_w, row_h), (col_w, col_h) = sizes(px)
    body_w, body_h = (col_w, col_h) if column else (row_w, row_h)
    # Wide enough for the title too (16 px Helvetica averages under 9 px a character).
    width = max(body_w + 20.0, MIN_WIDTH_PX, 9.0 * len(title or "") + 40.0)

    gap_px = _typical_gap(main) * px if n_nodes > 1 else PANEL_PX
    bar_px = bar_len * px if len(e) else PANEL_PX / (3 * np.sqrt(n_nodes))
    # Nodes are a fraction of the bar length, but never so big that near neighbours merge.
    radius = float(np.clip(min(0.11 * bar_px if len(e) else bar_px, 0.32 * gap_px), 1.0, 6.5))
    bar_w = float(np.clip(0.42 * radius, 0.45, 2.4))
    # Arrow strokes follow the nodes, but a sparse set of long arrows on a dense frame is thicker.
    shaft = max(0.9, 0.3 * radius, 0.018 * arrow_len * px)
    head_w, head_l = max(3.6, 0.95 * radius, 0.06 * arrow_len * px), max(8.0, 2.0 * radius, 0.13 * arrow_len * px)

    # Each panel's drawing area (x, y, w, h) in pixels, and its clip box for the solution space.
    cells, clips = [], []
    left, y = (width - body_w) / 2, top
    for k, (w, h) in enumerate(zip(widths, heights)):
        if column:
            cells.append(((width - w) / 2, y + label_h, w, h))
            clips.append((0.0, y + label_h, width, h))
            y += label_h + h + caption_h + GAP_PX
        else:
            cells.append((left, top + label_h + (row_h - label_h - caption_h - h) / 2, w, h))
            lo_x = left - GAP_PX / 2 if k else 0.0
            hi_x = left + w + GAP_PX / 2 if k < n_panels - 1 else width
            clips.append((lo_x, top + label_h, hi_x - lo_x, row_h - label_h - caption_h))
            left += w + GAP_PX

    mode_colours = _ramp(GREEN_LIGHT, GREEN_DARK, max(len(modes), 1), GREEN)
    target_colours = _ramp(GREEN_LIGHT, GREEN_DARK, max(len(targets), 1), GREEN)
    space_colours = _ramp(BLUE_LIGHT, BLUE_DARK, max(len(solution), 1), BLUE_LIGHT)
    legend, legend_h = _legend(
        is_spec, len(e) > 0, modes, targets, solution, mode_colours, target_colours, space_colours,
        bool(len(source)), bool(len(target_nodes)), width, top + body_h + 6.0,
    )
    height = top + body_h + legend_h + 8.0

    out = [
        (
            f'<svg xmlns="http://www.w3.org/2000/svg" width="{_f(width)}" height="{_f(height)}" '
            f'viewBox="0 0 {_f(width)} {_f(height)}" font-family="Helvetica, Arial, sans-serif">'
        ),
        f'<rect width="{_f(width)}" height="{_f(height)}" fill="#ffffff"/>',
    ]
    if title:
        out.append(
            f'<text x="{_f(width / 2)}" y="24" text-anchor="middle" font-size="16" fill="#222">{escape(title)}</text>'
        )
    for k, ((s, depth), (lo, hi), (x0, y0, w, h)) in enumerate(zip(screen, boxes, cells)):
        # Data (screen units, y up) → pixels (y down) inside this panel.
        # Clipped far outside the picture so that every coordinate written is a plain number.
        to_px = lambda p, lo=lo, hi=hi, x0=x0, y0=y0: np.clip(
            np.column_stack([x0 + PAD_PX + (p[:, 0] - lo[0]) * px, y0 + PAD_PX + (hi[1] - p[:, 1]) * px]),
            -1e5, 1e5,
        )
        fade = np.clip((depth - d_lo) / d_span, 0, 1) if basis is not None else np.zeros(n_nodes)
        out.append(f'<g class="panel" id="panel-{k}">')
        cx, cy, cw, ch = clips[k]
        out.append(
            # The solution space may run up to the neighbouring panels (or the picture's edge).
            f'<clipPath id="clip-{k}"><rect x="{_f(cx)}" y="{_f(cy)}" width="{_f(cw)}" height="{_f(ch)}"/></clipPath>'
        )
        if k < len(labels) and labels[k]:
            # Over the panel's box (in a row: over the tallest panel, so labels line up).
            above = y0 if column else top + label_h
            out.append(
                f'<text class="label" x="{_f(x0 + w / 2)}" y="{_f(above - 6)}" text-anchor="middle" font-size="13" '
                f'fill="#333">{escape(labels[k])}</text>'
            )
        if k < len(captions) and captions[k]:
            # Under the panel's box (in a row: under the tallest panel, so captions line up).
            below = y0 + h if column else top + row_h - caption_h
            out.append(
                f'<text class="caption" x="{_f(x0 + w / 2)}" y="{_f(below + 12)}" text-anchor="middle" '
                f'font-size="12" fill="#555">{escape(captions[k])}</text>'
            )
        if k == frame_panel:
            out += _solution_layer(solution, space_colours, unit, basis, to_px, d_lo, d_span, radius, k)
        p = to_px(s)
        out += _bar_layer(p, e, fade, bar_w)
        if k == frame_panel:
            for t, colour in zip(target_vec, target_colours):
                out += _arrow_layer(p[spec], t * np.array([px, -px]), fade[spec], colour,
                                    shaft + 2.2, head_w + 3.0, head_l + 3.5, True, spec)
            for m, colour in zip(mode_vec, mode_colours):
                out += _arrow_layer(p[arrow_nodes], m * np.array([px, -px]), fade[arrow_nodes], colour,
                                    shaft, head_w, head_l, False, arrow_nodes)
        out += _node_layer(p, is_spec, fade, radius)
        out += _marker_layer(p, source, target_nodes, fade, radius)
        out.append("</g>")
    out += legend
    out.append("</svg>")
    return "\n".join(out)


def spread_subsample(points: np.ndarray, cells: int = ARROW_GRID) -> np.ndarray:
    """Indices (sorted) of a spread subset of points (n, 2): square cells, ``cells`` across the
    longer side of the points' bounding box; in each occupied cell the point nearest its centre."""
    lo = points.min(axis=0)
    side = float(np.max(np.ptp(points, axis=0))) / cells or 1.0
    cell = np.minimum(np.floor((points - lo) / side), cells - 1)
    dist = np.linalg.norm(points - (lo + (cell + 0.5) * side), axis=1)
    key = cell[:, 0] * cells + cell[:, 1]
    order = np.lexsort((dist, key))
    first = np.r_[True, key[order][1:] != key[order][:-1]]
    return np.sort(order[first])


def _typical_gap(points: np.ndarray, k: int = 1) -> float:
    """Median distance from a point (n ≥ 2, any dimension) to its k-th nearest other point
    (the farthest one when there are fewer), ignoring coincident points."""
    k = min(k, len(points) - 1)
    dist, _ = cKDTree(points).query(points, k=k + 1)
    gap = dist[:, k]
    gap = gap[gap > 0]
    return float(np.median(gap)) if len(gap) else 0.0


def _order(fade: np.ndarray) -> np.ndarray:
    """Painter's order: farthest first."""
    return np.argsort(-fade, kind="stable")


def _solution_layer(solution, colours, unit, basis, to_px, d_lo, d_span, radius, k) -> list[str]:
    """Conic branches as polylines — in 3D cut into short runs, each shaded by its depth — and
    clouds or isolated solutions as dots; clipped to the panel."""
    out = [f'<g clip-path="url(#clip-{k})" fill="none" stroke-linejoin="round" stroke-linecap="round">']
    for drawing, colour in zip(solution, colours):
        wire = drawing.kind != "conic"
        runs = []  # (fade, pixel polyline)
        for curve in drawing.curves:
            s, depth = _project(curve / unit, basis)
            p = to_px(s)
            if basis is None:
                runs.append((0.0, p))
                continue
            fade = np.clip((depth - d_lo) / d_span, 0, 1)
            for a in range(0, len(p) - 1, 10):
                runs.append((float(np.mean(fade[a : a + 11])), p[a : a + 11]))
        for f, p in sorted(runs, key=lambda r: -r[0]):
            out.append(
                f'<polyline class="solution" points="{_points_attr(p)}" stroke="{_mix_white(colour, 0.35 * f)}" '
                f'stroke-width="{_f((1.3 if wire else 2.6) * (1 - DEPTH_SHRINK * f))}"/>'
            )
        if len(drawing.points):
            s, depth = _project(drawing.points / unit, basis)
            fade = np.clip((depth - d_lo) / d_span, 0, 1) if basis is not None else np.zeros(len(s))
            r = max(1.2, 0.32 * radius) if drawing.kind.startswith("quadric") else 0.8 * radius
            p = to_px(s)
            for i in _order(fade):
                out.append(
                    f'<circle class="solution" cx="{_f(p[i, 0])}" cy="{_f(p[i, 1])}" '
                    f'r="{_f(r * (1 - DEPTH_SHRINK * fade[i]))}" fill="{_mix_white(colour, 0.5 * fade[i])}" stroke="none"/>'
                )
    out.append("</g>")
    return out


def _bar_layer(p, e, fade, width) -> list[str]:
    bar_fade = 0.5 * (fade[e[:, 0]] + fade[e[:, 1]]) if len(e) else np.zeros(0)
    return [
        f'<line class="bar" data-edge="{b}" x1="{_f(p[i, 0])}" y1="{_f(p[i, 1])}" x2="{_f(p[j, 0])}" y2="{_f(p[j, 1])}" '
        f'stroke="{_mix_white(BAR, DEPTH_FADE * bar_fade[b])}" stroke-width="{_f(width * (1 - DEPTH_SHRINK * bar_fade[b]))}" '
        f'stroke-linecap="round"/>'
        for b in _order(bar_fade)
        for i, j in [e[b]]
    ]


def _arrow_layer(p, vec, fade, colour, shaft, head_w, head_l, hollow: bool, node_ids) -> list[str]:
    out = []
    for i in _order(fade):
        if np.hypot(*vec[i]) < 2.0:  # shorter than a pixel or two: nothing to see
            continue
        shrink = 1 - DEPTH_SHRINK * fade[i]
        c = _mix_white(colour, DEPTH_FADE * fade[i])
        if hollow:
            v = vec[i] * (1 + 3.0 / np.hypot(*vec[i]))  # the outline encloses a solid arrow's tip
            poly = _arrow_polygon(p[i], v, shaft * shrink, head_w * shrink, head_l * shrink)
            style = f'fill="#ffffff" fill-opacity="0.85" stroke="{c}" stroke-width="1.5" stroke-linejoin="miter"'
            kind = "target"
        else:
            poly = _arrow_polygon(p[i], vec[i], shaft * shrink, head_w * shrink, head_l * shrink)
            style = f'fill="{c}"'
            kind = "mode"
        out.append(f'<polygon class="arrow {kind}" data-node="{node_ids[i]}" points="{_points_attr(poly)}" {style}/>')
    return out


def _node_layer(p, is_spec, fade, radius) -> list[str]:
    out = []
    for i in _order(fade):
        fill, line = SPECIFIED if is_spec[i] else UNSPECIFIED
        f = DEPTH_FADE * fade[i]
        out.append(
            f'<circle class="node {"specified" if is_spec[i] else "unspecified"}" data-node="{i}" cx="{_f(p[i, 0])}" '
            f'cy="{_f(p[i, 1])}" r="{_f(radius * (1 - DEPTH_SHRINK * fade[i]))}" fill="{_mix_white(fill, f)}" '
            f'stroke="{_mix_white(line, f)}" stroke-width="{_f(max(0.6, 0.18 * radius))}"/>'
        )
    return out


def _marker_shape(centre: np.ndarray, size: float, kind: str) -> np.ndarray:
    if kind == "source":
        return centre + size * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]])
    return centre + 1.35 * size * np.array([[0, -1], [1, 0], [0, 1], [-1, 0]])


def _marker_layer(p, source, target_nodes, fade, radius) -> list[str]:
    out = []
    for kind, nodes, colour in (("source", source, SOURCE), ("target", target_nodes, TARGET)):
        for i in nodes:
            poly = _marker_shape(p[i], 1.75 * radius * (1 - DEPTH_SHRINK * fade[i]), kind)
            out.append(
                f'<polygon class="marker {kind}" data-node="{i}" points="{_points_attr(poly)}" fill="none" '
                f'stroke="{colour}" stroke-width="{_f(max(1.2, 0.3 * radius))}"/>'
            )
    return out


def _legend(is_spec, has_bars, modes, targets, solution, mode_colours, target_colours, space_colours,
            has_source, has_target, width, y0) -> tuple[list[str], float]:
    """Legend items present in the picture, wrapped into rows: (SVG lines, height)."""
    items: list[tuple[str, str]] = []  # (marker SVG at origin, text)
    if is_spec.any():
        items.append((f'<circle r="5" fill="{SPECIFIED[0]}" stroke="{SPECIFIED[1]}"/>', "specified node"))
    if (~is_spec).any():
        items.append((f'<circle r="5" fill="{UNSPECIFIED[0]}" stroke="{UNSPECIFIED[1]}"/>', "unspecified node"))
    if has_bars:
        items.append((f'<line x1="-9" x2="9" stroke="{BAR}" stroke-width="2"/>', "bar"))
    many = len(targets) > 1 or len(modes) > 1
    for i, c in enumerate(target_colours[: len(targets)]):
        poly = _arrow_polygon(np.array([-9.0, 0.0]), np.array([19.0, 0.0]), 3.1, 6.6, 10.0)
        items.append((f'<polygon points="{_points_attr(poly)}" fill="#fff" stroke="{c}" stroke-width="1.5"/>',
                      f"requested motion {i + 1}" if many else "requested motion"))
    for i, c in enumerate(mode_colours[: len(modes)]):
        poly = _arrow_polygon(np.array([-9.0, 0.0]), np.array([18.0, 0.0]), 1.1, 3.8, 8.0)
        items.append((f'<polygon points="{_points_attr(poly)}" fill="{c}"/>',
                      f"zero mode {i + 1}" if many else "zero mode"))
    for i, (drawing, c) in enumerate(zip(solution, space_colours)):
        marker = (f'<line x1="-9" x2="9" stroke="{c}" stroke-width="2.6"/>' if drawing.curves
                  else f'<g fill="{c}"><circle cx="-6" r="2"/><circle r="2"/><circle cx="6" r="2"/></g>')
        name = "solution space" + (f" {i + 1}" if len(solution) > 1 else "")
        if not drawing.curves and not len(drawing.points):
            name += " (empty)"
        items.append((marker, name))
    if has_source:
        items.append((f'<polygon points="{_points_attr(_marker_shape(np.zeros(2), 6.0, "source"))}" fill="none" stroke="{SOURCE}" stroke-width="1.6"/>', "source"))
    if has_target:
        items.append((f'<polygon points="{_points_attr(_marker_shape(np.zeros(2), 6.0, "target"))}" fill="none" stroke="{TARGET}" stroke-width="1.6"/>', "target"))
    rows: list[list[tuple[str, str, float]]] = [[]]
    used = 0.0
    for marker, text in items:
        w = 30.0 + 6.6 * len(text) + 14.0
        if rows[-1] and used + w > width - 20:
            rows.append([])
            used = 0.0
        rows[-1].append((marker, text, w))
        used += w
    out = ['<g class="legend" font-size="12" fill="#333">']
    for r, row in enumerate(rows):
        total = sum(w for *_, w in row)
        x = (width - total) / 2
        y = y0 + 11 + 20 * r
        for marker, text, w in row:
            out.append(f'<g transform="translate({_f(x + 12)},{_f(y)})">{marker}</g>')
            out.append(f'<text x="{_f(x + 30)}" y="{_f(y + 4)}">{escape(text)}</text>')
            x += w
    out.append("</g>")
    return out, 20.0 * len(rows) + 6


# --------------------------------------------------------------------------------------------
# Validation and composition (what the CLI and POST /v1/plot call)


def figure_svg(
    frame: Frame,
    modes=None,
    targets=None,
    solution_space: bool = False,
    configurations=None,
    labels=None,
    source=(),
    target_nodes=(),
    title: str | None = None,
    seed: int = 0,
    captions=None,
    frame_panel: int = 0,
    arrow_nodes=None,
    view: tuple[float, float] = VIEW_3D,
) -> str:
    """Validate a plot request against the frame and render it (see ``render_svg``).

    modes: M arrays N × d; targets: M' arrays k × d (k = len(frame.specified), rows in the
    order of ``specified``); when solution_space is set, the solution space of every requested
    motion (targets, or else the modes' rows on the specified nodes) is drawn; labels and
    captions: one per panel at most, in panel order, the frame's panel being number
    ``frame_panel`` among the 1 + len(configurations); view: (azimuth, elevation) in degrees
    of a 3D frame.  Raises InvalidInput naming the first bad field.
    """
    n, d = frame.n_nodes, frame.dim
    k = len(frame.specified)
    mode_arr = _stack(modes, n, d, "modes", "the frame's nodes")
    if targets is not None and len(targets) and k == 0:
        raise InvalidInput("invalid_targets", "targets need specified nodes in the frame (specified is empty).")
    target_arr = _stack(targets, k, d, "targets", "the specified nodes")
    configs = _stack(configurations, n, d, "configurations", "the frame's nodes")
    node_lists = [("source", source), ("target_nodes", target_nodes)]
    if arrow_nodes is not None:
        node_lists.append(("arrow_nodes", arrow_nodes))
    for name, nodes in node_lists:
        if not all(isinstance(i, (int, np.integer)) and not isinstance(i, bool) for i in nodes):
            raise InvalidInput("invalid_nodes", f"{name} must be a list of integer node indices.")
        bad = [i for i in nodes if not 0 <= i < n]
        if bad:
            raise InvalidInput("invalid_nodes", f"{name} names node {bad[0]}, outside 0..{n - 1}.")
        if len(set(nodes)) != len(nodes):
            raise InvalidInput("invalid_nodes", f"{name} lists a node more than once.")
    n_panels = 1 + len(configs)
    labels, captions = list(labels or []), list(captions or [])
    for name, texts in (("labels", labels), ("captions", captions)):
        if len(texts) > n_panels:
            raise InvalidInput(
                f"invalid_{name}", f"{len(texts)} {name} for {n_panels} panels (the frame and its configurations)."
            )
    if isinstance(frame_panel, bool) or not isinstance(frame_panel, (int, np.integer)) or not 0 <= frame_panel < n_panels:
        raise InvalidInput("invalid_frame_panel", f"frame_panel must be a panel index in 0..{n_panels - 1}.")
    drawings = []
    if solution_space:
        motions = target_arr if len(target_arr) else mode_arr[:, list(frame.specified)]
        if k == 0 or not len(motions):
            raise InvalidInput(
                "no_motion", "solution_space needs specified nodes and a motion (targets or modes) to draw."
            )
        window = Window.around(frame.positions, view_basis(*view) if d == 3 else None)
        x_s = frame.positions[list(frame.specified)]
        for u_s in motions:
            try:
                drawings.append(solution_drawing(x_s, u_s, window, seed))
            except DomainError as exc:
                if exc.code != "no_solution":
                    raise
                # No unspecified node can join all specified nodes: the solution space is empty.
                drawings.append(SolutionDrawing("empty", (), np.zeros((0, d))))
    return render_svg(
        frame.positions, frame.edges, frame.specified, modes=mode_arr, targets=target_arr,
        solution=drawings, configurations=configs, labels=labels, source=list(source),
        target_nodes=list(target_nodes), title=title, captions=captions, frame_panel=int(frame_panel),
        arrow_nodes=None if arrow_nodes is None else list(arrow_nodes), view=tuple(view),
    )


def _stack(arrays, rows: int, d: int, name: str, what: str) -> np.ndarray:
    """A list of (rows × d) finite arrays as one (count, rows, d) array, or raise InvalidInput."""
    if arrays is None or not len(arrays):
        return np.zeros((0, rows, d))
    out = []
    for i, a in enumerate(arrays):
        a = check_positions(a, d, f"{name}[{i}]")
        if len(a) != rows:
            raise InvalidInput("invalid_shape", f"{name}[{i}] has {len(a)} rows; it needs one per node of {what} ({rows}).")
        out.append(a)
    return np.stack(out)
