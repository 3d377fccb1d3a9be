"""Allostery inside a given network (solver/applications/network_allostery.py), checked from scratch.

For each answer, through routes that share nothing with the solver: the modified frame keeps
every given node where it was and every given bar except the ones reported removed; its zero
modes (numpy SVD of C built from its definition, and PyRigi for small frames) are the rigid
motions plus one; driving the source with the reported source motion (oracles.rigidity.
driven_response) moves the target as prescribed to 1e-9; a strain ratio is also recomputed in
the tuning-by-pruning peer's own spring model (test_pruning.dense_ratio: springs k = 1/ℓ, source
strain imposed, dense KKT solve). The bars removed are exactly the given bars the mode strains.
"""

from __future__ import annotations

import numpy as np
import pytest
from oracles import pyrigi_adapter
from oracles.frames import SQUARE
from oracles.rigidity import compatibility_matrix, driven_response, normalised, reference_counts
from scipy.spatial import Delaunay
from test_pruning import dense_ratio

from benchmarks.allostery_tasks import make_task
from zeromode.solver import DomainError, Frame, InvalidInput
from zeromode.solver.applications.network_allostery import tune_network


def pair_strain(x, u) -> float:
    dx = x[0] - x[1]
    return float(dx @ (u[0] - u[1]) / (dx @ dx))


def delaunay_3d(n: int, seed: int) -> Frame:
    """A rigid, over-braced 3D network: the edges of a Delaunay tetrahedralisation."""
    x = np.random.default_rng(seed).uniform(-1, 1, (n, 3))
    tets = Delaunay(x).simplices
    pairs = np.concatenate([tets[:, [i, j]] for i in range(4) for j in range(i + 1, 4)])
    return Frame.build(x, np.unique(np.sort(pairs, axis=1), axis=0))


def nearest(x: np.ndarray, node: int, count: int) -> list[int]:
    order = np.argsort(np.linalg.norm(x - x[node], axis=1))
    return [int(i) for i in order[:count]]


def check_answer(given: Frame, result, source, target, u_tgt=None) -> np.ndarray:
    """Everything the answer promises, recomputed; returns the response (N', d)."""
    frame = result.frame
    x, edges = np.asarray(frame.positions), np.asarray(frame.edges)
    n, d = given.n_nodes, given.dim
    assert np.array_equal(x[:n], given.positions)
    kept = np.delete(given.edges, list(result.removed_edges), axis=0)
    assert np.array_equal(edges[: len(kept)], kept)
    added = edges[len(kept) :]
    assert np.array_equal(added, result.added_edges)
    assert np.all(added.max(axis=1) >= n)  # every added bar reaches an added node
    assert list(result.added_nodes) == list(range(n, len(x)))
    # Only the bars the mode strains are removed.
    c = compatibility_matrix(given.positions, given.edges)
    strain = np.abs(c @ result.mode[:n].ravel()) / np.linalg.norm(
        given.positions[given.edges[:, 0]] - given.positions[given.edges[:, 1]], axis=1
    )
    strained = np.flatnonzero(strain > 1e-9 * np.abs(result.mode).max())
    assert strained.tolist() == sorted(result.removed_edges)
    # Rigid motions plus exactly one: no other way to move, whatever the stiffnesses.
    counts = reference_counts(x, edges)
    assert counts["zero_modes"] == d * (d + 1) // 2 + 1
    assert np.linalg.norm(compatibility_matrix(normalised(x), edges) @ result.mode.ravel()) <= 1e-9 * np.linalg.norm(
        compatibility_matrix(normalised(x), edges), 2
    ) * np.linalg.norm(result.mode)
    if len(x) <= 60:
        flexes = pyrigi_adapter.flexes(x, edges)
        assert flexes.all.shape[1] == d * (d + 1) // 2 + 1
    response = driven_response(x, edges, list(source), result.mode[list(source)])
    if u_tgt is not None:
        error = np.linalg.norm(response[list(target)] - u_tgt) / np.linalg.norm(u_tgt)
        assert error <= 1e-9
    assert result.target_error <= 1e-9
    return response


@pytest.mark.parametrize("ratio", [1.0, -1.0, 2.0, 20.0, -100.0])
@pytest.mark.parametrize(("n", "seed"), [(40, 0), (60, 1)])
def test_strain_ratio_is_exact_in_the_pruning_peers_networks(n, seed, ratio):
    task = make_task(n, seed, ratio)
    result = tune_network(task.frame, task.source_pair, task.target_pair, strain_ratio=ratio)
    response = check_answer(task.frame, result, task.source_pair, task.target_pair)
    x = result.frame.positions
    eta = pair_strain(x[list(task.target_pair)], response[list(task.target_pair)]) / pair_strain(
        x[list(task.source_pair)], response[list(task.source_pair)]
    )
    assert abs(eta - ratio) <= 1e-9 * max(abs(ratio), 1)
    assert result.strain_ratio == pytest.approx(ratio, rel=1e-9)
    # The peer's elastic response (springs k = 1/ℓ, source strain imposed) agrees: the one
    # mechanism carries it, whatever the stiffnesses.
    spring = dense_ratio(x, np.asarray(result.frame.edges), task.source_pair, task.target_pair)
    assert abs(spring - ratio) <= 1e-8 * max(abs(ratio), 1)
    # One node of each pair swings on d − 1 = 1 kept bar; one coupler of d + 1 = 3 bars.
    assert len(result.moving) == 2 and len(result.added_nodes) == 1 and len(result.added_edges) == 3
    assert result.bonds_changed == len(result.removed_edges) + 3


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_site_motions_are_exact_in_2d(seed):
    task = make_task(50, seed, 1.0)
    rng = np.random.default_rng(seed)
    x = task.frame.positions
    source = nearest(x, task.source_pair[0], 3)
    target = nearest(x, task.target_pair[0], 2)
    u_src, u_tgt = rng.standard_normal((3, 2)), rng.standard_normal((2, 2))
    result = tune_network(task.frame, source, target, source_motion=u_src, target_motion=u_tgt)
    check_answer(task.frame, result, source, target, u_tgt)
    assert np.array_equal(result.mode[source], u_src) and np.array_equal(result.mode[target], u_tgt)
    assert result.strain_ratio is None


@pytest.mark.parametrize("seed", [0, 1])
def test_motions_and_strain_ratios_are_exact_in_3d(seed):
    frame = delaunay_3d(50, seed)
    x = frame.positions
    source = nearest(x, int(np.argmin(x[:, 0])), 3)
    target = nearest(x, int(np.argmax(x[:, 0])), 2)
    rng = np.random.default_rng(seed)
    u_src, u_tgt = rng.standard_normal((3, 3)), rng.standard_normal((2, 3))
    result = tune_network(frame, source, target, source_motion=u_src, target_motion=u_tgt)
    check_answer(frame, result, source, target, u_tgt)
    # A source pair in 3D leaves the rotation about its line free; strains do not see it.
    pair = source[:2]
    ratio = tune_network(frame, pair, target, strain_ratio=-3.0)
    modes = ratio.frame
    counts = reference_counts(modes.positions, modes.edges)
    assert counts["zero_modes"] == 7
    eta = pair_strain(x[target], ratio.mode[target]) / pair_strain(x[pair], ratio.mode[pair])
    assert eta == pytest.approx(-3.0, rel=1e-9)


def rotation(theta: float) -> np.ndarray:
    return np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])


@pytest.mark.parametrize(
    ("scale", "shift", "theta"), [(1e6, 3e6, 0.7), (1e-6, -5e-6, 0.0), (1.0, 37.0, 0.0), (37.0, 0.0, 2.0), (1.0, 0.0, 1.0)]
)
def test_strain_ratio_designs_are_the_same_up_to_the_same_similarity(scale, shift, theta):
    """x ↦ λQx + t on the given network: the same bars removed and added, the added nodes moved
    by the same map, and the moved answer is exact on its own (checked from scratch)."""
    task = make_task(40, 0, -2.0)
    q = rotation(theta)
    reference = tune_network(task.frame, task.source_pair, task.target_pair, strain_ratio=-2.0)
    moved_frame = Frame.build(scale * task.frame.positions @ q.T + shift, task.frame.edges)
    moved = tune_network(moved_frame, task.source_pair, task.target_pair, strain_ratio=-2.0)
    assert moved.removed_edges == reference.removed_edges
    assert np.array_equal(moved.added_edges, reference.added_edges)
    expected = scale * reference.frame.positions @ q.T + shift
    assert np.abs(moved.frame.positions - expected).max() <= 1e-9 * np.abs(expected).max()
    response = check_answer(moved_frame, moved, task.source_pair, task.target_pair)
    x, s, t = moved.frame.positions, list(task.source_pair), list(task.target_pair)
    eta = pair_strain(x[t], response[t]) / pair_strain(x[s], response[s])
    assert eta == pytest.approx(-2.0, rel=1e-9)


@pytest.mark.parametrize(
    ("scale", "speed", "shift", "theta"),
    [(1e6, 1e-6, 3e6, 0.7), (1e-6, 1e6, -5e-6, 2.0), (1.0, 2.0, 1e3, 0.0), (37.0, 1.0, 0.5, 1.0)],
)
def test_motion_designs_are_the_same_up_to_the_same_similarity(scale, speed, shift, theta):
    """x ↦ λQx + t, u ↦ μQu with site motions: the same bars, the added nodes and the mode moved
    by the same maps, and the moved answer exact on its own (checked from scratch)."""
    task = make_task(50, 0, 1.0)
    x = task.frame.positions
    source, target = nearest(x, task.source_pair[0], 3), nearest(x, task.target_pair[0], 2)
    rng = np.random.default_rng(0)
    u_src, u_tgt = rng.standard_normal((3, 2)), rng.standard_normal((2, 2))
    q = rotation(theta)
    reference = tune_network(task.frame, source, target, source_motion=u_src, target_motion=u_tgt)
    moved_frame = Frame.build(scale * x @ q.T + shift, task.frame.edges)
    moved = tune_network(
        moved_frame, source, target, source_motion=speed * u_src @ q.T, target_motion=speed * u_tgt @ q.T
    )
    assert moved.removed_edges == reference.removed_edges
    assert np.array_equal(moved.added_edges, reference.added_edges)
    expected = scale * reference.frame.positions @ q.T + shift
    assert np.abs(moved.frame.positions - expected).max() <= 1e-9 * np.abs(expected).max()
    expected_u = speed * reference.mode @ q.T
    assert np.abs(moved.mode - expected_u).max() <= 1e-9 * np.abs(expected_u).max()
    check_answer(moved_frame, moved, source, target, speed * u_tgt @ q.T)


def refusals():
    task = make_task(40, 0, 1.0)
    frame, s, t = task.frame, list(task.source_pair), list(task.target_pair)
    x = frame.positions
    u = task.specified_motion()
    square = Frame.build(SQUARE["positions"], SQUARE["edges"])
    rotation = np.column_stack([-x[s, 1], x[s, 0]])
    three_d = delaunay_3d(30, 0)
    return [
        ("floppy_network", (square, [0, 1], [2, 3]), {"strain_ratio": 1.0}),
        ("overlapping_sites", (frame, s, [s[0], t[0]]), {"strain_ratio": 1.0}),
        ("rigid_source", (frame, s, t), {"source_motion": np.ones((2, 2)), "target_motion": u[2:]}),
        ("rigid_source", (frame, s, t), {"source_motion": rotation, "target_motion": u[2:]}),
        ("rigid_target", (frame, s, t), {"source_motion": u[:2], "target_motion": np.zeros((2, 2))}),
        ("rigid_target", (frame, s, t), {"source_motion": u[:2], "target_motion": np.column_stack([-x[t, 1], x[t, 0]])}),
        ("zero_strain", (frame, s, t), {"strain_ratio": 0.0}),
        (
            "underdetermined_source",
            (three_d, [0, 1], [2, 3]),
            {"source_motion": np.eye(3)[:2], "target_motion": np.eye(3)[1:]},
        ),
        ("invalid_nodes", (frame, [s[0]], t), {"strain_ratio": 1.0}),
        ("invalid_nodes", (frame, [s[0], 10_000], t), {"strain_ratio": 1.0}),
        ("invalid_nodes", (frame, [s[0], s[0]], t), {"strain_ratio": 1.0}),
        ("invalid_response", (frame, s, t), {}),
        ("invalid_response", (frame, s, t), {"strain_ratio": 1.0, "source_motion": u[:2], "target_motion": u[2:]}),
        ("invalid_shape", (frame, s, t), {"source_motion": u[:1], "target_motion": u[2:]}),
    ]


@pytest.mark.parametrize(("code", "args", "kwargs"), refusals())
def test_requests_without_meaning_are_refused_with_their_code(code, args, kwargs):
    with pytest.raises(DomainError) as err:
        tune_network(*args, **kwargs)
    assert err.value.code == code, err.value.message
    assert len(err.value.message) > 20
    assert isinstance(err.value, InvalidInput) == code.startswith("invalid")
