"""Multistable rods-and-springs design (issue #41, item 1), checked through independent routes:
bar lengths and counts from scratch (oracles.motion, oracles.rigidity), the path by a
continuation written in the tests (oracles.motion.fidelity), and the energy, its gradient, the
rods-as-constraints curvature and scipy relaxations from the definition (oracles.elastic)."""

import numpy as np
import pytest
from oracles.elastic import constrained_curvature, energy, hessian, relax, relax_on_rods
from oracles.motion import bar_lengths, fidelity, relative_bar_error, rigid_distance
from oracles.rigidity import reference_counts, rigid_motions
from scipy.optimize import least_squares

from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.multistable.design import design_multistable
from zeromode.solver.multistable.linkage import placements

# The tristable triangle of docs/multistable.md: its apex rises and leans in three steps.
TRIANGLE = [
    [[0.0, 0.0], [1.0, 0.0], [0.3, 0.8]],
    [[0.0, 0.0], [1.0, 0.0], [0.45, 1.0]],
    [[0.0, 0.0], [1.0, 0.0], [0.65, 1.15]],
]
# A smooth 3D path x + t·u + t²·w of four random points, at t = 0, 0.05, 0.1.
_rng = np.random.default_rng(0)
_x, _u, _w = (_rng.standard_normal((4, 3)) for _ in range(3))
TETRA = [(_x + t * _u + t * t * _w).tolist() for t in (0.0, 0.05, 0.1)]
# Rods as stiff springs in the tests' own relaxations: stiff enough that the rods give by much
# less than the distance between conformations.
ROD_STIFFNESS = 1e6
# ε two continuations agree on; finite differences of an exact gradient (h = 1e-5) are good to
# about 1e-8 of the curvature.
REACHED, CURVATURE_RTOL = 1e-6, 1e-4


@pytest.fixture(scope="module", params=["triangle", "tetra"])
def tristable(request):
    confs = TRIANGLE if request.param == "triangle" else TETRA
    return confs, design_multistable(confs, seed=0)


def _springs(r):
    return r.springs.pairs, r.springs.stiffness, r.springs.rest_length


def test_every_conformation_is_a_realisation_on_one_motion(tristable):
    confs, r = tristable
    link = r.linkage
    k = len(confs[0])
    edges, spec = link.frame.edges, link.frame.specified
    for j, c in enumerate(confs):
        assert np.array_equal(link.conformations[j][:k], np.asarray(c))
        lengths = bar_lengths(link.conformations[j], edges)
        assert np.max(np.abs(lengths - bar_lengths(link.conformations[0], edges)) / lengths) <= 1e-12
        counts = reference_counts(link.conformations[j], edges)
        assert (counts["nontrivial_zero_modes"], counts["self_stresses"]) == (1, 0)
    # An independent continuation from conformation a meets every other one (all nodes).
    a = link.conformations[0]
    everything = range(link.frame.n_nodes)
    for c in link.conformations[1:]:
        assert fidelity(a, edges, everything, c - a) <= REACHED
    # The solver's own path keeps every bar, meets them in order, one mode all the way.
    assert relative_bar_error(link.path.positions, edges, a) <= 1e-9
    assert np.all(np.diff(link.parameters) > 0) and link.gap > 0
    assert spec == tuple(range(k))


def test_each_conformation_is_a_strict_constrained_minimum(tristable):
    _, r = tristable
    pairs, k, rest = _springs(r)
    rods = {tuple(sorted(e)) for e in r.linkage.frame.edges.tolist()}
    assert not rods & {tuple(sorted(p)) for p in pairs.tolist()}, "a spring doubles a rod"
    assert np.all(k > 0) and np.all(k <= r.max_stiffness) and np.all(rest > 0)
    for m, x in zip(r.landscape.minima, r.linkage.conformations):
        kkt, curvature = constrained_curvature(x, r.linkage.frame.edges, pairs, k, rest)
        assert kkt <= 1e-7  # ∇E ∈ range(Jᵀ): stationary on the rods' constraint manifold
        assert curvature > 0
        assert curvature == pytest.approx(m.curvature, rel=CURVATURE_RTOL)


def test_energy_along_the_motion_from_the_definition(tristable):
    _, r = tristable
    pairs, k, rest = _springs(r)
    land = r.landscape
    recomputed = np.array([energy(x, pairs, k, rest) for x in land.positions])
    assert np.allclose(recomputed, land.energy, rtol=1e-12, atol=0)
    edges = r.linkage.frame.edges
    assert relative_bar_error(land.positions, edges, r.linkage.conformations[0]) <= 1e-9
    at = land.conformation_samples
    for j, m in enumerate(land.minima):
        assert recomputed[at[j]] == pytest.approx(m.energy, rel=1e-12)
        assert m.barrier >= r.barrier * (1 - 1e-6)
        if j + 1 < len(at):  # the highest sample between neighbours is the barrier's top
            top = recomputed[at[j] : at[j + 1] + 1].max()
            assert top - recomputed[at[j]] >= r.barrier * (1 - 1e-6)
            assert top - recomputed[at[j + 1]] >= r.barrier * (1 - 1e-6)


def test_stiff_rod_hessian_and_relaxations(tristable):
    _, r = tristable
    pairs, k, rest = _springs(r)
    edges = r.linkage.frame.edges
    lengths = bar_lengths(r.linkage.conformations[0], edges)
    all_pairs = np.concatenate([edges, pairs])
    all_k = np.concatenate([np.full(len(edges), ROD_STIFFNESS * r.max_stiffness), k])
    all_rest = np.concatenate([lengths, rest])
    rng = np.random.default_rng(7)
    for j, c in enumerate(r.linkage.conformations):
        nearest = min(rigid_distance(c, y) for i, y in enumerate(r.linkage.conformations) if i != j)
        # Rods as stiff springs: the minimum moves a little; its Hessian is positive definite
        # on the complement of the rigid motions.
        x = relax(c, all_pairs, all_k, all_rest)
        assert rigid_distance(x, c) <= 0.1 * nearest
        h = hessian(x, all_pairs, all_k, all_rest)
        rigid = rigid_motions(x)
        q = np.linalg.svd(np.eye(x.size) - rigid @ rigid.T)[0][:, : x.size - rigid.shape[1]]
        assert np.linalg.eigvalsh(q.T @ h @ q)[0] > 0
        # Rods as constraints: relaxations from seeded perturbations come back to c itself.
        for _ in range(2 if c.shape[1] == 2 else 1):
            kick = rng.standard_normal(c.shape)
            start = c + 0.01 * nearest * kick / np.linalg.norm(kick)
            back = relax_on_rods(start, edges, lengths, pairs, k, rest)
            assert rigid_distance(back, c) <= 1e-5 * nearest
    assert all(check.ok for check in r.checks)


def test_bistable_two_conformations():
    a = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    b = a + [[0.0, 0.0], [0.1, 0.0], [0.25, -0.1], [0.1, 0.05]]
    r = design_multistable([a, b], seed=1)
    assert len(r.landscape.minima) == 2
    pairs, k, rest = _springs(r)
    for m, x in zip(r.landscape.minima, r.linkage.conformations):
        kkt, curvature = constrained_curvature(x, r.linkage.frame.edges, pairs, k, rest)
        assert kkt <= 1e-7 and curvature == pytest.approx(m.curvature, rel=CURVATURE_RTOL) and curvature > 0
    assert fidelity(r.linkage.conformations[0], r.linkage.frame.edges, range(r.linkage.frame.n_nodes),
                    r.linkage.conformations[1] - r.linkage.conformations[0]) <= REACHED


@pytest.mark.parametrize("confs", [TRIANGLE, TETRA])
def test_placements_keep_every_bar_in_three_conformations(confs):
    x = np.asarray(confs)
    m = {2: 3, 3: 4}[x.shape[2]]
    points = placements(x[:, :m], np.random.default_rng(0))
    assert points
    for p in points:
        r = np.linalg.norm(p[:, None, :] - x[:, :m], axis=-1)  # (3, m)
        assert np.max(np.abs(r - r[0]) / r[0]) <= 1e-9


def _node_residual(confs, starts):
    """min over ``starts`` seeded starts of the least-squares residual of |p^a − x_i^a|² = |p^j − x_i^j|²
    (j = b, c; every anchor i), relative to the squared size: zero iff a node can be joined."""
    x = np.asarray(confs)
    d = x.shape[2]

    def residual(z):
        p = z.reshape(3, d)
        sq = np.sum((p[:, None, :] - x) ** 2, axis=-1)  # (3, k)
        return np.concatenate([sq[1] - sq[0], sq[2] - sq[0]])

    rng = np.random.default_rng(0)
    best = min(least_squares(residual, 3 * rng.standard_normal(3 * d)).cost for _ in range(starts))
    return np.sqrt(2 * best)


def test_refuses_three_conformations_no_node_can_join():
    # The triangle dilated twice: no point keeps its distances to all three corners in all three.
    a = np.asarray(TRIANGLE[0])
    confs = [a, 1.2 * a, 1.4 * a]
    assert _node_residual(confs, 100) > 1e-3  # the oracle's own search finds no such point
    assert _node_residual(TRIANGLE, 20) < 1e-9  # where the solver finds one, so does the oracle
    with pytest.raises(DomainError) as err:
        design_multistable(confs)
    assert err.value.code == "no_linkage"


def test_refuses_rigidly_related_conformations():
    a = np.asarray(TRIANGLE[0])
    turn = np.array([[0.0, -1.0], [1.0, 0.0]])
    with pytest.raises(DomainError) as err:
        design_multistable([a, np.asarray(TRIANGLE[1]), a @ turn.T + 2.0])
    assert err.value.code == "rigid_target"


def test_refuses_too_many_specified_nodes_before_any_work():
    rng = np.random.default_rng(2)
    x = rng.standard_normal((17, 2))
    with pytest.raises(DomainError) as err:
        design_multistable([x, x + 0.1 * rng.standard_normal(x.shape)])
    assert err.value.code == "too_expensive"


def test_refuses_a_barrier_out_of_reach_with_the_best_figure():
    with pytest.raises(DomainError) as err:
        design_multistable(TRIANGLE, barrier=10.0)
    assert err.value.code == "no_springs" and "largest barrier" in err.value.message


@pytest.mark.parametrize(
    "confs,code",
    [([TRIANGLE[0]], "invalid_conformations"), ([TRIANGLE[0], TRIANGLE[1][:2]], "invalid_shape"),
     ([[[0, 0], [1, 0]], [[0, 0], [2, 0]]], "too_few_nodes")],
)
def test_bad_input(confs, code):
    with pytest.raises(InvalidInput) as err:
        design_multistable(confs)
    assert err.value.code == code
