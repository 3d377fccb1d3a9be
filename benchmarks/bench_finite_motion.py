"""Finite-motion benchmark: speed against accuracy of the three routes to a finite motion, and
where they fail (issue 6, items 6 and 7).

Usage:  .venv/bin/python benchmarks/bench_finite_motion.py [--quick] [--out DIR] [--replot]
(--quick: ≤ 2 minutes, written to a temp folder unless --out is given)

Targets.  Every frame is built by the product's own designer, ``design(x_S, u_S, seed=...)``:
the paper's outward square (example ``outward_2d``) and seeded random targets, 2D with k = 3
and 3D with k = 4 specified nodes (x_S, u_S standard normal), each at the relative amplitudes
a = 0.1 and 0.2 (a = RMS displacement of the specified nodes over their RMS size, the
convention of ``refine.target_displacement``).

Part 1 (speed vs accuracy).  For each (target, a), three methods, each one (wall time, ε) point:
  * linear design only: time of ``design()`` (median of 3 calls); ε = the finite-motion
    fidelity ε(a) of the designed frame (``finite_motion.motion_fidelity``, not timed);
  * linear + continuation: design + ``motion_fidelity`` (``trace_motion`` both ways, then the
    configuration closest to the target polished on the constraint manifold).  Continuation
    follows the linear design's own finite motion, so its ε is the linear design's ε; it buys
    the configurations of that motion, not accuracy;
  * IPOPT refinement ``refine(frame, u_S, a, K, tol)`` for K in KS and tol in TOLS, its time
    including the design.  A failed refinement counts with the ε of its best frame.
Medians per method are marked; the Pareto front (no other median both faster and at least as
accurate) is drawn through them, and whether refine()'s default (K, tol) lies on it is printed.

Part 2 (where methods fail).  2D k = 3 and 3D k = 4 targets whose motion is
u_S = (1 − η)·(dilation) + η·(seeded random motion), both of unit RMS, designed by design(),
over amplitudes a ∈ MAP_AMPLITUDES (up to 100 %) and randomness η ∈ RANDOMNESS.  Each cell
records whether continuation of the linear design meets a singular point before its closest
approach to the target (``singular_path``: the closest configuration is the singular end of the
path, so the target lies beyond it) and whether refinement with the defaults fails
(``refinement_failed``, or the cell's time bound).  Every run is bounded: IPOPT by
MAP_IPOPT_S per solve, each cell's continuation and refinement by CELL_BUDGET_S (a
``time_budget``).

Part 3 (``--scale``: motion at scale, issue 13).  Medians of REPEATS runs, with the machine's
load average before and after (``/proc/loadavg``; the machine is shared):
  * a general (non-periodic) frame of 10⁴ degrees of freedom: two jittered triangulated patches
    of 2500 nodes (rigid, thousands of self-stresses) joined by two equal parallel bars, a
    parallelogram linkage whose motion meets a branch point each way (the bars line up with
    their anchors); ``trace_motion`` with the default step, to both singular points;
  * the 50 × 50 auxetic sheet (ν = −0.5, 15 202 degrees of freedom) to the end of its strain
    range, the point where nodes of neighbouring modules collide: the periodic route (one
    cell traced, tiled, checked and the collision located on the sheet, ``periodic.py``), and
    once the sheet's own sparse continuation for comparison;
  * a 3D chain of 64 blocks (``lattice.auxetic_chain_3d``, 2118 degrees of freedom) along its
    mode to parameter ±0.1.
Writes <out>/finite_motion_scale.json and <out>/finite_motion_scale.md.

Writes <out>/finite_motion_bench.json and <out>/finite_motion.png (matplotlib, a
benchmark-only dependency).  The machine may be shared: medians and ratios are the figures to
quote.  BLAS runs single-threaded so the timings do not fight over the cores.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import inspect
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from zeromode.service.wire.examples import example_request
from zeromode.service.wire.responses import json_safe
from zeromode.solver.budget import time_budget
from zeromode.solver.construction.design import design
from zeromode.solver.errors import DomainError
from zeromode.solver.motion.finite_motion import motion_fidelity
from zeromode.solver.motion.refine import RefinementFailed, refine, target_displacement

KS = (2, 4, 8, 16)
TOLS = (1e-4, 1e-6, 1e-8)
_DEFAULTS = inspect.signature(refine).parameters
DEFAULT_K, DEFAULT_TOL = _DEFAULTS["K"].default, _DEFAULTS["tol"].default
SPEED_AMPLITUDES = (0.1, 0.2)
RANDOM_SHAPES = ((3, 2), (4, 3))  # (k, d): 2D with 3 specified nodes, 3D with 4
MAP_AMPLITUDES = (0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0)
RANDOMNESS = (0.0, 0.25, 0.5, 0.75, 1.0)
MAP_IPOPT_S = 2.0
CELL_BUDGET_S = 5.0
# IPOPT statuses of a run stopped by the time bound (a failure the bound, not the method, made).
TIME_STOPS = ("Maximum_WallTime_Exceeded", "Maximum_CpuTime_Exceeded")
LINEAR, CONTINUATION = "linear design only", "linear + continuation"


def refine_method(K: int, tol: float) -> str:
    return f"refine K={K} tol={tol:.0e}"


def targets(seeds) -> list[dict]:
    """The outward square (the paper's Fig. 3b request) and seeded random 2D k = 3 / 3D k = 4."""
    square = example_request("outward_2d")
    out = [
        {
            "name": "outward_2d",
            "x_s": np.asarray(square["positions"], float),
            "u_s": np.asarray(square["motions"][0], float),
            "seed": square["options"]["seed"],
        }
    ]
    for k, d in RANDOM_SHAPES:
        for seed in seeds:
            rng = np.random.default_rng(seed)
            x_s, u_s = rng.standard_normal((k, d)), rng.standard_normal((k, d))
            out.append({"name": f"random_{d}d_k{k}_s{seed}", "x_s": x_s, "u_s": u_s, "seed": seed})
    return out


def clock() -> np.ndarray:
    """(wall, CPU) seconds now: CPU time of this process is the load-insensitive companion of
    the wall time on a shared machine (IPOPT runs in this thread, BLAS single-threaded)."""
    return np.array([time.perf_counter(), time.process_time()])


def timed_design(x_s, u_s, seed: int, repeats: int = 3):
    """(Design, median (wall, CPU) ms over ``repeats`` identical calls)."""
    times = []
    for _ in range(repeats):
        t0 = clock()
        result = design(x_s, u_s, seed=seed)
        times.append(1e3 * (clock() - t0))
    return result, np.median(times, axis=0)


def run_refine(frame, u_s, a: float, **options) -> dict:
    """One refine() call: status, ε after (the best frame's on failure), wall/CPU/IPOPT time."""
    t0 = clock()
    try:
        res, status, message = refine(frame, u_s, a, **options), "ok", None
    except RefinementFailed as exc:
        res, status, message = exc.best, exc.code, exc.message
    except DomainError as exc:  # the cell's time budget, or a frame refine() does not take
        wall, cpu = 1e3 * (clock() - t0)
        return {"status": exc.code, "message": exc.message, "wall_ms": wall, "cpu_ms": cpu}
    wall, cpu = 1e3 * (clock() - t0)
    return {
        "status": status,
        "message": message,
        "wall_ms": wall,
        "cpu_ms": cpu,
        "ipopt_ms": res.ipopt_time_ms,
        "attempts": res.attempts,
        "epsilon_before": res.epsilon_before,
        "epsilon_after": res.epsilon_after,
    }


def speed_vs_accuracy(target_list) -> list[dict]:
    """One row per (target, a, method): wall and CPU time (design included) and ε."""
    rows = []
    for tgt in target_list:
        try:
            made, design_ms = timed_design(tgt["x_s"], tgt["u_s"], tgt["seed"])
        except DomainError as exc:
            print(f"{tgt['name']:20s} design failed: {exc.code}", flush=True)
            rows.append({"target": tgt["name"], "method": "design", "status": exc.code})
            continue
        frame = made.frame
        for a in SPEED_AMPLITUDES:
            base = {"target": tgt["name"], "amplitude": a}
            delta, _ = target_displacement(frame, tgt["u_s"], a)
            t0 = clock()
            fid, path = motion_fidelity(frame, delta)
            continuation_ms = 1e3 * (clock() - t0)
            for method, status, spent in (
                (LINEAR, "ok", design_ms),
                (CONTINUATION, path.status, design_ms + continuation_ms),
            ):
                rows.append(
                    {
                        **base,
                        "method": method,
                        "status": status,
                        "time_ms": spent[0],
                        "cpu_ms": spent[1],
                        "epsilon": fid.epsilon,
                    }
                )
            print(
                f"{tgt['name']:20s} a={a:.2f} design {design_ms[0]:6.1f} ms  continuation "
                f"{continuation_ms[0]:6.1f} ms  eps_linear {fid.epsilon:.2e} ({path.status})",
                flush=True,
            )
            for K in KS:
                for tol in TOLS:
                    run = run_refine(frame, tgt["u_s"], a, K=K, tol=tol)
                    rows.append(
                        {
                            **base,
                            "method": refine_method(K, tol),
                            "K": K,
                            "tol": tol,
                            "status": run["status"],
                            "message": run["message"],
                            "time_ms": design_ms[0] + run["wall_ms"],
                            "cpu_ms": design_ms[1] + run["cpu_ms"],
                            "ipopt_ms": run.get("ipopt_ms"),
                            "epsilon": run.get("epsilon_after", np.nan),
                        }
                    )
                    print(
                        f"{'':20s} K={K:2d} tol={tol:.0e} {run['status']:17s} "
                        f"eps {run.get('epsilon_after', np.nan):.2e}  {run['wall_ms']:7.1f} ms",
                        flush=True,
                    )
    return rows


def methods() -> list[str]:
    return [LINEAR, CONTINUATION] + [refine_method(K, tol) for K in KS for tol in TOLS]


def summarise(rows: list[dict]) -> list[dict]:
    """Median time (wall and CPU) and ε per method, and which medians are Pareto-optimal
    (minimise both), by wall time (the chart) and by CPU time (insensitive to the load)."""
    table = []
    for m in methods():
        sel = [r for r in rows if r["method"] == m and np.isfinite(r.get("epsilon") or np.nan)]
        if not sel:
            continue
        table.append(
            {
                "method": m,
                "median_time_ms": float(np.median([r["time_ms"] for r in sel])),
                "median_cpu_ms": float(np.median([r["cpu_ms"] for r in sel])),
                "median_epsilon": float(np.median([r["epsilon"] for r in sel])),
                "max_epsilon": float(np.max([r["epsilon"] for r in sel])),
                "median_ipopt_ms": float(np.median([r["ipopt_ms"] for r in sel]))
                if all(r.get("ipopt_ms") is not None for r in sel)
                else None,
                "failures": sum(r["status"] not in ("ok", "singular_path") for r in sel),
                "singular_paths": sum(r["status"] == "singular_path" for r in sel),
                "runs": len(sel),
            }
        )
    for row in table:
        row["on_front"] = _non_dominated(row, table, "median_time_ms")
        row["on_front_cpu"] = _non_dominated(row, table, "median_cpu_ms")
    return table


def _non_dominated(row: dict, table: list[dict], time_key: str) -> bool:
    """No other median is at least as fast and at least as accurate, and better in one."""
    mine = (row[time_key], row["median_epsilon"])
    return not any(
        o[time_key] <= mine[0]
        and o["median_epsilon"] <= mine[1]
        and (o[time_key], o["median_epsilon"]) != mine
        for o in table
    )


def mixed_motion(x_s: np.ndarray, eta: float, rng: np.random.Generator) -> np.ndarray:
    """u_S = (1 − η)·dilation + η·random, each of unit RMS over the specified nodes."""

    def unit(u):
        return u / np.sqrt(np.mean(np.sum(u**2, axis=1)))

    return (1 - eta) * unit(x_s - x_s.mean(axis=0)) + eta * unit(rng.standard_normal(x_s.shape))


def continuation(frame, delta) -> dict:
    """The linear design's motion towards x_S + Δ_S: ``status`` is ``singular_path`` when it
    stops at a singular point before its closest approach to the target (the closest
    configuration is the singular end), ``ok`` otherwise, or a DomainError's code (e.g. the
    cell's time budget); with ε of the linear design and the singular points met anywhere on
    the traced path (both ways, to 3× the linear estimate of the target's parameter)."""
    try:
        fid, path = motion_fidelity(frame, delta)
    except DomainError as exc:
        return {"status": exc.code}
    blocked = any(
        np.sign(sg.parameter) == np.sign(fid.parameter)
        and abs(sg.parameter) <= abs(fid.parameter) * (1 + 1e-9)
        for sg in path.singularities
    )
    return {
        "status": "singular_path" if blocked else "ok",
        "epsilon_linear": fid.epsilon,
        "singular_points": len(path.singularities),
    }


def failure_map(seeds, amplitudes, randomness) -> list[dict]:
    rows = []
    for k, d in RANDOM_SHAPES:
        for eta in randomness:
            for seed in seeds:
                rng = np.random.default_rng(1000 + seed)
                x_s = rng.standard_normal((k, d))
                u_s = mixed_motion(x_s, eta, rng)
                base = {"dim": d, "k": k, "eta": eta, "seed": seed}
                try:
                    frame = design(x_s, u_s, seed=seed).frame
                except DomainError as exc:
                    rows.append({**base, "design": exc.code})
                    continue
                for a in amplitudes:
                    delta, _ = target_displacement(frame, u_s, a)
                    t0 = clock()
                    with time_budget(CELL_BUDGET_S):
                        cont = continuation(frame, delta)
                    with time_budget(CELL_BUDGET_S):
                        ref = run_refine(frame, u_s, a, max_time_s=MAP_IPOPT_S)
                    rows.append(
                        {
                            **base,
                            "design": "ok",
                            "amplitude": a,
                            "continuation": cont["status"],
                            "epsilon_linear": cont.get("epsilon_linear"),
                            "singular_points": cont.get("singular_points"),
                            "refine": ref["status"],
                            "refine_message": ref["message"],
                            "refine_time_bound": ref["status"] == "too_expensive"
                            or any(stop in (ref["message"] or "") for stop in TIME_STOPS),
                            "epsilon_after": ref.get("epsilon_after"),
                            "wall_ms": 1e3 * (clock() - t0)[0],
                        }
                    )
                    print(
                        f"{d}D k={k} eta={eta:.2f} seed={seed} a={a:.2f}  continuation {cont['status']:13s} "
                        f"refine {ref['status']:17s} {rows[-1]['wall_ms']:7.0f} ms",
                        flush=True,
                    )
    return rows


def fractions(fail_rows, d, key, bad, amplitudes, randomness) -> tuple[np.ndarray, list]:
    """Fraction of designed targets per (η, a) cell whose ``key`` is in ``bad``, and 'n/m'
    notes with a '*' for each refinement the time bound stopped."""
    grid = np.full((len(randomness), len(amplitudes)), np.nan)
    notes = [["" for _ in amplitudes] for _ in randomness]
    for i, eta in enumerate(randomness):
        for j, a in enumerate(amplitudes):
            cell = [
                r
                for r in fail_rows
                if r["dim"] == d and r["eta"] == eta and r.get("amplitude") == a
            ]
            if cell:
                hits = sum(r[key] in bad for r in cell)
                grid[i, j] = hits / len(cell)
                bound = sum(r[key] in bad and r.get(f"{key}_time_bound", False) for r in cell)
                notes[i][j] = f"{hits}/{len(cell)}" + "*" * bound
    return grid, notes


def _front_line(ax, summary, right: float) -> None:
    """The Pareto front of the medians as a step line (down-right staircase) to ``right``."""
    front = sorted((r["median_time_ms"], r["median_epsilon"]) for r in summary if r["on_front"])
    ft, fe = zip(*front)
    ax.step(list(ft) + [right], list(fe) + [fe[-1]], where="post", color="black", lw=1.3, zorder=2)


def _mark_default(ax, summary, offset=None) -> None:
    """Ring refine()'s default (K, tol) median; with ``offset`` (points) also name it."""
    default = next(r for r in summary if r["method"] == refine_method(DEFAULT_K, DEFAULT_TOL))
    xy = (default["median_time_ms"], default["median_epsilon"])
    ax.scatter(*xy, s=420, facecolor="none", edgecolor="gold", lw=2.5, zorder=4)
    if offset is None:
        return
    ax.annotate(
        f"default K={DEFAULT_K}, tol={DEFAULT_TOL:.0e}"
        + ("" if default["on_front"] else " (off the front)"),
        xy,
        xytext=offset,
        textcoords="offset points",
        fontsize=9,
        arrowprops={"arrowstyle": "-", "color": "goldenrod"},
    )


def _label_points(ax, points, labels) -> None:
    """Label each point at the first of a few offsets whose text overlaps no marker and no
    label placed before it (display coordinates; the figure is drawn once to measure text)."""
    from matplotlib.transforms import Bbox

    fig = ax.figure
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    taken = [Bbox.from_bounds(x - 12, y - 12, 24, 24) for x, y in ax.transData.transform(points)]
    offsets = (
        (9, 6, "left"),
        (9, -14, "left"),
        (-9, 6, "right"),
        (-9, -14, "right"),
        (9, 16, "left"),
    )
    for xy, label in zip(points, labels):
        for dx, dy, ha in offsets:
            text = ax.annotate(
                label, xy, xytext=(dx, dy), textcoords="offset points", fontsize=7.5, ha=ha
            )
            box = text.get_window_extent(renderer)
            if not any(box.overlaps(t) for t in taken):
                break
            text.remove()
        else:  # every place is taken: keep the first
            text = ax.annotate(
                label, xy, xytext=offsets[0][:2], textcoords="offset points", fontsize=7.5
            )
            box = text.get_window_extent(renderer)
        taken.append(box)


def plot(rows, summary, fail_rows, amplitudes, randomness, path: Path) -> None:
    """Top: speed vs accuracy (all runs; zoom on the refinement medians with their interquartile
    ranges).  Bottom: the failure maps, singular_path and refinement failures, 2D and 3D."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    fig = plt.figure(figsize=(16, 13))
    outer = fig.add_gridspec(3, 1, height_ratios=(1.55, 0.12, 1), hspace=0.3)
    top = outer[0].subgridspec(1, 2, width_ratios=(1.15, 1), wspace=0.18)
    ax, zoom = fig.add_subplot(top[0]), fig.add_subplot(top[1])

    k_colours = dict(zip(KS, ("tab:blue", "tab:orange", "tab:green", "tab:red")))
    tol_markers = dict(zip(TOLS, ("o", "s", "^")))
    style = {LINEAR: ("dimgrey", "D"), CONTINUATION: ("tab:purple", "P")}
    for K in KS:
        for tol in TOLS:
            style[refine_method(K, tol)] = (k_colours[K], tol_markers[tol])
    timed = [
        r for r in rows if r.get("method") in style and np.isfinite(r.get("epsilon") or np.nan)
    ]
    right = 1.5 * max(r["time_ms"] for r in timed)
    for r in timed:
        colour, marker = style[r["method"]]
        ax.scatter(r["time_ms"], r["epsilon"], s=12, alpha=0.3, color=colour, marker=marker, lw=0)
    refined = [r for r in summary if r["method"].startswith("refine")]
    for row in summary:
        colour, marker = style[row["method"]]
        targets_ax = (ax, zoom) if row in refined else (ax,)
        for a in targets_ax:
            a.scatter(
                row["median_time_ms"],
                row["median_epsilon"],
                s=110,
                color=colour,
                marker=marker,
                edgecolor="black",
                lw=1.4 if row["on_front"] else 0.5,
                zorder=3,
            )
    for a in (ax, zoom):
        _front_line(a, summary, right)
        a.axhline(1e-6, color="black", ls=":", lw=0.8)
        a.text(0.01, 1e-6, "ε = 1e-6", transform=a.get_yaxis_transform(), va="bottom", fontsize=8)
        a.set_xscale("log")
        a.set_yscale("log")
        a.set_xlabel("wall time per target, design included [ms]")
    ax.set_xlim(right=right)
    ax.set_ylabel("finite-motion error ε(a) of the frame's motion")
    n_targets = len({r["target"] for r in timed})
    ax.set_title(
        f"Speed vs accuracy, {n_targets} designed targets × a ∈ {{10 %, 20 %}}\n"
        "small: one run; large: median per method (bold edge: on the front); line: Pareto front",
        fontsize=10,
    )
    # Zoom: medians of the refinement settings with the interquartile range of the runs.
    for row in refined:
        sel = [r for r in timed if r["method"] == row["method"]]
        t_q = np.percentile([r["time_ms"] for r in sel], (25, 75))
        e_q = np.percentile([r["epsilon"] for r in sel], (25, 75))
        colour = style[row["method"]][0]
        zoom.plot(t_q, [row["median_epsilon"]] * 2, color=colour, lw=0.8, alpha=0.6)
        zoom.plot([row["median_time_ms"]] * 2, e_q, color=colour, lw=0.8, alpha=0.6)
    t_lo = min(r["median_time_ms"] for r in refined)
    t_hi = max(r["median_time_ms"] for r in refined)
    zoom.set_xlim(t_lo / 1.6, t_hi * 1.6)
    e_lo = min(r["median_epsilon"] for r in refined)
    e_hi = max(r["median_epsilon"] for r in refined)
    zoom.set_ylim(e_lo / 30, e_hi * 30)
    zoom.set_title(
        "Zoom on the IPOPT refinement medians (K, tol)\nbars: interquartile range of the runs",
        fontsize=10,
    )
    _mark_default(ax, summary, (-150, -40))
    _mark_default(zoom, summary)
    _label_points(
        zoom,
        [(r["median_time_ms"], r["median_epsilon"]) for r in refined],
        [r["method"].removeprefix("refine ").replace(" tol=", ", ") for r in refined],
    )
    # Three legend columns of four: the methods and marks, the K colours, the tol markers.
    handles = [
        Line2D([], [], color=style[LINEAR][0], marker="D", ls="", label=LINEAR),
        Line2D(
            [],
            [],
            color=style[CONTINUATION][0],
            marker="P",
            ls="",
            ms=8,
            label=CONTINUATION + " (same ε)",
        ),
        Line2D([], [], color="black", lw=1.3, label="Pareto front of the medians"),
        Line2D(
            [],
            [],
            color="gold",
            marker="o",
            mfc="none",
            ms=12,
            mew=2.5,
            ls="",
            label="refine() defaults",
        ),
        *[
            Line2D([], [], color=k_colours[K], marker="o", ls="", label=f"refine K = {K}")
            for K in KS
        ],
        *[
            Line2D(
                [], [], color="grey", marker=tol_markers[t], ls="", label=f"refine tol = {t:.0e}"
            )
            for t in TOLS
        ],
        Line2D([], [], ls="", label=" "),
    ]
    legend_ax = fig.add_subplot(outer[1])
    legend_ax.axis("off")
    legend_ax.legend(handles=handles, fontsize=9, ncol=3, loc="center", frameon=False)

    panels = (
        ("continuation", {"singular_path"}, "continuation meets a\nsingular point (singular_path)"),
        (
            "refine",
            {"refinement_failed", "too_expensive"},
            "refine (defaults) fails\n(refinement_failed or over budget)",
        ),
    )
    maps = outer[2].subgridspec(1, 4, wspace=0.35)
    image = None
    for col, ((k, d), (key, bad, label)) in enumerate(
        (shape, panel) for shape in RANDOM_SHAPES for panel in panels
    ):
        axm = fig.add_subplot(maps[col])
        values, notes = fractions(fail_rows, d, key, bad, amplitudes, randomness)
        image = axm.imshow(values, origin="lower", cmap="Reds", vmin=0, vmax=1, aspect="auto")
        for i in range(len(randomness)):
            for j in range(len(amplitudes)):
                dark = np.isfinite(values[i, j]) and values[i, j] > 0.6
                axm.text(
                    j,
                    i,
                    notes[i][j],
                    ha="center",
                    va="center",
                    fontsize=7,
                    color="white" if dark else "black",
                )
        axm.set_xticks(
            range(len(amplitudes)), [f"{a:.0%}" for a in amplitudes], fontsize=7.5, rotation=45
        )
        axm.set_yticks(range(len(randomness)), [f"{e:g}" for e in randomness], fontsize=8)
        axm.set_xlabel("amplitude a", fontsize=9)
        if col == 0:
            axm.set_ylabel("target randomness η", fontsize=9)
        axm.set_title(f"{d}D, k = {k}: {label}", fontsize=9.5)
    cbar = fig.colorbar(image, ax=fig.axes[3:], fraction=0.02, pad=0.02)
    cbar.set_label("fraction of designed targets", fontsize=9)
    fig.text(
        0.5,
        0.075,
        f"cells: failures / designed targets (seeded); * = a refinement stopped by the "
        f"{MAP_IPOPT_S:g} s IPOPT bound of this map; refine() defaults K={DEFAULT_K}, "
        f"tol={DEFAULT_TOL:.0e}",
        ha="center",
        fontsize=9,
    )
    fig.savefig(path, dpi=110, bbox_inches="tight")


def report(summary) -> None:
    for row in summary:
        ipopt = row["median_ipopt_ms"]
        print(
            f"{row['method']:26s} median wall {row['median_time_ms']:7.1f} ms  CPU {row['median_cpu_ms']:7.1f} ms"
            + (f"  IPOPT {ipopt:6.1f} ms" if ipopt is not None else " " * 18)
            + f"  eps {row['median_epsilon']:.2e} (max {row['max_epsilon']:.1e})  failures {row['failures']}/{row['runs']}"
            + ("  [front]" if row["on_front"] else "")
            + ("  [CPU front]" if row["on_front_cpu"] else "")
        )
    default = next(r for r in summary if r["method"] == refine_method(DEFAULT_K, DEFAULT_TOL))
    for key, what in (("on_front", "wall-time"), ("on_front_cpu", "CPU-time")):
        print(
            f"refine() defaults K={DEFAULT_K}, tol={DEFAULT_TOL:.0e} "
            + ("lie" if default[key] else "do NOT lie")
            + f" on the {what} Pareto front of the medians."
        )


def loadavg() -> str:
    """The 1-, 5- and 15-minute load averages (the machine is shared by several agents)."""
    return " ".join(Path("/proc/loadavg").read_text().split()[:3])


def parallelogram_of_patches(per_patch: int, angle_deg: float = 75.0):
    """Two jittered triangulated patches (benchmarks/lattices.py) joined by two equal parallel
    bars at ``angle_deg`` from their anchors' line: one nontrivial mode, a branch point each way."""
    from lattices import triangulated_lattice

    from zeromode.solver import Frame

    patch = triangulated_lattice(per_patch, jitter=0.1, seed=0)
    x, n = patch.positions, patch.n_nodes
    top = int(np.argmax(x[:, 1] - 0.01 * x[:, 0]))
    bottom = int(np.argmin(x[:, 1] + 0.01 * x[:, 0]))
    angle = np.deg2rad(angle_deg)
    shift = 1.5 * np.ptp(x[:, 0]) * np.array([np.cos(angle), np.sin(angle)])
    return Frame.build(
        np.vstack([x, x + shift]),
        np.vstack([patch.edges, patch.edges + n, [[top, top + n], [bottom, bottom + n]]]),
    )


def sheet_tiling(nx: int, ny: int) -> np.ndarray:
    """(cell node, cell x, cell y) of each node of lattice.auxetic_sheet(nx, ny): the corner grid
    first (row-major in y) as node 0 of its cell, then each module's two nodes as nodes 1, 2."""
    p, q = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1))
    corners = np.column_stack([np.zeros(p.size, int), p.ravel(), q.ravel()])
    i, j = np.meshgrid(np.arange(nx), np.arange(ny))
    cells = np.column_stack([i.ravel(), j.ravel()])
    inner = [np.column_stack([np.full(len(cells), 1 + s), cells]) for s in (0, 1)]
    return np.vstack([corners, np.stack(inner, axis=1).reshape(-1, 3)])


SCALE_REPEATS = 3


def timed_runs(fn, repeats: int = SCALE_REPEATS):
    """(median wall seconds, last result) over ``repeats`` calls."""
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


def path_row(name: str, frame, seconds: float, path, note: str, strain=None) -> dict:
    return {
        "case": name,
        "dof": frame.dim * frame.n_nodes,
        "bars": frame.n_edges,
        "median_s": seconds,
        "method": path.method,
        "configurations": len(path.parameter),
        "singular_points": [
            {"parameter": sg.parameter, "extra_zero_modes": sg.extra_zero_modes, "sigma": sg.sigma}
            for sg in path.singularities
        ],
        "max_relative_bar_error": path.max_relative_bar_error,
        "strain_at_end": strain,
        "note": note,
    }


def motion_at_scale() -> dict:
    """Part 3 (module docstring)."""
    from zeromode.solver.applications import lattice as lattices
    from zeromode.solver.motion.boundary_strain import boundary_strains
    from zeromode.solver.motion.finite_motion import trace_motion
    from zeromode.solver.motion.periodic import PeriodicCell, tiled_motion, trace_periodic_motion

    rows, load = [], {"before": loadavg()}
    general = parallelogram_of_patches(2500)
    seconds, path = timed_runs(lambda: trace_motion(general, amplitude=1.0))
    rows.append(path_row("general frame, parallelogram of two patches", general, seconds, path, "sparse continuation, both ways to the branch points"))
    print(rows[-1], flush=True)

    sheet = lattices.auxetic_sheet(50, 50, poisson=-0.5)
    tiling = sheet_tiling(50, 50)
    boundary = {k: np.asarray(v) for k, v in sheet.boundary.items()}

    def periodic():
        cell = PeriodicCell.from_frame(sheet.frame, tiling, [[2.0, 0.0], [0.0, 2.0]])
        return tiled_motion(sheet.frame, tiling, cell, trace_periodic_motion(cell, tiling, amplitude=0.3, direction="forward"))

    def end_strain(p):
        moved = p.positions[p.singularities[-1].step] if p.singularities else p.positions[-1]
        return boundary_strains(sheet.frame.positions, moved - sheet.frame.positions, boundary)[0]

    seconds, path = timed_runs(periodic)
    rows.append(path_row("auxetic sheet 50 × 50, periodic route", sheet.frame, seconds, path, "cell traced, tiled, checked on the sheet; collision located on the sheet", end_strain(path)))
    print(rows[-1], flush=True)
    seconds, path = timed_runs(lambda: trace_motion(sheet.frame, mode=sheet.mode, amplitude=0.3, direction="forward"), 1)
    rows.append(path_row("auxetic sheet 50 × 50, sheet continuation", sheet.frame, seconds, path, "every node, no periodicity assumed (one run)", end_strain(path)))
    print(rows[-1], flush=True)

    # lattice.py refuses chains above its MAX_CHAIN_BLOCKS while its states were traced by the
    # dense continuation; the sparse one lifts that reason, so the benchmark raises the limit.
    lattices.MAX_CHAIN_BLOCKS = max(lattices.MAX_CHAIN_BLOCKS, 64)
    chain = lattices.auxetic_chain_3d(64, poisson=-0.5)
    seconds, path = timed_runs(lambda: trace_motion(chain.frame, mode=chain.mode, amplitude=0.1))
    rows.append(path_row("3D chain of 64 blocks", chain.frame, seconds, path, "sparse continuation, ±0.1"))
    print(rows[-1], flush=True)
    load["after"] = loadavg()
    return {"rows": rows, "loadavg": load, "repeats": SCALE_REPEATS}


def scale_markdown(data: dict) -> str:
    lines = [
        "# Finite motion at scale",
        "",
        ("Generated by `python benchmarks/bench_finite_motion.py --scale`: medians of "
        f"{data['repeats']} runs (wall time) on the shared 2-core machine, load average "
        f"{data['loadavg']['before']} before and {data['loadavg']['after']} after (1, 5, 15 min)."),
        "",
        "| case | dN | bars | method | median (s) | configurations | singular points (parameter, extra zero modes, σ/σ_max) | ε_x at the end | max bar error |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in data["rows"]:
        sing = "; ".join(
            f"{s['parameter']:+.4f}, {s['extra_zero_modes']}, {s['sigma']:.1e}" for s in r["singular_points"]
        ) or "none"
        strain = "" if r["strain_at_end"] is None else f"{r['strain_at_end']:+.4f}"
        lines.append(
            f"| {r['case']} | {r['dof']} | {r['bars']} | {r['method']} | {r['median_s']:.1f} | "
            f"{r['configurations']} | {sing} | {strain} | {r['max_relative_bar_error']:.1e} |"
        )
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer targets and cells (≤ 2 min)")
    parser.add_argument("--scale", action="store_true", help="only part 3, motion at scale")
    parser.add_argument("--out", help="output folder (default docs/; with --quick a temp folder)")
    parser.add_argument("--replot", action="store_true", help="redraw the PNG from the saved JSON")
    args = parser.parse_args(argv)
    if args.out:
        out = Path(args.out)
    elif args.quick:  # a smoke run must not overwrite the committed figures
        out = Path(tempfile.gettempdir()) / "zeromode_finite_motion"
    else:
        out = Path(__file__).resolve().parents[1] / "docs"
    out.mkdir(parents=True, exist_ok=True)
    if args.scale:
        data = motion_at_scale()
        (out / "finite_motion_scale.json").write_text(json.dumps(json_safe(data), indent=1))
        (out / "finite_motion_scale.md").write_text(scale_markdown(data))
        print(f"wrote {out / 'finite_motion_scale.md'}")
        return 0
    data_file = out / "finite_motion_bench.json"
    if args.replot:
        data = json.loads(data_file.read_text())
    else:
        t0 = time.perf_counter()
        if args.quick:
            seeds, map_seeds = range(2), range(1)
            amplitudes, randomness = (0.05, 0.2, 0.5, 1.0), (0.0, 0.5, 1.0)
        else:
            seeds, map_seeds, amplitudes, randomness = (
                range(5),
                range(3),
                MAP_AMPLITUDES,
                RANDOMNESS,
            )
        rows = speed_vs_accuracy(targets(seeds))
        fail_rows = failure_map(map_seeds, amplitudes, randomness)
        data = {
            "settings": {
                "KS": KS,
                "TOLS": TOLS,
                "default_K": DEFAULT_K,
                "default_tol": DEFAULT_TOL,
                "speed_amplitudes": SPEED_AMPLITUDES,
                "map_amplitudes": amplitudes,
                "randomness": randomness,
                "map_ipopt_s": MAP_IPOPT_S,
                "cell_budget_s": CELL_BUDGET_S,
                "quick": args.quick,
            },
            "speed_vs_accuracy": rows,
            "failure_map": fail_rows,
            "runtime_s": time.perf_counter() - t0,
        }
    data["summary"] = summarise(data["speed_vs_accuracy"])
    data_file.write_text(json.dumps(json_safe(data), indent=1))
    report(data["summary"])
    settings = data["settings"]
    plot(
        data["speed_vs_accuracy"],
        data["summary"],
        data["failure_map"],
        settings["map_amplitudes"],
        settings["randomness"],
        out / "finite_motion.png",
    )
    print(f"wrote {data_file} and {out / 'finite_motion.png'} ({data['runtime_s']:.0f} s of runs)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
