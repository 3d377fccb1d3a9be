"""The solution space of one unspecified node joined to k specified nodes (paper, Eqs. 4–6 and
Supplementary Methods, "Rewriting the Vector Form into a Linear Solution with Quadratic
Constraint").

Every expected value is rebuilt here from the paper's definitions — Ã = [u_Sᵀ, x_Sᵀ, −1],
b_i = x_Si·u_Si, the block formula for Q, the quadratic along a line in α-space — and the
code under test only supplies the object being checked.  Geometric facts used as oracles:

* Thales: for an outward (dilation) motion u_i = x_i − o, the bar (x_i − x_U)·(u_i − u_U) = 0
  says x_i lies on the sphere with diameter [x_U, u_U + o]; for specified nodes on a circle or
  sphere of centre o and radius R this forces |x_U − o| = R and u_U = o − x_U (antipode − o).
* Row redundancy (paper: v4 = v2 + v3 − v1) is built from affine combinations of rows whose
  b-entry stays consistent, so the nullity grows by one per redundant row.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from oracles.frames import CUBE_CORNERS, SQUARE_CORNERS, random_rotation
from oracles.rigidity import REFERENCE_RTOL, normalised
from oracles.solution_space import (
    a_tilde,
    bar_residuals,
    paper_quadric,
    points_on_random_lines,
    roots_on_line,
)
from oracles.solution_space import (
    nullity as expected_nullity,
)

from zeromode.solver.construction.solution_space import solution_space
from zeromode.solver.errors import DomainError

# Derandomised: a property failure reproduces on every machine and every run.
PROPERTY = settings(max_examples=50, deadline=None, derandomize=True)
KIND = {1: "points", 2: "conic", 3: "quadric_surface"}

SQUARE = np.array(SQUARE_CORNERS)
CUBE = np.array(CUBE_CORNERS)


def check_samples(x, u, space, positions, motions, rtol: float = 1e-9) -> None:
    """Every sample keeps all bars, and there are samples whenever real points exist (found
    here along random lines of α-space with the paper's quadric)."""
    for x_u, u_u in zip(positions, motions, strict=True):
        assert np.all(bar_residuals(x, u, x_u, u_u) <= rtol)
    real = points_on_random_lines(space.w_tilde, x.shape[1], np.random.default_rng(0))
    assert len(positions) or not len(real)


def generic_target(d: int, k: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return rng.standard_normal((k, d)), rng.standard_normal((k, d))


def redundant_target(d: int, r: int, extra: int, seed: int, consistent: bool = True):
    """r generic specified nodes plus ``extra`` nodes whose rows of Ã are affine combinations
    Σc_j·row_j (Σc_j = 1, as the paper's v4 = v2 + v3 − v1) of the first r rows.

    Along c = e_1 + tδ (Σδ = 0) the new node is (x_1 + tΔx, u_1 + tΔu) and
    b_new − Σc_j b_j = t·[(x_1·Δu + Δx·u_1 − Σδ_j b_j) + t·Δx·Δu]; its nonzero root t* keeps b in
    R(Ã) (``consistent``), t* + 1 takes it out.
    """
    rng = np.random.default_rng(seed)
    x, u = rng.standard_normal((r, d)), rng.standard_normal((r, d))
    b = np.sum(x * u, axis=1)
    new_x, new_u = [], []
    while len(new_x) < extra:
        delta = rng.standard_normal(r)
        delta -= delta.mean()
        dx, du = delta @ x, delta @ u
        quad = dx @ du
        lin = x[0] @ du + dx @ u[0] - delta @ b
        if abs(quad) < 0.2:
            continue
        t = -lin / quad + (0.0 if consistent else 1.0)
        if not 0.2 < abs(t) < 5:
            continue
        new_x.append(x[0] + t * dx)
        new_u.append(u[0] + t * du)
    return np.vstack([x, new_x]), np.vstack([u, new_u])


# --------------------------------------------------------------------------- linear structure
@PROPERTY
@given(d=st.sampled_from([2, 3]), data=st.data(), seed=st.integers(0, 2**32 - 1))
def test_basis_solves_the_linear_system(d, data, seed):
    """Ã W = 0, Ã ṽ* = b, ṽ* = Ã⁺b, WᵀW = I, shapes (2d+1)×(m+1) and (m+1)×(m+1), Q = Qᵀ."""
    k = data.draw(st.integers(1, 2 * d), label="k")
    x, u = generic_target(d, k, seed)
    space = solution_space(x, u, d)
    a, b = a_tilde(x, u)
    m = space.nullity
    assert m == expected_nullity(x, u) == 2 * d + 1 - k
    assert space.w_tilde.shape == (2 * d + 1, m + 1)
    assert space.quadric.shape == (m + 1, m + 1)
    w, v_star = space.w_tilde[:, :m], space.w_tilde[:, m]
    a_norm = np.linalg.norm(a, 2)
    assert np.linalg.norm(a @ w) <= 1e-12 * a_norm
    assert np.linalg.norm(a @ v_star - b) <= 1e-12 * (
        a_norm * np.linalg.norm(v_star) + np.linalg.norm(b)
    )
    pinv = np.linalg.pinv(a, rcond=REFERENCE_RTOL) @ b
    assert np.linalg.norm(v_star - pinv) <= 1e-9 * np.linalg.norm(pinv)
    assert np.allclose(w.T @ w, np.eye(m), atol=1e-12)
    assert np.allclose(
        space.quadric, space.quadric.T, rtol=0, atol=1e-14 * np.abs(space.quadric).max()
    )
    assert space.dimension == m - 1


@PROPERTY
@given(d=st.sampled_from([2, 3]), data=st.data(), seed=st.integers(0, 2**32 - 1))
def test_quadric_matches_the_supplementary_block_formula(d, data, seed):
    k = data.draw(st.integers(1, 2 * d), label="k")
    x, u = generic_target(d, k, seed)
    space = solution_space(x, u, d)
    expected = paper_quadric(space.w_tilde, d)
    assert np.allclose(space.quadric, expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())


@PROPERTY
@given(d=st.sampled_from([2, 3]), data=st.data(), seed=st.integers(0, 2**32 - 1))
def test_points_of_the_quadric_close_the_coupling(d, data, seed):
    """For α̃ on α̃ᵀQα̃ = 0 (found here along random lines), ṽ = W̃α̃ has c = x_U·u_U and keeps
    all k bars: Q really encodes the dropped constraint."""
    k = data.draw(st.integers(1, 2 * d), label="k")  # m ≥ 1
    x, u = generic_target(d, k, seed)
    space = solution_space(x, u, d)
    m = space.nullity
    rng = np.random.default_rng(seed)
    found = 0
    for _ in range(6):
        a0 = np.zeros(m) if m == 1 else rng.standard_normal(m)
        delta = rng.standard_normal(m)
        for t in roots_on_line(space.quadric, a0, delta):
            v = space.w_tilde @ np.append(a0 + t * delta, 1.0)
            x_u, u_u, c = v[:d], v[d : 2 * d], v[2 * d]
            assert abs(c - x_u @ u_u) <= 1e-9 * (
                abs(c) + np.linalg.norm(x_u) * np.linalg.norm(u_u) + 1
            )
            assert np.all(bar_residuals(x, u, x_u, u_u) <= 1e-9)
            found += 1
    # The specified nodes themselves solve the k ≤ d + 1 problem, so a real point must exist.
    if k <= d + 1:
        assert found > 0


@PROPERTY
@given(d=st.sampled_from([2, 3]), data=st.data(), seed=st.integers(0, 2**32 - 1))
def test_every_sample_keeps_all_bars(d, data, seed):
    k = data.draw(st.integers(1, 2 * d), label="k")
    x, u = generic_target(d, k, seed)
    space = solution_space(x, u, d)
    positions, motions = space.sample(12, np.random.default_rng(seed))
    assert positions.shape == motions.shape and positions.shape[1] == d
    assert len(positions) <= 12
    if k <= d + 1:  # nonempty: x_U = x_Si solves it (u_U then follows linearly)
        assert len(positions) > 0
    check_samples(x, u, space, positions, motions)


@pytest.mark.parametrize("d", [2, 3])
def test_isolated_points_match_the_roots_of_the_quadratic(d):
    """m = 1 (k = 2d generic): the solution set is the real roots of one quadratic in α_1."""
    for seed in range(20):
        x, u = generic_target(d, 2 * d, seed)
        space = solution_space(x, u, d)
        assert (space.nullity, space.kind, space.dimension) == (1, "points", 0)
        roots = roots_on_line(space.quadric, np.zeros(1), np.ones(1))
        expected = np.array([space.w_tilde @ np.array([t, 1.0]) for t in roots]).reshape(
            -1, 2 * d + 1
        )
        positions, motions = space.sample(4, np.random.default_rng(seed))
        assert len(positions) == len(expected)
        for v in expected:
            hit = np.linalg.norm(positions - v[:d], axis=1) + np.linalg.norm(
                motions - v[d : 2 * d], axis=1
            )
            assert hit.min() <= 1e-8 * (1 + np.linalg.norm(v))


# --------------------------------------------------------------------------- kinds and nullity
@pytest.mark.parametrize(
    ("d", "k", "nullity", "kind"),
    [
        (2, 4, 1, "points"),
        (2, 3, 2, "conic"),
        (2, 2, 3, "quadric_surface"),
        (2, 1, 4, "quadric_hypersurface"),
        (3, 6, 1, "points"),
        (3, 5, 2, "conic"),
        (3, 4, 3, "quadric_surface"),
        (3, 3, 4, "quadric_hypersurface"),
        (3, 2, 5, "quadric_hypersurface"),
    ],
)
def test_kind_follows_the_nullity(d, k, nullity, kind):
    for seed in range(5):
        x, u = generic_target(d, k, seed)
        space = solution_space(x, u, d)
        assert space.nullity == expected_nullity(x, u) == nullity
        assert space.kind == kind
        assert space.dimension == nullity - 1


@pytest.mark.parametrize("d", [2, 3])
def test_no_real_point_when_the_linear_solution_is_unique(d):
    """m = 0 (k = 2d + 1 generic): the one linear solution misses the coupling → no_solution,
    not a "quadric_hypersurface" of dimension −1."""
    x, u = generic_target(d, 2 * d + 1, 0)
    a, b = a_tilde(x, u)
    v = np.linalg.solve(a, b)  # square and invertible: the only candidate ṽ
    assert abs(v[2 * d] - v[:d] @ v[d : 2 * d]) > 1e-3  # ... and it misses the coupling
    with pytest.raises(DomainError) as err:
        solution_space(x, u, d)
    assert err.value.code == "no_solution"


def test_unique_linear_solution_on_the_coupling_is_the_one_sample():
    """k = 2d + 1 specified nodes that all admit one chosen node (x*, u*): the sample is it."""
    rng = np.random.default_rng(7)
    d = 2
    x_star, u_star = rng.standard_normal(d), rng.standard_normal(d)
    x = rng.standard_normal((2 * d + 1, d))
    u = rng.standard_normal((2 * d + 1, d))
    dx = x - x_star
    u -= (np.sum(dx * (u - u_star), axis=1) / np.sum(dx * dx, axis=1))[:, None] * dx
    space = solution_space(x, u, d)
    assert space.nullity == expected_nullity(x, u) == 0
    assert (space.kind, space.dimension) == ("points", 0)
    positions, motions = space.sample(4, np.random.default_rng(0))
    assert len(positions) == 1
    assert np.allclose(positions[0], x_star, atol=1e-9) and np.allclose(
        motions[0], u_star, atol=1e-9
    )


# --------------------------------------------------------------------------- the paper's cases
def test_paper_redundant_rows_square():
    """Paper: rows v1 = [1,1,1,1,−1], v2 = [−1,1,−1,1,−1], v3 = [1,−1,1,−1,−1], v4 = v2 + v3 − v1.
    Reading [u_Sᵀ, x_Sᵀ, −1] off them gives four nodes on a square moving outward (u = x)."""
    rows = np.array([[1, 1, 1, 1, -1], [-1, 1, -1, 1, -1], [1, -1, 1, -1, -1]], dtype=float)
    rows = np.vstack([rows, rows[1] + rows[2] - rows[0]])
    u, x = rows[:, :2], rows[:, 2:4]
    assert np.array_equal(rows[:, 4], -np.ones(4))
    space = solution_space(x, u, 2)
    # Four rows but rank 3: m = 2 (a conic), not the generic m = 1 (points).
    assert space.nullity == expected_nullity(x, u) == 2 > 2 * 2 + 1 - 4
    assert space.kind == "conic"
    positions, motions = space.sample(24, np.random.default_rng(1))
    assert len(positions) >= 12
    # Thales: the circle through the square, u_U the antipode of x_U.
    assert np.allclose(np.linalg.norm(positions, axis=1), np.sqrt(2), rtol=1e-9)
    assert np.allclose(motions, -positions, atol=1e-9)


def test_paper_redundant_rows_cube():
    """Paper, Fig. 3d: eight cube corners moving outward, rank Ã = 4, m = 3, a sphere."""
    space = solution_space(CUBE, CUBE, 3)
    assert space.nullity == expected_nullity(CUBE, CUBE) == 3
    assert space.kind == "quadric_surface"
    positions, motions = space.sample(40, np.random.default_rng(2))
    assert len(positions) >= 20
    assert np.allclose(np.linalg.norm(positions, axis=1), np.sqrt(3), rtol=1e-9)
    assert np.allclose(motions, -positions, atol=1e-9)
    # A surface, not a curve: the samples span space.
    assert np.linalg.matrix_rank(positions - positions.mean(0), tol=1e-6) == 3


def test_three_nodes_in_the_plane_give_their_circumcircle():
    """2D, k = 3, dilation about o: the conic is the circumcircle (Thales), through the nodes."""
    rng = np.random.default_rng(3)
    centre, radius = rng.standard_normal(2), 1.7
    angles = rng.uniform(0, 2 * np.pi, 3)
    x = centre + radius * np.column_stack([np.cos(angles), np.sin(angles)])
    o = np.array([0.3, -0.2])
    space = solution_space(x, x - o, 2)
    assert (space.nullity, space.kind) == (2, "conic")
    positions, motions = space.sample(16, np.random.default_rng(0))
    assert len(positions) >= 8
    assert np.allclose(np.linalg.norm(positions - centre, axis=1), radius, rtol=1e-9)
    assert np.allclose(motions + o, 2 * centre - positions, atol=1e-9)


@PROPERTY
@given(d=st.sampled_from([2, 3]), data=st.data(), seed=st.integers(0, 2**32 - 1))
def test_redundant_rows_raise_the_nullity(d, data, seed):
    """Each consistent redundant row adds one to the nullity beyond the generic 2d + 1 − k."""
    r = data.draw(st.integers(2, 2 * d), label="independent rows")
    extra = data.draw(st.integers(1, 2), label="redundant rows")
    x, u = redundant_target(d, r, extra, seed)
    space = solution_space(x, u, d)
    k = r + extra
    assert space.nullity == expected_nullity(x, u) == 2 * d + 1 - r
    assert space.nullity > 2 * d + 1 - k  # larger than for k independent rows
    positions, motions = space.sample(8, np.random.default_rng(seed))
    check_samples(x, u, space, positions, motions)


# --------------------------------------------------------------------------- no solution
@pytest.mark.parametrize(("d", "k"), [(2, 6), (2, 7), (3, 8)])
def test_overdetermined_generic_target_has_no_solution(d, k):
    for seed in range(3):
        x, u = generic_target(d, k, seed)
        a, b = a_tilde(normalised(x), normalised(u))
        coef = np.linalg.lstsq(a, b, rcond=None)[0]
        assert np.linalg.norm(a @ coef - b) > 1e-3 * np.linalg.norm(b)  # b ∉ R(Ã), checked here
        with pytest.raises(DomainError) as err:
            solution_space(x, u, d)
        assert err.value.code == "no_solution"
        assert err.value.message


@pytest.mark.parametrize("d", [2, 3])
def test_inconsistent_redundant_row_has_no_solution(d):
    """A row of Ã that depends on the others while its b-entry does not: b ∉ R(Ã) with k ≤ 2d."""
    for seed in range(5):
        x, u = redundant_target(d, d + 1, 1, seed, consistent=False)
        assert expected_nullity(x, u) == 2 * d + 1 - (d + 1)  # rows dependent ...
        with pytest.raises(DomainError) as err:
            solution_space(x, u, d)
        assert err.value.code == "no_solution"


def test_non_concyclic_outward_motion_has_no_solution():
    """The paper's rows with v4 = 2v2 − v1 instead: Ã keeps rank 3, but the four nodes (moving
    outward, u = x) are not on one circle, so no Thales circle exists."""
    x = np.array([[1.0, 1.0], [-1.0, 1.0], [1.0, -1.0], [-3.0, 1.0]])
    assert expected_nullity(x, x) == 2
    with pytest.raises(DomainError) as err:
        solution_space(x, x, 2)
    assert err.value.code == "no_solution"


@pytest.mark.parametrize(
    ("positions", "motions", "dim"),
    [
        ([[0, 0], [1, 0], [0, 1]], [[0, 0], [1, 0]], 2),
        ([[0, 0], [1, 0], [0, 1]], [[0, 0, 0], [1, 0, 0], [0, 1, 0]], 2),
        ([[0, 0], [1, 0], [0, 1]], [[0, 0], [1, 0], [0, 1]], 3),
        ([[0, 0], [1, 0, 2], [0, 1]], [[0, 0], [1, 0], [0, 1]], 2),
        ([[0, np.nan], [1, 0], [0, 1]], [[0, 0], [1, 0], [0, 1]], 2),
        ([[0, 0], [1, 0], [0, 1]], [[0, 0], [np.inf, 0], [0, 1]], 2),
    ],
)
def test_malformed_input_is_rejected_with_a_code(positions, motions, dim):
    with pytest.raises(DomainError) as err:
        solution_space(positions, motions, dim)
    assert err.value.code in {"invalid_shape", "not_finite", "invalid_dim"}
    assert err.value.message


# --------------------------------------------------------------------------- invariance
@PROPERTY
@given(
    d=st.sampled_from([2, 3]),
    data=st.data(),
    seed=st.integers(0, 2**32 - 1),
    x_exp=st.floats(-3, 3),
    u_exp=st.floats(-3, 3),
    redundant=st.booleans(),
)
def test_nullity_and_kind_are_invariant(d, data, seed, x_exp, u_exp, redundant):
    """Translation and scaling by 1e-3 … 1e3 of the positions, and separately of the motions, and
    one rotation of both, keep every bar constraint (x_Si − x_U)·(u_Si − u_U) = 0 up to a factor,
    so they leave m and the kind unchanged.  (Separate rotations would not: they change b.)"""
    if redundant:
        x, u = redundant_target(d, data.draw(st.integers(2, 2 * d), label="r"), 1, seed)
    else:
        x, u = generic_target(d, data.draw(st.integers(1, 2 * d), label="k"), seed)
    reference = solution_space(x, u, d)
    rng = np.random.default_rng(seed)
    sx, su = 10.0**x_exp, 10.0**u_exp
    rotation = random_rotation(rng, d)
    x2 = sx * x @ rotation + 3 * sx * rng.standard_normal(d)
    u2 = su * u @ rotation + 3 * su * rng.standard_normal(d)
    moved = solution_space(x2, u2, d)
    assert (moved.nullity, moved.kind, moved.dimension) == (
        reference.nullity,
        reference.kind,
        reference.dimension,
    )
    assert moved.nullity == expected_nullity(x2, u2)
    positions, motions = moved.sample(6, np.random.default_rng(seed))
    check_samples(x2, u2, moved, positions, motions, rtol=1e-8)


@pytest.mark.parametrize("scale", [1e-3, 1e-1, 1e1, 1e3])
def test_paper_cases_are_scale_free(scale):
    for points, m in ((SQUARE, 2), (CUBE, 3)):
        for x, u in (
            (scale * points, points),
            (points, scale * points),
            (scale * points, scale * points),
        ):
            space = solution_space(x, u, points.shape[1])
            assert space.nullity == m
            positions, motions = space.sample(8, np.random.default_rng(0))
            assert len(positions) > 0
            check_samples(x, u, space, positions, motions)
