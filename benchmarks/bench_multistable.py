"""Multistable design benchmark (issue #41, item 1; floor: a tristable 2D design ≤ 5 s).

Usage:  .venv/bin/python benchmarks/bench_multistable.py [--repeats 5]

CPU time (time.process_time of this process: the machine is shared, so wall time measures the
neighbours) of ``design_multistable`` on
  * the tristable triangle of docs/multistable.md (example ``tristable_triangle_2d``), whole and
    by stage (linkage with its continuation, springs, verification);
  * a bistable 2D square (two conformations, the two-configuration route);
  * a tristable 3D tetrahedron (three conformations on x + t·u + t²·w, t = 0, 0.05, 0.1);
medians of ``--repeats`` runs, the load average (/proc/loadavg) before and after.

The spring program, measured both ways on the triangle's samples (the choice in springs.py):
cvxpy + Clarabel (the cone program the solver solves) against casadi + IPOPT on the same
variables, constraints and objective (the stored energy Σ_m Σ_s (α_s ℓ_s,m − β_s)²/(2α_s)).
"""

from __future__ import annotations

import argparse
import itertools
import statistics
import time

import numpy as np

from zeromode.service.wire.examples import example_request
from zeromode.solver.analysis.normalisation import Normalisation
from zeromode.solver.multistable import springs as springs_module
from zeromode.solver.multistable.design import design_multistable
from zeromode.solver.multistable.linkage import design_linkage
from zeromode.solver.multistable.springs import design_springs
from zeromode.solver.multistable.verify import check_minima
from zeromode.solver.tolerances import SPRING_DROP_RTOL

TRIANGLE = example_request("tristable_triangle_2d")["conformations"]
SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
BISTABLE = [SQUARE, SQUARE + [[0.0, 0.0], [0.1, 0.0], [0.25, -0.1], [0.1, 0.05]]]
_rng = np.random.default_rng(0)
_x, _u, _w = (_rng.standard_normal((4, 3)) for _ in range(3))
TETRA = [_x + t * _u + t * t * _w for t in (0.0, 0.05, 0.1)]


def load() -> str:
    with open("/proc/loadavg", encoding="ascii") as f:
        return " ".join(f.read().split()[:3])


def cpu(call, repeats: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeats):
        t0 = time.process_time()
        out = call()
        times.append(time.process_time() - t0)
    return statistics.median(times), out


def casadi_program(samples, h: float):
    """The solver's spring program (springs._program, barriers ≥ h) by casadi + IPOPT:
    (CPU seconds, stored energy at the optimum, IPOPT's return status)."""
    import casadi as ca

    ell, s, at = samples.ell, samples.s, samples.at
    n = ell.shape[1]
    a, b = ca.SX.sym("a", n), ca.SX.sym("b", n)
    energy = ca.mtimes(ca.DM(ell**2 / 2), a) - ca.mtimes(ca.DM(ell), b)
    g, lo, hi = [], [], []

    def add(expr, low, high):
        g.append(expr)
        lo.append(low)
        hi.append(high)

    for j, k in enumerate(at):
        d1, d2 = samples.d1[j], samples.d2[j]
        add(ca.dot(ca.DM(ell[k] * d1), a) - ca.dot(ca.DM(d1), b), 0.0, 0.0)
        add(ca.dot(ca.DM(d1**2 + ell[k] * d2), a) - ca.dot(ca.DM(d2), b), springs_module.CURVATURE_FLOOR, ca.inf)
    diff = energy[1:] - energy[:-1]
    for k in range(at[0]):
        add(diff[k], -ca.inf, 0.0)
    for k in range(at[-1], len(s) - 1):
        add(diff[k], 0.0, ca.inf)
    for left, right in itertools.pairwise(at):
        peak = left + 1 + int(np.argmin(np.abs(s[left + 1 : right] - 0.5 * (s[left] + s[right]))))
        for k in range(left, peak):
            add(diff[k], 0.0, ca.inf)
        for k in range(peak, right):
            add(diff[k], -ca.inf, 0.0)
        add(energy[peak] - energy[left], h, ca.inf)
        add(energy[peak] - energy[right], h, ca.inf)
    rest_lo, rest_hi = springs_module.REST_RANGE[0] * ell.min(axis=0), springs_module.REST_RANGE[1] * ell.max(axis=0)
    for i in range(n):
        add(b[i] - rest_lo[i] * a[i], 0.0, ca.inf)
        add(rest_hi[i] * a[i] - b[i], 0.0, ca.inf)
    stored = sum(sum((ell[k, i] * a[i] - b[i]) ** 2 for k in at) / (2 * a[i]) for i in range(n))
    t0 = time.process_time()
    solver = ca.nlpsol("springs", "ipopt", {"x": ca.vertcat(a, b), "f": stored, "g": ca.vertcat(*g)},
                       {"ipopt.print_level": 0, "print_time": False, "ipopt.tol": 1e-8})
    x0 = np.concatenate([np.full(n, 0.5), 0.5 * ell.mean(axis=0)])
    res = solver(x0=x0, lbx=[1e-9] * n + [-np.inf] * n, ubx=[1.0] * n + [np.inf] * n, lbg=lo, ubg=hi)
    return time.process_time() - t0, float(res["f"]), solver.stats()["return_status"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    print(f"load before: {load()}")
    for name, confs in (("tristable 2D triangle", TRIANGLE), ("bistable 2D square", BISTABLE),
                        ("tristable 3D tetrahedron", TETRA)):
        t, r = cpu(lambda c=confs: design_multistable(c), args.repeats)
        link = r.linkage
        print(f"{name}: {t:.2f} s CPU (median of {args.repeats}); N = {link.frame.n_nodes}, rods = {link.frame.n_edges}, "
              f"springs = {len(r.springs.pairs)}, gap = {link.gap:.3g}, barriers = "
              f"{[round(m.barrier, 8) for m in r.landscape.minima]}, E'' = {[round(m.curvature, 5) for m in r.landscape.minima]}")
    # Stages of the triangle.
    t_link, link = cpu(lambda: design_linkage(TRIANGLE), args.repeats)
    t_springs, (springs, land, _) = cpu(lambda: design_springs(link, None), args.repeats)
    t_check, _ = cpu(lambda: check_minima(link.frame, link.conformations, springs, land, 1.0), args.repeats)
    print(f"triangle by stage (CPU, medians): linkage + continuation {t_link:.2f} s, springs {t_springs:.2f} s, "
          f"verification {t_check:.2f} s")
    # The spring program both ways.
    samples = springs_module._samples(link, Normalisation.of(link.frame.positions))
    h = 0.5 * springs_module._largest_barrier(samples) * (1 + springs_module.BARRIER_MARGIN)
    t_cvx, sol = cpu(lambda: springs_module._program(samples, h), args.repeats)
    alpha, beta, _ = sol
    keep = alpha > SPRING_DROP_RTOL
    stored = sum(np.sum((alpha[keep] * samples.ell[k, keep] - beta[keep]) ** 2 / alpha[keep]) / 2 for k in samples.at)
    t_ipopt, stored_ipopt, status = casadi_program(samples, h)
    print(f"spring program (normalised units): cvxpy + Clarabel {t_cvx:.3f} s CPU, stored energy {stored:.6g}; "
          f"casadi + IPOPT {t_ipopt:.3f} s CPU, stored energy {stored_ipopt:.6g} ({status})")
    print(f"load after: {load()}")


if __name__ == "__main__":
    main()
