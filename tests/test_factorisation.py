"""Elimination orders and the sparse Cholesky factorisation, against dense numpy.

The orders are checked for what they are for: each is a permutation, and eliminating the nodes
in that order (the elimination game played on the bar graph, plain Python sets) creates far
fewer edges than a random order; the factorisation solves A x = b as numpy.linalg.solve does.
"""

import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from zeromode.solver.analysis.factorisation import cholesky, minimum_degree, nested_dissection
from zeromode.solver.analysis.rigidity import compatibility_matrix


def lattice(make, n: int):
    """A jittered lattice patch and its normalised positions."""
    from benchmarks.lattices import LATTICES

    frame = LATTICES[make](n, jitter=0.1, seed=3)
    return frame, frame.normalised_positions()


def fill(n: int, pairs: np.ndarray, order: np.ndarray) -> int:
    """Off-diagonal nonzeros of the Cholesky factor of a matrix with the graph (n, pairs),
    eliminated in ``order``: each eliminated vertex joins its later neighbours pairwise."""
    neighbours = [set() for _ in range(n)]
    for i, j in pairs:
        neighbours[i].add(int(j))
        neighbours[j].add(int(i))
    position = np.empty(n, dtype=int)
    position[order] = np.arange(n)
    total = 0
    for v in order:
        later = {u for u in neighbours[v] if position[u] > position[v]}
        total += len(later)
        for u in later:
            neighbours[u] |= later - {u}
    return total


def coordinates(node_order: np.ndarray, d: int) -> np.ndarray:
    return (d * node_order[:, None] + np.arange(d)).ravel()


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 40), st.data())
def test_orders_are_permutations(n, data):
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    m = data.draw(st.integers(0, 3 * n))
    pairs = rng.integers(0, n, size=(m, 2))
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    points = rng.standard_normal((n, data.draw(st.sampled_from([2, 3]))))
    for order in (minimum_degree(n, pairs), nested_dissection(points, pairs, leaf=4)):
        assert np.array_equal(np.sort(order), np.arange(n))


@pytest.mark.parametrize("make, n", [("triangulated", 1000), ("cubic-diagonal", 1000), ("fcc", 500)])
def test_orders_reduce_fill(make, n):
    """The nodes are renumbered at random first, so the given order is no banded lattice order."""
    frame, x = lattice(make, n)
    n = frame.n_nodes
    label = np.random.default_rng(0).permutation(n)
    pairs, points = label[frame.edges], np.empty_like(x)
    points[label] = x
    given_fill = fill(n, pairs, np.arange(n))
    assert fill(n, pairs, minimum_degree(n, pairs)) < 0.35 * given_fill
    assert fill(n, pairs, nested_dissection(points, pairs, leaf=8)) < 0.35 * given_fill


@pytest.mark.parametrize("make, n", [("near-isostatic 3D", 1000), ("fcc", 864)])
def test_analysis_orders_the_gram_matrix_by_whichever_fills_less(make, n):
    """The order analyze takes for CᵀC (rigidity._elimination_order, read per node) on a 3D
    lattice patch is dissection, which fills less than minimum degree there; on a near-isostatic
    network (mean degree ≈ 2d), where dissection fills 1.8× as much as minimum degree (42 860
    against 23 384), it is no node order at all but CHOLMOD's own minimum degree of CᵀC."""
    from benchmarks.bench_analysis import FRAMES
    from zeromode.solver.analysis.rigidity import _elimination_order

    frame = FRAMES[make](n)
    x, pairs, d = frame.normalised_positions(), np.asarray(frame.edges), frame.dim
    candidates = (minimum_degree(frame.n_nodes, pairs), nested_dissection(x, pairs))
    fills = [fill(frame.n_nodes, pairs, order) for order in candidates]
    chosen = _elimination_order(x, pairs, count_modes=True)
    if make.startswith("near-isostatic"):
        assert chosen is None and fills[0] < 0.6 * fills[1]
        return
    assert np.array_equal(chosen, coordinates(chosen[::d] // d, d))  # a node's coordinates together
    assert fill(frame.n_nodes, pairs, chosen[::d] // d) == min(fills) < 0.9 * max(fills)


@pytest.mark.parametrize("order_by", ["none", "minimum_degree", "nested_dissection"])
def test_cholesky_solves_like_numpy(order_by):
    frame, x = lattice("triangulated", 200)
    c = compatibility_matrix(x, frame.edges)
    gram = (c.T @ c).tocsr()
    node_order = {
        "none": None,
        "minimum_degree": minimum_degree(frame.n_nodes, frame.edges),
        "nested_dissection": nested_dissection(x, frame.edges, leaf=8),
    }[order_by]
    order = None if node_order is None else coordinates(node_order, frame.dim)
    shift = 1e-3
    b = np.random.default_rng(1).standard_normal((gram.shape[0], 3))
    expected = np.linalg.solve(gram.toarray() + shift * np.eye(gram.shape[0]), b)
    got = cholesky(gram, order, shift=shift).solve(b)
    assert np.allclose(got, expected, rtol=1e-8, atol=1e-10 * np.abs(expected).max())


@pytest.mark.parametrize("supernodal", [False, True])
def test_pivots_are_those_of_numpy_cholesky_in_the_same_order(supernodal):
    """P A Pᵀ = L D Lᵀ: D's diagonal is diag(cholesky(P A Pᵀ))², whichever kernel CHOLMOD
    keeps (at 200 nodes its own choice is the simplicial L D Lᵀ). CHOLMOD may postorder the
    elimination tree, which permutes the pivots, so they are compared sorted."""
    frame, x = lattice("triangulated", 200)
    c = compatibility_matrix(x, frame.edges)
    gram = (c.T @ c).tocsr()
    order = coordinates(minimum_degree(frame.n_nodes, frame.edges), frame.dim)
    shift = 1e-3
    permuted = gram.toarray()[np.ix_(order, order)] + shift * np.eye(gram.shape[0])
    expected = np.sort(np.diag(np.linalg.cholesky(permuted)) ** 2)
    got = np.sort(cholesky(gram, order, shift=shift, supernodal=supernodal).pivots())
    assert np.allclose(got, expected, rtol=1e-9, atol=0.0)


@pytest.mark.parametrize("supernodal", [False, True])
@pytest.mark.parametrize("width", [0, 1, 2, 3, 4, 5, 6, 7, 9])
def test_block_solves_are_numpys_on_either_kernel(supernodal, width):
    """Blocks of any width (a supernodal factor solves them four columns at a time through
    CHOLMOD's sparse solve, a remainder under BLOCK_SOLVE_MIN_COLUMNS column by column); a
    column of zeros solves to zeros (CHOLMOD's sparse result leaves it out, so the result is
    scattered rather than read as a full block); 1-D b keeps its shape."""
    frame, x = lattice("triangulated", 200)
    c = compatibility_matrix(x, frame.edges)
    gram = (c.T @ c).tocsr()
    shift = 1e-3
    factor = cholesky(gram, shift=shift, supernodal=supernodal)
    assert factor.supernodal is supernodal  # CHOLMOD's own choice at 200 nodes is simplicial
    b = np.random.default_rng(width).standard_normal((gram.shape[0], width))
    if width >= 2:
        b[:, 1] = 0.0
    dense = gram.toarray() + shift * np.eye(gram.shape[0])
    expected = np.linalg.solve(dense, b)
    got = factor.solve(b)
    assert got.shape == b.shape
    assert np.allclose(got, expected, rtol=1e-8, atol=1e-10 * np.abs(expected).max(initial=1.0))
    if width:
        column = factor.solve(b[:, 0])
        assert column.shape == (gram.shape[0],) and np.allclose(column, expected[:, 0], rtol=1e-8)


@pytest.mark.parametrize("width", [1, 2, 3, 6])
def test_block_solves_on_a_factor_past_the_two_column_order(width):
    """A factor of order ≥ BLOCK_SOLVE_TWO_COLUMNS_MIN_ORDER (2·13 225 unknowns), where two
    columns also go through the sparse solve: (A + δI)x = b checked by SciPy's product."""
    from zeromode.solver.analysis.factorisation import BLOCK_SOLVE_TWO_COLUMNS_MIN_ORDER

    frame, x = lattice("triangulated", 13_225)
    c = compatibility_matrix(x, frame.edges)
    gram = (c.T @ c).tocsr()
    assert gram.shape[0] >= BLOCK_SOLVE_TWO_COLUMNS_MIN_ORDER
    shift = 1e-3
    factor = cholesky(gram, shift=shift, supernodal=True)
    b = np.random.default_rng(width).standard_normal((gram.shape[0], width))
    got = factor.solve(b)
    residual = gram @ got + shift * got - b
    assert np.linalg.norm(residual) <= 1e-10 * np.linalg.norm(b)


def test_benchmark_clock_sees_a_counts_cholmod_calls_and_gives_the_binding_back():
    # The analysis benchmark splits a count's time between cvxopt's AMD and CHOLMOD calls and the
    # rest by wrapping the binding's functions (benchmarks.bench_analysis.CholmodClock). Inside,
    # every part of a count is seen: the factorisation, at least two shift-invert steps of a block
    # of OVERSAMPLE columns beyond the null vectors found, and the node graph's ordering where the
    # count takes one (a lattice patch: a near-isostatic network leaves it to CHOLMOD's symbolic
    # step); its parts never add up to more than the call. Outside, the binding's own functions
    # are back.
    from cvxopt import amd, cholmod

    from benchmarks.bench_analysis import FRAMES, CholmodClock
    from zeromode.solver import analyze
    from zeromode.solver.analysis.rigidity import OVERSAMPLE

    names = [(amd, "order"), (cholmod, "symbolic"), (cholmod, "numeric"), (cholmod, "solve"), (cholmod, "spsolve")]
    originals = [getattr(module, name) for module, name in names]
    frame = FRAMES["near-isostatic 2D"](1000)
    with CholmodClock() as clock:
        t0 = time.process_time()
        a = analyze(frame, bases=False)
        total = time.process_time() - t0
        assert cholmod.numeric is not originals[2]
    assert [getattr(module, name) for module, name in names] == originals
    assert clock.seconds["ordering"] == 0 and all(s > 0 for p, s in clock.seconds.items() if p != "ordering")
    assert sum(clock.seconds.values()) <= total
    with CholmodClock() as patch_clock:
        analyze(FRAMES["triangulated"](1000), bases=False)
    assert all(seconds > 0 for seconds in patch_clock.seconds.values())
    assert a.nontrivial_zero_modes > 0
    assert clock.columns >= 2 * (a.nontrivial_zero_modes + OVERSAMPLE)
