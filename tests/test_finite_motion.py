"""Finite motion by continuation, singular points, and the fidelity ε(a).

Checks go through independent routes: bar lengths recomputed from the returned positions,
the analytic geometry of four-bar linkages (the parallelogram flattens at its branch points,
a four-bar's configuration curve is closed), the paper's solution-space equations solved
numerically, ε by the independent continuation of oracles.motion, and Kabsch properties by
hypothesis against an independent rigid alignment.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from oracles.mechanisms import (
    bipartite_design,
    four_bar,
    outward_square,
    parallelogram,
    random_targets,
    solution_points,
)
from oracles.motion import fidelity as reference_fidelity
from oracles.motion import relative_bar_error, rigid_distance
from oracles.rigidity import (
    nontrivial_flexes,
    reference_counts,
    rigid_motions,
)

from zeromode.solver import DomainError, Frame
from zeromode.solver.motion.finite_motion import (
    MotionPath,
    fidelity,
    kabsch_distance,
    motion_fidelity,
    signed_mode,
    trace_motion,
)


def nonrigid_part(frame: Frame, u: np.ndarray) -> np.ndarray:
    """u (flattened) minus its projection on the rigid motions of the frame."""
    rigid = rigid_motions(frame.positions)
    v = np.ravel(u)
    return v - rigid @ (rigid.T @ v)


def the_mode(frame: Frame) -> np.ndarray:
    """The single nontrivial zero mode (flattened, unit) of a one-mechanism frame."""
    flexes = nontrivial_flexes(frame.positions, frame.edges)
    assert flexes.shape[1] == 1
    return flexes[:, 0]


def test_four_bar_path_keeps_every_bar_and_starts_along_the_mode():
    frame = four_bar()
    path = trace_motion(frame, amplitude=0.5, max_step=0.02)
    assert path.status == "ok" and not path.singularities
    assert path.max_relative_bar_error <= 1e-9
    assert relative_bar_error(path.positions, frame.edges, frame.positions) <= 1e-9
    assert np.all(np.diff(path.parameter) > 0)
    assert path.parameter[0] == pytest.approx(-0.5) and path.parameter[-1] == pytest.approx(0.5)
    ref = path.reference_index
    assert np.array_equal(path.positions[ref], frame.positions)
    # A short first step leaves along the nontrivial mode (mod rigid motions).
    mode = the_mode(frame)
    short = trace_motion(frame, amplitude=1e-6, max_step=1e-6, direction="forward")
    step = nonrigid_part(frame, short.positions[1] - short.positions[0])
    cos = abs(step @ mode) / np.linalg.norm(step)
    assert cos > 1 - 1e-6
    # Consecutive configurations are close: the path is continuous.
    jumps = np.linalg.norm(np.diff(path.positions, axis=0), axis=(1, 2))
    radius = np.sqrt(np.mean(np.sum((frame.positions - frame.positions.mean(0)) ** 2, axis=1)))
    assert jumps.max() <= 2 * 0.02 * radius * np.sqrt(frame.n_nodes)


def test_four_bar_configuration_curve_closes():
    # A four-bar that never flattens has a closed configuration curve: following it long
    # enough brings the linkage back to its starting shape (up to a rigid motion).
    frame = four_bar()
    path = trace_motion(frame, amplitude=6.0, max_step=0.05, direction="forward")
    assert not path.singularities
    start = frame.positions
    dist = np.array([rigid_distance(x, start) for x in path.positions])
    away = np.flatnonzero(dist > 0.5)[0]
    assert dist[away:].min() < 0.05  # back near the start (coarse sampling)
    # ...and exactly: polished on the curve itself, the path passes through the start shape.
    # (fidelity's target is x_S + a·u_S; choosing x_S = start − a·u_S makes it the start.)
    back = MotionPath(
        path.positions[away:],
        path.parameter[away:],
        0,
        path.max_relative_bar_error,
        (),
        frame.edges,
    )
    a, u = 1e-6, np.ones_like(start)
    fid = fidelity(back, range(4), start - a * u, u, a)
    assert fid.epsilon * np.linalg.norm(a * u) < 1e-9


def collinearity(x: np.ndarray) -> float:
    s = np.linalg.svd(x - x.mean(axis=0), compute_uv=False)
    return s[-1] / s[0]


def test_parallelogram_branch_points_are_located_and_reported():
    frame = parallelogram(np.pi / 3)
    path = trace_motion(frame, amplitude=3.0, max_step=0.05)
    assert path.status == "singular_path"
    assert len(path.singularities) == 2
    for sing in path.singularities:
        assert sing.kind == "rank_drop" and sing.extra_zero_modes == 1
        assert sing.sigma <= 1e-6
        flat = path.positions[sing.step]
        assert collinearity(flat) < 1e-6  # the analytic branch points: the linkage is flat
        assert path.parameter[sing.step] == pytest.approx(sing.parameter)
        # Independent count at the reported configuration: C has lost one rank.
        assert reference_counts(flat, frame.edges, rtol=1e-6)["nontrivial_zero_modes"] == 2
    # The path ends at the singular points: nothing is stepped over.
    assert {s.step for s in path.singularities} == {0, len(path.parameter) - 1}
    inner = path.positions[1:-1]
    assert min(collinearity(x) for x in inner) > 1e-4
    assert relative_bar_error(path.positions, frame.edges, frame.positions) <= 1e-9


def test_outward_conic_from_the_papers_equations():
    # Solve A ṽ = b + c·1 numerically for the outward targets: every solution lies on the
    # circle |x_U|² = 2 and moves inward, u_U = −x_U (the conic outward_square() uses).
    x_s = np.array([[1.0, 1.0], [1.0, -1.0], [-1.0, 1.0], [-1.0, -1.0]])
    for x_u, u_u in solution_points(x_s, x_s, 6, np.random.default_rng(0)):
        assert x_u @ x_u == pytest.approx(2.0, abs=1e-9)
        assert np.allclose(u_u, -x_u, atol=1e-9)
    frame = outward_square()
    counts = reference_counts(frame.positions, frame.edges)
    assert (frame.n_nodes, frame.n_edges) == (6, 8)
    assert (counts["nontrivial_zero_modes"], counts["self_stresses"]) == (1, 0)
    # The nontrivial mode restricted to the specified nodes is u_S = x_S (mod rigid motions).
    full = np.vstack([x_s, -frame.positions[4:]])
    mode = nonrigid_part(frame, full)
    assert abs(mode @ the_mode(frame)) / np.linalg.norm(mode) == pytest.approx(1.0, abs=1e-9)


def test_linear_design_drifts_and_fidelity_matches_an_independent_continuation():
    frame = outward_square()
    x_s = frame.positions[:4]
    fid, _ = motion_fidelity(frame, 0.2 * x_s)
    assert 0.05 < fid.epsilon < 1.0  # the linear design misses by tens of per cent at a = 20 %
    # The configuration curve followed and polished by the continuation of oracles.motion.
    expected = reference_fidelity(frame.positions, frame.edges, frame.specified, 0.2 * x_s)
    assert fid.epsilon == pytest.approx(expected, rel=1e-9)


def test_3d_bipartite_mechanism():
    x_s, u_s = random_targets(4, 3, seed=1)
    frame = bipartite_design(x_s, u_s, 5, seed=1)
    path = trace_motion(frame, amplitude=0.2, max_step=0.02)
    assert path.status == "ok"
    assert relative_bar_error(path.positions, frame.edges, frame.positions) <= 1e-9
    short = trace_motion(frame, amplitude=1e-6, max_step=1e-6, direction="forward")
    step = nonrigid_part(frame, short.positions[1] - short.positions[0])
    assert abs(step @ the_mode(frame)) / np.linalg.norm(step) > 1 - 1e-6


def test_chosen_mode_of_a_two_mode_frame():
    # A pentagon has two nontrivial modes: the default is ambiguous; a given mode is followed.
    angles = np.linspace(0, 2 * np.pi, 5, endpoint=False) + 0.1 * np.arange(5)
    frame = Frame.build(
        np.column_stack([np.cos(angles), np.sin(angles)]), [[i, (i + 1) % 5] for i in range(5)]
    )
    with pytest.raises(DomainError) as err:
        trace_motion(frame)
    assert err.value.code == "ambiguous_mode"
    flexes = nontrivial_flexes(frame.positions, frame.edges)
    assert flexes.shape[1] == 2
    chosen = (flexes[:, 0] + 0.5 * flexes[:, 1]).reshape(frame.positions.shape)
    path = trace_motion(frame, mode=chosen, amplitude=0.3, direction="forward")
    assert relative_bar_error(path.positions, frame.edges, frame.positions) <= 1e-9
    short = trace_motion(frame, mode=chosen, amplitude=1e-6, max_step=1e-6, direction="forward")
    step = nonrigid_part(frame, short.positions[1] - short.positions[0])
    assert step @ chosen.ravel() / (np.linalg.norm(step) * np.linalg.norm(chosen)) > 1 - 1e-6


def test_mode_errors():
    triangle = Frame.build([[0, 0], [1, 0], [0, 1]], [[0, 1], [1, 2], [0, 2]])
    with pytest.raises(DomainError) as err:
        trace_motion(triangle)
    assert err.value.code == "no_motion"
    frame = four_bar()
    with pytest.raises(DomainError) as err:
        trace_motion(frame, mode=np.ones((4, 2)) * [1.0, 0.0])
    assert err.value.code == "rigid_mode"
    with pytest.raises(DomainError) as err:
        trace_motion(frame, mode=np.arange(8.0).reshape(4, 2) ** 2)
    assert err.value.code == "not_a_zero_mode"
    with pytest.raises(DomainError) as err:
        trace_motion(frame, mode=np.ones((3, 2)))
    assert err.value.code == "invalid_shape"


rotations = st.floats(-np.pi, np.pi)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), angle=rotations, dim=st.sampled_from([2, 3]))
def test_kabsch_distance_properties(seed, angle, dim):
    rng = np.random.default_rng(seed)
    p = rng.standard_normal((5, dim))
    q = rng.standard_normal((5, dim))
    if dim == 2:
        rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    else:
        axis = rng.standard_normal(3)
        axis /= np.linalg.norm(axis)
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        rot = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
    shift = rng.standard_normal(dim)
    # A rigidly moved copy is at distance 0; moving either argument rigidly changes nothing.
    assert kabsch_distance(p @ rot.T + shift, p) < 1e-12
    assert kabsch_distance(p @ rot.T + shift, q) == pytest.approx(kabsch_distance(p, q), abs=1e-12)
    # The minimum over rigid motions is at most the plain distance, and never negative; it is
    # the minimum found by the closed form (2D) or Wahba's problem (3D) in oracles.motion.
    assert 0 <= kabsch_distance(p, q) <= np.linalg.norm(p - q) + 1e-12
    assert kabsch_distance(p, q) == pytest.approx(rigid_distance(p, q), rel=1e-9, abs=1e-12)
    # Reflections are not motions: a mirrored, non-planar (3D) or non-collinear (2D) shape
    # stays at a positive distance.
    mirror = np.eye(dim)
    mirror[0, 0] = -1
    assert kabsch_distance(p @ mirror, p) > 1e-6


# ----------------------------------------------------------------------------- at scale


@pytest.mark.parametrize(
    "frame, amplitude",
    [(parallelogram(np.pi / 3), 3.0), (bipartite_design(*random_targets(4, 3, seed=1), 5, seed=1), 0.2)],
)
def test_sparse_route_follows_the_dense_one(frame, amplitude):
    """The sparse bordered LU (pinned coordinates, block elimination) and the dense LU of the
    same bordered Jacobian take the same steps: same configurations, same singular points."""
    dense = trace_motion(frame, amplitude=amplitude, max_step=0.05, method="dense")
    sparse = trace_motion(frame, amplitude=amplitude, max_step=0.05, method="sparse")
    assert (dense.method, sparse.method) == ("dense", "sparse")
    assert sparse.parameter.shape == dense.parameter.shape
    assert np.allclose(sparse.parameter, dense.parameter, atol=1e-7)
    assert np.allclose(sparse.positions, dense.positions, atol=1e-6)
    assert [s.extra_zero_modes for s in sparse.singularities] == [
        s.extra_zero_modes for s in dense.singularities
    ]
    assert relative_bar_error(sparse.positions, frame.edges, frame.positions) <= 1e-9


def two_bodies(per_body: int, angle_deg: float = 75.0) -> tuple[Frame, tuple[int, int]]:
    """Two rigid jittered triangulated patches (many self-stresses) joined by two equal parallel
    bars: a parallelogram linkage. One nontrivial mode; it flattens — a branch point — when the
    bars line up with their anchors. Returns the frame and the anchor nodes of body A."""
    rng = np.random.default_rng(0)
    side = int(np.sqrt(per_body))
    i, j = np.meshgrid(np.arange(side), np.arange(side))
    x = np.column_stack([i.ravel() + 0.5 * j.ravel(), np.sqrt(3) / 2 * j.ravel()])
    x = x + 0.1 * rng.uniform(-1, 1, x.shape)
    node = np.arange(side * side).reshape(side, side)
    edges = np.vstack(
        [
            np.column_stack([node[:, :-1].ravel(), node[:, 1:].ravel()]),
            np.column_stack([node[:-1, :].ravel(), node[1:, :].ravel()]),
            np.column_stack([node[:-1, 1:].ravel(), node[1:, :-1].ravel()]),
        ]
    )
    top, bottom = int(node[-1, -1]), int(node[0, -1])
    shift = 1.5 * np.ptp(x[:, 0]) * np.array([np.cos(np.deg2rad(angle_deg)), np.sin(np.deg2rad(angle_deg))])
    n = len(x)
    frame = Frame.build(
        np.vstack([x, x + shift]),
        np.vstack([edges, edges + n, [[top, top + n], [bottom, bottom + n]]]),
    )
    return frame, (top, bottom)


def test_sparse_route_locates_the_branch_point_of_a_frame_with_self_stresses():
    frame, (top, bottom) = two_bodies(225)  # 900 degrees of freedom: the sparse route
    counts = reference_counts(frame.positions, frame.edges)
    assert counts["nontrivial_zero_modes"] == 1 and counts["self_stresses"] > 100
    path = trace_motion(frame, amplitude=1.0, max_step=0.05)
    assert path.method == "sparse" and path.status == "singular_path"
    assert relative_bar_error(path.positions, frame.edges, frame.positions) <= 1e-9
    n = frame.n_nodes // 2
    for sing in path.singularities:
        x = path.positions[sing.step]
        # The analytic branch point: both bars parallel to the line through their anchors.
        anchors, bar = x[top] - x[bottom], x[top + n] - x[top]
        cross = anchors[0] * bar[1] - anchors[1] * bar[0]
        assert abs(cross) <= 1e-6 * np.linalg.norm(anchors) * np.linalg.norm(bar)
        # Independent count at the reported configuration: C has lost one rank.
        assert reference_counts(x, frame.edges, rtol=1e-6)["zero_modes"] == counts["zero_modes"] + 1
    inner = path.positions[[i for i in range(len(path.positions)) if i not in {s.step for s in path.singularities}]]
    assert min(reference_counts(x, frame.edges)["zero_modes"] for x in inner[::5]) == counts["zero_modes"]


def sheet_tiling(nx: int, ny: int) -> np.ndarray:
    """lattice.auxetic_sheet's node order as (cell node, cell x, cell y): corners first (row-major
    in y, then x) as node 0 of their cell, then the two nodes of each module as nodes 1 and 2."""
    p, q = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1))
    corners = np.column_stack([np.zeros(p.size, int), p.ravel(), q.ravel()])
    i, j = np.meshgrid(np.arange(nx), np.arange(ny))
    cells = np.column_stack([i.ravel(), j.ravel()])
    inner = np.stack(
        [np.column_stack([np.full(len(cells), 1 + s), cells]) for s in (0, 1)], axis=1
    ).reshape(-1, 3)
    return np.vstack([corners, inner])


def test_periodic_cell_motion_tiled_on_a_sheet_matches_the_sheet_continuation():
    from zeromode.solver.applications.lattice import auxetic_sheet
    from zeromode.solver.motion.periodic import PeriodicCell, tiled_motion, trace_periodic_motion

    # 4 × 4: three columns of node pairs collide at once, an odd number of vanishing singular
    # values, which the determinant test sees (an even number would cancel in its sign).
    lattice = auxetic_sheet(4, 4, poisson=-0.5)
    frame, tiling = lattice.frame, sheet_tiling(4, 4)
    cell = PeriodicCell.from_frame(frame, tiling, [[2.0, 0.0], [0.0, 2.0]])
    assert (len(cell.positions), len(cell.edges)) == (3, 8)
    path = tiled_motion(frame, tiling, cell, trace_periodic_motion(cell, tiling, amplitude=0.4))
    assert path.method == "periodic"
    assert relative_bar_error(path.positions, frame.edges, frame.positions) <= 1e-9
    # The sheet's motion ends where nodes of neighbouring modules collide: a singular point of
    # the sheet that the cell, whose configuration space is smooth there, does not have.
    (sing,) = path.singularities
    end = path.positions[sing.step]
    assert sing.extra_zero_modes >= 1
    assert reference_counts(end, frame.edges, rtol=1e-6)["zero_modes"] == 4 + sing.extra_zero_modes
    gaps = np.linalg.norm(end[:, None] - end[None], axis=2)[np.triu_indices(frame.n_nodes, 1)]
    assert gaps.min() <= 1e-5
    # The same point by the sheet's own continuation (every node, no periodicity assumed).
    direct = trace_motion(frame, mode=lattice.mode, amplitude=0.4)
    (direct_sing,) = direct.singularities
    assert direct_sing.extra_zero_modes == sing.extra_zero_modes
    assert np.abs(direct.positions[direct_sing.step] - end).max() <= 1e-4 * np.ptp(frame.positions)


def test_stop_ends_each_direction_at_the_first_configuration_it_accepts():
    """``stop(x, sign)`` sees every new configuration (in the frame's coordinates) and ends its
    direction there, that configuration kept; the other direction runs to the amplitude."""
    frame = four_bar()
    x0 = frame.positions
    seen = {1: 0, -1: 0}

    def stop(x, sign):
        seen[sign] += 1
        assert x.shape == x0.shape
        # A configuration is on the motion: every bar keeps its length (recomputed here).
        assert relative_bar_error([x], frame.edges, x0) <= 1e-9
        return sign == 1 and seen[1] == 3

    path = trace_motion(frame, amplitude=0.5, max_step=0.02, stop=stop)
    assert seen[1] == 3 and path.reference_index == len(path.parameter) - 4
    assert path.parameter[-1] < 0.1 and path.parameter[0] == pytest.approx(-0.5)
    assert not path.singularities


def test_progress_of_a_motion_rises_to_one_through_a_located_singular_point():
    """Reports never go back, also while a singular point is located, and end at 1."""
    from zeromode.solver.applications.lattice import auxetic_sheet
    from zeromode.solver.progress import progress_scope

    sheet = auxetic_sheet(4, 4, poisson=-0.5)
    reports = []
    with progress_scope(lambda fraction, message: reports.append((fraction, message))):
        path = trace_motion(sheet.frame, mode=sheet.mode, amplitude=0.4)
    assert len(path.singularities) == 1  # the collision near parameter 0.079
    fractions = [f for f, _ in reports]
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    assert any("locating a singular point" in m for _, m in reports)


@settings(max_examples=50, deadline=None)
@given(st.integers(2, 30), st.integers(0, 2**32 - 1))
def test_a_modes_sign_does_not_follow_round_off_between_tied_entries(n, seed):
    # A symmetric frame's mode has entries of equal magnitude up to round-off, which differs
    # between BLAS kernels: the sign must come out the same whichever of the tied entries
    # round-off makes the largest (the first of them decides).
    rng = np.random.default_rng(seed)
    u = rng.uniform(-0.9, 0.9, n)
    i, j = sorted(rng.choice(n, 2, replace=False))
    u[i], u[j] = rng.choice([-1.0, 1.0]), rng.choice([-1.0, 1.0])
    signs = set()
    for bump_i, bump_j in [(1e-15, 0.0), (0.0, 1e-15)]:
        v = u.copy()
        v[i] *= 1 + bump_i
        v[j] *= 1 + bump_j
        w = signed_mode(v)
        assert np.array_equal(np.abs(w), np.abs(v))
        signs.add(np.sign(w[i]))
    assert signs == {1.0}
