"""Analysis benchmark: rank, zero modes and self-stresses of lattice frames, beside PyRigi (issue 2).

Run from the repository root:  .venv/bin/python -m benchmarks.bench_analysis [--quick]

Times ``analyze`` (library level, no HTTP, single-threaded BLAS as the service runs it) on 2D
triangulated and kagome patches of 10²…10⁵ nodes and on 3D cubic-with-face-diagonals and fcc
patches up to 10⁴ nodes: counts only (``bases=False``) and, for small frames, with both bases.
Medians over several runs for the small sizes; the machine is shared, so read medians and
ratios, not single numbers. On the ≤ 200-node frames PyRigi answers the same questions
(numerical rank, infinitesimal rigidity, nontrivial infinitesimal flexes, equilibrium stresses)
on the same normalised positions, and its counts must agree with ours.

A second table measures the dense/sparse crossover (``DENSE_MAX_DOF``): both routes on the
same frames of growing size, with bases (the service's default) and counts only.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import platform
import time
import warnings
from pathlib import Path

import numpy as np

from benchmarks.lattices import LATTICES
from zeromode.solver import Frame, analyze
from zeromode.solver.rigidity import DENSE_MAX_DOF

OUT = Path(__file__).resolve().parent.parent / "docs" / "benchmarks" / "analysis.md"
PYRIGI_MAX_NODES = 200


def median_time(fn, runs: int) -> tuple[float, object]:
    """Median wall time of ``runs`` calls and the last result."""
    times, result = [], None
    for _ in range(runs):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), result


def runs_for(n: int, dim: int) -> int:
    if n <= 1000:
        return 5
    return 3 if n <= 10_000 and dim == 2 else 1


def pyrigi_counts(frame: Frame) -> tuple[float, dict]:
    """PyRigi's numerical answers on the frame's normalised positions, and their total time.

    PyRigi's numerical rank uses an absolute singular-value tolerance (1e-9), so it is given
    the same scale-normalised positions zeromode decides its rank on.
    """
    from pyrigi import Framework, Graph

    x = frame.normalised_positions()
    graph = Graph([(int(i), int(j)) for i, j in frame.edges])
    graph.add_nodes_from(range(frame.n_nodes))
    framework = Framework(graph, {i: [float(v) for v in p] for i, p in enumerate(x)})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # PyRigi warns that numerical answers are numerical
        t0 = time.perf_counter()
        counts = {
            "rank": int(framework.rigidity_matrix_rank(numerical=True)),
            "inf_rigid": bool(framework.is_inf_rigid(numerical=True)),
            "flexes": len(framework.nontrivial_inf_flexes(numerical=True)),
            "stresses": len(framework.stresses(numerical=True)),
        }
        seconds = time.perf_counter() - t0
    return seconds, counts


def fmt_time(seconds: float | None) -> str:
    if seconds is None:
        return "–"
    return f"{1e3 * seconds:.1f} ms" if seconds < 1 else f"{seconds:.2f} s"


def lattice_table(sizes: dict[str, list[int]], pyrigi: set[tuple[str, int]]) -> list[str]:
    rows = [
        (
            "| frame | d | N | N_B | route | rank | nontrivial zero modes | self-stresses "
            "| counts | with bases | PyRigi | PyRigi agrees | PyRigi ÷ ours (bases) |"
        ),
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, targets in sizes.items():
        for target in targets:
            frame = LATTICES[name](target)
            n, d = frame.n_nodes, frame.dim
            runs = runs_for(n, d)
            counts_s, a = median_time(lambda f=frame: analyze(f, bases=False), runs)
            bases_s, bases_cell = None, "–"
            if target <= 1000:
                bases_s, b = median_time(lambda f=frame: analyze(f), runs)
                assert b.counts() == a.counts()
                bases_cell = fmt_time(bases_s) if b.bases_included else "too large"
            c = a.counts()
            py_s, agree, ratio = None, "", ""
            if (name, target) in pyrigi and n <= PYRIGI_MAX_NODES:
                py_s, py = pyrigi_counts(frame)
                ours = {
                    "rank": c["rank"],
                    "inf_rigid": c["nontrivial_zero_modes"] == 0,
                    "flexes": c["nontrivial_zero_modes"],
                    "stresses": c["self_stresses"],
                }
                agree = "yes" if py == ours else f"**no**: {py} vs {ours}"
                ratio = f"{py_s / bases_s:.0f}×" if b.bases_included else ""
            rows.append(
                f"| {name} | {d} | {n} | {frame.n_edges} | {a.method} | {c['rank']} "
                f"| {c['nontrivial_zero_modes']} | {c['self_stresses']} | {fmt_time(counts_s)} "
                f"| {bases_cell} | {fmt_time(py_s)} | {agree} | {ratio} |"
            )
            print(rows[-1], flush=True)
    return rows


def crossover_table(dofs: list[int]) -> list[str]:
    """Dense and sparse route on the same frames around the crossover, with and without bases."""
    rows = [
        "| frame | dN | N_B | dense, bases | sparse, bases | dense, counts | sparse, counts |",
        "|---|---|---|---|---|---|---|",
    ]
    for name in ("triangulated", "kagome", "cubic-diagonal"):
        seen = set()
        for dof in dofs:
            dim = 3 if name == "cubic-diagonal" else 2
            frame = LATTICES[name](dof // dim)
            dn = frame.dim * frame.n_nodes
            if dn in seen:  # the 3D patch side is an integer: nearby targets give the same frame
                continue
            seen.add(dn)
            cells = []
            for bases in (True, False):
                for method in ("dense", "sparse"):
                    seconds, _ = median_time(
                        lambda f=frame, m=method, b=bases: analyze(f, method=m, bases=b), 3
                    )
                    cells.append(fmt_time(seconds))
            rows.append(f"| {name} | {dn} | {frame.n_edges} | " + " | ".join(cells) + " |")
            print(rows[-1], flush=True)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes only (about a minute)")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    if args.quick:
        sizes = {
            "triangulated": [100, 1000, 10_000],
            "kagome": [100, 1000, 10_000],
            "cubic-diagonal": [100, 1000],
            "fcc": [100],
        }
        pyrigi = {("triangulated", 100)}
        dofs = [300, 600]
    else:
        sizes = {
            "triangulated": [100, 1000, 10_000, 100_000],
            "kagome": [100, 1000, 10_000, 100_000],
            "cubic-diagonal": [100, 1000, 10_000],
            "fcc": [100, 1000, 10_000],
        }
        pyrigi = {(name, 100) for name in sizes}
        dofs = [200, 300, 400, 600, 1000]
    print("## Lattices", flush=True)
    lattice_rows = lattice_table(sizes, pyrigi)
    print("## Dense/sparse crossover", flush=True)
    crossover_rows = crossover_table(dofs)
    lines = [
        "# Analysis benchmark",
        "",
        (
            f"`.venv/bin/python -m benchmarks.bench_analysis{' --quick' if args.quick else ''}` "
            f"on {platform.machine()}, {os.cpu_count()} cores, Python "
            f"{platform.python_version()}, BLAS threads {os.environ['OPENBLAS_NUM_THREADS']}; "
            "a shared, noisy machine."
        ),
        "",
        (
            "Library-level `analyze` times (frame already built). *counts*: `bases=False`; "
            "*with bases*: the default call, which also returns orthonormal bases of the "
            "nontrivial zero modes and self-stresses (sizes up to 10³; *too large*: past "
            "BASIS_MAX_NUMBERS the service returns counts only). Medians of 5 runs up to 10³ "
            "nodes, 3 runs for 2D at 10⁴, one run above. *route*: dense SVD up to "
            f"DENSE_MAX_DOF = {DENSE_MAX_DOF} degrees of freedom, sparse shift-invert subspace "
            "iteration above. *PyRigi* (one run): `rigidity_matrix_rank`, `is_inf_rigid`, "
            "`nontrivial_inf_flexes` and `stresses`, all `numerical=True`, on the same "
            "normalised positions; *PyRigi agrees*: its rank, rigidity, flex count and stress "
            "count equal ours."
        ),
        "",
        *lattice_rows,
        "",
        "## Dense/sparse crossover",
        "",
        "The same frames through both routes (`method=`), medians of 3 runs.",
        "",
        *crossover_rows,
        "",
    ]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
