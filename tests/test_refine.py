"""IPOPT refinement for finite-motion fidelity (real IPOPT runs through casadi; kept small).

Independent checks: for the outward square the exact refined geometry follows from the bar
constraints by hand (below); bar lengths along IPOPT's path are recomputed from scratch; ε
after refinement is measured by continuation from the refined frame; zero modes and
self-stresses of the refined frame are counted by PyRigi; ε before and after is measured again
by the independent continuation of oracles.motion.

Outward square, by hand: the specified corners x_i = (±1, ±1) must reach λ·x_i (λ = 1 + a).
An unspecified node at x (reference) and y (final) keeps its four bars iff
|y − λx_i|² = |x − x_i|² for all i, i.e. (2x − 2λy)·x_i = const over the four corners, so
x = λy, and then |y|² + 2λ² = |x|² + 2, i.e. |x|² = 2λ²: the refined unspecified nodes sit on
the circle of radius λ√2 (the linear design has them on radius √2).
"""

import numpy as np
import pytest
from oracles import pyrigi_adapter
from oracles.mechanisms import bipartite_design, outward_square, random_targets
from oracles.motion import fidelity, relative_bar_error, rigid_distance

from zeromode.solver import DomainError, Frame
from zeromode.solver.motion.refine import RefinementFailed, refine

# ε of the same curve by two continuations agrees to round-off (~1e-14 relative measured); the
# margin covers the polishing of either minimum. Below ROUND_OFF_EPSILON a target is met to the
# bar-length round-off of the configurations, and the two values are both "zero".
SAME_EPSILON = 1e-6
ROUND_OFF_EPSILON = 1e-9


def pyrigi_counts(positions, edges) -> tuple[int, int]:
    """(nontrivial flexes, stresses) by PyRigi."""
    flexes = pyrigi_adapter.flexes(positions, edges)
    return flexes.nontrivial.shape[1], flexes.stresses


def check_epsilons(original: Frame, result) -> None:
    """ε before (original frame) and after (refined frame) are what the independent
    continuation of oracles.motion measures for the result's target x_S + Δ_S."""
    for frame, reported in (
        (original, result.epsilon_before),
        (result.frame, result.epsilon_after),
    ):
        measured = fidelity(frame.positions, frame.edges, frame.specified, result.displacement)
        assert measured == pytest.approx(reported, rel=SAME_EPSILON, abs=ROUND_OFF_EPSILON)


def test_outward_square_reaches_its_target_exactly():
    frame = outward_square()
    x_s = frame.positions[:4]
    res = refine(frame, x_s, 0.2)
    assert res.ok and res.ipopt_status == "Solve_Succeeded"
    assert 0.05 < res.epsilon_before < 1.0
    assert res.epsilon_after <= 1e-6
    assert np.allclose(res.displacement, 0.2 * x_s)
    check_epsilons(frame, res)
    # The hand-derived geometry: unspecified nodes on the circle of radius 1.2·√2.
    assert np.allclose(np.linalg.norm(res.frame.positions[4:], axis=1), 1.2 * np.sqrt(2), rtol=1e-6)
    assert np.array_equal(res.frame.positions[:4], x_s)  # specified nodes do not move
    # IPOPT's path: K+1 configurations, every bar at its reference length, the end on target.
    assert res.path.shape == (9, 6, 2)
    assert relative_bar_error(res.path, frame.edges, res.path[0]) <= 1e-6
    assert np.allclose(res.path[-1][:4], 1.2 * x_s, atol=1e-12)
    # Re-verified by PyRigi: one nontrivial flex and no self-stress at both ends.
    assert pyrigi_counts(res.path[0], frame.edges) == (1, 0)
    assert pyrigi_counts(res.path[-1], frame.edges) == (1, 0)


def test_targets_given_as_final_positions_up_to_a_rigid_motion():
    frame = outward_square()
    x_s = frame.positions[:4]
    c, s = np.cos(0.5), np.sin(0.5)
    targets = 1.2 * x_s @ np.array([[c, -s], [s, c]]).T + [3.0, -1.0]
    res = refine(frame, targets=targets)
    assert res.epsilon_after <= 1e-6
    # x_S + Δ_S is the given target up to a rigid motion, and ε is measured for it.
    assert rigid_distance(x_s + res.displacement, targets) <= 1e-12 * np.linalg.norm(targets)
    check_epsilons(frame, res)
    assert np.allclose(res.path[-1][:4], targets, atol=1e-12)
    # A rigid motion of the target changes nothing about the refined frame's geometry.
    assert np.allclose(np.linalg.norm(res.frame.positions[4:], axis=1), 1.2 * np.sqrt(2), rtol=1e-6)


@pytest.mark.parametrize(
    "k, d, n_unspecified, seed", [(3, 2, 2, 0), (3, 2, 2, 1), (4, 3, 5, 0), (4, 3, 5, 2)]
)
def test_random_targets_at_ten_percent(k, d, n_unspecified, seed):
    x_s, u_s = random_targets(k, d, seed)
    frame = bipartite_design(x_s, u_s, n_unspecified, seed=seed)
    res = refine(frame, u_s, 0.1)
    assert res.epsilon_after <= 1e-3
    assert res.epsilon_after < res.epsilon_before
    check_epsilons(frame, res)
    assert relative_bar_error(res.path, frame.edges, res.path[0]) <= 1e-6
    # Δ_S has RMS a·r_S with r_S the RMS radius of the specified positions.
    r_s = np.sqrt(np.mean(np.sum((x_s - x_s.mean(0)) ** 2, axis=1)))
    assert np.sqrt(np.mean(np.sum(res.displacement**2, axis=1))) == pytest.approx(0.1 * r_s)
    assert pyrigi_counts(res.path[0], frame.edges) == (1, 0)


def test_infeasible_refinement_fails_with_the_best_result():
    # Keeping u_S an exact zero mode pins the unspecified nodes to the circle |x_U| = √2 (the
    # paper's conic), but reaching 1.2·x_S needs |x_U| = 1.2·√2: no solution exists.
    frame = outward_square()
    with pytest.raises(RefinementFailed) as err:
        refine(frame, frame.positions[:4], 0.2, stay_on_solution_space=True)
    assert err.value.code == "refinement_failed"
    best = err.value.best
    assert not best.ok and best.ipopt_status not in (
        "Solve_Succeeded",
        "Solved_To_Acceptable_Level",
    )
    # The best result found is returned, and its ε is what continuation measures for it.
    assert best.epsilon_after <= best.epsilon_before
    check_epsilons(frame, best)


def test_iteration_limit_fails_and_keeps_the_better_frame():
    x_s, u_s = random_targets(4, 3, 0)
    frame = bipartite_design(x_s, u_s, 5, seed=0)
    with pytest.raises(RefinementFailed) as err:
        refine(frame, u_s, 0.1, max_iter=2)
    best = err.value.best
    assert best.ipopt_status == "Maximum_Iterations_Exceeded" and best.iterations == 2
    assert best.epsilon_after <= best.epsilon_before
    check_epsilons(frame, best)
    assert "Maximum_Iterations_Exceeded" in err.value.message


def test_bad_requests():
    frame = outward_square()
    with pytest.raises(DomainError) as err:
        refine(Frame.build(frame.positions, frame.edges, [0]), [[1.0, 1.0]], 0.2)
    assert err.value.code == "too_few_specified"
    with pytest.raises(DomainError) as err:
        refine(frame, frame.positions[:3], 0.2)
    assert err.value.code == "invalid_shape"
    with pytest.raises(DomainError) as err:
        refine(frame, frame.positions[:4], 0.2, targets=frame.positions[:4])
    assert err.value.code == "invalid_request"
    with pytest.raises(DomainError) as err:
        refine(Frame.build(frame.positions, frame.edges, list(range(6))), np.ones((6, 2)), 0.2)
    assert err.value.code == "nothing_to_refine"
    pentagon = Frame.build(
        [[np.cos(t), np.sin(t)] for t in np.linspace(0, 6, 5)],
        [[i, (i + 1) % 5] for i in range(5)],
        [0, 1, 2],
    )
    with pytest.raises(DomainError) as err:
        refine(pentagon, np.eye(3, 2), 0.1)
    assert err.value.code == "not_single_mode"


def test_a_design_whose_first_path_straddles_two_branches_still_reaches_its_target():
    # A dilation of a random triangle (the benchmark's η = 0, seed 3 design): with K = 8 IPOPT's
    # configurations land on two branches of the configuration space, which continuation from
    # the refined frame detects (ε stays ~0.8); the retry with 2K = 16 reaches the target.
    x_s = np.random.default_rng(1003).standard_normal((3, 2))
    u_s = x_s - x_s.mean(axis=0)
    u_s /= np.sqrt(np.mean(np.sum(u_s**2, axis=1)))
    frame = bipartite_design(x_s, u_s, 2, seed=3)
    res = refine(frame, u_s, 0.2, K=8)
    assert res.ok and res.epsilon_after <= 1e-6
    check_epsilons(frame, res)
    assert (res.attempts, res.K) in {(1, 8), (2, 16)}
    assert res.path.shape[0] == res.K + 1


def test_refined_frame_carries_its_mode():
    """The refined frame's reported mode is its nontrivial zero mode: C(refined)·u = 0 with C
    built here, and u is not a rigid motion."""
    from oracles.rigidity import compatibility_matrix, mode_residual, normalised

    frame = outward_square()
    res = refine(frame, frame.positions[:4], 0.2)
    assert res.mode is not None and res.mode.shape == frame.positions.shape
    x = res.frame.positions
    assert mode_residual(compatibility_matrix(normalised(x), frame.edges), res.mode) <= 1e-9
    # The corners' motion is not a rigid motion: their pairwise distances change to first order.
    u = res.mode[:4]
    rates = [(x[i] - x[j]) @ (u[i] - u[j]) for i in range(4) for j in range(i + 1, 4)]
    assert max(abs(r) for r in rates) > 1e-6 * np.linalg.norm(u) ** 2


def test_rigid_target_is_reached_without_ipopt():
    """Targets that are a rotation + translation of x_S: ε = 0 at once, the frame unchanged,
    the path's end a rigid motion of the reference (every bar kept, checked here)."""
    frame = outward_square()
    x_s = frame.positions[:4]
    c, s = np.cos(0.3), np.sin(0.3)
    targets = x_s @ np.array([[c, s], [-s, c]]) + [0.5, -0.2]
    res = refine(frame, targets=targets)
    assert res.ok and res.epsilon_after == 0.0 and res.iterations == 0
    assert np.array_equal(res.frame.positions, frame.positions)
    assert relative_bar_error(res.path, frame.edges, frame.positions) <= 1e-12
    assert rigid_distance(res.path[-1][:4], targets) <= 1e-12


def test_overdetermined_refinement_is_refused_in_design_terms():
    """A 3 × 3 auxetic sheet with its corner grid specified: K·N_B bar equations outnumber the
    (K − 1)·N·d + 2·N_U·d coordinates (counted here), so IPOPT could not even start; the
    refusal names the counts, with a code, before any NLP."""
    from zeromode.solver.applications.lattice import auxetic_sheet

    lat = auxetic_sheet(3, 3, poisson=-0.5)
    corners = list(range(16))
    frame = Frame.build(lat.frame.positions, lat.frame.edges, corners)
    K, n, n_u, n_b = 8, frame.n_nodes, frame.n_nodes - 16, frame.n_edges
    assert K * n_b > (K - 1) * n * 2 + 2 * n_u * 2
    with pytest.raises(DomainError) as err:
        refine(frame, lat.mode[corners], 0.05, K=K)
    assert err.value.code == "too_few_unknowns"
    assert f"{K * n_b} bar equations" in err.value.message
