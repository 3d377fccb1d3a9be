"""Finite-motion benchmark: speed against accuracy of IPOPT refinement, and where methods fail.

Usage:  .venv/bin/python benchmarks/bench_finite_motion.py [--quick] [--out docs]

Part 1 (speed vs accuracy).  For each design (frame, u_S, a) the linear design's ε(a) is
measured, then refine() runs for every K in KS and tol in TOLS; each run records IPOPT's time,
the whole refinement's time (both ε measurements and the re-verification included), ε after
and the status.  Medians over designs are reported per (K, tol).

Part 2 (where methods fail).  2D designs with k = 3 specified nodes whose motion is
u_S = (1 − η)·(dilation) + η·(seeded random motion), both scaled to unit RMS, over amplitudes a
up to 1 (100 % of the specified nodes' size) and randomness η ∈ [0, 1].  Each cell records
whether continuation of the linear design meets a singular point within parameter a
(`singular_path`), the linear design's ε, whether refinement fails (`refinement_failed`),
and ε after.

Writes <out>/finite_motion_bench.json and <out>/finite_motion.png (matplotlib, a
benchmark-only dependency).  The machine may be shared: medians, and ratios, are the figures
to quote.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

# Hand-made linear designs live with the tests until zeromode.solver.design provides them;
# a caller can pass any list of designs to speed_vs_accuracy() and failure_map().
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from mechanisms import bipartite_design, outward_square, random_targets

from zeromode.solver.errors import DomainError
from zeromode.solver.finite_motion import motion_fidelity, trace_motion
from zeromode.solver.refine import RefinementFailed, refine, target_displacement

KS = (2, 4, 8, 16)
TOLS = (1e-4, 1e-6, 1e-8)
AMPLITUDES = (0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0)
RANDOMNESS = (0.0, 0.25, 0.5, 0.75, 1.0)


def default_designs(seeds) -> list[dict]:
    """The outward square at a = 0.2, random 2D k = 3 and 3D k = 4 designs at a = 0.1."""
    square = outward_square()
    designs = [
        {"name": "outward_2d", "frame": square, "motion": square.positions[:4], "amplitude": 0.2}
    ]
    for k, d, nu in ((3, 2, 2), (4, 3, 5)):
        for seed in seeds:
            x_s, u_s = random_targets(k, d, seed)
            designs.append(
                {
                    "name": f"random_{d}d_k{k}_s{seed}",
                    "frame": bipartite_design(x_s, u_s, nu, seed=seed),
                    "motion": u_s,
                    "amplitude": 0.1,
                }
            )
    return designs


def run_refine(frame, motion, amplitude, **options) -> dict:
    t0 = time.perf_counter()
    try:
        res, status = refine(frame, motion, amplitude, **options), "ok"
    except RefinementFailed as exc:
        res, status = exc.best, exc.code
    except DomainError as exc:
        return {
            "status": exc.code,
            "message": exc.message,
            "wall_ms": 1e3 * (time.perf_counter() - t0),
        }
    return {
        "status": status,
        "ipopt_status": res.ipopt_status,
        "iterations": res.iterations,
        "attempts": res.attempts,
        "ipopt_ms": res.ipopt_time_ms,
        "total_ms": res.time_ms,
        "epsilon_before": res.epsilon_before,
        "epsilon_after": res.epsilon_after,
    }


def speed_vs_accuracy(designs) -> list[dict]:
    rows = []
    for design in designs:
        for K in KS:
            for tol in TOLS:
                row = run_refine(
                    design["frame"], design["motion"], design["amplitude"], K=K, tol=tol
                )
                rows.append({"design": design["name"], "K": K, "tol": tol, **row})
                print(
                    f"{design['name']:20s} K={K:2d} tol={tol:.0e}  {row['status']:18s} "
                    f"eps {row.get('epsilon_before', np.nan):.2e} -> {row.get('epsilon_after', np.nan):.2e}  "
                    f"ipopt {row.get('ipopt_ms', np.nan):7.1f} ms  total {row.get('total_ms', np.nan):7.1f} ms",
                    flush=True,
                )
    return rows


def mixed_motion(x_s, eta, rng):
    """u_S = (1 − η)·dilation + η·random, each of unit RMS over the specified nodes."""

    def unit(u):
        return u / np.sqrt(np.mean(np.sum(u**2, axis=1)))

    dilation = unit(x_s - x_s.mean(axis=0))
    return (1 - eta) * dilation + eta * unit(rng.standard_normal(x_s.shape))


def failure_map(seeds) -> list[dict]:
    rows = []
    for eta in RANDOMNESS:
        for seed in seeds:
            rng = np.random.default_rng(1000 + seed)
            x_s = rng.standard_normal((3, 2))
            u_s = mixed_motion(x_s, eta, rng)
            try:
                frame = bipartite_design(x_s, u_s, 2, seed=seed)
            except RuntimeError:
                continue
            # Continuation of the linear design, both ways, once: a cell at amplitude a counts a
            # singular point met within |parameter| ≤ a (the path's own units).
            far = trace_motion(frame, amplitude=max(AMPLITUDES), direction="both")
            singular_at = [abs(sg.parameter) for sg in far.singularities]
            for a in AMPLITUDES:
                delta, _ = target_displacement(frame, u_s, a)
                fid, path = motion_fidelity(frame, delta)
                linear = {
                    "linear_epsilon": fid.epsilon,
                    "linear_path": path.status,
                    "continuation": "singular_path" if any(p <= a for p in singular_at) else "ok",
                }
                row = run_refine(frame, u_s, a, K=8, tol=1e-8)
                rows.append({"eta": eta, "seed": seed, "amplitude": a, **linear, **row})
                print(
                    f"eta={eta:.2f} seed={seed} a={a:.2f}  continuation {linear['continuation']:13s} "
                    f"eps_linear {fid.epsilon:.2e}  refine {row['status']:18s} "
                    f"eps_after {row.get('epsilon_after', np.nan):.2e}",
                    flush=True,
                )
    return rows


def summarise(speed: list[dict]) -> list[dict]:
    table = []
    for K in KS:
        for tol in TOLS:
            sel = [r for r in speed if r["K"] == K and r["tol"] == tol and "epsilon_after" in r]
            if not sel:
                continue
            ok = [r for r in sel if r["status"] == "ok"]
            table.append(
                {
                    "K": K,
                    "tol": tol,
                    "median_ipopt_ms": float(np.median([r["ipopt_ms"] for r in sel])),
                    "median_total_ms": float(np.median([r["total_ms"] for r in sel])),
                    # ε over the successful runs; a failure reports the best frame's ε instead.
                    "median_epsilon_after": float(
                        np.median([r["epsilon_after"] for r in ok] or [np.nan])
                    ),
                    "max_epsilon_after": float(
                        np.max([r["epsilon_after"] for r in ok] or [np.nan])
                    ),
                    "two_attempts": sum(r.get("attempts", 1) == 2 for r in sel),
                    "failures": sum(r["status"] != "ok" for r in sel),
                    "runs": len(sel),
                }
            )
    return table


def plot(speed, summary, fail_rows, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, 6.8))
    colours = dict(zip(KS, ("tab:blue", "tab:orange", "tab:green", "tab:red")))
    markers = dict(zip(TOLS, ("o", "s", "^")))
    floor = 1e-16
    for r in speed:
        if "epsilon_after" in r:
            ax1.scatter(
                r["ipopt_ms"],
                max(r["epsilon_after"], floor),
                s=14,
                alpha=0.35,
                color=colours[r["K"]],
                marker=markers[r["tol"]],
            )
    for row in summary:
        ax1.scatter(
            row["median_ipopt_ms"],
            max(row["median_epsilon_after"], floor),
            s=90,
            color=colours[row["K"]],
            marker=markers[row["tol"]],
            edgecolor="black",
            label=f"K={row['K']}, tol={row['tol']:.0e} (median)",
        )
    before = [r["epsilon_before"] for r in speed if "epsilon_before" in r]
    ax1.axhline(np.median(before), color="grey", ls="--", lw=1, label="linear design (median ε)")
    ax1.axhline(1e-6, color="black", ls=":", lw=1, label="target ε = 1e-6")
    ax1.set_xscale("log")
    ax1.set_yscale("log")
    ax1.set_xlabel("IPOPT time per refinement [ms]")
    ax1.set_ylabel("finite-motion error ε after refinement")
    ax1.set_title("Speed vs accuracy (each point one design; large: median)")
    ax1.legend(fontsize=7, ncol=3, loc="upper center", bbox_to_anchor=(0.5, -0.14))

    grid = np.full((len(RANDOMNESS), len(AMPLITUDES)), np.nan)
    notes = [["" for _ in AMPLITUDES] for _ in RANDOMNESS]
    for i, eta in enumerate(RANDOMNESS):
        for j, a in enumerate(AMPLITUDES):
            cell = [r for r in fail_rows if r["eta"] == eta and r["amplitude"] == a]
            if not cell:
                continue
            grid[i, j] = np.mean([r["status"] != "ok" for r in cell])
            singular = sum(r["continuation"] != "ok" for r in cell)
            eps = [
                r["epsilon_after"]
                for r in cell
                if r["status"] == "ok" and r.get("epsilon_after") is not None
            ]
            notes[i][j] = f"S{singular}/{len(cell)}\n" + (f"{np.median(eps):.0e}" if eps else "—")
    im = ax2.imshow(grid, origin="lower", cmap="Reds", vmin=0, vmax=1, aspect="auto")
    for i in range(len(RANDOMNESS)):
        for j in range(len(AMPLITUDES)):
            ax2.text(j, i, notes[i][j], ha="center", va="center", fontsize=7)
    ax2.set_xticks(range(len(AMPLITUDES)), [f"{a:.0%}" for a in AMPLITUDES])
    ax2.set_yticks(range(len(RANDOMNESS)), [f"{e:.2f}" for e in RANDOMNESS])
    ax2.set_xlabel("amplitude a (RMS displacement / RMS size of the specified nodes)")
    ax2.set_ylabel("target randomness η")
    ax2.set_title(
        "Where methods fail (2D, k = 3)\ncolour: refinement_failed fraction; "
        "S: linear path singular; median ε after"
    )
    fig.colorbar(im, ax=ax2, fraction=0.046)
    fig.tight_layout()
    fig.savefig(path, dpi=130)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer seeds (a smoke run)")
    parser.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs"))
    parser.add_argument("--replot", action="store_true", help="redraw the PNG from the saved JSON")
    args = parser.parse_args(argv)
    seeds = range(2) if args.quick else range(5)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.replot:  # recompute the summary and redraw from the saved runs
        data = json.loads((out / "finite_motion_bench.json").read_text())
        data["summary"] = summarise(data["speed_vs_accuracy"])
        (out / "finite_motion_bench.json").write_text(json.dumps(data, indent=1))
        plot(
            data["speed_vs_accuracy"],
            data["summary"],
            data["failure_map"],
            out / "finite_motion.png",
        )
        return 0
    speed = speed_vs_accuracy(default_designs(seeds))
    summary = summarise(speed)
    fail_rows = failure_map(range(2) if args.quick else range(4))
    for row in summary:
        print(row)
    (out / "finite_motion_bench.json").write_text(
        json.dumps(
            {"speed_vs_accuracy": speed, "summary": summary, "failure_map": fail_rows}, indent=1
        )
    )
    plot(speed, summary, fail_rows, out / "finite_motion.png")
    print(f"wrote {out / 'finite_motion_bench.json'} and {out / 'finite_motion.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
