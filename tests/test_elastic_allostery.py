"""The elastic response model of allostery in a given network (solver/applications/
elastic_allostery.py), checked from its definition.

The oracle (tests/oracles/springs.py, from the definition): the dense stiffness matrix
K = Σ_b k_b q_b q_bᵀ, the source strain imposed by minimising ½uᵀKu under q_Sᵀu = ℓ_S through the
KKT system solved by dense least squares, η = ε_T/ε_S read off u. Stability: the singular values
of diag(√k) Q (numpy SVD) leave exactly d(d+1)/2 zero modes. The edit is read from the answer's
frame (kept bars = given bars less the removed ones) and stiffnesses (one changed at most).
Networks: the issue's seeded jammed-like Delaunay networks (benchmarks/allostery_tasks.py).
"""

from __future__ import annotations

import numpy as np
import pytest
from oracles.springs import spring_ratio, spring_zero_modes

from benchmarks.allostery_tasks import make_task
from zeromode.solver import DomainError, Frame, InvalidInput
from zeromode.solver.applications.elastic_allostery import (
    MAX_STIFFNESS,
    RatioOutOfReach,
    tune_elastic,
)


def edited(task, result) -> tuple[np.ndarray, np.ndarray]:
    """(edges, stiffness) of the answer, checked against the given network and the report."""
    given = task.frame.edges
    kept = np.delete(given, list(result.removed_edges), axis=0)
    assert np.array_equal(result.frame.edges, kept)
    assert np.array_equal(result.frame.positions, task.frame.positions)
    k = np.asarray(result.stiffness)
    changed = np.flatnonzero(k != 1.0)
    if result.tuned_edge is None:
        assert changed.size == 0
    else:
        (only,) = changed
        assert tuple(kept[only]) == tuple(given[result.tuned_edge])
        assert result.tuned_stiffness == (1.0, k[only])
        assert 0.0 < k[only] <= MAX_STIFFNESS
    assert result.changes == len(result.removed_edges) + changed.size
    return kept, k


@pytest.mark.parametrize(("n", "seed", "ratio"), [(100, 0, 1.0), (100, 1, -1.0), (400, 0, 2.0), (400, 1, -1.0)])
def test_edit_is_exact_fewest_and_keeps_the_network_rigid(n, seed, ratio):
    task = make_task(n, seed, ratio)
    result = tune_elastic(task.frame, task.source_pair, task.target_pair, ratio)
    x = task.frame.positions
    edges, k = edited(task, result)
    eta = spring_ratio(x, edges, k, task.source_pair, task.target_pair)
    assert abs(eta - ratio) <= 1e-9 * max(1.0, abs(ratio))
    assert result.strain_ratio == pytest.approx(eta, abs=1e-9)
    assert result.initial_ratio == pytest.approx(
        spring_ratio(x, task.frame.edges, np.ones(task.frame.n_edges), task.source_pair, task.target_pair), abs=1e-9
    )
    assert spring_zero_modes(x, edges, k) == 3 == spring_zero_modes(x, task.frame.edges, np.ones(task.frame.n_edges))
    assert result.changes >= 1 and result.tuned_edge is not None


def test_sensitivity_is_the_slope_of_the_ratio_in_the_tuned_stiffness():
    task = make_task(100, 0, 2.0)
    result = tune_elastic(task.frame, task.source_pair, task.target_pair, 2.0)
    edges, k = edited(task, result)
    (b,) = np.flatnonzero(k != 1.0)
    h = 1e-5 * k[b]
    up, down = k.copy(), k.copy()
    up[b] += h
    down[b] -= h
    x = task.frame.positions
    slope = (spring_ratio(x, edges, up, task.source_pair, task.target_pair)
             - spring_ratio(x, edges, down, task.source_pair, task.target_pair)) / (2 * h)
    assert result.sensitivity == pytest.approx(slope, rel=1e-4)


def test_no_single_stiffness_of_the_given_network_reaches_the_ratio_when_bars_were_removed():
    """The first step's claim, by brute force with the oracle: η(k_b) is monotone in k_b, so η*
    is reachable by bar b alone iff it lies between η at k_b = 0 and at k_b = k_max."""
    task = make_task(100, 1, 2.0)
    result = tune_elastic(task.frame, task.source_pair, task.target_pair, 2.0)
    assert result.removed_edges, "this task needs removals"
    x, edges = task.frame.positions, task.frame.edges
    for b in range(len(edges)):
        ends = []
        for value in (0.0, MAX_STIFFNESS):
            k = np.ones(len(edges))
            k[b] = value
            ends.append(spring_ratio(x, edges, k, task.source_pair, task.target_pair))
        assert not min(ends) <= 2.0 <= max(ends) or spring_zero_modes(x, edges[np.arange(len(edges)) != b], np.ones(len(edges) - 1)) > 3


def test_stated_stiffnesses_are_honoured():
    task = make_task(100, 0, -1.0)
    x, edges = task.frame.positions, task.frame.edges
    stiffness = 1.0 / np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1)  # pruning's springs
    result = tune_elastic(task.frame, task.source_pair, task.target_pair, -1.0, stiffness=stiffness)
    kept = np.delete(np.arange(len(edges)), list(result.removed_edges))
    k = np.asarray(result.stiffness)
    assert np.count_nonzero(k != stiffness[kept]) == (result.tuned_edge is not None)
    eta = spring_ratio(x, edges[kept], k, task.source_pair, task.target_pair)
    assert abs(eta + 1.0) <= 1e-9


def test_a_ratio_out_of_reach_is_refused_with_the_best_figures():
    task = make_task(100, 0, 1.0)
    with pytest.raises(RatioOutOfReach) as err:
        tune_elastic(task.frame, task.source_pair, task.target_pair, 1e6)
    best = err.value.best
    assert err.value.code == "ratio_out_of_reach"
    k = np.ones(task.frame.n_edges)
    if best["tuned_edge"] is not None:
        k[best["tuned_edge"]] = best["tuned_stiffness"][1]
    keep = np.ones(task.frame.n_edges, dtype=bool)
    keep[best["removed_edges"]] = False
    keep &= k > 0
    x = task.frame.positions
    eta = spring_ratio(x, task.frame.edges[keep], k[keep], task.source_pair, task.target_pair)
    assert best["strain_ratio"] == pytest.approx(eta, rel=1e-6)
    assert abs(eta - 1e6) > 1e-9 * 1e6


@pytest.mark.parametrize(
    ("kwargs", "code"),
    [
        ({"stiffness": [1.0, 2.0]}, "invalid_stiffness"),
        ({"stiffness": "negative"}, "invalid_stiffness"),
        ({"max_stiffness": 0.5}, "invalid_target"),
        ({"source_pair": [0]}, "invalid_pair"),
    ],
)
def test_bad_input_is_refused(kwargs, code):
    task = make_task(100, 0, 1.0)
    args = {"source_pair": task.source_pair, "target_pair": task.target_pair, "strain_ratio": 1.0, **kwargs}
    if args.get("stiffness") == "negative":
        args["stiffness"] = -np.ones(task.frame.n_edges)
    with pytest.raises(InvalidInput) as err:
        tune_elastic(task.frame, **args)
    assert err.value.code == code


def test_a_floppy_network_is_refused():
    square = Frame.build(np.array([[0, 0], [1, 0], [1, 1], [0, 1.0]]), np.array([[0, 1], [1, 2], [2, 3], [3, 0]]))
    with pytest.raises(DomainError) as err:
        tune_elastic(square, (0, 2), (1, 3), 1.0)
    assert err.value.code == "floppy_network"


def test_three_dimensional_network():
    """The model is d-general: a 3D Delaunay network (over-braced), η* reached exactly."""
    from scipy.spatial import Delaunay

    x = np.random.default_rng(3).uniform(-1, 1, (60, 3))
    tets = Delaunay(x).simplices
    pairs = np.concatenate([tets[:, [i, j]] for i in range(4) for j in range(i + 1, 4)])
    frame = Frame.build(x, np.unique(np.sort(pairs, axis=1), axis=0))
    order = np.argsort(np.linalg.norm(x - x[0], axis=1))
    source, target = (0, int(order[1])), (int(order[-1]), int(order[-2]))
    result = tune_elastic(frame, source, target, -0.3)
    k = np.asarray(result.stiffness)
    assert np.array_equal(result.frame.edges, np.delete(frame.edges, list(result.removed_edges), axis=0))
    assert abs(spring_ratio(x, result.frame.edges, k, source, target) + 0.3) <= 1e-9
    assert spring_zero_modes(x, result.frame.edges, k) == 6
