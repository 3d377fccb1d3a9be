"""Benchmarks of allosteric design (issue 14).

Run from the repository root:  .venv/bin/python -m benchmarks.bench_allostery [--quick] [--part P]
Writes docs/benchmarks/allostery.md (tables), docs/benchmarks/allostery.json (every row),
docs/img/allostery_distance.png and docs/img/allostery_network.png. Parts (default: all):
  distance  design_allosteric on the same site shapes (seeded, d + 1 nodes each, random motions)
            with the target moved D site sizes away, D = 3 … 200, 2D and 3D, economy chains: target error from the
            frame's own null space (numpy SVD here, independent of the solver), the solver's gap
            and sensitivities, modules, nodes and wall time; the floors (error ≤ 1e-9,
            sensitivity not growing with D, ≤ 5 s at D = 96 and ≤ 20 s at D = 200) are checked;
  amplification
            the builder's amplification A against D = 12, 48, 96, 200 in 2D and 3D, default
            (robustness "robust") and "economy" chains, same seeded sites: the reported A and
            A_worst, and A sampled here — every node moved by 1e-7 mean bar lengths in a seeded
            random direction, the zero mode of the perturbed frame from numpy's SVD (svd_null),
            driven by u_src, ‖δw_T‖/(1e-7 ‖w_T‖), worst of four perturbations — against the
            issue's floor A ≤ 100·√(D/12);
  network   the tuning-by-pruning peer (benchmarks/pruning.py) and network_allostery.tune_network
            on the same given networks (benchmarks/allostery_tasks.py: jammed-like 2D networks,
            ΔZ = 0.5, a source pair and a distant target pair), N = 50 … 10⁴, η* ∈ {+1, −1, +2,
            +20, −100}: success (|η − η*| ≤ 1e-9·max(|η*|, 1), and the peer's 1 %), error, bars
            changed, nodes added, time. η of an answer is measured on its final frame: the peer's
            from a fresh factorisation of its pruned network, ours from the zero mode the modified
            frame's source strain drives (allostery.response, a solve on the frame alone), the bar
            extensions of the returned mode, and up to SVD_MAX_NODES numpy's SVD of C;
  edits     the issue's 18 tasks (N = 100, 400, 1 600, seeds 0 and 1, η* ∈ {+1, +2, −1}, ΔZ = 0.5,
            z ≈ 4.5): bars changed by the pruning peer (to its 1 % stop), by the elastic response model
            (elastic_allostery.tune_elastic, exact, with the peer's own stiffnesses k = 1/ℓ) and by the
            mechanism (tune_network); η of every answer recomputed here by a dense solve of
            (K + R Rᵀ) u = q_S (R the rigid motions), zero modes by numpy's SVD up to SVD_MAX_NODES;
            CPU time of each call;
  modes     /v1/design (design.design) with M = 1 … 4 motions in 2D and 3D: success (checked by
            numpy's SVD of the returned frame) and time.
Timings are wall-clock on a shared, noisy machine with single-threaded BLAS: read medians.
"""

from __future__ import annotations

import os

# One BLAS thread: the machine is shared, and oversubscribed threads made dense SVDs 5× slower.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np

from benchmarks.allostery_tasks import DEFAULT_EXCESS_COORDINATION, make_task, random_network
from benchmarks.pruning import prune_for_allostery
from zeromode.solver.applications.allostery import design_allosteric, response
from zeromode.solver.applications.elastic_allostery import tune_elastic
from zeromode.solver.applications.network_allostery import pair_strain, tune_network
from zeromode.solver.construction.design import design
from zeromode.solver.errors import DomainError
from zeromode.solver.tolerances import TARGET_ERROR_MAX

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "benchmarks" / "allostery.md"
RAW = ROOT / "docs" / "benchmarks" / "allostery.json"
IMG = ROOT / "docs" / "img"
DISTANCES = (3.0, 6.0, 12.0, 24.0, 48.0, 96.0, 200.0)
RATIOS = (1.0, -1.0, 2.0, 20.0, -100.0)
# Up to this many nodes the network answers are re-checked by a dense SVD of C (≈ 3 s at 800).
SVD_MAX_NODES = 800


def cells(*values) -> str:
    """One row of a Markdown table."""
    return "| " + " | ".join(str(v) for v in values) + " |"


# ----------------------------------------------------------------------------- distance


def sites(d: int, distance: float, seed: int):
    """The seeded site shapes of tests/test_allostery.py: d + 1 nodes each, random motions, the
    target moved ``distance`` along x."""
    rng = np.random.default_rng([d, seed])
    x_src, x_tgt = rng.standard_normal((d + 1, d)), rng.standard_normal((d + 1, d))
    u_src, u_tgt = rng.standard_normal((d + 1, d)), rng.standard_normal((d + 1, d))
    x_tgt[:, 0] += distance
    return x_src, u_src, x_tgt, u_tgt


def svd_null(positions: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """N(C) (dN × z) from numpy's SVD of C, built here from its definition on normalised positions
    (row b: x_i − x_j at node i, x_j − x_i at node j); rank at 1e-9 of the largest singular value."""
    x = positions - positions.mean(axis=0)
    x = x / np.sqrt(np.mean(np.sum(x**2, axis=1)))
    n, d = x.shape
    diff = x[edges[:, 0]] - x[edges[:, 1]]
    c = np.zeros((len(edges), n * d))
    rows = np.arange(len(edges))[:, None]
    c[rows, edges[:, :1] * d + np.arange(d)] = diff
    c[rows, edges[:, 1:] * d + np.arange(d)] = -diff
    _, s, vt = np.linalg.svd(c, full_matrices=True)
    return vt[int(np.count_nonzero(s > 1e-9 * s[0])) :].T


def driven(null: np.ndarray, source, u_src: np.ndarray) -> np.ndarray:
    """(N, d) zero mode in span(null) whose source rows match u_src (least squares)."""
    d = u_src.shape[1]
    rows = (np.asarray(source)[:, None] * d + np.arange(d)).ravel()
    coef, *_ = np.linalg.lstsq(null[rows], u_src.ravel(), rcond=None)
    return (null @ coef).reshape(-1, d)


def independent_error(frame, source, target, u_src, u_tgt) -> float:
    """‖w_T − u_tgt‖/‖u_tgt‖ with w the zero mode (numpy SVD, ``svd_null``) driven by u_src."""
    w = driven(svd_null(frame.positions, frame.edges), source, u_src)
    return float(np.linalg.norm(w[list(target)] - u_tgt) / np.linalg.norm(u_tgt))


def run_distance(seeds: int) -> list[dict]:
    rows = []
    for d in (2, 3):
        for distance in DISTANCES:
            for seed in range(seeds):
                x_src, u_src, x_tgt, u_tgt = sites(d, distance, seed)
                t0 = time.perf_counter()
                try:
                    result = design_allosteric(x_src, u_src, x_tgt, u_tgt, seed=0, robustness="economy")
                except DomainError as exc:
                    rows.append({"d": d, "distance": distance, "seed": seed, "ok": False, "code": exc.code,
                                 "time": time.perf_counter() - t0})
                    continue
                elapsed = time.perf_counter() - t0
                f = result.figures
                frame = result.design.frame
                rows.append({
                    "d": d, "distance": distance, "seed": seed, "ok": True, "time": elapsed,
                    "error": f.target_error,
                    "independent_error": independent_error(frame, result.source, result.target, u_src, u_tgt),
                    "gap": f.gap, "sensitivity": f.sensitivity, "motion_sensitivity": f.motion_sensitivity,
                    "modules": result.modules, "nodes": frame.n_nodes, "bars": frame.n_edges,
                })
                print(f"distance d={d} D={distance:g} seed={seed}: {rows[-1]}", flush=True)
    return rows


def distance_table(rows: list[dict]) -> list[str]:
    lines = [
        ("| d | D | solved | max error (solver) | max error (numpy SVD) | min gap | median sensitivity "
        "| median motion sensitivity | modules | nodes | median time [s] | max time [s] |"),
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for d in (2, 3):
        for distance in DISTANCES:
            runs = [r for r in rows if r["d"] == d and r["distance"] == distance]
            ok = [r for r in runs if r["ok"]]
            if not ok:
                lines.append(f"| {d} | {distance:g} | 0/{len(runs)} | – | – | – | – | – | – | – | – | – |")
                continue
            lines.append(
                cells(
                    d, f"{distance:g}", f"{len(ok)}/{len(runs)}",
                    f"{max(r['error'] for r in ok):.1e}", f"{max(r['independent_error'] for r in ok):.1e}",
                    f"{min(r['gap'] for r in ok):.1e}", f"{np.median([r['sensitivity'] for r in ok]):.1e}",
                    f"{np.median([r['motion_sensitivity'] for r in ok]):.1e}",
                    int(np.median([r["modules"] for r in ok])), int(np.median([r["nodes"] for r in ok])),
                    f"{np.median([r['time'] for r in runs]):.2f}", f"{max(r['time'] for r in runs):.2f}",
                )
            )
    return lines


def distance_floors(rows: list[dict]) -> list[str]:
    """The issue's floors, each with its verdict."""
    out = []
    ok = [r for r in rows if r["ok"]]
    worst = max(max(r["error"], r["independent_error"]) for r in ok)
    out.append(f"- target error ≤ 1e-9 at every distance: {'met' if worst <= TARGET_ERROR_MAX and len(ok) == len(rows) else 'NOT met'} (worst {worst:.1e}, {len(ok)}/{len(rows)} solved)")
    for d in (2, 3):
        growth = []
        for seed in sorted({r["seed"] for r in ok}):
            s = {r["distance"]: r["sensitivity"] for r in ok if r["d"] == d and r["seed"] == seed}
            if 24.0 in s and 200.0 in s:
                growth.append(s[200.0] / s[24.0])
        verdict = "met" if growth and max(growth) <= 2 else "NOT met"
        out.append(f"- {d}D sensitivity not growing with distance (D = 200 vs 24, same sites): {verdict} (ratios {', '.join(f'{g:.2f}' for g in growth)})")
    for distance, limit in ((96.0, 5.0), (200.0, 20.0)):
        slowest = max(r["time"] for r in rows if r["distance"] == distance)
        out.append(f"- ≤ {limit:g} s at D = {distance:g}: {'met' if slowest <= limit else 'NOT met'} (slowest {slowest:.2f} s)")
    return out


def distance_chart(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    colours = {2: "#1f77b4", 3: "#d62728"}
    for d in (2, 3):
        ok = [r for r in rows if r["ok"] and r["d"] == d]
        dist = sorted({r["distance"] for r in ok})

        def stat(key, fn, dist=dist, ok=ok):
            return [fn([r[key] for r in ok if r["distance"] == D]) for D in dist]

        axes[0].plot(dist, stat("independent_error", max), "o-", color=colours[d], label=f"{d}D (numpy SVD, worst seed)")
        axes[0].plot(dist, stat("error", max), "x--", color=colours[d], alpha=0.6, label=f"{d}D (reported)")
        axes[1].plot(dist, stat("sensitivity", np.median), "o-", color=colours[d], label=f"{d}D target shape")
        axes[1].plot(dist, stat("motion_sensitivity", np.median), "s:", color=colours[d], alpha=0.6,
                     label=f"{d}D whole target motion")
        axes[2].plot(dist, stat("time", np.median), "o-", color=colours[d], label=f"{d}D median")
        axes[2].plot(dist, stat("time", max), "v:", color=colours[d], alpha=0.6, label=f"{d}D slowest")
    axes[0].axhline(TARGET_ERROR_MAX, color="k", lw=0.8, ls="--")
    save_log_chart(
        fig, axes, "site distance D [site sizes]",
        (("accuracy (floor 1e-9)", "target error ‖w_T − u_T‖/‖u_T‖"),
         ("sensitivity (linearised)", "relative change per 1e-6 site-size perturbation"),
         ("time", "time per design [s]")),
        path,
    )


def save_log_chart(fig, axes, xlabel: str, titles, path: Path, titled: bool = True, xticks=()) -> None:
    """Log–log axes with grid and legend, each (title, y label); written to ``path``. titled=False
    keeps the titles the axes already have; ``xticks``: the only labelled x values."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    for ax, (title, label) in zip(axes, titles):
        ax.set_xscale("log")
        ax.set_yscale("log")
        if len(xticks):
            ax.set_xticks(list(xticks), [f"{t:g}" for t in xticks])
            ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel(xlabel)
        ax.set_ylabel(label)
        if titled:
            ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ----------------------------------------------------------------------------- amplification

AMPLIFICATION_DISTANCES = (12.0, 48.0, 96.0, 200.0)
# Node error of the sampled perturbations, in mean bar lengths (the issue's), and how many.
NODE_ERROR, PERTURBATIONS = 1e-7, 4


def amplification_floor(distance: float) -> float:
    """The issue's floor: what a serial chain of well-conditioned relays allows (√ of their number)."""
    return 100.0 * float(np.sqrt(distance / 12.0))


def sampled_amplification(frame, source, target, u_src) -> float:
    """Worst of PERTURBATIONS seeded perturbations of ‖δw_T‖/(ε‖w_T‖): every node moved by
    ε = NODE_ERROR mean bar lengths along a random unit vector, the response re-solved from
    numpy's SVD of the perturbed frame (svd_null, driven)."""
    x, edges = frame.positions, frame.edges
    mean_bar = float(np.mean(np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1)))
    w = driven(svd_null(x, edges), source, u_src)[list(target)]
    worst = 0.0
    for seed in range(PERTURBATIONS):
        e = np.random.default_rng(seed).standard_normal(x.shape)
        e /= np.linalg.norm(e, axis=1, keepdims=True)
        moved = driven(svd_null(x + NODE_ERROR * mean_bar * e, edges), source, u_src)[list(target)]
        worst = max(worst, float(np.linalg.norm(moved - w) / (NODE_ERROR * np.linalg.norm(w))))
    return worst


# The profile's near-source share counts the nodes within this fraction of the frame's length
# (along the source-to-target axis) from the source site's centroid.
SOURCE_REACH = 0.1


def amplification_profile(frame, source, target, u_src) -> dict:
    """Where A comes from, by finite differences on numpy's SVD (svd_null, driven; independent of
    the solver's linearisation): every node coordinate moved alone by NODE_ERROR·ℓ̄, the columns
    J_j = δw_T/δx_j of the target response's derivative. Returns the shares of ‖J‖_F² that are
    a rigid motion of the target site (J projected on its rigid motions, orthonormalised here)
    and that come from nodes within SOURCE_REACH of the frame's length from the source."""
    x, edges = frame.positions, frame.edges
    n, d = x.shape
    step = NODE_ERROR * float(np.mean(np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1)))
    target = list(target)
    w = driven(svd_null(x, edges), source, u_src)[target].ravel()
    jac = np.zeros((w.size, n * d))
    for j in range(n * d):
        moved = x.copy()
        moved.flat[j] += step
        jac[:, j] = (driven(svd_null(moved, edges), source, u_src)[target].ravel() - w) / step
    y = x[target] - x[target].mean(axis=0)
    rotations = [np.c_[-y[:, 1], y[:, 0]]] if d == 2 else [np.cross(axis, y) for axis in np.eye(3)]
    translations = [np.tile(axis, len(y)) for axis in np.eye(d)]
    basis, _ = np.linalg.qr(np.array(translations + [r.ravel() for r in rotations]).T)
    total = float(np.sum(jac**2))
    axis = x[target].mean(axis=0) - x[list(source)].mean(axis=0)
    along = (x - x[list(source)].mean(axis=0)) @ axis / np.linalg.norm(axis)
    near = np.repeat(along <= SOURCE_REACH * np.ptp(along), d)
    return {"rigid_share": float(np.sum((basis.T @ jac) ** 2)) / total, "source_share": float(np.sum(jac[:, near] ** 2)) / total}


def run_amplification(seeds: int) -> list[dict]:
    rows = []
    for d in (2, 3):
        for distance in AMPLIFICATION_DISTANCES:
            for robustness in ("robust", "economy"):
                for seed in range(seeds):
                    x_src, u_src, x_tgt, u_tgt = sites(d, distance, seed)
                    t0 = time.process_time()
                    result = design_allosteric(x_src, u_src, x_tgt, u_tgt, robustness=robustness)
                    cpu = time.process_time() - t0
                    f, frame = result.figures, result.design.frame
                    rows.append({
                        "d": d, "distance": distance, "robustness": robustness, "seed": seed, "cpu": cpu,
                        "amplification": f.amplification, "amplification_worst": f.amplification_worst,
                        "sampled": sampled_amplification(frame, result.source, result.target, u_src),
                        **(amplification_profile(frame, result.source, result.target, u_src) if robustness == "robust" else {}),
                        "error": f.target_error, "gap": f.gap, "nodes": frame.n_nodes, "modules": result.modules,
                        "chain": [result.options.port, result.options.growth, result.options.aspect],
                    })
                    print(f"amplification {rows[-1]}", flush=True)
    return rows


def amplification_table(rows: list[dict]) -> list[str]:
    lines = [
        ("| d | D | chains | floor 100·√(D/12) | A sampled (worst of 4, worst site) | A reported (RMS, worst site) "
         "| A_worst reported | nodes (median) | max target error | min gap | median CPU [s] |"),
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for d in (2, 3):
        for distance in AMPLIFICATION_DISTANCES:
            for robustness in ("robust", "economy"):
                runs = [r for r in rows if (r["d"], r["distance"], r["robustness"]) == (d, distance, robustness)]
                if not runs:
                    continue
                name = "default (robust)" if robustness == "robust" else "economy"
                lines.append(cells(
                    d, f"{distance:g}", name, f"{amplification_floor(distance):.0f}",
                    f"{max(r['sampled'] for r in runs):.0f}", f"{max(r['amplification'] for r in runs):.0f}",
                    f"{max(r['amplification_worst'] for r in runs):.0f}", int(np.median([r["nodes"] for r in runs])),
                    f"{max(r['error'] for r in runs):.1e}", f"{min(r['gap'] for r in runs):.1e}",
                    f"{np.median([r['cpu'] for r in runs]):.2f}",
                ))
    return lines


def amplification_floors(rows: list[dict]) -> list[str]:
    """The floor A(D) ≤ 100·√(D/12) for the default chains, each (d, D) with its verdict."""
    out = []
    for d in (2, 3):
        for distance in AMPLIFICATION_DISTANCES:
            runs = [r for r in rows if (r["d"], r["distance"], r["robustness"]) == (d, distance, "robust")]
            if not runs:
                continue
            worst = max(r["sampled"] for r in runs)
            floor = amplification_floor(distance)
            out.append(f"- {d}D, D = {distance:g}: {'met' if worst <= floor else 'NOT met'} "
                       f"(worst sampled A {worst:.0f}, floor {floor:.0f})")
    bounded = all(r["sampled"] <= r["amplification_worst"] * 1.01 for r in rows)
    ratios = [r["sampled"] / r["amplification"] for r in rows]
    out.append(f"- every sampled A ≤ the reported A_worst: {'yes' if bounded else 'NO'}; sampled worst of 4 / "
               f"reported A from {min(ratios):.2f} to {max(ratios):.2f}")
    return out


def profile_table(rows: list[dict]) -> list[str]:
    """Shares of ‖J‖_F² (amplification_profile) of the default designs, per (d, D): the site with
    the largest sampled A, and the range over the sites."""
    lines = [
        ("| d | D | worst site: sampled A | its rigid share of the target | its share from nodes near the source "
         "| rigid share, all sites | near-source share, all sites |"),
        "|---|---|---|---|---|---|---|",
    ]
    for d in (2, 3):
        for distance in AMPLIFICATION_DISTANCES:
            runs = [r for r in rows if (r["d"], r["distance"], r["robustness"]) == (d, distance, "robust")
                    and "rigid_share" in r]
            if not runs:
                continue
            worst = max(runs, key=lambda r: r["sampled"])
            lines.append(cells(
                d, f"{distance:g}", f"{worst['sampled']:.0f}", f"{worst['rigid_share']:.1%}", f"{worst['source_share']:.1%}",
                f"{min(r['rigid_share'] for r in runs):.0%} – {max(r['rigid_share'] for r in runs):.0%}",
                f"{min(r['source_share'] for r in runs):.0%} – {max(r['source_share'] for r in runs):.0%}",
            ))
    return lines


def amplification_chart(rows: list[dict], path: Path) -> None:
    """A against D, log–log, in the paper's colours (viz.style: 2D blue, 3D red), default chains
    solid, economy dashed; the floor in grey."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from zeromode.viz import style

    plt.rcParams["font.family"] = style.FONT_RASTER
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    dist = np.array(AMPLIFICATION_DISTANCES)
    line = np.geomspace(dist[0], dist[-1], 50)
    colours = {2: style.UNSPECIFIED[0], 3: style.SPECIFIED[0]}
    for ax, d in zip(axes, (2, 3)):
        ax.plot(line, [amplification_floor(D) for D in line], color=style.BAR, lw=2.5, label="floor 100·√(D/12)")
        for robustness, ls, name in (("robust", "-", "default (robust)"), ("economy", "--", "economy")):
            runs = [r for r in rows if r["d"] == d and r["robustness"] == robustness]
            if not runs:
                continue
            sampled = [max(r["sampled"] for r in runs if r["distance"] == D) for D in dist]
            reported = [max(r["amplification"] for r in runs if r["distance"] == D) for D in dist]
            ax.plot(dist, sampled, "o" + ls, color=colours[d], label=f"{name}: sampled, worst of 4")
            ax.plot(dist, reported, "x" + ls, color=colours[d], alpha=0.55, label=f"{name}: reported A")
        ax.set_title(f"{d}D: amplification a builder feels", color=style.TITLE_INK)
    save_log_chart(fig, axes, "site distance D", (
        ("2D", "A = relative response change / relative node error"), ("3D", "")), path, titled=False,
        xticks=AMPLIFICATION_DISTANCES)


# ----------------------------------------------------------------------------- network


def ours(task) -> dict:
    t0 = time.perf_counter()
    try:
        result = tune_network(task.frame, task.source_pair, task.target_pair, strain_ratio=task.ratio)
    except DomainError as exc:
        return {"ok_run": False, "code": exc.code, "time": time.perf_counter() - t0}
    elapsed = time.perf_counter() - t0
    frame = result.frame
    x, edges = frame.positions, frame.edges
    src, tgt = list(task.source_pair), list(task.target_pair)
    w = response(frame, src, result.mode[src])
    row = {
        "ok_run": True, "time": elapsed, "eta": strain_ratio(x, src, tgt, w), "removed": len(result.removed_edges),
        "added_bars": len(result.added_edges), "added_nodes": len(result.added_nodes),
    }
    # Independent of the solver: bar extensions of the returned mode from positions, and up to
    # SVD_MAX_NODES the zero modes and the driven response from numpy's SVD of C.
    mode = result.mode
    diff = x[edges[:, 0]] - x[edges[:, 1]]
    extension = np.einsum("ij,ij->i", diff, mode[edges[:, 0]] - mode[edges[:, 1]]) / np.linalg.norm(diff, axis=1)
    row["bar_residual"] = float(np.abs(extension).max() / np.abs(mode).max())
    if frame.n_nodes <= SVD_MAX_NODES:
        null = svd_null(x, edges)
        row["nontrivial_svd"] = null.shape[1] - 3
        row["eta_svd"] = strain_ratio(x, src, tgt, driven(null, src, mode[src]))
    return row


def strain_ratio(x: np.ndarray, src, tgt, w: np.ndarray) -> float:
    """η = ε_T/ε_S of the motion w (N, d), pair strains from positions."""
    return pair_strain(x[tgt], w[tgt]) / pair_strain(x[src], w[src])


def peer(task) -> dict:
    result = prune_for_allostery(task.frame, task.source_pair, task.target_pair, task.ratio, task.tol, seed=task.seed)
    return {
        "ok_run": True, "time": result.time_s, "eta": result.achieved_ratio, "removed": result.bars_removed,
        "added_bars": 0, "added_nodes": 0, "stop": result.stop_reason,
    }


EDIT_SIZES = (100, 400, 1600)
EDIT_SEEDS = (0, 1)
EDIT_RATIOS = (1.0, 2.0, -1.0)
EDIT_METHODS = ("pruning", "elastic", "mechanism")


def peer_stiffness(frame) -> np.ndarray:
    """The peer's springs, k_b = 1/ℓ_b on the normalised positions (benchmarks/pruning.py)."""
    x, e = frame.normalised_positions(), frame.edges
    return 1.0 / np.linalg.norm(x[e[:, 0]] - x[e[:, 1]], axis=1)


def dense_spring_check(x: np.ndarray, edges: np.ndarray, k: np.ndarray, src, tgt) -> dict:
    """η of the spring network by a dense solve written here: K = Σ k_b q_b q_bᵀ from unit bar
    vectors, u = (K + R Rᵀ)⁻¹ q_S = K⁺ q_S (q_S ⟂ the rigid motions R, orthonormal), η = ε_T/ε_S;
    up to SVD_MAX_NODES also the zero modes of diag(√k) Q by numpy's SVD."""
    n, d = x.shape
    xc = x - x.mean(axis=0)

    def rows(pairs):
        q = np.zeros((len(pairs), n, d))
        unit = xc[pairs[:, 0]] - xc[pairs[:, 1]]
        unit /= np.linalg.norm(unit, axis=1, keepdims=True)
        q[np.arange(len(pairs)), pairs[:, 0]] = unit
        q[np.arange(len(pairs)), pairs[:, 1]] = -unit
        return q.reshape(len(pairs), n * d)

    q = rows(edges)
    q_s, q_t = rows(np.array([src, tgt]))
    rigid = [np.tile(np.eye(d)[a], n) for a in range(d)]
    rigid += [np.column_stack([-xc[:, 1], xc[:, 0]]).ravel()] if d == 2 else [
        np.cross(np.eye(3)[a], xc).ravel() for a in range(3)]
    r, _ = np.linalg.qr(np.column_stack(rigid))
    u = np.linalg.solve(q.T @ (k[:, None] * q) + r @ r.T, q_s)
    length = lambda p: np.linalg.norm(xc[p[0]] - xc[p[1]])
    out = {"eta_dense": float((q_t @ u / length(tgt)) / (q_s @ u / length(src)))}
    if n <= SVD_MAX_NODES:
        s = np.linalg.svd(np.sqrt(k)[:, None] * q, compute_uv=False)
        out["zero_modes_svd"] = int(n * d - np.sum(s > 1e-9 * s[0]))
    return out


def edit_row(method: str, task) -> dict:
    """One method on one task: its edit, η reported and rechecked, CPU time of the call."""
    frame, src, tgt = task.frame, task.source_pair, task.target_pair
    k0 = peer_stiffness(frame)
    c0 = time.process_time()
    if method == "pruning":
        result = prune_for_allostery(frame, src, tgt, task.ratio, task.tol, seed=task.seed)
        cpu = time.process_time() - c0
        keep = np.ones(frame.n_edges, dtype=bool)
        keep[list(result.removed_edges)] = False
        row = {"eta": result.achieved_ratio, "removed": result.bars_removed, "tuned": 0, "added_bars": 0,
               **dense_spring_check(frame.positions, frame.edges[keep], k0[keep], src, tgt)}
    elif method == "elastic":
        try:
            result = tune_elastic(frame, src, tgt, task.ratio, stiffness=k0)
        except DomainError as exc:
            return {"ok_run": False, "code": exc.code, "cpu": time.process_time() - c0, "error": float("inf")}
        cpu = time.process_time() - c0
        row = {"eta": result.strain_ratio, "removed": len(result.removed_edges), "tuned": int(result.tuned_edge is not None),
               "added_bars": 0, "sensitivity": result.sensitivity, "scaled_sensitivity": result.scaled_sensitivity,
               "tuned_stiffness": result.tuned_stiffness, "softest_mode": result.softest_mode,
               **dense_spring_check(frame.positions, result.frame.edges, result.stiffness, src, tgt)}
    else:
        row = ours(task)
        cpu = time.process_time() - c0
        row["tuned"] = 0
        if not row["ok_run"]:
            return {**row, "cpu": cpu, "error": float("inf")}
    row = {"ok_run": True, "cpu": cpu, **row}
    etas = [row[key] for key in ("eta", "eta_dense", "eta_svd") if key in row]
    row["error"] = max(abs(e - task.ratio) for e in etas) / max(abs(task.ratio), 1.0)
    rigid_springs = method == "mechanism" or row.get("zero_modes_svd", 3) == 3
    if not rigid_springs or row.get("nontrivial_svd", 1) != 1 or row.get("bar_residual", 0.0) > 1e-9:
        row["error"] = float("inf")  # a new zero mode, or not one exact mechanism
    row["changed"] = row["removed"] + row["tuned"] + row["added_bars"]
    return row


def run_edits() -> list[dict]:
    """Every method on the issue's 18 tasks, after one untimed warm-up call of each."""
    warm = make_task(100, 0, 1.0)
    for method in EDIT_METHODS:
        edit_row(method, warm)
    rows = []
    for n in EDIT_SIZES:
        for seed in EDIT_SEEDS:
            for ratio in EDIT_RATIOS:
                task = make_task(n, seed, ratio)
                for method in EDIT_METHODS:
                    row = {"method": method, "n": n, "seed": seed, "ratio": ratio, **edit_row(method, task)}
                    rows.append(row)
                    print(f"edits {row}", flush=True)
        random_network.cache_clear()
    return rows


def edits_table(rows: list[dict]) -> list[str]:
    lines = [
        ("| N | method | tasks | exact (≤ 1e-9) | within 1 % | worst error | bars changed: median (values) "
         "| removed + stiffness changed + added (medians) | median CPU [s] | max CPU [s] |"),
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for n in EDIT_SIZES:
        for method in EDIT_METHODS:
            runs = [r for r in rows if r["n"] == n and r["method"] == method]
            done = [r for r in runs if r["ok_run"]]
            changed = [r["changed"] for r in done]
            lines.append(cells(
                n, method, len(runs), sum(r["error"] <= 1e-9 for r in runs), sum(r["error"] <= 1e-2 for r in runs),
                f"{max(r['error'] for r in runs):.1e}", f"{np.median(changed):g} ({', '.join(map(str, changed))})",
                " + ".join(f"{np.median([r[key] for r in done]):g}" for key in ("removed", "tuned", "added_bars")),
                f"{np.median([r['cpu'] for r in runs]):.3f}", f"{max(r['cpu'] for r in runs):.3f}",
            ))
    return lines


def edits_sensitivity_table(rows: list[dict]) -> list[str]:
    lines = [
        "| N | seed | η* | bars removed | tuned stiffness: given → new | dη/dk | k_given dη/dk | softest mode / given's |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if r["method"] == "elastic" and r["ok_run"] and r["tuned"]:
            lines.append(cells(
                r["n"], r["seed"], f"{r['ratio']:+g}", r["removed"],
                f"{r['tuned_stiffness'][0]:.3g} → {r['tuned_stiffness'][1]:.3g}", f"{r['sensitivity']:.3g}",
                f"{r['scaled_sensitivity']:.3g}", f"{r['softest_mode']:.2g}",
            ))
    return lines


def edits_floor(rows: list[dict]) -> list[str]:
    lines = []
    for n in EDIT_SIZES:
        med = {m: np.median([r["changed"] for r in rows if r["n"] == n and r["method"] == m and r["ok_run"]])
               for m in ("pruning", "elastic")}
        elastic = [r for r in rows if r["n"] == n and r["method"] == "elastic"]
        exact = all(r["error"] <= 1e-9 for r in elastic)
        line = (f"- N = {n}: median bars changed elastic {med['elastic']:g} ≤ pruning {med['pruning']:g}: "
                f"{'met' if med['elastic'] <= med['pruning'] else 'NOT met'}; exact to 1e-9: "
                f"{'all' if exact else 'NOT all'} {len(elastic)}")
        if n == 1600:
            worst = max(r["cpu"] for r in elastic)
            line += f"; CPU ≤ 1 s: {'met' if worst <= 1.0 else 'NOT met'} (max {worst:.2f} s)"
        lines.append(line)
    return lines


def network_plan(quick: bool) -> list[tuple[int, int]]:
    """(N, seeds) of the comparison: 5 seeds up to 800 nodes, fewer above (network generation
    and the peer's Green's-function diagonal grow fastest)."""
    if quick:
        return [(50, 2), (100, 2)]
    return [(50, 5), (100, 5), (200, 5), (400, 5), (800, 5), (1600, 2), (3200, 2), (10_000, 1)]


def run_network(quick: bool) -> tuple[list[dict], dict]:
    rows, generation = [], {}
    for n, seeds in network_plan(quick):
        for seed in range(seeds):
            t0 = time.perf_counter()
            random_network(n, seed, DEFAULT_EXCESS_COORDINATION)  # make_task's call: cached from here on
            generation[f"{n}/{seed}"] = time.perf_counter() - t0
            for ratio in RATIOS:
                task = make_task(n, seed, ratio)
                for method, fn in (("pruning", peer), ("analytic", ours)):
                    row = {"method": method, "n": n, "seed": seed, "ratio": ratio, "bars0": task.frame.n_edges, **fn(task)}
                    scale = max(abs(ratio), 1.0)
                    etas = [row[k] for k in ("eta", "eta_svd") if k in row]
                    row["error"] = max(abs(e - ratio) for e in etas) / scale if row["ok_run"] else float("inf")
                    if row.get("nontrivial_svd", 1) != 1 or row.get("bar_residual", 0.0) > 1e-9:
                        row["error"] = float("inf")  # not one exact mechanism
                    row["exact"] = row["error"] <= 1e-9
                    row["one_percent"] = row["error"] <= 1e-2
                    row["changed"] = row.get("removed", 0) + row.get("added_bars", 0) if row["ok_run"] else None
                    rows.append(row)
                    print(f"network {row}", flush=True)
            random_network.cache_clear()  # the largest networks take gigabytes in the cache otherwise
    return rows, generation


def network_table(rows: list[dict]) -> list[str]:
    lines = [
        ("| N | method | tasks | exact (≤ 1e-9) | within 1 % | median error | worst error | bars changed (median, max) "
        "| removed + added (medians) | nodes added | median time [s] |"),
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for n in sorted({r["n"] for r in rows}):
        for method in ("analytic", "pruning"):
            runs = [r for r in rows if r["n"] == n and r["method"] == method]
            changed = [r["changed"] for r in runs if r["changed"] is not None]
            lines.append(
                cells(
                    n, method, len(runs), f"{sum(r['exact'] for r in runs)}/{len(runs)}",
                    f"{sum(r['one_percent'] for r in runs)}/{len(runs)}", f"{np.median([r['error'] for r in runs]):.1e}",
                    f"{max(r['error'] for r in runs):.1e}", f"{np.median(changed):.0f}, {max(changed)}",
                    f"{np.median([r.get('removed', 0) for r in runs]):.0f} + {np.median([r.get('added_bars', 0) for r in runs]):.0f}",
                    int(np.median([r.get("added_nodes", 0) for r in runs])),
                    f"{np.median([r['time'] for r in runs]):.3g}",
                )
            )
    return lines


def network_goals(rows: list[dict]) -> list[str]:
    """The issue's goals for given networks, each with its verdict."""
    ours_ = [r for r in rows if r["method"] == "analytic"]
    exact = sum(r["exact"] for r in ours_)
    out = [f"- every task solved to 1e-9: {'met' if exact == len(ours_) else 'NOT met'} ({exact}/{len(ours_)})"]
    fewer, faster = [], []
    for n in sorted({r["n"] for r in rows}):
        def med(key, method, n=n):
            return float(np.median([r[key] for r in rows if r["n"] == n and r["method"] == method and r[key] is not None]))

        fewer.append((n, med("changed", "analytic"), med("changed", "pruning")))
        if n >= 1000:
            faster.append((n, med("time", "analytic"), med("time", "pruning")))
    worse = [f"N = {n}: {a:.0f} vs {p:.0f}" for n, a, p in fewer if a >= p]
    out.append(
        "- fewer bars changed than pruning (medians per N): "
        + ("met at every N" if not worse else f"NOT met at {len(worse)} of {len(fewer)} sizes ({'; '.join(worse)})")
        + f" — medians analytic/pruning: {', '.join(f'{n}: {a:.0f}/{p:.0f}' for n, a, p in fewer)}"
    )
    slow = [n for n, a, p in faster if a >= p]
    out.append(
        "- faster than pruning from N = 10³: "
        + ("met" if faster and not slow else "NOT met" if faster else "not measured")
        + (f" ({', '.join(f'N = {n}: {a:.2f} s vs {p:.2f} s' for n, a, p in faster)})" if faster else "")
    )
    return out


def ratio_table(rows: list[dict]) -> list[str]:
    lines = ["| η* | method | exact | within 1 % | median bars changed | median error |", "|---|---|---|---|---|---|"]
    for ratio in RATIOS:
        for method in ("analytic", "pruning"):
            runs = [r for r in rows if r["ratio"] == ratio and r["method"] == method]
            lines.append(
                cells(
                    f"{ratio:+g}", method, f"{sum(r['exact'] for r in runs)}/{len(runs)}",
                    f"{sum(r['one_percent'] for r in runs)}/{len(runs)}",
                    f"{np.median([r['changed'] for r in runs if r['changed'] is not None]):.0f}",
                    f"{np.median([r['error'] for r in runs]):.1e}",
                )
            )
    return lines


def network_chart(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    style = {"analytic": ("o-", "#2ca02c"), "pruning": ("s--", "#ff7f0e")}
    sizes = sorted({r["n"] for r in rows})
    for method, (marker, colour) in style.items():
        def med(key, fn=np.median, method=method):
            return [fn([r[key] for r in rows if r["n"] == n and r["method"] == method]) for n in sizes]

        axes[0].plot(sizes, med("time"), marker, color=colour, label=method)
        axes[1].plot(sizes, [np.median([r["changed"] for r in rows if r["n"] == n and r["method"] == method
                                        and r["changed"] is not None]) for n in sizes], marker, color=colour, label=method)
        axes[2].plot(sizes, [max(v, 1e-17) for v in med("error", np.max)], marker, color=colour,
                     label=f"{method} (worst task)")
    axes[2].axhline(1e-9, color="k", lw=0.8, ls="--")
    axes[2].axhline(1e-2, color="k", lw=0.8, ls=":")
    save_log_chart(
        fig, axes, "network size N",
        (("time per task", "wall time [s]"), ("bars changed", "bars removed + added"),
         ("accuracy", "|η − η*| / max(|η*|, 1)")),
        path,
    )


# ----------------------------------------------------------------------------- document


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sweeps (smoke run)")
    parser.add_argument("--part", choices=("distance", "amplification", "network", "edits", "modes", "all"),
                        default="all")
    args = parser.parse_args(argv)
    raw = json.loads(RAW.read_text()) if RAW.exists() else {}
    load = os.getloadavg()
    if args.part in ("distance", "all"):
        raw["distance"] = {"rows": run_distance(1 if args.quick else 3), "load": load}
        distance_chart(raw["distance"]["rows"], IMG / "allostery_distance.png")
    if args.part in ("amplification", "all"):
        raw["amplification"] = {"rows": run_amplification(1 if args.quick else 3), "load": load}
        amplification_chart(raw["amplification"]["rows"], IMG / "allostery_amplification.png")
    if args.part in ("network", "all"):
        rows, generation = run_network(args.quick)
        raw["network"] = {"rows": rows, "generation_s": generation, "load": load}
        network_chart(rows, IMG / "allostery_network.png")
    if args.part in ("edits", "all"):
        raw["edits"] = {"rows": run_edits(), "load": load}
    if args.part in ("modes", "all"):
        raw["modes"] = {"rows": run_modes(1 if args.quick else 8), "load": load}
    raw["machine"] = f"Python {platform.python_version()}, {os.cpu_count()} cores, single-threaded BLAS"
    RAW.parent.mkdir(parents=True, exist_ok=True)
    RAW.write_text(json.dumps(raw, indent=1, default=float))
    DOC.write_text("\n".join(document(raw)))
    print("\n".join(document(raw)))


def document(raw: dict) -> list[str]:
    lines = [
        "# Allosteric design: accuracy at any distance, given networks, several motions",
        "",
        (f"Generated by `python -m benchmarks.bench_allostery` ({raw.get('machine', '')}; shared machine, "
        "wall-clock medians). Raw rows: `docs/benchmarks/allostery.json`."),
        "",
    ]
    if "distance" in raw:
        part = raw["distance"]
        lines += [
            "## Site distance (`design_allosteric`, economy chains)",
            "",
            (f"Load average when run: {', '.join(f'{v:.2f}' for v in part['load'])}. Economy chains "
            "(`robustness` \"economy\"; the default before the amplification search). Same site shapes at every "
            "distance (3 seeds, d + 1 nodes each, random motions); D in site sizes (the larger site's RMS "
            "radius). Errors: reported, and recomputed here from numpy's SVD of C. Sensitivity: the largest "
            "relative change of the target's shape change (motion modulo rigid motions of the target site) "
            "when the nodes move by 1e-6 site sizes (Euclidean norm over all nodes, worst direction); "
            "motion sensitivity: the same for the whole target motion (a lever: it grows with D)."),
            "",
            "![accuracy, sensitivity and time against site distance](../img/allostery_distance.png)",
            "",
            *distance_table(part["rows"]),
            "",
            "Floors:",
            "",
            *distance_floors(part["rows"]),
            "",
        ]
    if "amplification" in raw:
        part = raw["amplification"]
        lines += [
            "## Fabrication error: the amplification a builder feels",
            "",
            (f"Load average when run: {', '.join(f'{v:.2f}' for v in part['load'])}; CPU time per design. The "
            f"seeded sites of the distance part ({len({r['seed'] for r in part['rows']})} seeds; the target cloud "
            "moved D along x, site RMS radii ≈ 1.2–1.7), designed with the default options (`robustness` "
            "\"robust\": every chain of `ROBUST_CHAINS` designed; the best rebuilt, for each source base of "
            "`REACHES` (3D), with the `REFINED_BUILDS` placements of the source site's first port (`SOURCE_SIDES`) "
            "whose source side tilts the target least (`source_tilt`, screened on the source side alone); the "
            "answer of smallest √(A² + 3 A_top²) kept, A_top the worst direction's share) and with "
            "\"economy\" (the first chain meeting the floors). A is the relative change of the target's whole "
            "response per relative node error, node errors in mean bar lengths ℓ̄. Sampled here: every node moved "
            "by 1e-7·ℓ̄ in a seeded random direction, the perturbed frame's zero mode from numpy's SVD of C "
            "(built here), driven by the source motion; worst of four perturbations. Reported: the solver's "
            "linearisation, A = ‖J‖_F ℓ̄/(√d‖w_T‖) (RMS over such errors) and A_worst = ‖J‖₂ ℓ̄ √N/‖w_T‖ (worst "
            "direction, a bound)."),
            "",
            "![amplification against site distance](../img/allostery_amplification.png)",
            "",
            *amplification_table(part["rows"]),
            "",
            "Floor A(D) ≤ 100·√(D/12), default options, worst of four perturbations and of the seeded sites:",
            "",
            *amplification_floors(part["rows"]),
            "",
            ("Where A comes from (default designs; `amplification_profile`: every node coordinate moved alone by "
             f"1e-7·ℓ̄ and the response re-solved from numpy's SVD, the columns of J = ∂w_T/∂x by finite "
             "differences): the share of ‖J‖_F² that is a rigid motion (translation, rotation) of the target site, "
             f"and the share from nodes within {SOURCE_REACH:.0%} of the frame's length from the source — the "
             "source site and its module."),
            "",
            *profile_table(part["rows"]),
            "",
            ("Reading: in 3D almost all of A is the target site carried rigidly — the angle at which the chain "
             "leaves the source, set by node errors on the source side and carried to the target by a lever of "
             "length D. A bar (i, j) of length L whose node moves by δ changes its constraint by (u_i − u_j)·δ, "
             "which turns what it holds by about |u_i − u_j| δ/(L m), m the width of what holds the chain (the "
             "site size s when the chain leaves from the site's own nodes), so to first order A ~ D·ℓ̄·|u_i − "
             "u_j|/(L·m·|u_T|). The default now widens m: the chain leaves from a *source base* (`source_base`, "
             "ChainOptions.reach): d + 1 nodes 0.25 or 0.4 of the gap away, each joined by d long bars to d "
             "site nodes along the one direction in which its motion stays of the site's size (normal to the "
             "differences of their motions; any other direction needs a motion r/s times larger). Measured "
             "before it (previous run: 92 / 679 / 591 / 814 at D = 12 / 48 / 96 / 200) and with the source-side "
             "screen alone (89 / 396 / 405 / 774), the base brought the worst 3D sites at D = 48 and 96 under the "
             "floor. Not yet at D = 200: shape 2 keeps 872 (its reported A fell from 932 to 508 and A_worst from "
             "7581 to 4046, but the four fixed perturbations fall near its worst direction), its profile "
             "splitting between the site's nodes, the base and the target's module; a base at the target's end "
             "as well lowered it by only ~10 % (A 467 → 409 on one chain) and was not kept. Tried and not kept: "
             "the relays carrying the source's or the target's rigid motion (best A over 60 placements 297 and "
             "204 against 232 at rest, D = 48, shape 2; not better once the base was there), bases on both "
             "sides of the site (8 nodes: tilt 145 against 62 for 4)."),
            "",
        ]
    if "network" in raw:
        part = raw["network"]
        rows = part["rows"]
        gen = part["generation_s"]
        lines += [
            "## Given networks: tuning-by-pruning against `tune_network` (`/v1/design/allosteric/network`)",
            "",
            (f"Load average when run: {', '.join(f'{v:.2f}' for v in part['load'])}. The same tasks for both "
            "methods (`benchmarks/allostery_tasks.py`): a jammed-like 2D network of N nodes (ΔZ = 0.5), a "
            "source pair and a target pair at ≥ 3/4 of the largest distance, η* = ε_T/ε_S ∈ "
            f"{{{', '.join(f'{r:+g}' for r in RATIOS)}}}. Pruning stops at the peer's own tolerance (1 % of "
            "max(|η*|, 1)) or when no removal helps; the analytic answer is exact or refused. Bars changed: "
            "removed (pruning), removed + added (analytic, which also adds the nodes listed). η of each answer is "
            "measured on its final frame: the peer's by a fresh factorisation of its pruned network; ours by the "
            "zero mode the source strain drives (`allostery.response`), by numpy's bar extensions of the returned "
            f"mode (≤ 1e-9 of its size), and up to N = {SVD_MAX_NODES} by numpy's SVD of C built here (exactly one "
            "nontrivial zero mode, η of the driven null-space motion); the worse figure counts. Network "
            f"generation, not timed in either method: {sum(gen.values()):.0f} s in all "
            f"(largest: {max(gen.values()):.0f} s)."),
            "",
            "![time, bars changed and accuracy against network size](../img/allostery_network.png)",
            "",
            *network_table(rows),
            "",
            "By η* (all sizes):",
            "",
            *ratio_table(rows),
            "",
            "Goals of the issue:",
            "",
            *network_goals(rows),
            "",
        ]
    if "edits" in raw:
        part = raw["edits"]
        lines += [
            "## Fewest changes on the issue's 18 tasks: two response contracts (issue 42, item 3)",
            "",
            ("Two contracts for allostery in a given network (`POST /v1/design/allosteric/network`, "
            "`options.response`):"),
            "",
            ("- **mechanism** (the default): the edited network has exactly one nontrivial zero mode, and driving "
            "the source pair moves the target pair at η* *whatever the bars' stiffnesses* (a mechanism needs no "
            "stiffness). It needs at least two removals per site and a three-bar coupler (≥ 7 changes)."),
            ("- **elastic** (`\"elastic\"`): pruning's own contract, ended exact. The bars are springs (stiffness 1 "
            "unless `options.stiffness` states them), the source strain is imposed and the network relaxes "
            "(linear response); η = ε_T/ε_S as `benchmarks/pruning.py` defines it. Bars are removed as pruning "
            "ranks them (bond Green's function, Sherman–Morrison on one factorisation) and the search ends at the "
            "first step where changing ONE bar's stiffness within [0, 10 k_b] gives η = η* (closed form: η(k_b) is a "
            "ratio of affine functions of k_b). It holds *for the stated stiffnesses*: the report gives the tuned "
            "bar's dη/dk (and k_given dη/dk, η's change per stiffness error in units of the bar's given stiffness, "
            "which the choice among the bars that reach η* makes smallest), the measure of how precisely it "
            "must be made. Every answer is re-solved by another route (sparse LU of the bordered system with the "
            "imposed strain as a Lagrange multiplier) and keeps the softest nontrivial eigenvalue ≥ 1e-4 of the "
            "given network's; otherwise 422 `ratio_out_of_reach` with the best verified figures."),
            "",
            (f"Load average when run: {', '.join(f'{v:.2f}' for v in part['load'])}. N = 100, 400, 1 600 "
            "(ΔZ = 0.5, z ≈ 4.5), seeds 0 and 1, η* ∈ {+1, +2, −1} (`make_task`). pruning: the peer to its 1 % "
            "stop; elastic: `tune_elastic` with the peer's own springs (k = 1/ℓ on the normalised positions), so "
            "the comparison is like with like; mechanism: `tune_network` (for reference). Bars changed: removed + "
            "stiffness changed + added. η of every answer recomputed here: springs by a dense solve of "
            "(K + R Rᵀ) u = q_S written in the benchmark (and, up to N = "
            f"{SVD_MAX_NODES}, numpy's SVD of diag(√k) Q: no zero mode beyond the rigid ones); the mechanism as in "
            "the part above; the worse figure counts. CPU time of the call (`time.process_time`), after one "
            "untimed warm-up call of each method."),
            "",
            *edits_table(part["rows"]),
            "",
            "The tuned bar of each elastic answer:",
            "",
            *edits_sensitivity_table(part["rows"]),
            "",
            "Floor (median bars changed ≤ pruning's at every N, exact to 1e-9, ≤ 1 s at N = 1 600):",
            "",
            *edits_floor(part["rows"]),
            "",
        ]
    if "modes" in raw:
        part = raw["modes"]
        lines += [
            "## Several motions (`/v1/design`, M = 1 … 4)",
            "",
            (f"Load average when run: {', '.join(f'{v:.2f}' for v in part['load'])}. k = d + 2 specified nodes at "
            f"seeded random positions, M seeded random motions, {len({r['seed'] for r in part['rows']})} seeds per "
            "line. Designed and verified: `design` answers, and numpy's SVD of the returned frame's C (built here) "
            "has exactly M nontrivial zero modes whose specified rows reproduce every requested motion to 1e-9 "
            "(misfit: least-squares residual relative to the motion). M ≤ d: the paper's bipartite construction; "
            "d < M ≤ 2d: hierarchical groups of unspecified nodes; M > 2d is refused up front (`too_many_motions`)."),
            "",
            *modes_table(part["rows"]),
            "",
        ]
    return lines


def run_modes(seeds: int) -> list[dict]:
    """design.design with M = 1 … 4 random motions of k = d + 2 random specified nodes."""
    rows = []
    for d in (2, 3):
        k = d + 2
        for m in (1, 2, 3, 4):
            for seed in range(seeds):
                rng = np.random.default_rng([d, m, k, seed])
                x, motions = rng.standard_normal((k, d)), rng.standard_normal((m, k, d))
                t0 = time.perf_counter()
                try:
                    result = design(x, motions, seed=seed)
                except DomainError as exc:
                    row = {"ok": False, "code": exc.code}
                else:
                    # Independent: N(C) from numpy's SVD; each motion must be the specified rows of
                    # a zero mode, and the nontrivial zero modes must be exactly M.
                    null = svd_null(result.frame.positions, result.frame.edges)
                    rows_s = (np.arange(k)[:, None] * d + np.arange(d)).ravel()
                    fit = max(
                        float(np.linalg.norm(null[rows_s] @ np.linalg.lstsq(null[rows_s], u.ravel(), rcond=None)[0] - u.ravel())
                              / np.linalg.norm(u))
                        for u in motions
                    )
                    row = {
                        "nodes": result.frame.n_nodes, "residual": result.mode_residual,
                        "nontrivial_svd": null.shape[1] - d * (d + 1) // 2, "fit_svd": fit,
                    }
                    row["ok"] = row["nontrivial_svd"] == m and fit <= 1e-9
                rows.append({"d": d, "m": m, "k": k, "seed": seed, "time": time.perf_counter() - t0, **row})
                print(f"modes {rows[-1]}", flush=True)
    return rows


def modes_table(rows: list[dict]) -> list[str]:
    lines = [
        ("| d | M | k | construction | designed and verified | median nodes | max mode residual (solver) "
         "| max motion misfit (numpy SVD) | median time [s] | max time [s] |"),
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for d in (2, 3):
        for m in (1, 2, 3, 4):
            runs = [r for r in rows if r["d"] == d and r["m"] == m]
            ok = [r for r in runs if r["ok"]]
            how = "bipartite" if m <= d else "hierarchical groups"
            nodes = f"{np.median([r['nodes'] for r in ok]):.0f}" if ok else "–"
            residual = f"{max(r['residual'] for r in ok):.1e}" if ok else "–"
            misfit = f"{max(r['fit_svd'] for r in ok):.1e}" if ok else "–"
            lines.append(
                cells(
                    d, m, runs[0]["k"], how, f"{len(ok)}/{len(runs)}", nodes, residual, misfit,
                    f"{np.median([r['time'] for r in runs]):.2f}", f"{max(r['time'] for r in runs):.2f}",
                )
            )
    return lines


if __name__ == "__main__":
    main()
