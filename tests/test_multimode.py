"""Multi-mode construction (paper, "Multi-Mode Construction", Eq. 8, and Supplementary "Defining
a Projection from Solution Coordinates to Spatial Coordinates").

Every check goes through a route that shares nothing with the code under test:
  * the position set of one motion, derived here from Eq. 1 alone: an unspecified node at p can
    keep all k bars (x_Si − p)·(u_Si − u_U) = 0 iff the k × d system (x_Si − p)ᵀ u_U =
    (x_Si − p)·u_Si has a solution, i.e. iff the augmented k × (d+1) matrix
    [x_Si − p | (x_Si − p)·u_Si] has rank ≤ d.  For k = d + 1 that is a determinant F(p) = 0,
    and subtracting the first row shows F is quadratic in p: a conic (2D) or quadric surface
    (3D) through every specified node (the first row vanishes at p = x_Si);
  * sympy's exact resultants and real-root isolation on integer conics;
  * PyRigi's numerical flexes and stresses, and a compatibility matrix C built from Eq. 3
    (oracles.designs.check_design).

Two facts follow from the derivation and are used below.  In 2D with k = 3 both conics of two
motions pass through the three specified nodes, so their fourth intersection is real whenever it
is finite (complex points come in pairs): it is found here from a cubic with two known roots.
And the tangent of such a conic at x_S1 depends only on the ratio of the strain rates
(x_Si − x_S1)·(u_Si − u_S1), i = 2, 3, of the two bars at node 1; two motions with the same
ratio give conics tangent at x_S1, whose four intersections are then the specified nodes alone.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from oracles.designs import check_design
from oracles.frames import FIG4_TETRAHEDRON, FIG4_TRIANGLE

from zeromode.solver.construction.design import design
from zeromode.solver.construction.multimode import (
    common_positions,
    conic_intersections,
    spatial_quadric,
)
from zeromode.solver.construction.solution_space import solution_space
from zeromode.solver.errors import DomainError


# --------------------------------------------------------------------------- independent oracles
def augmented(xs: np.ndarray, us: np.ndarray, p: np.ndarray) -> np.ndarray:
    """[x_Si − p | (x_Si − p)·u_Si] (k × (d+1)) on normalised positions and motions: its rank is
    ≤ d exactly when an unspecified node at p can carry the motion on all k bars."""
    radius = np.sqrt(np.mean(np.sum((xs - xs.mean(axis=0)) ** 2, axis=1)))
    v = us - us.mean(axis=0)
    speed = np.sqrt(np.mean(np.sum(v**2, axis=1)))
    diff = (xs - p) / radius
    return np.column_stack([diff, np.einsum("ij,ij->i", diff, v / speed)])


def off_position_set(xs, us, p) -> float:
    """σ_{d+1} / σ_1 of the augmented matrix: 0 on the position set of motion us."""
    s = np.linalg.svd(augmented(xs, us, np.asarray(p, dtype=float)), compute_uv=False)
    return float(s[xs.shape[1]] / s[0])


def determinant_conic(xs: np.ndarray, us: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """2D, k = 3: F(p) = det[x_Si − p | (x_Si − p)·u_Si] = pᵀA p + 2bᵀp + c.  F is exactly
    quadratic (see the module docstring), so six samples determine it: returns (A, b, c)."""
    rng = np.random.default_rng(0)
    pts = xs.mean(axis=0) + rng.standard_normal((6, 2))
    monomials = np.column_stack(
        [pts[:, 0] ** 2, pts[:, 0] * pts[:, 1], pts[:, 1] ** 2, pts[:, 0], pts[:, 1], np.ones(6)]
    )
    values = [
        np.linalg.det(np.column_stack([xs - p, np.einsum("ij,ij->i", xs - p, us)])) for p in pts
    ]
    c = np.linalg.solve(monomials, values)
    return np.array([[c[0], c[1] / 2], [c[1] / 2, c[2]]]), c[3:5] / 2, float(c[5])


def fourth_intersection(xs: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> np.ndarray:
    """The fourth common point of the two conics of 2D k = 3 targets (the first three are x_S).

    On the ray p = x_S1 + s(1, t) a conic through x_S1 has F = s²·Q(t) + s·L(t) with
    Q(t) = vᵀAv, L(t) = 2vᵀ(A x_S1 + b), so its second point is s = −L/Q.  Both conics share it
    iff L₁Q₂ − L₂Q₁ = 0, a cubic in t whose roots are the directions to x_S2, x_S3 and the
    fourth point; Vieta's sum gives the third root.
    """
    p1 = xs[0]
    (a1, b1, _), (a2, b2, _) = determinant_conic(xs, u1), determinant_conic(xs, u2)

    def quad(a):  # Q(t), coefficients high → low
        return np.array([a[1, 1], 2 * a[0, 1], a[0, 0]])

    def lin(a, b):  # L(t)
        g = a @ p1 + b
        return np.array([2 * g[1], 2 * g[0]])

    cubic = np.polysub(np.polymul(lin(a1, b1), quad(a2)), np.polymul(lin(a2, b2), quad(a1)))
    known = [(xs[i, 1] - p1[1]) / (xs[i, 0] - p1[0]) for i in (1, 2)]
    t4 = -cubic[1] / cubic[0] - sum(known)
    s4 = -np.polyval(lin(a1, b1), t4) / np.polyval(quad(a1), t4)
    return p1 + s4 * np.array([1.0, t4])


def random_target(d: int, k: int, seed: int, n_modes: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng([d, k, seed, 4])
    return rng.standard_normal((k, d)), rng.standard_normal((n_modes, k, d))


# --------------------------------------------------------------------------- conic intersections
def conic(a: np.ndarray, b: np.ndarray, c: float) -> np.ndarray:
    """3 × 3 Q with [x y 1] Q [x y 1]ᵀ = xᵀa x + 2bᵀx + c."""
    q = np.zeros((3, 3))
    q[:2, :2], q[:2, 2], q[2, :2], q[2, 2] = a, b, b, c
    return q


def on_conic(q: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Relative residual |[p;1]ᵀQ[p;1]| / (‖Q‖(1 + |p|²)) of each point."""
    ph = np.hstack([pts, np.ones((len(pts), 1))])
    return np.abs(np.einsum("ni,ij,nj->n", ph, q, ph)) / (np.linalg.norm(q) * np.sum(ph**2, axis=1))


def same_points(found: np.ndarray, expected: np.ndarray, tol: float = 1e-9) -> bool:
    """Equal as sets (each expected point matched once), to tol relative to max(1, |p|)."""
    if len(found) != len(expected):
        return False
    left = list(range(len(found)))
    for p in expected:
        dist = [np.linalg.norm(found[i] - p) for i in left]
        j = int(np.argmin(dist))
        if dist[j] > tol * max(1.0, np.linalg.norm(p)):
            return False
        left.pop(j)
    return True


KNOWN_PAIRS = {
    # x² + y² = 4 and (x − 2)² + y² = 4 meet at (1, ±√3).
    "two circles": (
        conic(np.eye(2), np.zeros(2), -4.0),
        conic(np.eye(2), np.array([-2.0, 0.0]), 0.0),
        np.array([[1.0, np.sqrt(3)], [1.0, -np.sqrt(3)]]),
    ),
    # x²/4 + y² = 1 and x² + y²/4 = 1 meet at (±2/√5, ±2/√5).
    "two ellipses": (
        conic(np.diag([0.25, 1.0]), np.zeros(2), -1.0),
        conic(np.diag([1.0, 0.25]), np.zeros(2), -1.0),
        2 / np.sqrt(5) * np.array([[1, 1], [1, -1], [-1, 1], [-1, -1]], dtype=float),
    ),
    # Hyperbola xy = 1 and circle x² + y² = 4: x² = 2 ± √3, y = 1/x.
    "hyperbola and circle": (
        conic(np.array([[0, 0.5], [0.5, 0]]), np.zeros(2), -1.0),
        conic(np.eye(2), np.zeros(2), -4.0),
        np.array(
            [
                [s * np.sqrt(2 + r * np.sqrt(3)), s / np.sqrt(2 + r * np.sqrt(3))]
                for s in (1, -1)
                for r in (1, -1)
            ]
        ),
    ),
    # Disjoint: unit circle and the circle of radius 1 about (5, 0); nested ellipses.
    "disjoint circles": (
        conic(np.eye(2), np.zeros(2), -1.0),
        conic(np.eye(2), np.array([-5.0, 0.0]), 24.0),
        np.zeros((0, 2)),
    ),
    "nested ellipses": (
        conic(np.diag([1.0, 4.0]), np.zeros(2), -1.0),
        conic(np.diag([1.0, 1.0]), np.zeros(2), -9.0),
        np.zeros((0, 2)),
    ),
}


def moved(q: np.ndarray, shift, scale: float) -> np.ndarray:
    """The conic Q carried by p ↦ shift + scale·p."""
    m = np.array([[1 / scale, 0, -shift[0] / scale], [0, 1 / scale, -shift[1] / scale], [0, 0, 1]])
    return m.T @ q @ m


@pytest.mark.parametrize("name", sorted(KNOWN_PAIRS))
def test_conic_intersections_known_pairs(name):
    q1, q2, expected = KNOWN_PAIRS[name]
    for seed in range(5):  # the seeded rotation must not change the answer
        found = conic_intersections(q1, q2, np.random.default_rng(seed))
        assert same_points(found, expected), (name, seed, found)
        # Moved copies of the pair: the points move with them.
        for shift, scale in [((3.0, -7.0), 1.0), ((0.0, 0.0), 1e-3), ((0.0, 0.0), 1e3)]:
            found = conic_intersections(
                moved(q1, shift, scale), moved(q2, shift, scale), np.random.default_rng(seed)
            )
            assert same_points(found / scale, (np.asarray(shift) + scale * expected) / scale)


def test_conic_intersections_small_conics_far_from_the_origin():
    # Two ellipses of size 1e-3 at (3, −7) lost 2 of their 4 points before conic_intersections
    # centred and scaled them; a hyperbola and a circle were off by 2e-5 of their size.
    shift, scale = (3.0, -7.0), 1e-3
    for name, (q1, q2, expected) in KNOWN_PAIRS.items():
        found = conic_intersections(
            moved(q1, shift, scale), moved(q2, shift, scale), np.random.default_rng(0)
        )
        assert same_points(found / scale, (np.asarray(shift) + scale * expected) / scale), name



def line_through(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The line l with l·[x y 1] = 0 through p and q (unit normal)."""
    line = np.cross([*p, 1.0], [*q, 1.0])
    return line / np.linalg.norm(line[:2])


def line_pair(l1: np.ndarray, l2: np.ndarray) -> np.ndarray:
    """The degenerate conic (l1·x̃)(l2·x̃) = 0 as a symmetric 3 × 3 matrix."""
    return (np.outer(l1, l2) + np.outer(l2, l1)) / 2


def twice_area(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
    return float((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))


# The pencil of conics through four points p₁..p₄, no three on a line, is spanned by two line
# pairs, p₁p₂ ∪ p₃p₄ and p₁p₃ ∪ p₂p₄; two distinct members meet in exactly those four points
# (Bézout: 2·2 = 4, each met once). A conic of size s at distance R from the origin is fixed by
# its matrix entries only to ~ε(1 + R/s)² of s (its constant term is ~(R/s)² times its scale):
# the points are asked to that bound times CONDITIONING (1 572 random cases: the error was at
# most 116 times the bound, median 1.7), plus FLOOR; the translation is drawn up to 1e6 and at
# most RATIO times the size, where the bound is 2e-8 of the size (a conic of size 1e-6 at 1e6
# would be held by its matrices to no digit at all).
RATIO = 1e4
CONDITIONING = 1e3
FLOOR = 1e-9
pencil_points = st.lists(
    st.tuples(st.floats(-1, 1), st.floats(-1, 1)), min_size=4, max_size=4
).map(lambda pts: np.array(pts, dtype=float))


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(
    points=pencil_points,
    members=st.tuples(st.floats(0, np.pi), st.floats(0, np.pi)),
    log_scale=st.floats(-6, 6),
    direction=st.floats(0, 2 * np.pi),
    reach=st.floats(0, 1),
    seed=st.integers(0, 2**32 - 1),
)
def test_conic_intersections_recover_known_points_anywhere(points, members, log_scale, direction, reach, seed):
    p1, p2, p3, p4 = points
    assume(min(abs(twice_area(*points[list(t)])) for t in [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)]) >= 0.1)
    assume(abs(np.sin(members[0] - members[1])) >= 0.2)  # two distinct members of the pencil
    spanning = (line_pair(line_through(p1, p2), line_through(p3, p4)),
                line_pair(line_through(p1, p3), line_through(p2, p4)))
    q1, q2 = (np.cos(t) * spanning[0] + np.sin(t) * spanning[1] for t in members)
    scale = 10.0**log_scale
    distance = reach * min(1e6, RATIO * scale)
    shift = distance * np.array([np.cos(direction), np.sin(direction)])

    found = conic_intersections(moved(q1, shift, scale), moved(q2, shift, scale), np.random.default_rng(seed))

    back = (found - shift) / scale  # in the pencil's own coordinates, where the points are ~1
    tol = FLOOR + CONDITIONING * np.finfo(float).eps * (1 + distance / scale) ** 2
    assert same_points(back, points, tol=tol), (back, points, tol)
    # The definition: each point found is on both conics (relative residual).
    assert np.all(on_conic(q1, back) <= tol) and np.all(on_conic(q2, back) <= tol), (back, tol)


def test_conic_intersections_with_a_common_point_at_infinity():
    parabola = conic(np.diag([1.0, 0.0]), np.array([0.0, -0.5]), -1.0)  # y = x² − 1
    hyperbola = conic(np.array([[0, 0.5], [0.5, 0]]), np.zeros(2), -1.0)  # xy = 1
    plastic = 1.324717957244746  # the real root of x³ − x − 1 = x(x² − 1) − 1
    shifted = conic(np.diag([1.0, 0.0]), np.array([0.5, -0.5]), -1.0)  # y = x² + x − 1
    upright = conic(np.diag([1.0, 0.0]), np.array([0.0, -0.5]), 0.0)  # y = x²
    for seed in range(6):
        rng = np.random.default_rng(seed)
        found = conic_intersections(parabola, hyperbola, rng)
        assert same_points(found, np.array([[plastic, plastic**2 - 1]])), (seed, found)
        found = conic_intersections(upright, shifted, rng)
        assert same_points(found, np.array([[1.0, 1.0]])), (seed, found)


X, Y = sp.symbols("x y")


def exact_real_points(q1: np.ndarray, q2: np.ndarray) -> np.ndarray | None:
    """The real common points of two integer conics, by sympy: the resultant in y is a
    polynomial in x whose real roots (isolated exactly) are the abscissas of the common points.
    None for the cases where that correspondence needs care (a shared component, a repeated
    root, a vanishing x² or y² coefficient, a common point at infinity)."""
    if 0 in (q1[0, 0], q1[1, 1], q2[0, 0], q2[1, 1]):
        return None
    t = sp.Symbol("t")
    at_infinity = [int(q[0, 0]) * t**2 + 2 * int(q[0, 1]) * t + int(q[1, 1]) for q in (q1, q2)]
    if sp.resultant(*at_infinity, t) == 0:  # the quadratic parts share a direction (t : 1)
        return None
    f, g = (
        sp.Poly(
            int(q[0, 0]) * X**2
            + 2 * int(q[0, 1]) * X * Y
            + int(q[1, 1]) * Y**2
            + 2 * int(q[0, 2]) * X
            + 2 * int(q[1, 2]) * Y
            + int(q[2, 2]),
            X,
            Y,
        )
        for q in (q1, q2)
    )
    if sp.gcd(f, g).total_degree() > 0:
        return None
    r = sp.Poly(sp.resultant(f.as_expr(), g.as_expr(), Y), X)
    if r.is_zero or sp.degree(sp.gcd(r, r.diff(X)), X) > 0:
        return None
    points = []
    for root in sp.real_roots(r):
        x0 = float(root.evalf(30))
        # One common point per simple root; it is real, since a complex y would bring its
        # conjugate with the same abscissa (a double root).
        ys = np.roots(
            [float(v) for v in sp.Poly(f.as_expr().subs(X, root.evalf(30)), Y).all_coeffs()]
        )
        gy = [abs(complex(g.as_expr().subs({X: root.evalf(30), Y: complex(y)}))) for y in ys]
        points.append([x0, ys[int(np.argmin(gy))].real])
    return np.array(points).reshape(-1, 2)


def test_conic_intersections_match_sympy_on_random_integer_conics():
    rng = np.random.default_rng(2024)
    seen = {}
    for _ in range(60):
        q1, q2 = (rng.integers(-4, 5, (3, 3)) for _ in range(2))
        q1, q2 = q1 + q1.T, q2 + q2.T  # symmetric integer matrices
        expected = exact_real_points(q1, q2)
        if expected is None:
            continue
        found = conic_intersections(q1.astype(float), q2.astype(float), np.random.default_rng(1))
        assert same_points(found, expected, 1e-7), (q1, q2, found, expected)
        if len(found):
            assert max(on_conic(q1, found).max(), on_conic(q2, found).max()) <= 1e-12
        seen[len(expected)] = seen.get(len(expected), 0) + 1
    # The sample exercised every real count a generic pair can have.
    print(
        f"random integer conic pairs by number of real common points: {dict(sorted(seen.items()))}"
    )
    assert {0, 2, 4} <= set(seen), seen


# --------------------------------------------------------------------------- spatial quadrics
@pytest.mark.parametrize("seed", range(4))
def test_spatial_conic_is_the_position_set_2d(seed):
    """2D, k = 3 (m = d): the supplement's projected conic Q̃ is the determinant conic F, and
    motions_at gives, on it, a motion that keeps all three bars."""
    x, motions = random_target(2, 3, seed, 1)
    space = solution_space(x, motions[0])
    quadric = spatial_quadric(space)
    assert quadric is not None and quadric.plane is None
    a, b, c = determinant_conic(x, motions[0])
    # Proportional as functions of p (Q̃ lives on normalised coordinates y, p = x0 + L·y).
    y = np.random.default_rng(seed).standard_normal((12, 2))
    p = space.norm.positions_out(y)
    ratio = (np.einsum("ni,ij,nj->n", p, a, p) + 2 * p @ b + c) / quadric.values(y)[:, 0]
    assert np.allclose(ratio, ratio[0], rtol=1e-8)
    # Points of F = 0 on rays from x_S1: F(x_S1 + s v) = s²vᵀAv + 2s vᵀ(A x_S1 + b).
    for t in np.linspace(-2.0, 2.0, 7):
        v = np.array([np.cos(t), np.sin(t)])
        p = x[0] - 2 * (v @ (a @ x[0] + b)) / (v @ a @ v) * v
        u = quadric.motions_at(space.norm.positions_in(p[None]))[0]
        bars = np.einsum("ij,ij->i", x - p, motions[0] - u)
        assert np.abs(bars).max() <= 1e-9 * np.abs(x - p).max() * np.abs(motions[0] - u).max()


@pytest.mark.parametrize(("k", "plane"), [(4, False), (5, True)])
def test_spatial_quadric_and_common_positions_3d(k, plane):
    """3D: k = 4 gives a quadric surface (m = d), k = 5 a quadric cut by the supplement's
    hyperplane pᵀP⁻¹β̃ = 1 (m = d − 1).  Points found on it carry the motion on all k bars."""
    for seed in range(3):
        x, motions = random_target(3, k, seed, 1)
        space = solution_space(x, motions[0])
        quadric = spatial_quadric(space)
        assert quadric is not None and (quadric.plane is not None) == plane
        local = common_positions([quadric], np.random.default_rng(seed), 8)
        assert len(local) >= 4
        pts = space.norm.positions_out(local)
        for p, u in zip(pts, quadric.motions_at(local)):
            assert off_position_set(x, motions[0], p) <= 1e-9
            bars = np.einsum("ij,ij->i", x - p, motions[0] - u)
            assert np.abs(bars).max() <= 1e-9 * np.abs(x - p).max() * np.abs(motions[0] - u).max()


# --------------------------------------------------------------------------- two-mode designs
def test_two_motion_designs_2d_k3():
    """2D, k = 3, two motions: one unspecified node joined to all three specified nodes at the
    fourth common point of the two conics (N_D = 2·4 − 3 = 5), and conic_intersections on the
    solver's projected conics returns exactly {x_S1, x_S2, x_S3, fourth point}."""
    built = 0
    for seed in range(30):
        x, motions = random_target(2, 3, seed, 2)
        p4 = fourth_intersection(x, motions[0], motions[1])
        quadrics = [spatial_quadric(solution_space(x, u)) for u in motions]
        norm = quadrics[0].space.norm
        found = norm.positions_out(
            conic_intersections(quadrics[0].q_hat, quadrics[1].q_hat, np.random.default_rng(seed))
        )
        assert same_points(found, np.vstack([x, p4]), 1e-7), seed
        try:
            result = design(x, motions, seed=seed)
        except DomainError as err:
            # The fourth point is real (found above), so a refusal must not deny it.
            assert err.code == "no_solution" and "no real point" not in err.message, err.message
            continue
        check_design(result, x, motions)
        assert (result.unspecified_nodes, result.frame.n_edges, result.analysis.maxwell_count) == (
            1,
            3,
            5,
        )
        assert np.linalg.norm(result.frame.positions[3] - p4) <= 1e-9 * max(1.0, np.linalg.norm(p4))
        built += 1
    assert built >= 20, built


# The tangent-conic target of the last test with the second motion of node 1 raised from (0, 1)
# to (0, 1 + δ): the strain-rate ratios at node 0 become 1 : 1 and 1 + δ : 1, the conics are no
# longer tangent there, and δ places their fourth common point (module docstring).
NEAR_TANGENT_X = np.array([[0.0, 0.0], [3.0, 1.0], [1.0, 2.0]])


def near_tangent_motions(delta: float) -> np.ndarray:
    return np.array([[[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]], [[0.0, 0.0], [0.0, 1 + delta], [-1, 1]]])


REFUSED_FOURTH_POINTS = {
    # δ = 1e-6: the fourth point is ~4e-7 from x_S1, a bar of no length.
    "next to a specified node": 1e-6,
    # δ = 2.7911, near the pole of the fourth point: it lies ~1e4 radii out.
    "far outside the specified set": 2.7911,
}


@pytest.mark.parametrize("where", sorted(REFUSED_FOURTH_POINTS))
def test_refusal_message_tells_the_true_reason_2d_k3(where):
    """The 2D k = 3 fourth point is real and finite, and carries both motions (checked on the
    position sets derived here), but no design may use it: the refusal must say so, not claim
    that the solution spaces have no real point."""
    x, motions = NEAR_TANGENT_X, near_tangent_motions(REFUSED_FOURTH_POINTS[where])
    p4 = fourth_intersection(x, motions[0], motions[1])
    assert np.all(np.isfinite(p4))
    assert max(off_position_set(x, u, p4) for u in motions) <= 1e-9
    radius = np.sqrt(np.mean(np.sum((x - x.mean(axis=0)) ** 2, axis=1)))
    gap = np.min(np.linalg.norm(x - p4, axis=1)) / radius
    assert gap < 1e-6 if where == "next to a specified node" else gap > 1e3
    with pytest.raises(DomainError) as err:
        design(x, motions, seed=0)
    assert err.value.code == "no_solution"
    assert "no real point" not in err.value.message, err.value.message


def test_two_motion_designs_3d_k4():
    """3D, k = 4, two motions: every unspecified node lies on both quadric surfaces (checked on
    the determinant quadrics derived here and on the solver's projected ones); N_D = 8."""
    for seed in range(8):
        x, motions = random_target(3, 4, seed, 2)
        result = design(x, motions, seed=seed)
        check_design(result, x, motions)
        assert result.analysis.maxwell_count == 8
        for p in result.frame.positions[4:]:
            for u in motions:
                assert off_position_set(x, u, p) <= 1e-9
                q = spatial_quadric(solution_space(x, u))
                y = q.space.norm.positions_in(p[None])
                assert abs(q.values(y)[0, 0]) <= 1e-9 * np.abs(q.q_hat).max() * (1 + y @ y.T)[0, 0]


TRIANGLE = np.array(FIG4_TRIANGLE)
CORNER_TETRAHEDRON = np.array(FIG4_TETRAHEDRON)


def test_paper_fig4_two_motions_three_nodes_2d():
    """Fig. 4a–c: three specified nodes, two motions (outward from the centroid and a shear
    u = (y, 0)) → one unspecified node at the conics' common point, N_D = 5."""
    motions = np.stack(
        [TRIANGLE - TRIANGLE.mean(axis=0), np.column_stack([TRIANGLE[:, 1], np.zeros(3)])]
    )
    result = design(TRIANGLE, motions, seed=0)
    counts = check_design(result, TRIANGLE, motions)
    assert result.unspecified_nodes == 1 and result.analysis.maxwell_count == 5
    p4 = fourth_intersection(TRIANGLE, motions[0], motions[1])
    assert np.allclose(result.frame.positions[3], p4, atol=1e-12)
    print(f"paper Fig. 4c: unspecified node at {np.round(p4, 6)}, {counts}")


def test_paper_fig4_two_motions_four_nodes_3d():
    """Fig. 4d–f: four specified nodes, two motions (outward and a shear u = (y, 0, 0)) → four
    unspecified nodes on the intersection curve of the two quadric surfaces, N_D = 8."""
    x = CORNER_TETRAHEDRON
    motions = np.stack([x - x.mean(axis=0), np.column_stack([x[:, 1], np.zeros(4), np.zeros(4)])])
    result = design(x, motions, seed=0)
    counts = check_design(result, x, motions)
    assert result.unspecified_nodes == 4 and result.analysis.maxwell_count == 8
    assert all(set(a) == {0, 1, 2, 3} for a in result.anchor_sets)
    for p in result.frame.positions[4:]:
        assert max(off_position_set(x, u, p) for u in motions) <= 1e-9
    print(f"paper Fig. 4f: {counts}")


def test_tangent_conics_have_no_common_point_and_no_design():
    """Two motions of the same three nodes whose bars at node 0 (the docstring's x_S1) have the
    same strain-rate ratio (1 : 1) give conics tangent there (module docstring): by sympy's exact
    resultant their only real common points are the specified nodes, so no unspecified node
    carries both motions."""
    x = np.array([[0, 0], [3, 1], [1, 2]])
    motions = np.array([[[0, 0], [0, 1], [1, 0]], [[0, 0], [0, 1], [-1, 1]]])
    strains = [[(x[i] - x[0]) @ (u[i] - u[0]) for i in (1, 2)] for u in motions]
    assert strains[0] == strains[1] == [1, 1]

    def exact_conic(u):
        rows = [
            [a - X, b - Y, (a - X) * p + (b - Y) * q]
            for (a, b), (p, q) in zip(x.tolist(), u.tolist())
        ]
        return sp.expand(sp.Matrix(rows).det())

    f, g = exact_conic(motions[0]), exact_conic(motions[1])
    assert sp.Poly(f, X, Y).coeff_monomial(Y**2) and sp.Poly(g, X, Y).coeff_monomial(Y**2)
    common = set()
    for x0 in sp.real_roots(sp.Poly(sp.resultant(f, g, Y), X)):
        for y0 in sp.solve([f.subs(X, x0), g.subs(X, x0)], Y, dict=True):
            common.add((x0, y0[Y]))
    assert common == {tuple(map(sp.Integer, p)) for p in x.tolist()}

    with pytest.raises(DomainError) as err:
        design(x.astype(float), motions.astype(float), seed=0)
    assert err.value.code == "no_solution"
    # The only real common points are the specified nodes themselves: the message must say that
    # no point exists or that the candidates coincide with existing nodes.
    assert (
        "no real point" in err.value.message
        or "coincide with an existing node" in err.value.message
    )
