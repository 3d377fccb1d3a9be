"""Large specified sets: the partitioned construction (Supplementary "Combining Networks Through
Judicious Constraint Placement").

For k > 2d specified nodes no single unspecified node can generally join them all, so the design
is built from modules: anchor sets of at most 2d specified nodes (primary modules when disjoint,
coupling modules when they overlap), each carrying unspecified nodes on its own solution space.
Every design is checked by the independent route of oracles.designs.check_design (PyRigi's flexes
and stresses, a compatibility matrix built here, exact specified rows); the claims that a
specified set has no full-set solution are checked exactly with sympy.

Counting lower bound on the number of unspecified nodes, from Eq. 7: the design must bring
N_D = dk down to d(d+1)/2 + 1, and an unspecified node with a anchors brings d coordinates and
a bars, where a ≤ 2d (its solution space has dimension 2d − a; a generic target has no
solution for a > 2d).  So each node removes at most d degrees of freedom and
N_U ≥ ⌈(dk − d(d+1)/2 − 1)/d⌉.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from oracles.designs import check_design

from zeromode.solver.construction.design import design

# The greedy placement is not optimal; it must stay within this factor of the counting bound.
MINIMALITY_FACTOR = 2.0


def lower_bound(d: int, k: int) -> int:
    return -(-(d * k - d * (d + 1) // 2 - 1) // d)


def check_modules(result, k: int, d: int) -> None:
    """The anchor sets are modules of the paper's partition: each has d + 1 … 2d specified nodes
    (pinned, with a real solution space), together they cover every specified node, and they
    are coupled — the graph joining overlapping anchor sets is connected."""
    sets = [set(a) for a in result.anchor_sets]
    assert all(d + 1 <= len(s) <= 2 * d for s in sets), result.anchor_sets
    assert set().union(*sets) == set(range(k))
    reached, frontier = {0}, [0]
    while frontier:
        i = frontier.pop()
        for j, s in enumerate(sets):
            if j not in reached and s & sets[i]:
                reached.add(j)
                frontier.append(j)
    assert reached == set(range(len(sets)))


def report_line(d, k, seed, result, counts) -> str:
    bound = lower_bound(d, k)
    return (
        f"d={d} k={k:2d} seed={seed}: N_U={result.unspecified_nodes:2d} (bound {bound}, "
        f"ratio {result.unspecified_nodes / bound:.2f}), N_B={counts['bars']}, "
        f"modules={len(set(result.anchor_sets))}"
    )


def random_target(d: int, k: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng([d, k, seed, 5])
    return rng.standard_normal((k, d)), rng.standard_normal((1, k, d))


@pytest.mark.parametrize(
    ("d", "k"), [(2, 5), (2, 6), (2, 7), (2, 8), (3, 7), (3, 8), (3, 9), (3, 10)]
)
def test_random_large_k_single_motion(d, k):
    lines = []
    for seed in range(3):
        x, motions = random_target(d, k, seed)
        result = design(x, motions, seed=seed)
        counts = check_design(result, x, motions)
        check_modules(result, k, d)
        assert (
            lower_bound(d, k) <= result.unspecified_nodes <= MINIMALITY_FACTOR * lower_bound(d, k)
        )
        lines.append(report_line(d, k, seed, result, counts))
    print("\n" + "\n".join(lines))


def joining_nodes(x, u) -> tuple[int, int]:
    """(number of real, number of complex) positions of one unspecified node joined to all k
    specified nodes, exactly: the differences of the bar equations (Eq. 1) are linear in
    (x_U, u_U); their solution set, put into the first equation, leaves a polynomial."""
    d = len(x[0])
    xu, uu = sp.symbols(f"x0:{d}"), sp.symbols(f"u0:{d}")
    bars = [
        sp.expand(sum((sp.Integer(xi[a]) - xu[a]) * (sp.Integer(ui[a]) - uu[a]) for a in range(d)))
        for xi, ui in zip(x, u)
    ]
    linear = [sp.expand(b - bars[0]) for b in bars[1:]]
    solutions = sp.linsolve(linear, [*xu, *uu])
    if solutions == sp.EmptySet:
        return 0, 0
    (line,) = solutions
    rest = sp.expand(bars[0].subs(dict(zip([*xu, *uu], line))))
    free = sorted(rest.free_symbols, key=str)
    assert len(free) == 1, "a one-parameter family expected for k = 2d"
    poly = sp.Poly(rest, free[0])
    real = len(sp.real_roots(poly))
    return real, poly.degree() - real


HEXAGON = [[2, 0], [1, 2], [-1, 2], [-2, 0], [-1, -2], [1, -2]]
HEXAGON_MOTION = [[-1, 2], [1, 0], [0, 0], [2, -2], [0, 1], [0, 2]]
OCTAHEDRON = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]
OCTAHEDRON_MOTION = [[-1, 1, 0], [2, 2, -1], [0, -1, 1], [1, 2, 2], [2, 2, 2], [-2, -2, 0]]


@pytest.mark.parametrize(
    ("name", "x", "u"),
    [("2D six nodes", HEXAGON, HEXAGON_MOTION), ("3D six nodes", OCTAHEDRON, OCTAHEDRON_MOTION)],
)
def test_paper_partition_cases(name, x, u):
    """The supplement's two examples: six specified nodes with no real position for a node joined
    to all of them (2D: the linear system is inconsistent; 3D: its two solutions are complex),
    designed through primary and coupling modules."""
    d = len(x[0])
    real, complex_ = joining_nodes(x, u)
    assert real == 0 and (complex_ == 0 if d == 2 else complex_ == 2)
    xs, us = np.array(x, dtype=float), np.array([u], dtype=float)
    result = design(xs, us, seed=0)
    counts = check_design(result, xs, us)
    check_modules(result, len(x), d)
    assert result.analysis.maxwell_count == d * (d + 1) // 2 + 1
    bound = lower_bound(d, len(x))
    assert bound <= result.unspecified_nodes <= MINIMALITY_FACTOR * bound
    print(
        f"\n{name}: N_U={result.unspecified_nodes}, N_B={counts['bars']}, "
        f"N_D={result.analysis.maxwell_count}, bound {bound}, "
        f"modules={sorted(set(result.anchor_sets))}"
    )
