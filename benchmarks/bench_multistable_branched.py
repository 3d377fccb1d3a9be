"""Branched multistable designs and the fast ``no_path`` refusal (issue #41, item 1).

Usage:  .venv/bin/python benchmarks/bench_multistable_branched.py [--repeats 3]

CPU time (time.process_time: the machine is shared) of ``design_multistable`` on the tristable
triangle of docs/multistable.md with ``bifurcation`` 0, 1 and 2, with the branch point's figures
(angle between the tangents, kept and dropped σ/σ_max, the largest ε of the conformations on the
branch taken), and of the refusal of the triangle that turns over (``no_path``); medians of
``--repeats`` runs and the load average (/proc/loadavg) before and after.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from zeromode.solver.errors import DomainError
from zeromode.solver.multistable.design import design_multistable

APEX = [[0.3, 0.8], [0.45, 1.0], [0.65, 1.15]]
TRIANGLE = [[[0.0, 0.0], [1.0, 0.0], p] for p in APEX]
FLIPPED = [[[0.0, 0.0], [1.0, 0.0], [0.4, 0.15]], [[0.0, 0.0], [1.0, 0.0], [0.6, -0.15]]]


def load() -> str:
    return Path("/proc/loadavg").read_text().split()[0]


def cpu(run) -> tuple[float, object]:
    t = time.process_time()
    out = run()
    return time.process_time() - t, out


def refused(conformations):
    try:
        design_multistable(conformations)
    except DomainError as exc:
        return exc.code
    return "designed"


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=3)
    repeats = parser.parse_args().repeats
    print(f"load before {load()}")
    for j in (0, 1, 2):
        runs = [cpu(lambda j=j: design_multistable(TRIANGLE, bifurcation=j)) for _ in range(repeats)]
        design = runs[-1][1]
        b, link = design.bifurcation, design.linkage
        print(
            f"bifurcation={j}: {statistics.median(t for t, _ in runs):.2f} s CPU; angle {b.point.angle:.1f}°, "
            f"σ kept {b.point.sigma_kept:.3g}, dropped {b.point.sigma_dropped:.1e}, kind {b.dyad_kind}, "
            f"max ε {max(link.epsilons):.1e}, other branch: reach {b.other_branch.reach[1]:.3g}, "
            f"bar error {b.other_branch.max_relative_bar_error:.1e}, separation {b.other_branch.separation:.2g}; "
            f"nodes {link.frame.n_nodes}, rods {link.frame.n_edges}, springs {len(design.springs.pairs)}"
        )
    runs = [cpu(lambda: refused(FLIPPED)) for _ in range(repeats)]
    print(f"turned-over triangle: {runs[-1][1]} in {statistics.median(t for t, _ in runs):.2f} s CPU")
    print(f"load after {load()}")


if __name__ == "__main__":
    main()
