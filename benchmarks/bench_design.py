"""Design benchmark: time per solution space and per design, with the mode residual and the
bars used beside each time (issues 3 and 4), and the hierarchical 3D design of many motions
(issue 42, item 4: k = 64, M = 4 ≤ 10 s).

    python benchmarks/bench_design.py [--quick] [--many-motions-only] [--out docs/benchmarks/design.md]

Library-level timings (no HTTP), single-threaded BLAS, medians over seeds; the machine is
shared, so read ratios and medians, not single numbers.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import time
from pathlib import Path

import numpy as np

from zeromode.solver.analysis.rigidity import warm_up
from zeromode.solver.construction.design import design
from zeromode.solver.construction.solution_space import solution_space
from zeromode.solver.errors import DomainError


def random_target(d: int, k: int, modes: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Specified nodes spread with unit density (so large k means a large target)."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1, 1, (k, d)) * k ** (1 / d)
    u = rng.standard_normal((modes, k, d))
    return x, u


def time_designs(d: int, k: int, modes: int, seeds: int) -> dict:
    times, residuals, nodes, bars, failures = [], [], [], [], 0
    for seed in range(seeds):
        x, u = random_target(d, k, modes, seed)
        t0 = time.perf_counter()
        try:
            result = design(x, u, seed=seed)
        except DomainError:
            failures += 1
            times.append(time.perf_counter() - t0)
            continue
        times.append(time.perf_counter() - t0)
        residuals.append(result.mode_residual)
        nodes.append(result.unspecified_nodes)
        bars.append(result.frame.n_edges)
    return {
        "median_ms": 1e3 * float(np.median(times)),
        "p90_ms": 1e3 * float(np.percentile(times, 90)),
        "max_residual": max(residuals, default=float("nan")),
        "median_nodes": float(np.median(nodes)) if nodes else float("nan"),
        "median_bars": float(np.median(bars)) if bars else float("nan"),
        "solved": f"{seeds - failures}/{seeds}",
    }


def time_solution_spaces(d: int, k: int, seeds: int) -> float:
    times = []
    for seed in range(seeds):
        x, u = random_target(d, k, 1, seed)
        t0 = time.perf_counter()
        try:
            solution_space(x, u[0]).sample(8, np.random.default_rng(seed))
        except DomainError:  # k > 2d + 1: no single-layer solution space (expected)
            pass
        times.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(times))


def independent_counts(positions: np.ndarray, edges: np.ndarray, modes: np.ndarray) -> tuple[int, int, float]:
    """(nontrivial zero modes, self-stresses, worst ‖C u‖/(‖C‖₂‖u‖)) from numpy's SVD of a C
    written here from its definition (row e = (i, j): x_i − x_j at node i, x_j − x_i at node j)
    on the centred frame scaled to RMS radius 1; σ ≤ 1e-9 σ_max counts as zero."""
    x = positions - positions.mean(axis=0)
    x /= np.sqrt(np.mean(np.sum(x**2, axis=1)))
    n, d = x.shape
    c = np.zeros((len(edges), n * d))
    for row, (i, j) in enumerate(edges):
        c[row, d * i : d * i + d] = x[i] - x[j]
        c[row, d * j : d * j + d] = x[j] - x[i]
    s = np.linalg.svd(c, compute_uv=False)
    rank = int(np.count_nonzero(s > 1e-9 * s[0]))
    residual = max(np.linalg.norm(c @ m.ravel()) / (s[0] * np.linalg.norm(m)) for m in modes)
    return n * d - rank - d * (d + 1) // 2, len(edges) - rank, float(residual)


def many_motions(seeds: int) -> list[str]:
    """3D, k = 64 specified nodes, M = 4 motions (hierarchical groups past M = d): CPU and wall
    time per design (one process, single-threaded BLAS), each frame checked by
    independent_counts.  Targets: random_target (x_S uniform in a cube of volume k, motions
    standard normal), seeds 0 … seeds − 1.  The analysis's compiled kernels are loaded first
    (rigidity.warm_up, as the service does when it starts)."""
    warm_up()
    lines = ["", "## Many motions in 3D: k = 64, M = 4 (issue 42, item 4)", "",
             ("Seeded targets (random_target: x_S uniform in [−1, 1]³·k^(1/3), each motion's rows "
             "standard normal), design seed = target seed. Each frame checked by numpy's SVD of a C "
             "written in the benchmark: nontrivial zero modes, self-stresses, worst ‖C u‖/(‖C‖‖u‖)."), "",
             f"Load average at the start: {os.getloadavg()[0]:.1f} (2 cores, shared).", "",
             "| seed | CPU s | wall s | unspecified nodes | bars | nontrivial zero modes | self-stresses | max residual |",
             "|---|---|---|---|---|---|---|---|"]
    for seed in range(seeds):
        x, u = random_target(3, 64, 4, seed)
        c0, w0 = time.process_time(), time.perf_counter()
        result = design(x, u, seed=seed)
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
        frame = result.frame
        modes_, stresses, residual = independent_counts(np.asarray(frame.positions), np.asarray(frame.edges), result.modes)
        lines.append(f"| {seed} | {cpu:.1f} | {wall:.1f} | {result.unspecified_nodes} | {frame.n_edges} | "
                     f"{modes_} | {stresses} | {residual:.1e} |")
        print(lines[-1], flush=True)
    lines.append(f"\nLoad average at the end: {os.getloadavg()[0]:.1f}.")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--many-motions-only", action="store_true", help="print the k = 64, M = 4 table only")
    parser.add_argument("--out", default="docs/benchmarks/design.md")
    args = parser.parse_args()
    if args.many_motions_only:
        many_motions(3)
        return
    seeds = 10 if args.quick else 40
    lines = ["# Design benchmark", "", f"Seeds per row: {seeds} (large-k rows: {max(seeds // 4, 3)}).", ""]

    lines += ["## Single-mode designs (issue 3)", "",
              "| d | k | solution space ms | design median ms | p90 ms | max residual | unspecified nodes | bars | solved |",
              "|---|---|---|---|---|---|---|---|---|"]
    for d, k in [(2, 3), (2, 4), (3, 4), (3, 5), (3, 8)]:
        r = time_designs(d, k, 1, seeds)
        ss = time_solution_spaces(d, k, seeds)
        lines.append(f"| {d} | {k} | {ss:.2f} | {r['median_ms']:.1f} | {r['p90_ms']:.1f} | {r['max_residual']:.1e} | "
                     f"{r['median_nodes']:.0f} | {r['median_bars']:.0f} | {r['solved']} |")
        print(lines[-1], flush=True)

    lines += ["", "## Two-mode designs (issue 4)", "",
              "| d | k | design median ms | p90 ms | max residual | unspecified nodes | bars | solved |",
              "|---|---|---|---|---|---|---|---|"]
    for d, k in [(2, 3), (3, 4)]:
        r = time_designs(d, k, 2, seeds)
        lines.append(f"| {d} | {k} | {r['median_ms']:.1f} | {r['p90_ms']:.1f} | {r['max_residual']:.1e} | "
                     f"{r['median_nodes']:.0f} | {r['median_bars']:.0f} | {r['solved']} |")
        print(lines[-1], flush=True)

    lines += ["", "## Large targets: partitioned construction vs k (issue 4)", "",
              "Lower bound on bars for one mode: d·N_U + (d·k − d(d+1)/2 − 1) with N_U ≥ ⌈(d·k − d(d+1)/2 − 1)/(2d − d)⌉ (every node on a 2d-node anchor set).",
              "",
              "| d | k | design median ms | p90 ms | max residual | unspecified nodes | bars | bars lower bound | solved |",
              "|---|---|---|---|---|---|---|---|---|"]
    big = [(2, 5), (2, 8), (2, 10), (2, 20), (2, 30), (2, 40), (3, 7), (3, 10), (3, 20), (3, 30)]
    if args.quick:
        big = [(2, 8), (2, 20), (3, 10), (3, 20)]
    for d, k in big:
        r = time_designs(d, k, 1, max(seeds // 4, 3))
        reduction = d * k - d * (d + 1) // 2 - 1
        n_min = -(-reduction // d)
        lines.append(f"| {d} | {k} | {r['median_ms']:.0f} | {r['p90_ms']:.0f} | {r['max_residual']:.1e} | "
                     f"{r['median_nodes']:.0f} | {r['median_bars']:.0f} | {d * n_min + reduction} | {r['solved']} |")
        print(lines[-1], flush=True)

    lines += many_motions(3)

    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
