"""Motions aimed at a target (solver.motion.target), checked through independent routes: the
four-bar's closed-form position analysis, distances, angles and bar lengths recomputed with
numpy, a lattice's strain from its boundary sets (oracles.motion), finite differences for the
gradients, and hypothesis over random reachable targets."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from oracles.mechanisms import (
    crank_angle,
    crank_angle_limit,
    four_bar,
    four_bar_at_crank_angle,
    in_ground_frame,
    parallelogram,
)
from oracles.motion import boundary_strains, relative_bar_error

from zeromode.solver.applications.lattice import auxetic_sheet
from zeromode.solver.errors import InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.motion.finite_motion import trace_motion
from zeromode.solver.motion.target import (
    BoundaryStrain,
    MotionTarget,
    NodeAngle,
    TargetUnreachable,
    aim_motion,
)

FOUR_BAR = four_bar()  # a triple rocker: its crank angle at node 0 is bounded
X = FOUR_BAR.positions
A, B = np.linalg.norm(X[1] - X[0]), np.linalg.norm(X[2] - X[1])  # crank, coupler
C, G = np.linalg.norm(X[3] - X[2]), np.linalg.norm(X[3] - X[0])  # rocker, ground
PHI0 = float(np.arctan2(X[1, 1], X[1, 0]))
PHI_MAX = crank_angle_limit(X)  # the crank angle's turning point
CRANK = (3, 0, 1)


@pytest.mark.parametrize("phi", [PHI0 + 0.4, PHI0 - 0.25, 1.2, -1.0])
def test_four_bar_crank_driven_to_an_angle_matches_the_position_analysis(phi):
    aimed = aim_motion(FOUR_BAR, MotionTarget("angle", phi, CRANK))
    end = aimed.path.positions[aimed.index]
    assert abs(crank_angle(end) - phi) <= 1e-10
    assert np.max(np.abs(in_ground_frame(end) - four_bar_at_crank_angle(X, phi))) <= 1e-9
    assert relative_bar_error(aimed.path.positions, FOUR_BAR.edges, X) <= 1e-10
    assert aimed.error <= 1e-10
    assert aimed.index in (0, len(aimed.path.parameter) - 1)
    assert aimed.path.parameter[aimed.path.reference_index] == 0.0


def test_crank_beyond_its_turning_point_is_refused_with_the_extreme():
    with pytest.raises(TargetUnreachable) as info:
        aim_motion(FOUR_BAR, MotionTarget("angle", PHI_MAX + 0.05, CRANK))
    assert info.value.code == "target_past_turning_point"
    assert abs(info.value.best.reached - PHI_MAX) <= 1e-7
    assert relative_bar_error(info.value.best.path.positions, FOUR_BAR.edges, X) <= 1e-10


def test_coupler_distance_beyond_its_maximum_is_refused():
    # |x_2 − x_0| ≤ a + b (crank and coupler aligned), reached on this linkage.
    with pytest.raises(TargetUnreachable) as info:
        aim_motion(FOUR_BAR, MotionTarget("distance", A + B + 0.1, (0, 2)))
    assert info.value.code == "target_past_turning_point"
    assert abs(info.value.best.reached - (A + B)) <= 1e-7


@pytest.mark.parametrize("value", [1.9, 2.45])
def test_distance_target_recomputed_with_numpy(value):
    aimed = aim_motion(FOUR_BAR, MotionTarget("distance", value, (0, 2)))
    end = aimed.path.positions[aimed.index]
    assert abs(np.linalg.norm(end[2] - end[0]) - value) <= 1e-10 * value
    lengths = np.linalg.norm(end[FOUR_BAR.edges[:, 0]] - end[FOUR_BAR.edges[:, 1]], axis=1)
    reference = np.linalg.norm(X[FOUR_BAR.edges[:, 0]] - X[FOUR_BAR.edges[:, 1]], axis=1)
    assert np.max(np.abs(lengths - reference) / reference) <= 1e-10


@pytest.mark.parametrize("strain", [0.02, -0.04])
def test_lattice_strain_target_from_the_boundary_sets(strain):
    sheet = auxetic_sheet(3, 3, -0.5)
    boundary = {k: [int(i) for i in v] for k, v in sheet.boundary.items()}
    aimed = aim_motion(sheet.frame, MotionTarget("strain", strain, axis="x", boundary=boundary), periodic=True)
    end = aimed.path.positions[aimed.index]
    eps_x, _ = boundary_strains(sheet.frame.positions, end, boundary, finite=True)
    assert abs(eps_x - strain) <= 1e-10
    assert relative_bar_error(aimed.path.positions, sheet.frame.edges, sheet.frame.positions) <= 1e-10


def test_fraction_of_the_range_up_to_a_singular_point():
    # The parallelogram at θ = π/3 flattens at θ = 0 and π (branch points): the range ends there.
    frame = parallelogram()
    half = aim_motion(frame, MotionTarget("fraction", 0.5))
    whole = aim_motion(frame, MotionTarget("fraction", 1.0))
    end, reason = half.range_end
    assert reason == "singular_point" and whole.range_end[1] == "singular_point"
    assert half.path.parameter[half.index] == pytest.approx(0.5 * end, rel=1e-12)
    flat = whole.path.positions[whole.index]
    assert np.ptp(in_ground_frame(flat)[:, 1]) <= 1e-6  # all four nodes on a line
    assert relative_bar_error(half.path.positions, frame.edges, frame.positions) <= 1e-10


def test_path_from_a_branch_point_reports_a_singular_start():
    flat = Frame.build([[0, 0], [2, 0], [3, 0], [1, 0]], [[0, 1], [1, 2], [2, 3], [3, 0]])
    lifted = [[0, 0], [0, 0], [0, 1], [0, 1]]  # the parallelogram branch
    path = trace_motion(flat, mode=lifted, amplitude=0.3, max_step=0.05)
    start = path.singular_start
    assert start is not None and start.step == path.reference_index and start.parameter == 0.0
    assert start.extra_zero_modes == 1 and start.sigma <= 1e-12
    assert relative_bar_error(path.positions, flat.edges, flat.positions) <= 1e-10
    assert trace_motion(FOUR_BAR, amplitude=0.1).singular_start is None


@pytest.mark.parametrize(
    "target",
    [
        MotionTarget("angle", 0.5, (0, 1, 9)),
        MotionTarget("angle", 0.5, (0, 1, 0)),
        MotionTarget("distance", 1.0, (0,)),
        MotionTarget("distance", -1.0, (0, 2)),
        MotionTarget("strain", 0.1, axis="x"),
        MotionTarget("fraction", 1.5),
    ],
)
def test_malformed_targets_are_refused(target):
    with pytest.raises(InvalidInput) as info:
        aim_motion(FOUR_BAR, target)
    assert info.value.code == "invalid_target" and info.value.message.endswith(".")


def test_angle_with_coincident_nodes_is_refused():
    # Node 4 sits on node 1 (joined to 0 and 2 like it): the angle at 1 towards 4 has no arm.
    frame = Frame.build(np.vstack([X, X[1]]), [[0, 1], [1, 2], [2, 3], [3, 0], [4, 0], [4, 2]])
    with pytest.raises(InvalidInput) as info:
        aim_motion(frame, MotionTarget("angle", 0.5, (4, 1, 2)))
    assert "coincident" in info.value.message


def numeric_gradient(f, x, h=1e-6):
    g = np.zeros_like(x)
    for index in np.ndindex(x.shape):
        e = np.zeros_like(x)
        e[index] = h
        g[index] = (f(x + e) - f(x - e)) / (2 * h)
    return g


def test_gradients_match_central_differences():
    rng = np.random.default_rng(3)
    sheet = auxetic_sheet(2, 2, -0.5)
    strain = BoundaryStrain.of(sheet.frame.positions, {k: np.asarray(v) for k, v in sheet.boundary.items()}, "y")
    moved = sheet.frame.positions + 0.05 * rng.standard_normal(sheet.frame.positions.shape)
    assert np.allclose(strain.gradient(moved), numeric_gradient(strain.value, moved), atol=1e-7)
    x3 = rng.standard_normal((4, 3))
    angle = NodeAngle(0, 2, 3)
    assert np.allclose(angle.gradient(x3), numeric_gradient(angle.value, x3), atol=1e-7)
    assert np.allclose(NodeAngle(*CRANK).gradient(X), numeric_gradient(NodeAngle(*CRANK).value, X), atol=1e-7)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    kind=st.sampled_from(["angle", "distance"]),
    share=st.floats(min_value=-0.97, max_value=0.97).filter(lambda s: abs(s) > 1e-3),
)
def test_random_reachable_targets_end_exactly_on_them(kind, share):
    if kind == "angle":  # the crank's range is [−φ_max, φ_max] (the linkage is symmetric about the ground)
        value, target = share * PHI_MAX, MotionTarget("angle", share * PHI_MAX, CRANK)
    else:  # |x_2 − x_0| ranges over [g − c, a + b] on this linkage
        lo, hi = G - C, A + B
        value = 0.5 * (lo + hi) + 0.5 * share * (hi - lo)
        target = MotionTarget("distance", value, (0, 2))
    aimed = aim_motion(FOUR_BAR, target)
    end = aimed.path.positions[aimed.index]
    got = crank_angle(end) if kind == "angle" else float(np.linalg.norm(end[2] - end[0]))
    assert abs(got - value) <= 1e-10 * max(1.0, abs(value))
    assert relative_bar_error(aimed.path.positions, FOUR_BAR.edges, X) <= 1e-10
