"""Charts of a module's map (a /v1/map body) and of a chain (a /v1/design/sequential body), with
matplotlib: the graph of f over its usable range with the diagonal, its fixed points (filled:
stable, open: unstable) and folds; a chain's orbit as a cobweb, and the distances d_k along the
chain at the ends and middle of its traced motion."""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


def draw_map(axes: Axes, body: dict) -> None:
    """f, the diagonal, fixed points and folds of a /v1/map body on ``axes``."""
    d_in, d_out = body["d_in"], body["d_out"]
    axes.plot(d_in, d_out, color="C0", lw=2, label="f (usable range)")
    lo, hi = min(d_in + d_out), max(d_in + d_out)
    axes.plot([lo, hi], [lo, hi], color="0.6", lw=1, ls="--", label="d_out = d_in")
    for p in body["fixed_points"]:
        axes.plot([p["d"]], [p["d"]], "o", ms=8, color="C3", mfc="C3" if p["stable"] else "white",
                  label=f"fixed point f′ = {p['slope']:.3g}")
    for end in (body["lower"], body["upper"]):
        if end["kind"] == "fold":
            axes.plot([end["d_in"]], [end["d_out"]], "|", ms=14, color="k")
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


def map_figure(body: dict, scale: float = 1.0) -> Figure:
    """A /v1/map body's chart."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(5 * scale, 5 * scale), layout="constrained")
    axes = figure.add_subplot()
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
