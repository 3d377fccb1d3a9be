"""Laying out a picture: Picture → Scene (shapes in pixels), the paper's visual language applied.

3D frames are drawn in an orthographic view (style.VIEW_3D by default) with depth cues: farther
nodes, bars and arrows are lighter and smaller.  Arrows share one length scale, so a designed
mode and the motion it was asked to realise coincide on the specified nodes; the longest arrow
is ARROW_FRACTION of the frame's size, capped at ARROW_GAPS typical gaps between the nodes that
carry arrows so that neighbouring arrows do not run into each other.

Several configurations of one frame (a lattice's contracted and expanded states, say) are drawn
at one common scale in a row, or in a column when the panels are wide, whichever picture is
nearer 4:3; a row is kept within about ROW_PX so that its text stays legible page-wide.  Frames
of more than MAX_ARROW_NODES nodes get larger panels, smaller nodes and thinner bars (nodes are
kept below a third of the gap to their nearest neighbour), and mode arrows on a spread
subsample only — the node nearest the centre of each cell of an ARROW_GRID-wide grid — unless
the picture names the nodes.
"""

from __future__ import annotations

import numpy as np

from zeromode.solver.errors import DomainError
from zeromode.viz.curves import SolutionDrawing, solution_drawing
from zeromode.viz.geometry import (
    Window,
    arrow_polygon,
    marker_polygon,
    project,
    spread_subsample,
    typical_gap,
    view_basis,
)
from zeromode.viz.picture import Picture
from zeromode.viz.scene import Circle, Group, Line, Polygon, Polyline, Scene, Text
from zeromode.viz.style import (
    ARROW_FRACTION,
    ARROW_GAPS,
    ARROW_NEIGHBOUR,
    ASPECT,
    BAR,
    BIG_PANEL,
    BLUE_DARK,
    BLUE_LIGHT,
    CAPTION_INK,
    CAPTION_PX,
    DEPTH_FADE,
    DEPTH_SHRINK,
    GAP_PX,
    GREEN,
    GREEN_DARK,
    GREEN_LIGHT,
    LABEL_INK,
    LABEL_PX,
    LEGEND_INK,
    LEGEND_PX,
    MAX_ARROW_NODES,
    MIN_ARROW_PX,
    MIN_WIDTH_PX,
    PAD_PX,
    PANEL_PX,
    ROW_PX,
    SOURCE,
    SPECIFIED,
    TARGET,
    TITLE_INK,
    TITLE_PX,
    UNSPECIFIED,
    WHITE,
    mix_white,
    ramp,
)

# Unit-scaled coordinates are O(1): a frame smaller than this is a single point (or one spot).
TINY_SIZE = 1e-9


def solution_drawings(picture: Picture) -> list[SolutionDrawing]:
    """The solution space of every requested motion of the picture, traced in a window around
    the frame in the picture's view; an empty one (no node joins all specified nodes) as such."""
    if not picture.solution_space:
        return []
    frame = picture.frame
    window = Window.around(frame.positions, view_basis(*picture.view) if frame.dim == 3 else None)
    x_s = frame.positions[list(frame.specified)]
    drawings = []
    for u_s in picture.motions:
        try:
            drawings.append(solution_drawing(x_s, u_s, window, picture.seed))
        except DomainError as exc:
            if exc.code != "no_solution":
                raise
            drawings.append(SolutionDrawing("empty", (), np.zeros((0, frame.dim))))
    return drawings


def layout(picture: Picture) -> Scene:
    """The picture's shapes in pixels: title, panels (each a Group ``panel-<k>`` holding its
    label, caption, solution space, bars, arrows, nodes and markers, in painting order) and a
    legend of what the picture shows."""
    frame = picture.frame
    x, e = frame.positions, frame.edges
    n_nodes, d = x.shape
    spec = np.asarray(frame.specified, dtype=int)
    is_spec = np.zeros(n_nodes, bool)
    is_spec[spec] = True
    modes, targets = picture.modes, picture.targets
    labels, captions, title = picture.labels, picture.captions, picture.title
    frame_panel = picture.frame_panel
    basis = view_basis(*picture.view) if d == 3 else None
    solution = solution_drawings(picture)

    # One map from data to screen for every panel: unit-scaled first so that no coordinate can
    # overflow, then projected; arrows share one length scale.
    panels = list(picture.configurations)
    panels.insert(frame_panel, x)
    unit = max(float(np.max(np.abs(p))) for p in panels) or 1.0
    screen = [project(p / unit, basis) for p in panels]
    main = screen[frame_panel][0]
    size = max(float(np.max(np.ptp(s, axis=0))) for s, _ in screen)
    size = size if size > TINY_SIZE else 1.0
    bar_len = float(np.median(np.linalg.norm(x[e[:, 0]] / unit - x[e[:, 1]] / unit, axis=1))) if len(e) else size
    if picture.arrow_nodes is not None:
        arrow_nodes = np.asarray(picture.arrow_nodes, dtype=int)
    else:
        arrow_nodes = np.arange(n_nodes) if n_nodes <= MAX_ARROW_NODES else spread_subsample(main)
    arrows = np.concatenate([modes[:, arrow_nodes].reshape(-1, d), targets.reshape(-1, d)])
    amax = float(np.max(np.abs(arrows), initial=0.0)) or 1.0  # arrows have their own units
    longest = float(np.max(np.linalg.norm(arrows / amax, axis=1), initial=0.0))
    # Neighbouring arrows should not run into each other: the cap is measured between the nodes
    # that carry arrows (a subsample of a big lattice is sparser than its bars), in space, where
    # the arrows are (a projection brings nodes at different depths together).
    spacing = typical_gap(x[arrow_nodes] / unit, ARROW_NEIGHBOUR) if len(arrow_nodes) > 1 else bar_len
    arrow_len = min(ARROW_FRACTION * size, ARROW_GAPS * spacing) if longest > 0 else 0.0
    arrow_scale = arrow_len / longest / amax if longest > 0 else 0.0
    mode_vec = [project(m * arrow_scale, basis)[0][arrow_nodes] for m in modes]
    target_vec = [project(t * arrow_scale, basis)[0] for t in targets]
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

    gap_px = typical_gap(main) * px if n_nodes > 1 else PANEL_PX
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

    mode_colours = ramp(GREEN_LIGHT, GREEN_DARK, max(len(modes), 1), GREEN)
    target_colours = ramp(GREEN_LIGHT, GREEN_DARK, max(len(targets), 1), GREEN)
    space_colours = ramp(BLUE_LIGHT, BLUE_DARK, max(len(solution), 1), BLUE_LIGHT)
    legend, legend_h = _legend(
        is_spec, len(e) > 0, modes, targets, solution, mode_colours, target_colours, space_colours,
        bool(len(picture.source)), bool(len(picture.target_nodes)), width, top + body_h + 6.0,
    )
    height = top + body_h + legend_h + 8.0

    shapes: list = []
    if title:
        shapes.append(Text(np.array([width / 2, 24.0]), title, TITLE_PX, TITLE_INK, "middle"))
    for k, ((s, depth), (lo, hi), (x0, y0, w, h)) in enumerate(zip(screen, boxes, cells)):
        # Data (screen units, y up) → pixels (y down) inside this panel.
        # Clipped far outside the picture so that every coordinate written is a plain number.
        to_px = lambda p, lo=lo, hi=hi, x0=x0, y0=y0: np.clip(
            np.column_stack([x0 + PAD_PX + (p[:, 0] - lo[0]) * px, y0 + PAD_PX + (hi[1] - p[:, 1]) * px]),
            -1e5, 1e5,
        )
        fade = np.clip((depth - d_lo) / d_span, 0, 1) if basis is not None else np.zeros(n_nodes)
        panel: list = []
        if k < len(labels) and labels[k]:
            # Over the panel's box (in a row: over the tallest panel, so labels line up).
            above = y0 if column else top + label_h
            panel.append(Text(np.array([x0 + w / 2, above - 6]), labels[k], LABEL_PX, LABEL_INK, "middle", "label"))
        if k < len(captions) and captions[k]:
            # Under the panel's box (in a row: under the tallest panel, so captions line up).
            below = y0 + h if column else top + row_h - caption_h
            panel.append(
                Text(np.array([x0 + w / 2, below + 12]), captions[k], CAPTION_PX, CAPTION_INK, "middle", "caption")
            )
        if k == frame_panel and solution:
            # The solution space may run up to the neighbouring panels (or the picture's edge).
            panel.append(Group(tuple(_solution_shapes(solution, space_colours, unit, basis, to_px, d_lo, d_span, radius)),
                               clip=clips[k]))
        p = to_px(s)
        panel += bar_shapes(p, e, fade, bar_w)
        if k == frame_panel:
            for t, colour in zip(target_vec, target_colours):
                panel += _arrow_shapes(p[spec], t * np.array([px, -px]), fade[spec], colour,
                                       shaft + 2.2, head_w + 3.0, head_l + 3.5, True, spec)
            for m, colour in zip(mode_vec, mode_colours):
                panel += _arrow_shapes(p[arrow_nodes], m * np.array([px, -px]), fade[arrow_nodes], colour,
                                       shaft, head_w, head_l, False, arrow_nodes)
        panel += node_shapes(p, is_spec, fade, radius)
        panel += marker_shapes(p, picture.source, picture.target_nodes, fade, radius)
        shapes.append(Group(tuple(panel), cls="panel", id=f"panel-{k}"))
    shapes.append(legend)
    return Scene(width, height, tuple(shapes))


def _order(fade: np.ndarray) -> np.ndarray:
    """Painter's order: farthest first."""
    return np.argsort(-fade, kind="stable")


def _solution_shapes(solution, colours, unit, basis, to_px, d_lo, d_span, radius) -> list:
    """Conic branches as polylines — in 3D cut into short runs, each shaded by its depth — and
    clouds or isolated solutions as dots."""
    out: list = []
    for drawing, colour in zip(solution, colours):
        wire = drawing.kind != "conic"
        runs = []  # (fade, pixel polyline)
        for curve in drawing.curves:
            s, depth = project(curve / unit, basis)
            p = to_px(s)
            if basis is None:
                runs.append((0.0, p))
                continue
            fade = np.clip((depth - d_lo) / d_span, 0, 1)
            for a in range(0, len(p) - 1, 10):
                runs.append((float(np.mean(fade[a : a + 11])), p[a : a + 11]))
        for f, p in sorted(runs, key=lambda r: -r[0]):
            out.append(Polyline(p, mix_white(colour, 0.35 * f), (1.3 if wire else 2.6) * (1 - DEPTH_SHRINK * f), "solution"))
        if len(drawing.points):
            s, depth = project(drawing.points / unit, basis)
            fade = np.clip((depth - d_lo) / d_span, 0, 1) if basis is not None else np.zeros(len(s))
            r = max(1.2, 0.32 * radius) if drawing.kind.startswith("quadric") else 0.8 * radius
            p = to_px(s)
            out += [
                Circle(p[i], r * (1 - DEPTH_SHRINK * fade[i]), mix_white(colour, 0.5 * fade[i]), cls="solution")
                for i in _order(fade)
            ]
    return out


def bar_shapes(p, e, fade, width) -> list:
    bar_fade = 0.5 * (fade[e[:, 0]] + fade[e[:, 1]]) if len(e) else np.zeros(0)
    return [
        Line(p[e[b]], mix_white(BAR, DEPTH_FADE * bar_fade[b]), width * (1 - DEPTH_SHRINK * bar_fade[b]),
             "bar", (("edge", int(b)),))
        for b in _order(bar_fade)
    ]


def _arrow_shapes(p, vec, fade, colour, shaft, head_w, head_l, hollow: bool, node_ids) -> list:
    out = []
    for i in _order(fade):
        length = np.hypot(*vec[i])
        if length < MIN_ARROW_PX:
            continue
        shrink = 1 - DEPTH_SHRINK * fade[i]
        c = mix_white(colour, DEPTH_FADE * fade[i])
        data = (("node", int(node_ids[i])),)
        if hollow:
            v = vec[i] * (1 + 3.0 / length)  # the outline encloses a solid arrow's tip
            poly = arrow_polygon(p[i], v, shaft * shrink, head_w * shrink, head_l * shrink)
            out.append(Polygon(poly, WHITE, c, 1.5, 0.85, "arrow target", data))
        else:
            poly = arrow_polygon(p[i], vec[i], shaft * shrink, head_w * shrink, head_l * shrink)
            out.append(Polygon(poly, c, cls="arrow mode", data=data))
    return out


def node_shapes(p, is_spec, fade, radius) -> list:
    out = []
    for i in _order(fade):
        fill, line = SPECIFIED if is_spec[i] else UNSPECIFIED
        f = DEPTH_FADE * fade[i]
        out.append(Circle(
            p[i], radius * (1 - DEPTH_SHRINK * fade[i]), mix_white(fill, f), mix_white(line, f), max(0.6, 0.18 * radius),
            "node specified" if is_spec[i] else "node unspecified", (("node", int(i)),),
        ))
    return out


def marker_shapes(p, source, target_nodes, fade, radius) -> list:
    return [
        Polygon(marker_polygon(p[i], 1.75 * radius * (1 - DEPTH_SHRINK * fade[i]), kind), None, colour,
                max(1.2, 0.3 * radius), cls=f"marker {kind}", data=(("node", int(i)),))
        for kind, nodes, colour in (("source", source, SOURCE), ("target", target_nodes, TARGET))
        for i in nodes
    ]


def _legend(is_spec, has_bars, modes, targets, solution, mode_colours, target_colours, space_colours,
            has_source, has_target, width, y0) -> tuple[Group, float]:
    """Legend items present in the picture, wrapped into centred rows: (the legend, its height)."""
    items: list[tuple[tuple, str]] = []  # (marker shapes around the origin, text)
    origin = np.zeros(2)
    if is_spec.any():
        items.append(((Circle(origin, 5.0, SPECIFIED[0], SPECIFIED[1], 1.0),), "specified node"))
    if (~is_spec).any():
        items.append(((Circle(origin, 5.0, UNSPECIFIED[0], UNSPECIFIED[1], 1.0),), "unspecified node"))
    if has_bars:
        items.append(((Line(np.array([[-9.0, 0.0], [9.0, 0.0]]), BAR, 2.0),), "bar"))
    many = len(targets) > 1 or len(modes) > 1
    for i, c in enumerate(target_colours[: len(targets)]):
        poly = arrow_polygon(np.array([-9.0, 0.0]), np.array([19.0, 0.0]), 3.1, 6.6, 10.0)
        items.append(((Polygon(poly, WHITE, c, 1.5),), f"requested motion {i + 1}" if many else "requested motion"))
    for i, c in enumerate(mode_colours[: len(modes)]):
        poly = arrow_polygon(np.array([-9.0, 0.0]), np.array([18.0, 0.0]), 1.1, 3.8, 8.0)
        items.append(((Polygon(poly, c),), f"zero mode {i + 1}" if many else "zero mode"))
    for i, (drawing, c) in enumerate(zip(solution, space_colours)):
        if drawing.curves:
            marker = (Line(np.array([[-9.0, 0.0], [9.0, 0.0]]), c, 2.6),)
        else:
            marker = tuple(Circle(np.array([dx, 0.0]), 2.0, c) for dx in (-6.0, 0.0, 6.0))
        name = "solution space" + (f" {i + 1}" if len(solution) > 1 else "")
        if not drawing.curves and not len(drawing.points):
            name += " (empty)"
        items.append((marker, name))
    for present, kind, colour in ((has_source, "source", SOURCE), (has_target, "target", TARGET)):
        if present:
            items.append(((Polygon(marker_polygon(origin, 6.0, kind), None, colour, 1.6),), kind))
    rows: list[list[tuple[tuple, str, float]]] = [[]]
    used = 0.0
    for marker, text in items:
        w = 30.0 + 6.6 * len(text) + 14.0
        if rows[-1] and used + w > width - 20:
            rows.append([])
            used = 0.0
        rows[-1].append((marker, text, w))
        used += w
    shapes: list = []
    for r, row in enumerate(rows):
        total = sum(w for *_, w in row)
        x = (width - total) / 2
        y = y0 + 11 + 20 * r
        for marker, text, w in row:
            shapes.append(Group(marker, offset=(x + 12, y)))
            shapes.append(Text(np.array([x + 30, y + 4]), text, LEGEND_PX, LEGEND_INK))
            x += w
    return Group(tuple(shapes), cls="legend"), 20.0 * len(rows) + 6
