"""SDP certificates (zeromode.solver.certificates.prestress) against independent routes.

Oracles: PyRigi's is_prestress_stable wherever it decides (one flex, or one stress — where its
2×2-minor test is exact or the answer is positive definite), the literature (Connelly's
second-order rigid frame that is not prestress stable), brute-force searches over the stress
sphere and over stiffness allocations with flex/stress bases and stiffness matrices built from
scratch (tests/oracles/rigidity.py), the paper's outward module (Fig. 3b) with its analytic
mode, and symmetry.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from oracles import pyrigi_adapter
from oracles.frames import K4_SQUARE, SQUARE, TRIANGLE, random_rotation, triangle_with_taut_sides
from oracles.mechanisms import bipartite_design, four_bar, outward_square, random_targets
from oracles.rigidity import (
    compatibility_matrix,
    kernel,
    nontrivial_flexes,
    normalised,
    rigid_generators,
    self_stresses,
    singular_values,
    span,
)

from zeromode.solver import Frame
from zeromode.solver.certificates.prestress import (
    MAX_DOF,
    OPTIMAL_MAX_DIM,
    SDP_MAX_DIM,
    certify,
    solve_lmi,
    stiffness_program,
)
from zeromode.solver.certificates.stiffness import optimal_stiffness
from zeromode.solver.errors import DomainError, InvalidInput

# ----------------------------------------------------------------------------- frames


def taut_chain(joints: int, pendant: bool = False):
    """2D: nodes 0 … joints+1 on a line, chained and closed by the long bar (0, joints+1).

    One self-stress (chain in tension, long bar in compression) and `joints` flexes (each
    interior joint moves across the line); the tension stiffens every one of them. With
    ``pendant`` a node hangs off node 0 on one bar: a flex no stress touches.
    """
    x = [[float(i), 0.0] for i in range(joints + 2)]
    e = [[i, i + 1] for i in range(joints + 1)] + [[0, joints + 1]]
    if pendant:
        x.append([0.3, 1.0])
        e.append([0, joints + 2])
    return x, e


def frustum_2d():
    """PyRigi's Frustum(3): two homothetic triangles joined along lines through the centre."""
    th = 2 * np.pi * np.arange(3) / 3
    ring = np.column_stack([np.cos(th), np.sin(th)])
    e = [[0, 1], [1, 2], [0, 2], [3, 4], [4, 5], [3, 5], [0, 3], [1, 4], [2, 5]]
    return np.vstack([ring, 2 * ring]), e


def homothetic_frustum(body: np.ndarray):
    """3D: a rigid body (all pairs joined except antipodes) and its double, joined node to node.

    The joining bars all pass through the centre: the relative rotations about it are flexes,
    and the joining bars in tension (balanced inside each body) stiffen all of them.
    """
    n = len(body)
    pairs = [
        (i, j) for i in range(n) for j in range(i + 1, n) if not np.allclose(body[i], -body[j])
    ]
    e = pairs + [(i + n, j + n) for i, j in pairs] + [(i, i + n) for i in range(n)]
    return np.vstack([body, 2 * body]), e


TETRAHEDRON = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
OCTAHEDRON = np.vstack([np.eye(3), -np.eye(3)])


def connelly_second_order_rigid():
    """Connelly & Whiteley (1996) / PyRigi frameworkDB.SecondOrderRigid: 2 flexes, 2 stresses,
    second-order rigid but NOT prestress stable (nodes 1, 5 and 3, 6 coincide, unjoined)."""
    x = [(0, 0, 0), (0, 1, 0), (0, 0, 1), (1, 0, 0), (1, 1, 0), (0, 1, 0), (1, 0, 0)]
    e = [(0, 1), (0, 2), (0, 3), (0, 5), (0, 6), (1, 2), (1, 4), (1, 6), (2, 3), (2, 4),
         (3, 4), (3, 5), (4, 5), (4, 6), (5, 6)]  # fmt: skip
    return x, e


def three_prism_flexible():
    """PyRigi ThreePrism('flexible'): a continuously flexible prism (1 flex, 1 stress)."""
    x = [(0, 0), (2, 0), (1, 2), (0, 4), (2, 4), (1, 6)]
    e = [(0, 1), (1, 2), (0, 2), (3, 4), (4, 5), (3, 5), (0, 3), (1, 4), (2, 5)]
    return x, e


# ----------------------------------------------------------------------------- reference


def reference_bases(x, e):
    """From scratch: flexes F (dN × f, orthonormal, ⟂ rigid) and stresses S (N_B × s)."""
    return nontrivial_flexes(x, e), self_stresses(x, e)


def stress_energy(flexes: np.ndarray, stress: np.ndarray, e, d: int) -> np.ndarray:
    """Fᵀ(Ω ⊗ I)F written out as Σ_e ω_e (q_i − q_j)·(q_i − q_j) for the columns of F."""
    q = flexes.reshape(-1, d, flexes.shape[1])  # (N, d, f)
    out = np.zeros((flexes.shape[1], flexes.shape[1]))
    for w, (i, j) in zip(stress, e):
        diff = q[i] - q[j]
        out += w * diff.T @ diff
    return out


def brute_force_prestress_margin(x, e, samples: int = 4000) -> float:
    """max over unit stresses of λ_min of the stress energy, by sampling the stress sphere."""
    flexes, stresses = reference_bases(x, e)
    d = np.shape(x)[1]
    forms = np.array([stress_energy(flexes, s, e, d) for s in stresses.T])
    rng = np.random.default_rng(0)
    c = rng.standard_normal((samples, len(forms)))
    c /= np.linalg.norm(c, axis=1, keepdims=True)
    return float(max(np.linalg.eigvalsh(np.tensordot(ci, forms, axes=1))[0] for ci in c))


def reference_margin(x, e, modes, stiffness) -> float:
    """λ_min(Pᵀ Cᵀ diag(k) C P) from scratch, P ⟂ rigid motions ⊕ modes, C normalised."""
    xn = normalised(x)
    c = compatibility_matrix(xn, e)
    fixed = np.column_stack([rigid_generators(xn)] + [np.ravel(m) for m in modes])
    p = kernel(span(fixed).T)
    return float(np.linalg.eigvalsh(p.T @ c.T @ np.diag(stiffness) @ c @ p)[0])


# ----------------------------------------------------------------------------- prestress

# PyRigi 1.3 decides one flex (any stresses: is some stress energy nonzero?) and one stress by
# testing the 2×2 principal minors of its energy in a flex basis — exact for f ≤ 2 only.
PYRIGI_EXACT = {
    "collinear taut joint (f=1, s=1)": (taut_chain(1), True),
    "taut chain (f=2, s=1)": (taut_chain(2), True),
    "frustum 2D (f=1, s=1)": (frustum_2d(), True),
    "flexible three-prism (f=1, s=1)": (three_prism_flexible(), False),
    "square (f=1, s=0)": ((SQUARE["positions"], SQUARE["edges"]), False),
    "K4 in the plane (f=0)": ((K4_SQUARE["positions"], K4_SQUARE["edges"]), True),
}


@pytest.mark.parametrize("name", PYRIGI_EXACT)
def test_prestress_agrees_with_pyrigi_where_it_decides(name):
    (x, e), expected = PYRIGI_EXACT[name]
    got = certify(Frame.build(x, e), stiffness=False).prestress
    assert pyrigi_adapter.prestress_stable(x, e) is expected
    assert got.prestress_stable is expected
    flexes, stresses = reference_bases(x, e)
    assert (got.flexes, got.stresses) == (flexes.shape[1], stresses.shape[1])


ONE_STRESS = {
    "taut chain (f=3)": (taut_chain(3), True),
    "tetrahedral frustum 3D (f=3)": (homothetic_frustum(TETRAHEDRON), True),
    # PyRigi 1.3 answers True for these two: its test 4·a_ii·a_jj > a_ij² has no tolerance, and
    # the energy here is singular (the pendant swings freely, at zero energy), so round-off
    # decides. They are not even rigid.
    "taut joint with pendant (f=2)": (taut_chain(1, pendant=True), False),
    "taut chain with pendant (f=3)": (taut_chain(2, pendant=True), False),
}


@pytest.mark.parametrize("name", ONE_STRESS)
def test_one_stress_margin_is_the_definite_part_of_its_energy(name):
    """With s = 1 the stress ball is {c ω : |c| ≤ 1}: t* = max(λ_min(G), λ_min(−G), 0) exactly."""
    (x, e), expected = ONE_STRESS[name]
    flexes, stresses = reference_bases(x, e)
    assert stresses.shape[1] == 1 and flexes.shape[1] >= 2
    energy = stress_energy(flexes, stresses[:, 0], e, np.shape(x)[1])
    exact = max(np.linalg.eigvalsh(energy)[0], np.linalg.eigvalsh(-energy)[0], 0.0)
    got = certify(Frame.build(x, e), stiffness=False).prestress
    assert got.prestress_stable is expected
    assert got.margin == pytest.approx(exact, rel=1e-6, abs=1e-8)


GENERAL_CASE = {
    "two taut sides (2 flexes, 2 stresses)": (triangle_with_taut_sides(2), True),
    "three taut sides (3 flexes, 3 stresses)": (triangle_with_taut_sides(3), True),
    "octahedral frustum 3D (3 flexes, 3 stresses)": (homothetic_frustum(OCTAHEDRON), True),
    "Connelly's second-order rigid frame": (connelly_second_order_rigid(), False),
}


@pytest.mark.parametrize("name", GENERAL_CASE)
def test_prestress_general_case_that_pyrigi_cannot_decide(name):
    (x, e), expected = GENERAL_CASE[name]
    with pytest.raises(ValueError, match="general case"):
        pyrigi_adapter.prestress_stable(x, e)
    got = certify(Frame.build(x, e), stiffness=False).prestress
    assert got.flexes >= 2 and got.stresses >= 2 and got.decided_by == "sdp"
    assert got.prestress_stable is expected
    # No sampled unit stress beats the SDP, and the SDP's bracket is tight.
    assert brute_force_prestress_margin(x, e) <= got.margin_upper_bound + 1e-9
    assert got.margin_upper_bound - got.margin <= 1e-6
    if expected:
        # The certifying stress, checked from scratch: an equilibrium, unit, and its energy on
        # the reference flex basis has smallest eigenvalue = the reported margin > 0.
        c = compatibility_matrix(normalised(x), e)
        assert np.linalg.norm(c.T @ got.stress) <= 1e-8 * np.linalg.norm(c)
        assert np.linalg.norm(got.stress) == pytest.approx(1.0)
        flexes, _ = reference_bases(x, e)
        energy = stress_energy(flexes, got.stress, e, np.shape(x)[1])
        assert np.linalg.eigvalsh(energy)[0] == pytest.approx(got.margin, rel=1e-6)
        assert got.margin > 1e-2
    else:
        assert got.margin_upper_bound <= 1e-6 and got.stress is None


def test_two_taut_sides_margin_matches_a_one_dimensional_search():
    """s = 2: the stress sphere is a circle; a fine scan of it is the optimum to ~1e-8."""
    x, e = triangle_with_taut_sides(2)
    flexes, stresses = reference_bases(x, e)
    forms = [stress_energy(flexes, s, e, 2) for s in stresses.T]
    theta = np.linspace(0, 2 * np.pi, 20001)
    scan = max(np.linalg.eigvalsh(np.cos(t) * forms[0] + np.sin(t) * forms[1])[0] for t in theta)
    got = certify(Frame.build(x, e), stiffness=False).prestress
    assert got.margin == pytest.approx(scan, rel=1e-5)


def test_scs_agrees_with_clarabel():
    x, e = homothetic_frustum(OCTAHEDRON)
    a = certify(Frame.build(x, e), stiffness=False, solver="clarabel").prestress
    b = certify(Frame.build(x, e), stiffness=False, solver="scs").prestress
    assert (a.sdp.solver, b.sdp.solver) == ("clarabel", "scs")
    assert b.prestress_stable and b.margin == pytest.approx(a.margin, rel=1e-4)


def test_trivial_decisions_need_no_sdp():
    rigid = certify(Frame.build(TRIANGLE["positions"], TRIANGLE["edges"])).prestress
    assert (rigid.prestress_stable, rigid.decided_by, rigid.margin, rigid.sdp) == (
        True, "infinitesimal_rigidity", None, None)  # fmt: skip
    square = certify(four_bar()).prestress
    assert (square.prestress_stable, square.decided_by, square.margin, square.sdp) == (
        False, "no_self_stress", 0.0, None)  # fmt: skip


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 10_000),
    scale=st.floats(1e-3, 1e3),
    name=st.sampled_from(["two taut sides", "octahedral frustum", "Connelly"]),
)
def test_prestress_margin_is_invariant_under_similarity_and_edge_order(seed, scale, name):
    """t* depends on the frame, not on its placement, size, or the order/orientation of bars."""
    x, e = {
        "two taut sides": triangle_with_taut_sides(2),
        "octahedral frustum": homothetic_frustum(OCTAHEDRON),
        "Connelly": connelly_second_order_rigid(),
    }[name]
    x = np.asarray(x, float)
    rng = np.random.default_rng(seed)
    moved = scale * x @ random_rotation(rng, x.shape[1]).T + rng.standard_normal(x.shape[1])
    shuffled = [list(e[k])[:: rng.choice([-1, 1])] for k in rng.permutation(len(e))]
    a = certify(Frame.build(x, e), stiffness=False).prestress
    b = certify(Frame.build(moved, shuffled), stiffness=False).prestress
    assert a.prestress_stable is b.prestress_stable
    assert b.margin == pytest.approx(a.margin, rel=1e-6, abs=1e-8)


# ----------------------------------------------------------------------------- self-stress


@pytest.mark.parametrize(
    "frame", [triangle_with_taut_sides(3), connelly_second_order_rigid(), frustum_2d()]
)
def test_self_stress_certificate_matches_reference(frame):
    x, e = frame
    cert = certify(Frame.build(x, e), stiffness=False).self_stress
    c = compatibility_matrix(normalised(x), e)
    reference = self_stresses(x, e)
    assert cert.count == reference.shape[1]
    basis = cert.basis.T
    assert np.allclose(basis.T @ basis, np.eye(cert.count), atol=1e-10)
    assert np.allclose(reference @ reference.T, basis @ basis.T, atol=1e-8)  # same subspace
    sigma = singular_values(c)
    rank = len(e) - cert.count
    assert cert.smallest_nonzero == pytest.approx(sigma[rank - 1], rel=1e-9)
    assert cert.largest_zero == pytest.approx(sigma[rank] if rank < sigma.size else 0.0, abs=1e-12)
    assert cert.equilibrium_residual <= 1e-12


# ----------------------------------------------------------------------------- margins


def outward_mode(frame: Frame) -> np.ndarray:
    """The paper's Fig. 3b mode: u_S = x_S at the specified corners, u_U = −x_U (exact)."""
    u = np.array(frame.positions, float)
    u[4:] *= -1
    return u


def designed_flex(frame: Frame) -> np.ndarray:
    """The single nontrivial zero mode of a design, from scratch (N × d)."""
    flexes, _ = reference_bases(frame.positions, frame.edges)
    assert flexes.shape[1] == 1
    return flexes[:, 0].reshape(frame.n_nodes, frame.dim)


def check_margin(frame: Frame, modes, solver="clarabel"):
    got = certify(frame, modes, solver=solver).rigidity_margin
    x, e, nb = frame.positions, frame.edges, frame.n_edges
    assert got.undesigned_zero_modes == 0 and got.designed_modes == len(modes)
    assert got.uniform == pytest.approx(reference_margin(x, e, modes, np.ones(nb)), rel=1e-8)
    assert got.uniform > 0
    k = got.stiffness
    assert np.all(k >= 0) and k.sum() == pytest.approx(nb)
    # The allocation attains the reported optimum (from scratch), which is never below the
    # uniform margin nor below any random allocation, and the bracket is tight.
    assert reference_margin(x, e, modes, k) == pytest.approx(got.optimal, rel=1e-7)
    assert got.optimal >= got.uniform * (1 - 1e-6) and got.gain >= 1 - 1e-6
    rng = np.random.default_rng(1)
    for trial in rng.dirichlet(np.ones(nb), size=100) * nb:
        assert reference_margin(x, e, modes, trial) <= got.optimal_upper_bound + 1e-9
    assert got.optimal_upper_bound - got.optimal <= 1e-4 * got.optimal_upper_bound
    return got


def test_paper_outward_module_has_a_positive_margin():
    frame = outward_square()
    got = check_margin(frame, [outward_mode(frame)])
    assert got.complement_dim == 2 * 6 - 3 - 1


@pytest.mark.parametrize("k, d, n_unspecified, seed", [(3, 2, 2, 0), (4, 3, 5, 0)])
def test_bipartite_designs_have_positive_margin(k, d, n_unspecified, seed):
    x_s, u_s = random_targets(k, d, seed)
    frame = bipartite_design(x_s, u_s, n_unspecified, seed=seed)
    check_margin(frame, [designed_flex(frame)])


@pytest.mark.parametrize("d, k, m", [(2, 3, 1), (2, 4, 2), (3, 4, 1)])
def test_designs_from_the_designer_have_positive_margin(d, k, m):
    from zeromode.solver.construction.design import design

    rng = np.random.default_rng(10 * d + k)
    result = design(rng.standard_normal((k, d)), rng.standard_normal((m, k, d)), seed=0)
    check_margin(result.frame, list(result.modes))


def test_four_bar_margin_with_scs():
    frame = four_bar()
    got = check_margin(frame, [designed_flex(frame)], solver="scs")
    assert got.sdp.solver == "scs"


def test_equilateral_triangle_optimum_is_uniform():
    """The symmetric group of the triangle permutes its bars; the optimum of a concave function
    over a symmetric convex set is attained at the symmetric point k = 1, so the gain is 1."""
    th = np.pi / 2 + 2 * np.pi * np.arange(3) / 3
    got = certify(Frame.build(np.column_stack([np.cos(th), np.sin(th)]), [[0, 1], [1, 2], [0, 2]]))
    margin = got.rigidity_margin
    assert margin.gain == pytest.approx(1.0, abs=1e-6)
    assert margin.optimal == pytest.approx(margin.uniform, rel=1e-6)


def test_undesigned_zero_mode_makes_every_margin_zero():
    got = certify(four_bar()).rigidity_margin
    assert (got.undesigned_zero_modes, got.uniform, got.optimal, got.sdp) == (1, 0.0, 0.0, None)


def test_invalid_designed_modes_are_named():
    frame = four_bar()
    with pytest.raises(InvalidInput, match=r"modes\[0\] is not a zero mode") as info:
        certify(frame, [np.random.default_rng(0).standard_normal((4, 2))])
    assert info.value.code == "invalid_modes"
    translation = np.tile([1.0, 0.0], (4, 1))
    with pytest.raises(InvalidInput, match=r"modes\[1\] is a combination"):
        certify(frame, [designed_flex(frame), translation])
    with pytest.raises(InvalidInput, match=r"modes\[0\] must be 4×2"):
        certify(frame, [np.zeros((3, 2))])


def triangulated_strip(n: int):
    """A rigid triangulated strip of n nodes (no symmetry): p = 2n − 3 motions to isolate."""
    x = [[i // 2, i % 2 + 0.1 * (i // 2) ** 1.5 / n] for i in range(n)]
    e = [[i, i + 1] for i in range(n - 1)] + [[i, i + 2] for i in range(n - 2)]
    return x, e


def test_large_allocation_goes_to_the_interior_point_route_with_a_verified_bracket():
    x, e = triangulated_strip(SDP_MAX_DIM // 2 + 4)  # p = 2N − 3 > SDP_MAX_DIM
    got = certify(Frame.build(x, e)).rigidity_margin
    assert got.complement_dim > SDP_MAX_DIM and got.sdp.solver == "interior_point"
    k = got.stiffness
    assert np.all(k >= 0) and k.sum() == pytest.approx(len(e))
    # The lower bound is attained: λ_min at the returned allocation, from scratch.
    attained = reference_margin(x, e, [], k)
    assert got.optimal <= attained * (1 + 1e-9)
    assert got.optimal == pytest.approx(attained, rel=1e-6)
    # The upper bound is an upper bound: no allocation does better, the uniform one included.
    assert got.uniform == pytest.approx(reference_margin(x, e, [], np.ones(len(e))), rel=1e-8)
    for trial in np.random.default_rng(2).dirichlet(np.ones(len(e)), size=100) * len(e):
        assert reference_margin(x, e, [], trial) <= got.optimal_upper_bound
    assert got.uniform <= got.optimal <= got.optimal_upper_bound
    if got.sdp.status == "optimal":
        assert got.optimal_upper_bound - got.optimal <= 1e-3 * got.optimal_upper_bound


def test_interior_point_route_and_the_sdp_bracket_the_same_optimum():
    """Below SDP_MAX_DIM both routes apply: each verified bracket must contain the other's."""
    frame = outward_square()
    xn = normalised(frame.positions)
    c = compatibility_matrix(xn, frame.edges)
    fixed = span(np.column_stack([rigid_generators(xn), outward_mode(frame).ravel()]))
    p = kernel(fixed.T)
    sdp = solve_lmi(stiffness_program(c @ p))
    uniform = float(np.linalg.eigvalsh(p.T @ c.T @ c @ p)[0])
    large = optimal_stiffness(sp.csr_matrix(c), fixed, uniform)
    assert large.status == "optimal"
    assert large.lower <= sdp.upper * (1 + 1e-9) and sdp.lower <= large.upper * (1 + 1e-9)
    assert large.lower == pytest.approx(sdp.lower, rel=2e-3)
    k = large.stiffness
    assert float(np.linalg.eigvalsh(p.T @ c.T @ np.diag(k) @ c @ p)[0]) >= large.lower


def test_sizes_beyond_the_limits_are_refused_with_the_limit_named():
    x, e = triangulated_strip((OPTIMAL_MAX_DIM + 3) // 2 + 2)  # p > OPTIMAL_MAX_DIM
    frame = Frame.build(x, e)
    with pytest.raises(DomainError, match=str(OPTIMAL_MAX_DIM)) as info:
        certify(frame)
    assert info.value.code == "too_expensive" and "stiffness = false" in info.value.message
    # Without the allocation the uniform margin is computed (sparse route), from scratch equal.
    got = certify(frame, stiffness=False).rigidity_margin
    assert got.optimal is None and got.complement_dim == 2 * frame.n_nodes - 3
    assert got.uniform == pytest.approx(reference_margin(x, e, [], np.ones(len(e))), rel=1e-6)
    huge = Frame.build(np.column_stack([np.arange(MAX_DOF), np.zeros(MAX_DOF)]), [[0, 1]])
    with pytest.raises(DomainError, match=str(MAX_DOF)) as info:
        certify(huge, stiffness=False)
    assert info.value.code == "too_expensive"


@pytest.mark.parametrize("name", GENERAL_CASE)
def test_prestress_without_a_stress_basis_matches_the_full_basis(name):
    """A frame too large to keep its bases is certified through the projections onto N(Cᵀ)
    (bordered solves); the reduced SDP must give the full-basis answer and a stress checked
    from scratch."""
    from zeromode.solver.analysis.rigidity import analyze

    (x, e), expected = GENERAL_CASE[name]
    frame = Frame.build(x, e)
    full = certify(frame, stiffness=False).prestress
    reduced = certify(frame, stiffness=False, analysis=analyze(frame, bases=False)).prestress
    assert reduced.prestress_stable is expected is full.prestress_stable
    assert reduced.margin == pytest.approx(full.margin, rel=1e-6, abs=1e-8)
    assert brute_force_prestress_margin(x, e) <= reduced.margin_upper_bound + 1e-9
    if expected:
        c = compatibility_matrix(normalised(x), e)
        assert np.linalg.norm(c.T @ reduced.stress) <= 1e-8 * np.linalg.norm(c)
        flexes, _ = reference_bases(x, e)
        energy = stress_energy(flexes, reduced.stress, e, np.shape(x)[1])
        assert np.linalg.eigvalsh(energy)[0] == pytest.approx(reduced.margin, rel=1e-6)


def test_solver_failure_is_a_certificate_failed_error():
    """One iteration decides nothing: t* ≈ 0 (prestress) stays undecided. A lucky iterate
    would be accepted — its bounds are verified."""
    frame = Frame.build(*connelly_second_order_rigid())
    with pytest.raises(DomainError) as info:
        certify(frame, [], stiffness=False, max_iters=1)
    assert info.value.code == "certificate_failed"
    assert "clarabel: " in info.value.message and "scs: " in info.value.message


def test_conic_failures_on_the_allocation_fall_back_to_the_interior_point_route():
    """One conic iteration leaves the optimal allocation's bracket open for both solvers; the
    interior-point route (stiffness.py) then answers, its bracket checked from scratch, the
    failed attempts on record."""
    frame = outward_square()
    got = certify(frame, [outward_mode(frame)], stiffness=True, max_iters=1).rigidity_margin
    assert [a.solver for a in got.sdp.attempts] == ["clarabel", "scs", "interior_point"]
    assert got.sdp.solver == "interior_point" and got.sdp.status == "optimal"
    # the conic route's own answer, a bracket of 1e-4, agrees
    assert got.optimal == pytest.approx(check_margin(frame, [outward_mode(frame)]).optimal, rel=1e-3)
    x, e = frame.positions, frame.edges
    assert reference_margin(x, e, [outward_mode(frame)], got.stiffness) == pytest.approx(got.optimal, rel=1e-7)


def test_an_allocation_the_conic_solvers_cannot_verify_is_certified_by_the_interior_point_route():
    """The 2 × 2 finite-strain sheet (trammel modules, 25 nodes, a 46 × 46 LMI): Clarabel's and
    SCS's answers do not verify; the interior-point route of stiffness.py answers with a verified
    bracket, checked from scratch like every other margin, the failed attempts on record."""
    from zeromode.solver.applications.finite_strain import finite_strain_sheet

    lat = finite_strain_sheet(2, 2, poisson=-0.5, strain_range=(-0.1, 0.1), tolerance=0.02).lattice
    got = check_margin(lat.frame, [lat.mode])
    attempts = got.sdp.attempts
    assert attempts[-1].status in ("optimal", "optimal_inaccurate") and got.sdp.solver == attempts[-1].solver
    if any(a.status != "optimal" for a in attempts[:-1]):
        assert got.sdp.solver == "interior_point" and [a.solver for a in attempts] == ["clarabel", "scs", "interior_point"]
