"""Auxetic lattice benchmark: time against size for 2D sheets and 3D chains (issue 5).

    python benchmarks/bench_lattice.py [--quick] [--out docs/benchmarks/lattice.md]

Each row: median wall time of auxetic_sheet / auxetic_chain_3d (design, verification of the
single nontrivial mode by a rank analysis, Poisson ratio, exact finite states), the frame size,
the self-stress count of the symmetric tiling, the bar-length error of the states, and the
fitted growth exponent t ∝ N^α between consecutive sizes.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import time
from pathlib import Path

import numpy as np

from zeromode.solver.lattice import auxetic_chain_3d, auxetic_sheet


def median_time(fn, repeats: int):
    times, result = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--out", default="docs/benchmarks/lattice.md")
    args = parser.parse_args()
    sizes = [1, 2, 4, 8, 16, 32] if args.quick else [1, 2, 4, 8, 16, 32, 50]
    lines = [
        "# Auxetic lattices: time against size",
        "",
        "## 2D sheets (n × n modules, ν = −1)",
        "",
        "| cells | nodes | bars | self-stresses | analysis route | ν | max bar error (states) | median time s | growth α (t ∝ N^α) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    previous = None
    for n in sizes:
        t, lat = median_time(lambda n=n: auxetic_sheet(n, n), 3 if n <= 16 else 1)
        nodes = lat.frame.n_nodes
        alpha = "" if previous is None else f"{np.log(t / previous[1]) / np.log(nodes / previous[0]):.2f}"
        previous = (nodes, t)
        lines.append(
            f"| {n}×{n} | {nodes} | {lat.frame.n_edges} | {lat.analysis.self_stresses} | {lat.analysis.method} | "
            f"{lat.poisson_ratio:.6f} | {lat.max_relative_bar_error:.1e} | {t:.3f} | {alpha} |"
        )
        print(lines[-1], flush=True)
    lines += [
        "",
        "## 3D chains (ν = −0.5), states by continuation",
        "",
        "| blocks | nodes | bars | self-stresses | ν | max bar error (states) | median time s |",
        "|---|---|---|---|---|---|---|",
    ]
    for n in [1, 2, 4, 8] if args.quick else [1, 2, 4, 8, 16]:
        t, lat = median_time(lambda n=n: auxetic_chain_3d(n), 1)
        lines.append(
            f"| {n} | {lat.frame.n_nodes} | {lat.frame.n_edges} | {lat.analysis.self_stresses} | "
            f"{lat.poisson_ratio:.6f} | {lat.max_relative_bar_error:.1e} | {t:.3f} |"
        )
        print(lines[-1], flush=True)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
