"""The tuning-by-pruning peer (benchmarks/pruning.py), checked by dense solves written from scratch.

The independent route: build the unit compatibility matrix entry by entry, form the dense
stiffness matrix K = Qᵀ diag(1/ℓ) Q, impose the source strain through the KKT system
[[K, q_S], [q_Sᵀ, 0]] [u; λ] = [0; 1] solved by dense least squares (K is singular on the rigid
motions, which strain nothing), and read the target strain off u.
"""

import numpy as np
import pytest
from oracles.frames import SQUARE, TRIANGLE
from oracles.rigidity import reference_counts
from oracles.springs import spring_ratio

from benchmarks.allostery_tasks import make_task
from benchmarks.pruning import prune_for_allostery
from zeromode.solver import DomainError, Frame, InvalidInput


def dense_ratio(x: np.ndarray, edges: np.ndarray, source, target) -> float:
    """η = ε_T/ε_S of the spring network (k = 1/ℓ) under an imposed source strain."""
    return spring_ratio(x, edges, 1.0 / np.linalg.norm(x[edges[:, 0]] - x[edges[:, 1]], axis=1), source, target)


def nontrivial_zero_modes(x: np.ndarray, edges: np.ndarray) -> int:
    return reference_counts(x, edges)["nontrivial_zero_modes"]


@pytest.fixture(scope="module")
def task():
    return make_task(40, seed=0, ratio=1.0, tol=0.01)


def test_reaches_target_ratio_confirmed_by_dense_solve(task):
    result = prune_for_allostery(
        task.frame, task.source_pair, task.target_pair, task.ratio, task.tol, seed=0
    )
    x, edges = task.frame.positions, task.frame.edges
    before = dense_ratio(x, edges, task.source_pair, task.target_pair)
    after = dense_ratio(x, result.frame.edges, task.source_pair, task.target_pair)

    assert result.converged and result.stop_reason == "converged"
    assert abs(after - task.ratio) <= task.tol
    assert after == pytest.approx(result.achieved_ratio, abs=1e-8)
    assert before == pytest.approx(result.initial_ratio, abs=1e-8)
    assert abs(before - task.ratio) > task.tol  # pruning had work to do
    # The pruned frame is the input less exactly the reported bars, and it stays rigid.
    kept = np.delete(edges, list(result.removed_edges), axis=0)
    assert np.array_equal(result.frame.edges, kept)
    assert result.bars_used == len(edges) - result.bars_removed == len(kept)
    assert nontrivial_zero_modes(x, result.frame.edges) == 0


def test_every_removal_is_the_best_single_removal():
    """Replay the greedy path by brute force: at each step remove every surviving bar in turn,
    dense-solve, keep the removals that leave the frame rigid; the peer's bar must be the best."""
    task = make_task(24, seed=1, ratio=-1.0, tol=0.01)
    x, edges = task.frame.positions, task.frame.edges
    result = prune_for_allostery(
        task.frame, task.source_pair, task.target_pair, task.ratio, task.tol, seed=0
    )
    assert result.converged and result.bars_removed >= 3
    alive = np.ones(len(edges), dtype=bool)
    for chosen in result.removed_edges:
        errors = {}
        for b in np.flatnonzero(alive):
            rest = edges[alive & (np.arange(len(edges)) != b)]
            if nontrivial_zero_modes(x, rest) == 0:
                eta = dense_ratio(x, rest, task.source_pair, task.target_pair)
                errors[int(b)] = abs(eta - task.ratio)
        assert chosen == min(errors, key=errors.get)
        alive[chosen] = False


def test_unreachable_ratio_stops_where_no_single_removal_helps(task):
    """η = 50 is out of reach: at the stop, every remaining bar either opens a zero mode when
    removed or does not lower |η − 50| (brute force, dense solves), and the frame is rigid."""
    result = prune_for_allostery(task.frame, task.source_pair, task.target_pair, 50.0, 0.01)
    x, edges = task.frame.positions, result.frame.edges
    assert not result.converged
    assert result.stop_reason in {"no_improving_bond", "no_removable_bond"}
    assert nontrivial_zero_modes(x, edges) == 0
    error = abs(dense_ratio(x, edges, task.source_pair, task.target_pair) - 50.0)
    assert result.error == pytest.approx(error, abs=1e-8)
    for b in range(len(edges)):
        rest = np.delete(edges, b, axis=0)
        if nontrivial_zero_modes(x, rest) == 0:
            after = abs(dense_ratio(x, rest, task.source_pair, task.target_pair) - 50.0)
            assert after >= error - 1e-9


def test_floppy_frame_is_refused():
    square = Frame.build(SQUARE["positions"], SQUARE["edges"])
    with pytest.raises(DomainError) as info:
        prune_for_allostery(square, (0, 1), (2, 3), ratio=1.0, tol=0.01)
    assert info.value.code == "floppy_network"


@pytest.mark.parametrize(
    "source, ratio, tol",
    [
        ((0, 0), 1.0, 0.01),
        ((0, 99), 1.0, 0.01),
        ((0, 1.5), 1.0, 0.01),
        ((0, 1, 2), 1.0, 0.01),
        ((0, 1), float("nan"), 0.01),
        ((0, 1), 1.0, 0.0),
    ],
)
def test_bad_arguments_name_the_problem(source, ratio, tol):
    triangle = Frame.build(TRIANGLE["positions"], TRIANGLE["edges"])
    with pytest.raises(InvalidInput) as info:
        prune_for_allostery(triangle, source, (1, 2), ratio=ratio, tol=tol)
    assert info.value.code in {"invalid_pair", "invalid_target"}
    assert info.value.message
