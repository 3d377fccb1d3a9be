"""Sequential conformational change benchmark (issue 41 floors): a map module designed to a
fixed point and slope to 1e-8 (floor 5 s), and a 64-module chain verified by continuation
against the map's iterates (floor 30 s); and the soliton (no floor: design, anchors, the chain's
continuation over the whole drive, the uniform states' Hessians) at 16 and 32 copies.

Usage:  .venv/bin/python benchmarks/bench_sequential.py [--repeats 3] [--modules 64] [--soliton 16 32]

Each figure is the process CPU time (time.process_time) of one call, median of ``--repeats``;
the load average (/proc/loadavg) before and after is printed beside it (the machine is shared).
BLAS runs single-threaded here (set before numpy loads): on a loaded 2-core machine a
multithreaded BLAS spins its threads and counts their waiting as CPU time (a 64-module chain
measured 80 s of CPU with threads against 6 s without).
"""

from __future__ import annotations

import argparse
import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import statistics
import time

from zeromode.solver.sequential.chain import chain_of, verify_chain
from zeromode.solver.sequential.design import design_module, fixed_point
from zeromode.solver.sequential.soliton import design_soliton

FLOORS_S = {"fixed_point_design": 5.0, "chain_verified": 30.0}


def load() -> str:
    with open("/proc/loadavg", encoding="utf-8") as f:
        return " ".join(f.read().split()[:3])


def cpu(call):
    t0 = time.process_time()
    out = call()
    return time.process_time() - t0, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--modules", type=int, default=64)
    parser.add_argument("--soliton", type=int, nargs="*", default=[16, 32])
    args = parser.parse_args()
    design_module(fixed_point(1.5, -0.5))  # warm-up: numba kernels and casadi's first nlpsol
    print(f"load before: {load()}")
    rows = {}
    times = []
    for _ in range(args.repeats):
        t, design = cpu(lambda: design_module(fixed_point(1.2, 1.8)))
        times.append(t)
    rows["fixed_point_design"] = (statistics.median(times), f"deviation {design.deviation:.1e}")
    deployable = design_module(fixed_point(1.2, 1.8) + fixed_point(1.8, 0.4))
    times = []
    for _ in range(args.repeats):
        t, result = cpu(lambda: verify_chain(chain_of(deployable.map, args.modules, 1.5), deployable.map))
        times.append(t)
    rows["chain_verified"] = (
        statistics.median(times),
        (f"{args.modules} modules, {len(result.path.positions)} samples, deviation {result.deviation:.1e}, "
        f"ends {result.ends}"),
    )
    for n in args.soliton:
        times = []
        for _ in range(args.repeats):
            t, result = cpu(lambda n=n: design_soliton(fixed_point(1.2, 1.8) + fixed_point(1.8, 0.4), n_modules=n))
            times.append(t)
        sol = result.soliton
        rows[f"soliton_{n}"] = (
            statistics.median(times),
            (f"{len(result.chain.path.positions)} samples, {len(sol.drive)} on the drive, wall travels {sol.travel:.2f} "
             f"copies, deviation {result.chain.deviation:.1e}, barrier {sol.barrier:.4f}"),
        )
    for name, (seconds, note) in rows.items():
        floor = f"floor {FLOORS_S[name]:.0f} s" if name in FLOORS_S else "no floor"
        print(f"{name:20s} {seconds:7.2f} s CPU ({floor})  {note}")
    print(f"load after: {load()}")


if __name__ == "__main__":
    main()
