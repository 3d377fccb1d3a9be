"""Charts of a module's map (a /v1/map body) and of a chain (a /v1/design/sequential body), with
matplotlib: the graph of f over its usable range (shaded) with the diagonal, its fixed points
(filled: stable, |f′| < 1; open: unstable) and folds, beside the module itself in the paper's
visual language; a chain's orbit as a cobweb, and the distances d_k along the chain at the ends
and middle of its traced motion.

Every element of a map chart carries an id (matplotlib's gid: a ``<g id=…>`` in SVG) —
``map-f``, ``map-diagonal``, ``usable-range``, ``fixed-point-<k>-stable`` or ``-unstable``,
``fold-lower`` / ``fold-upper`` and ``module`` (the module's panel) — so that a reader (or a
test) can find them in the file."""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from zeromode.solver.frame import Frame
    from zeromode.viz.picture import Picture


# The map's panel (inches, at scale 1), the room its axes' labels take inside it, and the band
# of a title above the chart.
MAP_PANEL_INCHES, MAP_MARGIN_INCHES, MAP_TITLE_INCHES = 5.0, 0.6, 0.45


def draw_map(axes: Axes, body: dict) -> None:
    """f, the diagonal, the usable range, fixed points and folds of a /v1/map body on ``axes``."""
    d_in, d_out = body["d_in"], body["d_out"]
    lower, upper = body["lower"], body["upper"]
    axes.axvspan(lower["d_in"], upper["d_in"], color="C0", alpha=0.08, gid="usable-range",
                 label=f"usable range [{lower['d_in']:.4g}, {upper['d_in']:.4g}] ({lower['kind']} to {upper['kind']})")
    axes.plot(d_in, d_out, color="C0", lw=2, label="f", gid="map-f")
    lo, hi = min(d_in + d_out), max(d_in + d_out)
    axes.plot([lo, hi], [lo, hi], color="0.6", lw=1, ls="--", label="d_out = d_in", gid="map-diagonal")
    for k, p in enumerate(body["fixed_points"]):
        stability = "stable" if p["stable"] else "unstable"
        axes.plot([p["d"]], [p["d"]], "o", ms=8, color="C3", mfc="C3" if p["stable"] else "white",
                  label=f"fixed point {p['d']:.4g}, f′ = {p['slope']:.3g} ({stability})", gid=f"fixed-point-{k}-{stability}")
    for name, end in (("lower", lower), ("upper", upper)):
        if end["kind"] == "fold":
            axes.plot([end["d_in"]], [end["d_out"]], "|", ms=14, color="k", gid=f"fold-{name}",
                      label="fold (f′ = ±∞)" if name == "lower" or lower["kind"] != "fold" else None)
    axes.set_xlabel("d_in")
    axes.set_ylabel("d_out = f(d_in)")
    axes.set_aspect("equal", adjustable="datalim")


def draw_cobweb(axes: Axes, iterates: list[float]) -> None:
    """The orbit d_0, d_1 = f(d_0), … as a cobweb on the graph of f."""
    xs, ys = [iterates[0]], [iterates[0]]
    for a, b in itertools.pairwise(iterates):
        xs += [a, b]
        ys += [b, b]
    axes.plot(xs, ys, color="C2", lw=1, label="chain's orbit")


def module_picture(frame: Frame, input_pair, output_pair) -> Picture:
    """The module as viz draws frames (nodes, rods), its input pair marked as the source
    (squares) and its output pair as the target (diamonds), captioned so."""
    from zeromode.viz.picture import Picture

    (a, b), (c, e) = input_pair, output_pair
    return Picture.build(
        frame, source=(a, b), target_nodes=(c, e), labels=["the module"],
        captions=[f"input pair {a}–{b} (squares): d_in; output pair {c}–{e} (diamonds): d_out"],
    )


def map_figure(body: dict, frame: Frame | None = None, scale: float = 1.0, title: str | None = None) -> Figure:
    """A /v1/map body's chart: the map (draw_map) in a panel of 5·scale inches and, with the
    module's ``frame``, the module on its left (module_picture, at its own size: one SVG pixel a
    point, so its strokes and text are as in the SVG picture); ``title`` in a band above both."""
    from matplotlib.figure import Figure

    side = MAP_PANEL_INCHES * scale
    if frame is None:
        figure = Figure(figsize=(side, side), layout="constrained")
        axes = figure.add_subplot()
        if title is not None:
            figure.suptitle(title)
    else:
        from zeromode.viz.layout import layout
        from zeromode.viz.raster import POINTS_PER_INCH, draw_scene

        scene = layout(module_picture(frame, body["input_pair"], body["output_pair"]))
        w, h = scene.width / POINTS_PER_INCH, scene.height / POINTS_PER_INCH
        band = 0.0 if title is None else MAP_TITLE_INCHES
        width, body_height = w + side, max(h, side)
        height = body_height + band
        figure = Figure(figsize=(width, height))
        if title is not None:
            figure.suptitle(title, y=1 - 0.5 * band / height, va="center")
        module = figure.add_axes((0.0, (body_height - h) / (2 * height), w / width, h / height), gid="module")
        draw_scene(module, scene)
        margin = MAP_MARGIN_INCHES
        axes = figure.add_axes((
            (w + margin) / width, margin / height, (side - 1.4 * margin) / width, (body_height - 1.6 * margin) / height
        ))
    draw_map(axes, body)
    axes.legend(fontsize="small")
    return figure


def sequential_figure(body: dict, scale: float = 1.0) -> Figure:
    """A /v1/design/sequential body's chart: the designed map (with the chain's orbit) and, with
    a chain, d_k along the chain at three samples of its traced motion."""
    from matplotlib.figure import Figure

    chain = body.get("chain")
    figure = Figure(figsize=((10 if chain else 5) * scale, 5 * scale), layout="constrained")
    axes = figure.add_subplot(1, 2 if chain else 1, 1)
    draw_map(axes, body["map"])
    if chain:
        draw_cobweb(axes, chain["iterates"])
        right = figure.add_subplot(1, 2, 2)
        rows = chain["distances"]
        for i, label in ((0, "one end of the motion"), (len(rows) // 2, "middle"), (len(rows) - 1, "other end")):
            right.plot(range(len(rows[i])), rows[i], marker=".", label=label)
        right.set_xlabel("pair k along the chain")
        right.set_ylabel("d_k")
        right.legend(fontsize="small")
    axes.legend(fontsize="small")
    return figure



def draw_soliton_chain(axes: Axes, positions, edges, bars: int, switched, springs, input_pair) -> None:
    """The chain at one drive, its input pair laid horizontally at the origin: copy k's ``bars``
    bars (edges k·bars … in order) coloured by its switched fraction s_k = (d_k − d_u)/(d_s − d_u)
    (blue at d_u, red at d_s), the springs thin and dashed, the driven input pair thick black."""
    import numpy as np
    from matplotlib import colormaps

    x = np.asarray(positions, dtype=float)
    a, b = input_pair
    u = (x[b] - x[a]) / np.linalg.norm(x[b] - x[a])
    x = (x - x[a]) @ np.array([[u[0], -u[1]], [u[1], u[0]]])
    cmap = colormaps["coolwarm"]
    for e, (i, j) in enumerate(edges):
        axes.plot(*x[[i, j]].T, color=cmap(float(np.clip(switched[e // bars], 0, 1))), lw=1.4, solid_capstyle="round")
    for i, j in springs:
        axes.plot(*x[[i, j]].T, color="0.35", lw=0.5, ls=(0, (2, 1.5)))
    axes.plot(*x[[a, b]].T, color="k", lw=3)
    axes.set_aspect("equal")
    axes.set_axis_off()


def soliton_figure(body: dict, scale: float = 1.0) -> Figure:
    """A soliton's chart (a /v1/design/sequential body with ``soliton``): left, the chain at the
    snapshot drives (input pair fixed, black) with each copy coloured by how far it has switched;
    right, the wall's position against the drive |d_0 − d_u| (log scale) with the linearised
    slope, and the springs' energy along the drive."""
    import numpy as np
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.figure import Figure

    sol, chain = body["soliton"], body["chain"]
    d_u, d_s = sol["unstable"]["d"], sol["stable"]["d"]
    edges, pairs = chain["frame"]["edges"], chain["pairs"]
    bars = len(sol["module"]["frame"]["edges"])
    shots = sol["snapshots"]
    drive = np.asarray(sol["drive"])
    offset = np.abs(drive - d_u)
    wall = np.array([np.nan if w is None else w for w in sol["wall"]])
    n = len(pairs) - 1
    figure = Figure(figsize=(13 * scale, 6.5 * scale), layout="constrained")
    left, right = figure.subfigures(1, 2, width_ratios=[1.35, 1])
    cols = 2
    grid_rows = -(-len(shots) // cols)
    for i, j in enumerate(shots):
        axes = left.add_subplot(grid_rows, cols, i + 1)
        row = sol["rows"][j]
        d = np.asarray(chain["distances"][row])
        draw_soliton_chain(axes, chain["path"][row], edges, bars, (d - d_u) / (d_s - d_u), sol["springs"]["pairs"], pairs[0])
        axes.set_title(f"d₀ − d_u = {drive[j] - d_u:.1e}: wall at copy {wall[j]:.1f}", fontsize="small")
    bar = ScalarMappable(cmap=colormaps["coolwarm"])
    bar.set_clim(0, 1)
    left.colorbar(bar, ax=left.axes, orientation="horizontal", shrink=0.6,
                  label="switched fraction (d_k − d_u)/(d_s − d_u) of each copy: 0 at d_u, 1 at d_s")
    top, bottom = right.subplots(2, 1, sharex=True)
    top.plot(offset, wall, color="C0", lw=2, label="wall (where the fraction crosses ½)")
    bulk = np.flatnonzero(np.isfinite(wall) & (wall >= 1) & (wall <= n - 1))
    if len(bulk):
        ref = bulk[len(bulk) // 2]
        line = wall[ref] + sol["predicted_wall_slope"] * (np.log(offset) - np.log(offset[ref]))
        top.plot(offset, line, color="0.5", ls="--", lw=1, label=f"−ln|d₀ − d_u| / ln f′(d_u), f′(d_u) = {sol['unstable']['slope']:.3g}")
    for j in shots:
        top.plot([offset[j]], [wall[j]], "o", color="C3", ms=5)
    top.set_xscale("log")
    top.set_ylim(-0.5, n + 0.5)
    top.set_ylabel(f"wall position (copy, of {n})")
    top.set_title(f"the wall travels {sol['travel']:.1f} copies", fontsize="small")
    top.legend(fontsize="x-small")
    bottom.plot(offset, sol["energy"], color="C3", lw=2, label="E = Σ k (ℓ − L)²/2 along the drive")
    bottom.axhline(0.0, color="0.6", lw=1, ls="--", label="both uniform states: E = 0, strict minima")
    bottom.set_xlabel("drive |d₀ − d_u| (verified motion of the chain)")
    bottom.set_ylabel("energy (k × length²)")
    bottom.legend(fontsize="x-small", loc="center left")
    return figure
