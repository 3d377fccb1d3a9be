"""Zero-mode design by judicious constraint placement (paper, "Network Construction Through
Judicious Constraint Placement", Eq. 7, and Supplementary "Avoiding States of Self Stress in
3 Dimensions").

Each design is checked through routes that share nothing with the code under test:
PyRigi's numerical rigidity (nontrivial infinitesimal flexes, equilibrium stresses), a
compatibility matrix C built here from Eq. 3, exact (==) comparison of the specified rows,
and the paper's geometry (Thales circles/spheres for outward motions, the plane of the 3D
five-node solution curve).
"""

from __future__ import annotations

import numpy as np
import pytest
from oracles import pyrigi_adapter
from oracles.designs import check_design
from oracles.frames import CUBE_CORNERS, SQUARE_CORNERS
from oracles.rigidity import kernel, numerical_rank
from oracles.solution_space import a_tilde, paper_quadric

from zeromode.solver.construction.design import design
from zeromode.solver.errors import DomainError

SQUARE = np.array(SQUARE_CORNERS)
CUBE = np.array(CUBE_CORNERS)
# Supplementary Methods, "Avoiding States of Self Stress in 3 Dimensions".
FIVE_X = np.array([[2, 0, 1], [1, 0, 2], [3, 0, 3], [3.5, -1, 2.5], [3.5, 1, 2.5]])
FIVE_U = np.array([[-0.8, 0, 0.8], [0.8, 0, -0.8], [-0.8, 0, 0], [0, -0.8, 0], [0, 0.8, 0]])


def random_target(d: int, k: int, seed: int, n_modes: int = 1) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng([d, k, seed])
    return rng.standard_normal((k, d)), rng.standard_normal((n_modes, k, d))


# --------------------------------------------------------------------------- random targets
@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize(("d", "k"), [(2, 3), (2, 4), (3, 4), (3, 5), (3, 6)])
def test_random_single_motion_design(d, k, seed):
    x, motions = random_target(d, k, seed)
    check_design(design(x, motions, d, seed=seed), x, motions)


@pytest.mark.parametrize(("d", "k"), [(2, 5), (2, 6), (3, 7)])
def test_random_design_beyond_a_single_layer(d, k):
    """k ≥ 2d + 1: the full-set solution space has no point, so anchor subsets must carry it."""
    for seed in range(2):
        x, motions = random_target(d, k, seed)
        check_design(design(x, motions, d, seed=seed), x, motions)


@pytest.mark.parametrize(("d", "k"), [(2, 3), (3, 4)])
def test_random_two_motion_design(d, k):
    """Paper, "Multi-Mode Construction": when a design is returned it carries both motions
    (N_D = d(d+1)/2 + 2) and nothing else."""
    built = 0
    for seed in range(4):
        x, motions = random_target(d, k, seed, n_modes=2)
        try:
            result = design(x, motions, d, seed=seed)
        except DomainError as err:
            assert err.code == "no_solution" and err.message
            continue
        check_design(result, x, motions)
        built += 1
    assert built >= 2


def test_design_is_deterministic():
    for d, k in [(2, 4), (3, 5)]:
        x, motions = random_target(d, k, 11)
        first, second = design(x, motions, d, seed=3), design(x, motions, d, seed=3)
        assert np.array_equal(first.frame.positions, second.frame.positions)
        assert np.array_equal(first.frame.edges, second.frame.edges)
        assert np.array_equal(first.modes, second.modes)


SCALES = [(1e-3, 1.0), (1e3, 1.0), (1.0, 1e-3), (1e3, 1e-3)]
SCALE_CASES = [
    (d, k, seed) for d, k in [(2, 3), (2, 4), (3, 4), (3, 5), (3, 6)] for seed in range(6)
]


def test_scaling_keeps_the_design():
    """Positions × 1e±3 and motions × 1e±3 (separately): the same bars, positions scaled by the
    same factor, and the same counts (zero modes, no self-stress)."""
    for d, k, seed in SCALE_CASES:
        x, motions = random_target(d, k, seed)
        reference = design(x, motions, d, seed=seed)
        for sx, su in SCALES:
            scaled = design(sx * x, su * motions, d, seed=seed)
            assert scaled.frame.n_nodes == reference.frame.n_nodes
            assert np.array_equal(scaled.frame.edges, reference.frame.edges)
            assert np.allclose(
                scaled.frame.positions / sx, reference.frame.positions, rtol=1e-6, atol=1e-9
            )
            assert scaled.analysis.zero_modes == reference.analysis.zero_modes
            assert scaled.analysis.self_stresses == 0


# --------------------------------------------------------------------------- the paper's cases
def on_circumsphere(result, radius: float) -> None:
    """Thales: an unspecified node joined to ≥ d + 1 corners of the square/cube moving outward
    sits on their circumsphere (centre 0) and moves to its antipode: u_U = −x_U."""
    k = len(result.frame.specified)
    positions = np.asarray(result.frame.positions[k:])
    assert np.allclose(np.linalg.norm(positions, axis=1), radius, rtol=1e-9)
    assert np.allclose(result.modes[0][k:], -positions, atol=1e-9)


def test_paper_outward_square_two_nodes_eight_bars():
    """Fig. 3b: N_S = 4, N_D 8 → 4 with N_U = 2, N_B = 8."""
    result = design(SQUARE, [SQUARE], 2, seed=0)
    assert (result.unspecified_nodes, result.frame.n_edges) == (2, 8)
    check_design(result, SQUARE, SQUARE[None])
    on_circumsphere(result, np.sqrt(2))


def test_paper_outward_square_four_nodes_twelve_bars():
    """Fig. 3c: the same target with N_U = 4, N_B = 12."""
    result = design(SQUARE, [SQUARE], 2, seed=0, n_unspecified=4)
    assert (result.unspecified_nodes, result.frame.n_edges) == (4, 12)
    check_design(result, SQUARE, SQUARE[None])
    on_circumsphere(result, np.sqrt(2))


def test_paper_outward_cube():
    """Fig. 3d–e: eight cube corners moving outward; N_D = 7 with at most 5 unspecified nodes."""
    result = design(CUBE, [CUBE], 3, seed=0)
    assert result.unspecified_nodes <= 5
    assert result.analysis.zero_modes == 7
    check_design(result, CUBE, CUBE[None])
    on_circumsphere(result, np.sqrt(3))


@pytest.mark.parametrize(("n_unspecified", "bars"), [(5, 32), (6, 35)])
def test_paper_outward_cube_with_the_figure_node_counts(n_unspecified, bars):
    """Fig. 3e–f: N_U = 5 with N_B = 32 and N_U = 6 with N_B = 35 (Eq. 7 fixes N_B)."""
    result = design(CUBE, [CUBE], 3, seed=0, n_unspecified=n_unspecified)
    assert (result.unspecified_nodes, result.frame.n_edges) == (n_unspecified, bars)
    check_design(result, CUBE, CUBE[None])


def full_set_plane(
    x: np.ndarray, u: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """For 5 specified nodes in 3D, N(Ã) is 2-dimensional, so x_U = x* + W_x α sweeps a plane.

    Returns (x*, unit normal, W̃ = [W, ṽ*], Q) — all from the paper's Ã, b and block formula."""
    a, b = a_tilde(x, u)
    w = kernel(a)
    v = np.linalg.pinv(a) @ b
    assert w.shape[1] == 2 and np.linalg.norm(a @ v - b) <= 1e-12 * np.linalg.norm(b)
    w_x = w[:3]
    assert numerical_rank(w_x) == 2  # a plane, not a line or a volume
    normal = np.cross(w_x[:, 0], w_x[:, 1])
    w_tilde = np.column_stack([w, v])
    q = paper_quadric(w_tilde, 3)
    return v[:3], normal / np.linalg.norm(normal), w_tilde, q


def test_paper_five_nodes_in_3d_avoid_the_planar_self_stress():
    """Supplement: the full-set solution curve is planar, so N_U = 4 nodes on it, each joined to
    all five specified nodes (N_B = 20), promise N_D = 7 but carry a self-stress and two
    nontrivial flexes.  The design must reach N_D = 7 without that self-stress."""
    x, u = FIVE_X.astype(float), FIVE_U
    x_star, normal, w_tilde, q = full_set_plane(x, u)

    # The pathology, built here: four nodes on the planar curve, each joined to all five.
    rng = np.random.default_rng(0)
    curve = []
    while len(curve) < 4:
        a0, delta = rng.standard_normal(2), rng.standard_normal(2)
        p0, p1 = np.append(a0, 1.0), np.append(delta, 0.0)
        qa, qb, qc = p1 @ q @ p1, 2 * p1 @ q @ p0, p0 @ q @ p0
        disc = qb * qb - 4 * qa * qc
        if disc <= 0:
            continue
        t = (-qb + np.sqrt(disc)) / (2 * qa)
        point = (w_tilde @ np.append(a0 + t * delta, 1.0))[:3]
        if min(np.linalg.norm(np.vstack([x, *curve]) - point, axis=1)) > 0.3:
            curve.append(point)
    planar = np.vstack([x, curve])
    bars = [(i, 5 + j) for j in range(4) for i in range(5)]
    assert 3 * len(planar) - len(bars) == 7  # the count alone promises N_D = 7 ...
    flexes = pyrigi_adapter.flexes(planar, bars)
    assert flexes.stresses >= 1 and flexes.nontrivial.shape[1] >= 2  # ... but it is self-stressed.

    result = design(x, [u], 3, seed=0)
    check_design(result, x, u[None])  # PyRigi: one nontrivial flex, no stress
    assert result.analysis.zero_modes == 7
    positions, k = np.asarray(result.frame.positions), 5
    edges = np.asarray(result.frame.edges)
    anchors = {
        j: set(edges[edges[:, 1] == j, 0].tolist()) | set(edges[edges[:, 0] == j, 1].tolist())
        for j in range(k, len(positions))
    }
    full = [j for j, a in anchors.items() if a == set(range(k))]
    # Nodes joined to all five sit on the plane of the full-set curve ...
    assert full, "no unspecified node uses the full specified set"
    assert all(abs(normal @ (positions[j] - x_star)) <= 1e-9 * np.linalg.norm(x) for j in full)
    # ... and the design does not repeat the self-stressed pattern of all nodes joined to all five.
    assert len(full) < len(anchors)


# --------------------------------------------------------------------------- failure codes
def rotation_field(x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """An infinitesimal rotation u_i = Ω x_i (Ω skew)."""
    d = x.shape[1]
    a = rng.standard_normal((d, d))
    return x @ (a - a.T).T


@pytest.mark.parametrize("d", [2, 3])
def test_rigid_targets_are_refused(d):
    rng = np.random.default_rng(d)
    x = rng.standard_normal((d + 2, d))
    translation = np.tile(rng.standard_normal(d), (len(x), 1))
    rigid = {
        "zero": np.zeros_like(x),
        "translation": translation,
        "rotation": rotation_field(x, rng),
        "rotation + translation": rotation_field(x, rng) + translation,
    }
    for name, u in rigid.items():
        with pytest.raises(DomainError) as err:
            design(x, [u], d)
        assert err.value.code == "rigid_target", name
        assert err.value.message
    # Two motions that differ by a rigid motion add only one nontrivial mode.
    u = rng.standard_normal(x.shape)
    with pytest.raises(DomainError) as err:
        design(x, [u, 2 * u + rotation_field(x, rng)], d)
    assert err.value.code == "rigid_target"


@pytest.mark.parametrize("d", [2, 3])
def test_coincident_specified_nodes_are_refused(d):
    rng = np.random.default_rng(0)
    x = rng.standard_normal((d + 2, d))
    x[2] = x[0]
    with pytest.raises(DomainError) as err:
        design(x, [rng.standard_normal(x.shape)], d)
    assert err.value.code == "degenerate_specified"
    assert "0" in err.value.message and "2" in err.value.message


def test_three_nodes_in_3d_cannot_be_designed():
    """k = 3 in 3D: N_D = 9 must reach 7, but each unspecified node brings 3 coordinates and can
    take at most k = 3 (bipartite) bars, so no count of nodes ever lowers N_D."""
    x, motions = random_target(3, 3, 0)
    with pytest.raises(DomainError) as err:
        design(x, motions, 3)
    assert err.value.code == "no_solution"


def outward_square_node_counts() -> range:
    """The numbers of unspecified nodes the outward square can use, by counting (Eq. 7).

    N_D = d(k + N_U) − N_B must fall from dk = 8 to the target d(d+1)/2 + 1 = 4. A node joined to
    a of the k = 4 corners removes a − d degrees of freedom; it must remove at least one (with
    a = d bars it would be an idle node), and a ≤ k caps it at k − d = 2. So the 4 degrees of
    freedom take between ⌈4/2⌉ = 2 and 4 nodes."""
    k, d = SQUARE.shape
    to_remove = d * k - (d * (d + 1) // 2 + 1)
    return range(-(-to_remove // (k - d)), to_remove + 1)


@pytest.mark.parametrize("n_unspecified", range(7))
def test_n_unspecified_is_honoured_exactly_when_the_count_allows_it(n_unspecified):
    """Outward square: a feasible count gives a design with exactly that many nodes, each on the
    circumcircle (Thales); any other count is refused as no_solution."""
    if n_unspecified in outward_square_node_counts():
        result = design(SQUARE, [SQUARE], 2, seed=0, n_unspecified=n_unspecified)
        assert result.unspecified_nodes == n_unspecified
        check_design(result, SQUARE, SQUARE[None])
        on_circumsphere(result, np.sqrt(2))
    else:
        with pytest.raises(DomainError) as err:
            design(SQUARE, [SQUARE], 2, n_unspecified=n_unspecified)
        assert err.value.code == "no_solution"
        assert err.value.message


@pytest.mark.parametrize(
    ("positions", "motions", "dim"),
    [
        (SQUARE, [SQUARE[:3]], 2),  # one row short
        (SQUARE, [np.hstack([SQUARE, SQUARE[:, :1]])], 2),  # 3 coordinates in 2D
        (SQUARE, [SQUARE], 3),  # dim disagrees with the points
        (SQUARE, np.zeros((0, 4, 2)), 2),  # no motion at all
    ],
)
def test_mismatched_shapes_are_refused(positions, motions, dim):
    with pytest.raises(DomainError) as err:
        design(positions, motions, dim)
    assert err.value.code in {"invalid_shape", "invalid_dim"}
    assert err.value.message
