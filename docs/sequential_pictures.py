"""Regenerate the pictures of docs/module_maps.md:

    .venv/bin/python docs/sequential_pictures.py [module] [bifurcation] [deployable] [curvature] [soliton]

docs/img/sequential_map.png          the deployable example's module beside its map (what
                                     ``zeromode plot`` draws of a /v1/map answer)
docs/img/sequential_bifurcation.png  the orbit of f (iterates 300…399 from next to the fixed
                                     point) against the hinge's height h of the two-triangle
                                     module, its fixed point (solid: stable, dashed: unstable),
                                     its period-2 orbits and where orbits leave the usable
                                     range; a zoom on the flip
docs/img/sequential_deployable.png   the deployable example's map with the chain's orbit, and
                                     d_k along the 16-module chain over its verified motion
docs/img/sequential_curvature.png    the curvature example's chain where it turns least and most
                                     along its verified motion
docs/img/sequential_soliton.png      the soliton example: the chain at four drives coloured by how
                                     far each copy has switched, the wall against the drive, the
                                     springs' energy along it
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

import zeromode as zm
from zeromode.service.wire.schemas.sequential import SEQUENTIAL_EXAMPLES
from zeromode.solver.sequential.module_map import module_map, two_triangle_module

IMG = Path(__file__).parent / "img"
# The parameter: the whole range, and dense around the flip of the fixed point (h ≈ 0.325).
HEIGHTS = np.linspace(0.2, 0.9, 141)
ZOOM = np.linspace(0.320, 0.328, 81)
# The orbit starts next to the fixed point and runs long by the flip, where |f′(d*)| → 1 makes
# it converge slowly (300 iterates drew a transient there as if it were a cycle).
START_OFFSET = 1e-3
TRANSIENT, ZOOM_TRANSIENT, KEPT = 300, 3000, 100


def two_cycle(the_map, star: float) -> list[tuple[float, bool]]:
    """The points d of period-2 orbits of f (f(f(d)) = d, d ≠ d*), each with whether the orbit
    is stable (|f′(d)·f′(f(d))| < 1): sign changes of f(f(d)) − d between neighbours of a grid
    of the usable range (both with f(d) in it), interpolated linearly (a chart)."""
    lo, hi = the_map.range
    grid = np.linspace(lo, hi, 600)[1:-1]
    once = the_map.evaluate(grid)[0]
    inside = (once > lo) & (once < hi)
    g = np.full(grid.shape, np.nan)
    g[inside] = the_map.evaluate(once[inside])[0] - grid[inside]
    points = []
    for k in np.flatnonzero(np.sign(g[:-1]) * np.sign(g[1:]) < 0):
        if grid[k] <= star <= grid[k + 1]:
            continue  # the fixed point itself
        d = grid[k] - g[k] * (grid[k + 1] - grid[k]) / (g[k + 1] - g[k])
        image, slope = the_map.evaluate(d)
        multiplier = float(slope) * float(the_map.evaluate(image)[1])
        points.append((float(d), abs(multiplier) < 1))
    return points


def orbit_panel(axes, heights, transient: int, legend: bool) -> None:
    """The orbit, the fixed point and the period-2 orbits of f against h on ``axes``."""
    fixed, slopes, escaped = [], [], []
    for h in heights:
        the_map = module_map(two_triangle_module(hinge=(0.15, h)))
        star, slope = the_map.fixed_points()[0]
        fixed.append(star)
        slopes.append(slope)
        orbit = the_map.iterate(star * (1 + START_OFFSET), transient + KEPT)
        if len(orbit) == transient + KEPT + 1:
            axes.plot(np.full(KEPT, h), orbit[-KEPT:], "o", ms=1.5, color="k", zorder=3)
        else:
            escaped.append(h)
        for d, stable_cycle in two_cycle(the_map, star):
            axes.plot([h], [d], "o", ms=2, color="C2" if stable_cycle else "C1", zorder=2)
    fixed, slopes = np.array(fixed), np.array(slopes)
    stable = np.abs(slopes) < 1
    axes.plot(heights[stable], fixed[stable], color="C0", lw=1, label="fixed point d*, stable (|f′| < 1)")
    axes.plot(heights[~stable], fixed[~stable], color="C3", lw=1, ls="--", label="fixed point d*, unstable (f′ < −1)")
    if escaped:
        axes.axvspan(min(escaped), max(escaped), color="C3", alpha=0.12,
                     label="orbit leaves the usable range: a copy reaches its fold, no chain")
    flip = heights[np.argmin(np.abs(slopes + 1))]
    axes.axvline(flip, color="0.5", lw=0.8, label=f"f′(d*) = −1 (h ≈ {flip:.4f})")
    axes.set_xlabel("hinge height h (node 4 at (0.15, h))")
    axes.set_ylabel("input distance d")
    if legend:
        axes.plot([], [], "o", ms=2.5, color="k", label=f"orbit of f from d*·(1 + {START_OFFSET:g}): its last {KEPT} of {transient + KEPT} iterates")
        axes.plot([], [], "o", ms=2.5, color="C2", label="period-2 orbit (f(f(d)) = d), stable")
        axes.plot([], [], "o", ms=2.5, color="C1", label="period-2 orbit, unstable")
        axes.legend(loc="upper right", fontsize="x-small")


def bifurcation() -> None:
    figure = Figure(figsize=(12, 5.5), layout="constrained")
    whole, zoom = figure.add_subplot(1, 2, 1), figure.add_subplot(1, 2, 2)
    orbit_panel(whole, HEIGHTS, TRANSIENT, legend=True)
    whole.set_title("the two-triangle module's map f, orbits against h")
    orbit_panel(zoom, ZOOM, ZOOM_TRANSIENT, legend=False)
    zoom.set_title(f"zoom on the flip (orbit: the last {KEPT} of {ZOOM_TRANSIENT + KEPT} iterates)")
    figure.savefig(IMG / "sequential_bifurcation.png", dpi=110)


def module() -> None:
    body = SEQUENTIAL_EXAMPLES["deployable"]["value"]
    designed = zm.sequential(body["features"]).to_dict()["module"]
    frame = zm.Frame.build(designed["frame"]["positions"], designed["frame"]["edges"])
    zm.module_map(frame, designed["input_pair"], designed["output_pair"]).plot().savefig(IMG / "sequential_map.png", dpi=100)


def deployable() -> None:
    body = SEQUENTIAL_EXAMPLES["deployable"]["value"]
    result = zm.sequential(body["features"], n_modules=body["chain"]["n_modules"], d0=body["chain"]["d0"])
    result.plot().savefig(IMG / "sequential_deployable.png", dpi=100)


def turning(positions: np.ndarray, pairs: np.ndarray) -> float:
    """The chain's total turning (degrees): the angle from its first pair's vector to its last's,
    followed pair by pair."""
    vectors = positions[pairs[:, 1]] - positions[pairs[:, 0]]
    angles = np.unwrap(np.arctan2(vectors[:, 1], vectors[:, 0]))
    return float(np.degrees(angles[-1] - angles[0]))


def curvature() -> None:
    body = SEQUENTIAL_EXAMPLES["curvature"]["value"]
    result = zm.sequential(body["features"], n_modules=body["chain"]["n_modules"])
    verified = result.solution.chain
    positions, pairs = verified.path.positions, verified.chain.pairs
    turns = np.array([turning(x, pairs) for x in positions])
    edges = verified.chain.frame.edges
    n = verified.chain.n_modules
    figure = Figure(figsize=(10, 4.5), layout="constrained")
    for k, i in enumerate((int(np.argmin(np.abs(turns))), int(np.argmax(np.abs(turns))))):
        axes = figure.add_subplot(1, 2, k + 1)
        x = positions[i]
        for a, b in edges:
            axes.plot(*x[[a, b]].T, color="0.4", lw=1)
        axes.plot(*x.T, "o", ms=3, color="C0")
        axes.plot(*x[pairs[0]].T, color="C3", lw=3, label="input pair")
        axes.set_aspect("equal")
        axes.set_axis_off()
        axes.set_title(f"total turning {abs(turns[i]):.0f}°, {abs(turns[i]) / n:.1f}° per copy")
    figure.axes[0].legend(loc="lower left", fontsize="small")
    figure.savefig(IMG / "sequential_curvature.png", dpi=100)
    print(f"curvature: total turning from {np.abs(turns).min():.1f}° to {np.abs(turns).max():.1f}° over {n} copies")


def soliton() -> None:
    body = SEQUENTIAL_EXAMPLES["soliton"]["value"]
    result = zm.sequential(body["features"], soliton=body["soliton"])
    result.plot().savefig(IMG / "sequential_soliton.png", dpi=100)
    sol = result.to_dict()["soliton"]
    print(f"soliton: wall travels {sol['travel']:.2f} copies, slope {sol['wall_slope']:.3f} "
          f"(linearised {sol['predicted_wall_slope']:.3f}), barrier {sol['barrier']:.4f}, Hessian floors "
          f"{sol['unstable']['hessian_min_eigenvalue']:.4f} (d_u), {sol['stable']['hessian_min_eigenvalue']:.4f} (d_s)")


if __name__ == "__main__":
    import sys

    for name in sys.argv[1:] or ["module", "bifurcation", "deployable", "curvature", "soliton"]:
        globals()[name]()
