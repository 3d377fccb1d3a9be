"""Analysis benchmark: rank, zero modes and self-stresses of lattice frames and near-isostatic
networks, against one CHOLMOD factorisation and against PyRigi (issues 2 and 15).

Run from the repository root:  .venv/bin/python -m benchmarks.bench_analysis [--quick]

Times ``analyze`` (library level, no HTTP, single-threaded BLAS as the service runs it) on 2D
triangulated and kagome patches of 10²…10⁵ nodes and on 3D cubic-with-face-diagonals and fcc
patches of 10²…3·10⁴ nodes, and on near-isostatic disordered networks of 10²…10⁴ nodes in 2D
and 3D (benchmarks/networks.py: a few zero modes and self-stresses at any size, σ_r/σ_max
2e-6 in 2D and 6e-5 in 3D at 10⁴ nodes): counts only (``bases=False``) and with both bases (the default
call, where they fit in BASIS_MAX_NUMBERS). Beside each frame, in the same process and run, one
supernodal CHOLMOD factorisation of CᵀC + δI with CHOLMOD's own (AMD) ordering: the cost of any
factorisation-based rank method, the yardstick of issue 15. Times are process CPU seconds
(medians), which a shared machine disturbs less than wall time; the load average is recorded.

PyRigi (≥ 1.3) answers on the 10²-node frames, on the same normalised positions: one call
(``rigidity_matrix_rank``, from which every count follows) against one zeromode call for the
counts, and the four calls of the earlier benchmark (rank, infinitesimal rigidity, nontrivial
flexes, stresses) against one zeromode call that also returns both bases. Its counts must agree.

A second table measures the dense/sparse crossover that ``analyze`` uses (DENSE_MAX_ENTRIES*),
and a third splits the counts' time of the frames nearest issue 15's 2× between cvxopt's AMD
and CHOLMOD calls and everything else (``CholmodClock``; ``--split-only`` reruns it alone).
Another runs the 2D frames of 10⁶ nodes (triangulated; kagome with its many boundary zero
modes), each once in a fresh process, for the counts' time and the process's peak memory
(``--skip-million`` leaves it out).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import json
import platform
import subprocess
import sys
import time
import warnings
from pathlib import Path
from typing import Self

import numpy as np
import scipy.sparse.linalg as spla
from cvxopt import amd, cholmod

from benchmarks.lattices import LATTICES
from benchmarks.networks import NETWORKS
from zeromode.solver import Frame, analyze
from zeromode.solver.analysis.factorisation import cholesky
from zeromode.solver.analysis.rigidity import (
    BASIS_MAX_NUMBERS,
    DENSE_MAX_ENTRIES_BASES,
    DENSE_MAX_ENTRIES_COUNTS,
    compatibility_matrix,
)
from zeromode.solver.tolerances import NULL_SHIFT_RTOL

OUT = Path(__file__).resolve().parent.parent / "docs" / "benchmarks" / "analysis.md"
PYRIGI_MAX_NODES = 200
COUNTS = ("rank", "zero_modes", "rigid_body_modes", "nontrivial_zero_modes", "self_stresses")
FULL_SIZES = {
    "triangulated": [100, 1000, 10_000, 100_000],
    "kagome": [100, 1000, 10_000, 100_000],
    "cubic-diagonal": [100, 1000, 10_000, 30_000],
    "fcc": [100, 1000, 10_000, 30_000],
    "near-isostatic 2D": [100, 1000, 10_000],
    "near-isostatic 3D": [100, 1000, 10_000],
}
FRAMES = {**LATTICES, **NETWORKS}
MILLION = ("triangulated", "kagome")
CROSSOVER_ROUNDS = 31
# Medians up to 10⁴ nodes take as many rounds as fit in this many CPU seconds (runs_for) …
ROUND_BUDGET_S = 3.0
# … and at most this many.
MAX_RUNS = 101
# Lattice patches come in steps of a whole side (a triangulated patch jumps from 6 120 to 11 760 to
# 20 608 entries of C); the networks take any node count and fill the steps between.
CROSSOVER_FRAMES = ("triangulated", "kagome", "cubic-diagonal", "near-isostatic 2D", "near-isostatic 3D")
REST_HEADING = "## Through the service"
SPLIT_HEADING = "## Where the count's time goes"
# The frames whose ratio to one CHOLMOD factorisation is at or past issue 15's 2× (and a lattice
# patch that is well inside it, for contrast).
SPLIT_FRAMES = (
    ("triangulated", 100), ("kagome", 100), ("cubic-diagonal", 100), ("fcc", 100),
    ("near-isostatic 2D", 100), ("near-isostatic 3D", 100), ("near-isostatic 2D", 1000),
    ("near-isostatic 3D", 1000), ("near-isostatic 2D", 10_000), ("triangulated", 10_000),
)
MILLION_HEADING = "## 10⁶ nodes"
SIGMA_HEADING = "## σ_r as counted and as asked for"
SIGMA_INTRO = (
    "The sparse route's σ_r is the smallest nonzero Ritz value of the count's last block: never "
    "below σ_r, and some singular value of C lies within its stated relative bound (the Weyl "
    "bound of its residual, `rank_gap.last_nonzero_error`). `gap_rtol=1e-6` widens its Ritz "
    "space (one shifted solve a step) until that bound is 1e-6 (round-off in the residual, about "
    "ε·(σ_max/σ_r)², can keep it above: the service then answers 422 `not_converged`; here the "
    "bound reached is listed). *error*: against numpy's SVD of "
    "the normalised C (frames up to 10³ nodes; – above). *counts* and *with gap_rtol* timed in "
    "turn with one CHOLMOD factorisation as in the first table."
)
SIGMA_FRAMES = tuple(
    (name, n) for n in (100, 1000, 10_000)
    for name in ("triangulated", "kagome", "cubic-diagonal", "fcc", "near-isostatic 2D", "near-isostatic 3D")
)
SIGMA_RTOL = 1e-6
SPLIT_INTRO = (
    "Counts only (`analyze(frame, bases=False)`), CPU time split by wrapping cvxopt's AMD and "
    "CHOLMOD functions (`benchmarks.bench_analysis.CholmodClock`): *AMD ordering* (zeromode's "
    "minimum degree of the node graph; none where CHOLMOD orders CCᵀ itself, inside its "
    "factorisation), *CHOLMOD factorisation* (symbolic and numeric), *CHOLMOD solves* (in "
    "parentheses the columns solved in one count, with a simplicial factor one of them the solve "
    "that reads its pivots), *the rest*: everything else in the call (normalisation, C, the Gram matrix and its handover "
    "to CHOLMOD, σ_max, the block's QR and Rayleigh–Ritz steps, Python). *one CHOLMOD "
    "factorisation*: the yardstick of the first table, timed in turn in the same rounds (the "
    "order reversed every other round); medians "
    "(the parts' medians need not add up to the total's)."
)
RERUN = "Rerun alone:"
QUICK_SIZES = {
    "triangulated": [100, 1000, 10_000],
    "kagome": [100, 1000, 10_000],
    "cubic-diagonal": [100, 1000],
    "fcc": [100],
    "near-isostatic 2D": [100, 1000],
    "near-isostatic 3D": [100],
}


def paired_median_cpu(fns, runs: int) -> tuple[list[float], list]:
    """Median process CPU time of each callable over ``runs`` rounds that call them in turn
    (so a shared machine's slow spells fall on all of them alike), the order reversed every
    other round, and their last results.

    The reversal lets each call follow itself as often as the other: what a call pays in page
    faults depends on what ran before it and left the allocator's memory (2D 10⁴-node network:
    counts 40.0 ms after counts, 38.9 ms after the factorisation; the factorisation 18.7 ms after
    itself, 21.0 ms after counts), so a fixed order favours one side (there the counts: 1.84
    with them always after the factorisation, 2.14 with each after itself, 1.91 reversed)."""
    times = [[] for _ in fns]
    results = [None] * len(fns)
    for r in range(runs):
        for k, fn in (reversed(list(enumerate(fns))) if r % 2 else enumerate(fns)):
            t0 = time.process_time()
            results[k] = fn()
            times[k].append(time.process_time() - t0)
    return [float(np.median(t)) for t in times], results


def counts(a) -> dict[str, int]:
    return {name: getattr(a, name) for name in COUNTS}


def runs_for(n: int, fns=()) -> int:
    """Runs per median: many where one run is a millisecond or less, so the medians settle; up to
    10⁴ nodes, also as many as fit in ROUND_BUDGET_S, from one round of ``fns`` timed first
    (which also warms them up; at 10⁴ nodes a 2D count and its factorisation take 60 ms a round,
    and 7 rounds left their ratio 0.03–0.05 apart from run to run)."""
    least = MAX_RUNS if n <= 200 else 31 if n <= 2000 else 7 if n <= 10_000 else 3 if n <= 100_000 else 1
    if n > 10_000 or not fns:
        return least
    t0 = time.process_time()
    for fn in fns:
        fn()
    return max(least, min(MAX_RUNS, int(ROUND_BUDGET_S / max(time.process_time() - t0, 1e-9))))


def cholmod_factorisation(frame: Frame):
    """A callable that factorises CᵀC + δI of the normalised frame once, CHOLMOD's own order.

    CᵀC is formed outside the timed call; δ = NULL_SHIFT_RTOL·‖C‖_F² (the scale only matters for
    positive definiteness)."""
    c = compatibility_matrix(frame.normalised_positions(), frame.edges)
    gram = (c.T @ c).tocsr()
    shift = NULL_SHIFT_RTOL * spla.norm(c) ** 2
    return lambda: cholesky(gram, shift=shift, supernodal=True)


def pyrigi_framework(frame: Frame):
    from pyrigi import Framework, Graph

    x = frame.normalised_positions()
    graph = Graph()
    graph.add_vertices(range(frame.n_nodes))
    graph.add_edges([(int(i), int(j)) for i, j in frame.edges])
    return Framework(graph, {i: [float(v) for v in p] for i, p in enumerate(x)})


def pyrigi_calls(frame: Frame) -> tuple[float, float, dict]:
    """CPU seconds of PyRigi's one-call rank and of its four numerical calls, and its counts.

    PyRigi's numerical rank uses an absolute tolerance, so it is given the same scale-
    normalised positions zeromode decides its rank on."""
    framework = pyrigi_framework(frame)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # PyRigi warns that numerical answers are numerical
        t0 = time.process_time()
        rank = int(framework.rigidity_matrix_rank(numerical=True))
        one = time.process_time() - t0
        t0 = time.process_time()
        counts = {
            "rank": int(framework.rigidity_matrix_rank(numerical=True)),
            "inf_rigid": bool(framework.is_inf_rigid(numerical=True)),
            "flexes": len(framework.nontrivial_inf_flexes(numerical=True)),
            "stresses": len(framework.stresses(numerical=True)),
        }
        four = time.process_time() - t0
    assert counts["rank"] == rank
    return one, four, counts


def fmt_time(seconds: float | None) -> str:
    if seconds is None:
        return "–"
    if seconds < 1e-2:
        return f"{1e3 * seconds:.2f} ms"
    return f"{1e3 * seconds:.1f} ms" if seconds < 1 else f"{seconds:.2f} s"


def relative_sigma_r(frame: Frame, a) -> float:
    """σ_r / σ_max of the normalised frame: the analysis's σ_r over ARPACK's σ_max of C."""
    c = compatibility_matrix(frame.normalised_positions(), frame.edges)
    return a.rank_gap.last_nonzero / spla.svds(c, k=1, return_singular_vectors=False)[0]


def frame_table(sizes: dict[str, list[int]]) -> tuple[list[str], list[str], dict]:
    """The frames' rows, the PyRigi rows, and the counts-per-size summary for the guide (docs/benchmarks/)."""
    rows = [
        (
            "| frame | d | N | N_B | route | rank | nontrivial zero modes | self-stresses | σ_r / σ_max "
            "| counts | CHOLMOD factorisation | counts ÷ CHOLMOD | with bases | bases ÷ counts |"
        ),
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    pyrigi_rows = [
        (
            "| frame | N | PyRigi, 1 call (rank) | zeromode counts | ratio "
            "| PyRigi, 4 calls | zeromode with bases | ratio | same counts |"
        ),
        "|---|---|---|---|---|---|---|---|---|",
    ]
    summary: dict = {}
    for name, targets in sizes.items():
        for target in targets:
            frame = FRAMES[name](target)
            n, d = frame.n_nodes, frame.dim
            pair = [lambda f=frame: analyze(f, bases=False), cholmod_factorisation(frame)]
            runs = runs_for(n, pair)
            (counts_s, chol_s), (a, _) = paired_median_cpu(pair, runs)
            (bases_s,), (b,) = paired_median_cpu([lambda f=frame: analyze(f)], runs_for(n))
            c = counts(a)
            assert counts(b) == c
            numbers = c["nontrivial_zero_modes"] * d * n + c["self_stresses"] * frame.n_edges
            with_bases = fmt_time(bases_s) if b.bases_included else f"too large ({numbers:.1e})"
            ratio = f"{bases_s / counts_s:.1f}×" if b.bases_included else "–"
            rows.append(
                f"| {name} | {d} | {n} | {frame.n_edges} | {a.method} | {c['rank']} "
                f"| {c['nontrivial_zero_modes']} | {c['self_stresses']} | {relative_sigma_r(frame, a):.0e} "
                f"| {fmt_time(counts_s)} "
                f"| {fmt_time(chol_s)} | {counts_s / chol_s:.2f} | {with_bases} | {ratio} |"
            )
            print(rows[-1], flush=True)
            summary[(name, target)] = (counts_s, chol_s)
            if n <= PYRIGI_MAX_NODES:
                one, four, py = pyrigi_calls(frame)
                ours = {
                    "rank": c["rank"],
                    "inf_rigid": c["nontrivial_zero_modes"] == 0,
                    "flexes": c["nontrivial_zero_modes"],
                    "stresses": c["self_stresses"],
                }
                agree = "yes" if py == ours else f"**no**: {py} vs {ours}"
                pyrigi_rows.append(
                    f"| {name} | {n} | {fmt_time(one)} | {fmt_time(counts_s)} "
                    f"| {one / counts_s:.0f}× | {fmt_time(four)} | {fmt_time(bases_s)} "
                    f"| {four / bases_s:.0f}× | {agree} |"
                )
                print(pyrigi_rows[-1], flush=True)
    return rows, pyrigi_rows, summary


def crossover_table(dofs: list[int]) -> list[str]:
    """Dense and sparse route on the same frames around the crossover, with and without bases."""
    rows = [
        (
            "| frame | dN | N_B | N_B·dN | dense, counts | sparse, counts "
            "| dense, bases | sparse, bases |"
        ),
        "|---|---|---|---|---|---|---|---|",
    ]
    for name in CROSSOVER_FRAMES:
        seen = set()
        for dof in dofs:
            dim = 3 if name in ("cubic-diagonal", "near-isostatic 3D") else 2
            frame = FRAMES[name](dof // dim)
            dn = frame.dim * frame.n_nodes
            if dn in seen:  # a lattice patch's side is an integer: nearby targets give the same frame
                continue
            seen.add(dn)
            cells = []
            for bases in (False, True):
                seconds, _ = paired_median_cpu(
                    [lambda f=frame, m=method, b=bases: analyze(f, method=m, bases=b) for method in ("dense", "sparse")],
                    CROSSOVER_ROUNDS,
                )
                cells += [fmt_time(s) for s in seconds]
            rows.append(
                f"| {name} | {dn} | {frame.n_edges} | {dn * frame.n_edges} | "
                + " | ".join(cells)
                + " |"
            )
            print(rows[-1], flush=True)
    return rows


def sigma_r_table() -> list[str]:
    """σ_r's error and stated bound as counts report it and with gap_rtol, and the time of each
    against one CHOLMOD factorisation."""
    rows = [
        (
            f"| frame | N | counts ÷ CHOLMOD | σ_r error | stated bound | with gap_rtol {SIGMA_RTOL:.0e} ÷ CHOLMOD "
            "| σ_r error | stated bound |"
        ),
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, target in SIGMA_FRAMES:
        frame = FRAMES[name](target)
        calls = [
            lambda f=frame: analyze(f, bases=False),
            lambda f=frame: analyze(f, bases=False, gap_rtol=SIGMA_RTOL, require_gap=False),
            cholmod_factorisation(frame),
        ]
        (rough_s, exact_s, chol_s), (rough, exact, _) = paired_median_cpu(calls, runs_for(frame.n_nodes, calls))
        sigma_r = None
        if frame.n_nodes <= 1000:
            c = compatibility_matrix(frame.normalised_positions(), frame.edges).toarray()
            sigma_r = np.linalg.svd(c, compute_uv=False)[rough.rank - 1]
        cells = []
        for a, seconds in ((rough, rough_s), (exact, exact_s)):
            error = "–" if sigma_r is None else f"{abs(a.rank_gap.last_nonzero / sigma_r - 1):.0e}"
            cells += [f"{seconds / chol_s:.2f}", error, f"{a.rank_gap.last_nonzero_error:.0e}"]
        rows.append(f"| {name} | {frame.n_nodes} | " + " | ".join(cells) + " |")
        print(rows[-1], flush=True)
    return rows


def one_million(name: str) -> dict:
    """Counts of one 10⁶-node frame in this process (run by ``million_table`` in a child)."""
    frame = LATTICES[name](1_000_000)
    t0, w0 = time.process_time(), time.perf_counter()
    a = analyze(frame, bases=False)
    cpu, wall = time.process_time() - t0, time.perf_counter() - w0
    return {"n": frame.n_nodes, "nb": frame.n_edges, "cpu": cpu, "wall": wall, **counts(a),
            "gap": [a.rank_gap.last_nonzero, a.rank_gap.first_zero], "peak_gib": peak_memory_gib()}


def peak_memory_gib() -> float:
    """This process's peak resident memory: VmHWM, which starts afresh at exec (ru_maxrss keeps
    the forking parent's figure when that was larger)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) * 1024 / 2**30  # kB
    raise RuntimeError("no VmHWM in /proc/self/status (Linux only)")


def million_table() -> list[str]:
    """Each 10⁶-node frame once, alone in a fresh process: CPU and wall seconds of the counts
    (frame built beforehand) and the child's peak resident memory."""
    rows = [
        ("| frame | N | N_B | rank | nontrivial zero modes | self-stresses | σ_r / σ_{r+1} "
        "| counts (CPU) | counts (wall) | peak memory |"),
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name in MILLION:
        child = subprocess.Popen(
            [sys.executable, "-m", "benchmarks.bench_analysis", "--one-million", name],
            stdout=subprocess.PIPE, cwd=Path(__file__).resolve().parent.parent,
        )
        out = child.stdout.read()
        assert child.wait() == 0, f"{name}: exit status {child.returncode}"
        r = json.loads(out.decode().strip().splitlines()[-1])
        ratio = f"{r['gap'][0] / r['gap'][1]:.1e}" if r["gap"][1] > 0 else "∞"
        rows.append(
            f"| {name} | {r['n']} | {r['nb']} | {r['rank']} | {r['nontrivial_zero_modes']} "
            f"| {r['self_stresses']} | {ratio} | {fmt_time(r['cpu'])} | {fmt_time(r['wall'])} "
            f"| {r['peak_gib']:.2f} GiB |"
        )
        print(rows[-1], flush=True)
    return rows


def rest_table() -> list[str]:
    """POST /v1/analyze through the ASGI app (FastAPI's TestClient: the service's whole stack
    of middleware, validation and serialisation, without sockets): wall seconds, medians of 3,
    of lattices sent as JSON, gzip-compressed for the 10⁵-node one, with and without bases."""
    import gzip

    from fastapi.testclient import TestClient

    from zeromode.service.rest.app import create_app

    client = TestClient(create_app())
    rows = [
        "| frame | N | request body | options | status | wall | response body |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, target, compress in (
        ("triangulated", 1000, False),
        ("kagome", 1000, False),
        ("triangulated", 100_000, True),
    ):
        frame = LATTICES[name](target)
        for bases in (False, True) if target <= 10_000 else (False,):
            body = json.dumps({
                "frame": {"dim": frame.dim, "positions": frame.positions.tolist(),
                          "edges": frame.edges.tolist()},
                "options": {"bases": bases},
            }).encode()
            headers = {"content-type": "application/json", "accept-encoding": "gzip"}
            if compress:
                body = gzip.compress(body, compresslevel=6)
                headers["content-encoding"] = "gzip"
            times = []
            for _ in range(3):
                t0 = time.perf_counter()
                response = client.post("/v1/analyze", content=body, headers=headers)
                times.append(time.perf_counter() - t0)
            sent = response.headers.get("content-length") or str(len(response.content))
            encoding = response.headers.get("content-encoding", "identity")
            rows.append(
                f"| {name} | {frame.n_nodes} | {len(body) / 1e6:.1f} MB"
                f"{' gzip' if compress else ''} | bases={str(bases).lower()} "
                f"| {response.status_code} | {fmt_time(float(np.median(times)))} "
                f"| {int(sent) / 1e6:.2f} MB {encoding} |"
            )
            print(rows[-1], flush=True)
    return rows


# The binding's functions each part of the split wraps, by module.
CHOLMOD_PARTS = (("ordering", amd, ("order",)), ("factorisation", cholmod, ("symbolic", "numeric")),
                 ("solves", cholmod, ("solve", "spsolve")))


class CholmodClock:
    """Process CPU seconds spent inside cvxopt's AMD and CHOLMOD calls while active: the
    ordering (``amd.order``), the factorisation (``cholmod.symbolic`` and ``numeric``) and the
    solves (``cholmod.solve`` and ``spsolve``, with the number of columns solved). It wraps the
    binding's functions, which zeromode's factorisation module calls through the modules, and
    restores them on exit; everything else in a call (NumPy, SciPy, the handover of CᵀC to
    CHOLMOD, Python) is the rest."""

    def __init__(self) -> None:
        self.seconds = {part: 0.0 for part, _, _ in CHOLMOD_PARTS}
        self.columns = 0
        self._saved: list[tuple[object, str, object]] = []

    def __enter__(self) -> Self:
        for part, module, names in CHOLMOD_PARTS:
            for name in names:
                original = getattr(module, name)
                self._saved.append((module, name, original))
                setattr(module, name, self._timed(part, original))
        return self

    def __exit__(self, *exc) -> None:
        for module, name, original in self._saved:
            setattr(module, name, original)

    def _timed(self, part: str, original):
        def call(*args, **kwargs):
            if part == "solves":
                self.columns += args[1].size[1]
            t0 = time.process_time()
            try:
                return original(*args, **kwargs)
            finally:
                self.seconds[part] += time.process_time() - t0

        return call


def split_table() -> list[str]:
    """The counts' CPU time split between cvxopt's AMD and CHOLMOD calls and everything else,
    beside one CHOLMOD factorisation timed in turn in the same rounds, the order reversed every
    other round (medians)."""
    rows = [
        ("| frame | N | counts | AMD ordering | CHOLMOD factorisation | CHOLMOD solves (columns) "
         "| the rest | one CHOLMOD factorisation | counts ÷ it | the rest ÷ it |"),
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, target in SPLIT_FRAMES:
        frame = FRAMES[name](target)
        reference = cholmod_factorisation(frame)
        totals, parts, columns = [], {part: [] for part, _, _ in CHOLMOD_PARTS}, 0

        def split_count(frame=frame, parts=parts, totals=totals):
            nonlocal columns
            with CholmodClock() as clock:
                t0 = time.process_time()
                analyze(frame, bases=False)
                totals.append(time.process_time() - t0)
            for part, seconds in clock.seconds.items():
                parts[part].append(seconds)
            columns = clock.columns

        runs = runs_for(frame.n_nodes, [lambda f=frame: analyze(f, bases=False), reference])
        (_, ref), _ = paired_median_cpu([split_count, reference], runs)
        total = float(np.median(totals))
        median = {part: float(np.median(v)) for part, v in parts.items()}
        rest = float(np.median(np.array(totals) - sum(np.array(v) for v in parts.values())))
        rows.append(
            f"| {name} | {frame.n_nodes} | {fmt_time(total)} | {fmt_time(median['ordering'])} "
            f"| {fmt_time(median['factorisation'])} | {fmt_time(median['solves'])} ({columns}) "
            f"| {fmt_time(rest)} | {fmt_time(ref)} | {total / ref:.2f} | {rest / ref:.2f} |"
        )
        print(rows[-1], flush=True)
    return rows


def rewrite_table(path: Path, heading: str, table: list[str], note: str) -> None:
    """Replace the table of section ``heading`` in ``path``, keeping its text and stating
    ``note`` (in place of an earlier rerun's)."""
    text = path.read_text()
    start = text.index(heading)
    end = text.find("\n## ", start + len(heading))
    end = len(text) if end < 0 else end
    intro = text[start:end].split("\n| frame", 1)[0].rstrip().split("\n")
    intro = [line for line in intro if not line.startswith(RERUN)]
    section = "\n".join(intro) + f"\n{RERUN} {note}.\n\n" + "\n".join(table) + "\n"
    path.write_text(text[:start] + section + text[end:])


def load() -> str:
    return " ".join(Path("/proc/loadavg").read_text().split()[:3]) if Path("/proc/loadavg").exists() else "n/a"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes only (a few minutes)")
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument("--skip-million", action="store_true", help="leave out the 10⁶-node runs")
    parser.add_argument("--one-million", choices=MILLION, help=argparse.SUPPRESS)  # the child
    parser.add_argument(
        "--rest-only", action="store_true", help="rerun the service table alone, in place"
    )
    parser.add_argument(
        "--million-only", action="store_true", help="rerun the 10⁶-node table alone, in place"
    )
    parser.add_argument(
        "--split-only", action="store_true", help="rerun the time-split table alone, in place"
    )
    parser.add_argument(
        "--sigma-only", action="store_true", help="rerun the σ_r table alone, in place"
    )
    args = parser.parse_args()
    if args.one_million:
        print(json.dumps(one_million(args.one_million)))
        return
    if args.rest_only or args.million_only or args.split_only or args.sigma_only:
        heading, table = (
            (REST_HEADING, rest_table()) if args.rest_only
            else (MILLION_HEADING, million_table()) if args.million_only
            else (SIGMA_HEADING, sigma_r_table()) if args.sigma_only
            else (SPLIT_HEADING, split_table())
        )
        rewrite_table(args.out, heading, table, f"load average {load()} at its end, {time.strftime('%Y-%m-%d')}")
        print(f"wrote {args.out}")
        return
    sizes = QUICK_SIZES if args.quick else FULL_SIZES
    dofs = [50, 100, 150, 200, 300] if args.quick else [30, 40, 50, 60, 70, 80, 100, 120, 140, 160, 200, 300, 400]
    load_before = load()
    print(f"load average {load_before}", flush=True)
    print("## Frames", flush=True)
    frame_rows, pyrigi_rows, _ = frame_table(sizes)
    print("## Dense/sparse crossover", flush=True)
    crossover_rows = crossover_table(dofs)
    print("## Time split", flush=True)
    split_rows = split_table()
    print("## σ_r", flush=True)
    sigma_rows = [] if args.quick else sigma_r_table()
    print("## REST", flush=True)
    rest_rows = rest_table()
    million_rows = [] if args.quick or args.skip_million else million_table()
    load_after = load()
    lines = [
        "# Analysis benchmark",
        "",
        (
            f"`.venv/bin/python -m benchmarks.bench_analysis{' --quick' if args.quick else ''}` "
            f"on {platform.machine()}, {os.cpu_count()} cores, Python "
            f"{platform.python_version()}, BLAS threads {os.environ['OPENBLAS_NUM_THREADS']}; "
            f"a shared machine, load average (1, 5, 15 min) {load_before} at the start and "
            f"{load_after} at the end. Times are process CPU seconds."
        ),
        "",
        (
            "Lattice patches (`benchmarks/lattices.py`) and near-isostatic disordered networks "
            "(`benchmarks/networks.py`: Henneberg growth on random points, 5 bars removed and 10 "
            "added, seed 0: a few zero modes and self-stresses at any size, and σ_r falling with "
            "size). *σ_r / σ_max*: the analysis's σ_r over ARPACK's largest singular value of C. "
            "Library-level `analyze` (frame already built). *counts*: `bases=False`; *with "
            "bases*: the default call, which also returns orthonormal bases of the nontrivial "
            f"zero modes and self-stresses while they hold at most {BASIS_MAX_NUMBERS:.0e} "
            "numbers (*too large (k)*: counts only, as the service returns them; k numbers the "
            "bases would hold). *CHOLMOD "
            "factorisation*: one supernodal Cholesky factorisation of CᵀC + δI of the same frame "
            "with CHOLMOD's own ordering (AMD; cvxopt's build has no METIS), CᵀC formed "
            "beforehand and handed over from SciPy through the same binding zeromode uses — the "
            "cost of any factorisation-based rank method (zeromode's own factorisation lets "
            "CHOLMOD choose between its simplicial and supernodal kernels). *counts* and "
            "*CHOLMOD factorisation* are timed in turn in the same rounds (the order reversed "
            "every other round): medians of 101 rounds up to 200 nodes, at least 31 to 2 000 and "
            f"7 to 10⁴ (up to {MAX_RUNS} where they fit in {ROUND_BUDGET_S:.0f} CPU seconds, after "
            "one round that warms them up), 3 above; *with bases* in separate runs of 101, 31, 7 "
            "and 3. *route*: see the crossover table."
        ),
        "",
        *frame_rows,
        "",
        "## PyRigi",
        "",
        (
            "PyRigi 1.3 on the same normalised positions, one run. *1 call*: "
            "`rigidity_matrix_rank(numerical=True)`, from which every count follows, against "
            "one `analyze(bases=False)`: the fair ratio. *4 calls*: `rigidity_matrix_rank`, "
            "`is_inf_rigid`, `nontrivial_inf_flexes` and `stresses` (each rebuilds the matrix; "
            "the figure the README quoted before), against one `analyze` that also returns both "
            "bases. *same counts*: PyRigi's rank, rigidity, flex and stress counts equal ours."
        ),
        "",
        *pyrigi_rows,
        "",
        "## Dense/sparse crossover",
        "",
        (
            f"The same frames through both routes (`method=`), timed in turn, medians of {CROSSOVER_ROUNDS} rounds. `analyze` takes "
            f"the dense SVD while N_B·dN ≤ {DENSE_MAX_ENTRIES_COUNTS} for counts and "
            f"dN·max(N_B, dN) ≤ {DENSE_MAX_ENTRIES_BASES} with bases (sized by dN² since a frame with "
            "few bars still needs the dN × dN matrix V), the sparse route above."
        ),
        "",
        *crossover_rows,
        "",
    ]
    lines += [
        SPLIT_HEADING,
        "",
        SPLIT_INTRO,
        "",
        *split_rows,
        "",
    ]
    if sigma_rows:
        lines += [SIGMA_HEADING, "", SIGMA_INTRO, "", *sigma_rows, ""]
    lines += [
        REST_HEADING,
        "",
        (
            "`POST /v1/analyze` through the app's whole ASGI stack (middleware, validation, "
            "serialisation; FastAPI's TestClient, no sockets), wall time, medians of 3, "
            "`Accept-Encoding: gzip`. *response body*: bytes on the wire and their encoding."
        ),
        "",
        *rest_rows,
        "",
    ]
    if million_rows:
        lines += [
            MILLION_HEADING,
            "",
            (
                "Counts only (`analyze(frame, bases=False)`), each frame once, alone in a fresh "
                "process (the frame built before the clock starts); *peak memory*: the process's "
                "maximum resident set, frame construction and interpreter included."
            ),
            "",
            *million_rows,
            "",
        ]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
