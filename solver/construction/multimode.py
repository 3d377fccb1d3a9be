"""Multi-mode construction: unspecified nodes on the intersection of the position sets of
several motions (paper, "Multi-Mode Construction", Eq. 8, and Supplementary "Defining a
Projection from Solution Coordinates to Spatial Coordinates").

Each motion u^(i) of the same specified nodes has its own solution space α̃_iᵀ Q_i α̃_i = 0.
The projection β̃ = P_i α̃_i to spatial coordinates turns it into a quadric in the node position,
β̃ᵀ Q̃_i β̃ = 0 with Q̃_i = P_i⁻ᵀ Q_i P_i⁻¹:

  * m = d:      P = [[B W, B ṽ*], [0, 1]] with B selecting the x_U rows, β̃ = (x_U, 1);
  * m = d − 1:  P = B [W, ṽ*] (d × d), β̃ = x_U, plus the hyperplane pᵀ P⁻¹ β̃ = 1.

A position on every quadric (and hyperplane) carries one motion per mode, α̃_i = P_i⁻¹ β̃.
In 2D two conics meet in at most four points, found exactly from the resultant (a quartic);
in 3D the sets meet in curves (or points), sampled by Gauss–Newton from seeded starts.
Every point is verified against all bar constraints of every mode before it is used.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from numpy.polynomial import polynomial as poly

from zeromode.solver.construction.placement import CandidatePool, candidate_levels
from zeromode.solver.construction.solution_space import SolutionSpace, solution_space
from zeromode.solver.errors import DomainError
from zeromode.solver.tolerances import (
    COMMON_POSITION_ATOL,
    CONSTRAINT_ATOL,
    QUADRIC_STEP_ATOL,
    RANK_RTOL,
    RESULTANT_PIVOT_ATOL,
    RESULTANT_ROOT_IMAG_RTOL,
    ROOT_IMAG_RTOL,
    SAME_SOLUTION_ATOL,
)


@dataclass(frozen=True, eq=False)
class SpatialQuadric:
    """The position set of one solution space: [x; 1]ᵀ Q̂ [x; 1] = 0 (and hᵀx = 1 if ``plane``).

    Coordinates are those of ``space.norm`` (the normalised specified set).
    q_hat: (d+1) × (d+1); plane: (d,) or None; p_inv maps β̃ back to α̃.
    """

    space: SolutionSpace
    q_hat: np.ndarray
    plane: np.ndarray | None
    p_inv: np.ndarray

    def motions_at(self, x: np.ndarray) -> np.ndarray:
        """u_U at normalised positions x (n, d): α̃ = P⁻¹β̃, ṽ = W̃α̃ → motions (n, d), caller's units."""
        d = self.space.dim
        beta = x if self.plane is not None else np.hstack([x, np.ones((len(x), 1))])
        alpha_t = beta @ self.p_inv.T
        v = alpha_t @ self.space.w_tilde_n.T
        return self.space.norm.motions_out(v[:, d : 2 * d])

    def values(self, x: np.ndarray) -> np.ndarray:
        """Quadric (and plane) residuals at normalised positions x (n, d) → (n, 1 or 2)."""
        xh = np.hstack([x, np.ones((len(x), 1))])
        out = [np.einsum("ni,ij,nj->n", xh, self.q_hat, xh)]
        if self.plane is not None:
            out.append(x @ self.plane - 1.0)
        return np.column_stack(out)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """(n, 1 or 2, d) derivatives of ``values``."""
        d = self.space.dim
        xh = np.hstack([x, np.ones((len(x), 1))])
        rows = [2 * (xh @ self.q_hat)[:, :d][:, None, :]]
        if self.plane is not None:
            rows.append(np.broadcast_to(self.plane, (len(x), 1, d)))
        return np.concatenate(rows, axis=1)


def spatial_quadric(space: SolutionSpace) -> SpatialQuadric | None:
    """The supplement's projection for m = d and m = d − 1; None when it does not apply
    (other m, or positions that do not vary with α: P singular)."""
    d, m = space.dim, space.nullity
    w = space.w_tilde_n
    if m == d:
        p = np.zeros((d + 1, d + 1))
        p[:d] = w[:d]
        p[d, d] = 1.0
        plane_row = None
    elif m == d - 1:
        p = w[:d].copy()
        plane_row = np.zeros(d)
        plane_row[-1] = 1.0  # α̂, the coefficient of ṽ*, must be 1
    else:
        return None
    s = np.linalg.svd(p, compute_uv=False)
    if s[-1] <= RANK_RTOL * s[0]:
        return None
    p_inv = np.linalg.inv(p)
    q_tilde = p_inv.T @ space.quadric_n @ p_inv
    if plane_row is None:
        return SpatialQuadric(space, q_tilde, None, p_inv)
    q_hat = np.zeros((d + 1, d + 1))
    q_hat[:d, :d] = q_tilde
    return SpatialQuadric(space, q_hat, p_inv.T @ plane_row, p_inv)


def conic_intersections(q1: np.ndarray, q2: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """All real common points of two plane conics [x y 1] Q [x y 1]ᵀ = 0 (at most four), (n, 2)
    in the caller's coordinates.

    Centred and scaled first: with p = c + s·p′ the conics become Q′ = Mᵀ Q M,
    M = [[s, 0, c₀], [0, s, c₁], [0, 0, 1]], each then divided by a power of two near its norm
    (exactly). The centre c is the least-squares centre of both, [A₁; A₂] c = −[b₁; b₂] (A the
    quadratic part, b half the linear part, each conic weighted by 1/‖A‖; a direction in which
    both are parabolic keeps c = 0), and the scale s the geometric mean of their radii about c,
    (‖b′‖ + √(‖b′‖² + ‖A‖|c′|)) / ‖A‖ (the positive root of ‖A‖r² = 2‖b′‖r + |c′|), rounded to a
    power of two. The points are found for Q′ (conics of size ~1 about the origin, the scale the
    thresholds below assume) and carried back, p = c + s·p′. What no transformation recovers is
    what the matrices no longer hold: a conic of size s at distance R from the origin has
    entries up to ~(R/s)² times its own scale, so its points are fixed only to ~ε(1 + R/s)² of s
    (ε the machine epsilon).

    Exact route on Q′: after a seeded rotation (so no two points share an abscissa), the
    resultant of the two quadratics in y is a quartic in x; each real root gives y from the
    common-root formula, then one Newton polish on both conics.
    """
    centre, size = _centre_and_scale(q1, q2)
    m = np.array([[size, 0.0, centre[0]], [0.0, size, centre[1]], [0.0, 0.0, 1.0]])
    unit = [m.T @ q @ m for q in (q1, q2)]
    # Each divided by a power of two near its norm: exact, so conics whose quadratic parts were
    # equal stay equal (a shared point at infinity keeps the resultant's leading terms exactly 0).
    unit = [q / 2.0 ** np.round(np.log2(np.linalg.norm(q))) for q in unit]
    return centre + size * _unit_conic_intersections(*unit, rng)


def _centre_and_scale(q1: np.ndarray, q2: np.ndarray) -> tuple[np.ndarray, float]:
    """(c, s) of ``conic_intersections``: the conics' least-squares centre and their size about
    it, a power of two (so the scaling itself is exact)."""
    curved = [q / np.linalg.norm(q[:2, :2]) for q in (q1, q2) if np.linalg.norm(q[:2, :2]) > 0]
    if curved:
        a = np.vstack([q[:2, :2] for q in curved])
        b = np.concatenate([q[:2, 2] for q in curved])
        centre = np.linalg.lstsq(a, -b, rcond=RANK_RTOL)[0]
    else:  # two lines: any centre
        centre = np.zeros(2)
    m = np.array([[1.0, 0.0, centre[0]], [0.0, 1.0, centre[1]], [0.0, 0.0, 1.0]])
    radii = []
    for q in (q1, q2):
        q = m.T @ q @ m
        a, b, c = np.linalg.norm(q[:2, :2]), np.linalg.norm(q[:2, 2]), abs(q[2, 2])
        if a > 0:
            radii.append((b + np.sqrt(b * b + a * c)) / a)
        elif b > 0:  # a line: its distance from the centre
            radii.append(c / (2 * b))
    radii = [r for r in radii if np.isfinite(r) and r > 0]
    size = float(np.exp(np.mean(np.log(radii)))) if radii else 1.0
    return centre, float(2.0 ** np.round(np.log2(size)))


def _unit_conic_intersections(q1: np.ndarray, q2: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """``conic_intersections`` of two conics of size ~1 about the origin (the resultant route)."""
    theta = rng.uniform(0, 2 * np.pi)
    rot = np.eye(3)
    rot[:2, :2] = [[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]]
    a_q, b_q = rot.T @ q1 @ rot, rot.T @ q2 @ rot  # conics in rotated coordinates

    def coeffs(q):  # f = a2 y² + a1(x) y + a0(x), each a polynomial in x (low → high)
        return (
            np.array([q[1, 1]]),
            np.array([2 * q[1, 2], 2 * q[0, 1]]),
            np.array([q[2, 2], 2 * q[0, 2], q[0, 0]]),
        )

    a2, a1, a0 = coeffs(a_q)
    b2, b1, b0 = coeffs(b_q)
    m0 = poly.polysub(poly.polymul(a2, b0), poly.polymul(a0, b2))
    m1 = poly.polysub(poly.polymul(a2, b1), poly.polymul(a1, b2))
    m2 = poly.polysub(poly.polymul(a1, b0), poly.polymul(a0, b1))
    resultant = poly.polysub(poly.polymul(m0, m0), poly.polymul(m1, m2))
    resultant = np.trim_zeros(resultant, "b")
    if resultant.size < 2:
        return np.zeros((0, 2))
    roots = poly.polyroots(resultant)
    xs = roots[np.abs(roots.imag) <= RESULTANT_ROOT_IMAG_RTOL * (1 + np.abs(roots.real))].real
    points = []
    for x in xs:
        den = poly.polyval(x, m1)
        if abs(den) > RESULTANT_PIVOT_ATOL:
            ys = [-poly.polyval(x, m0) / den]
        else:  # tangency or a shared vertical: take f's roots that also solve g
            ys = np.roots([poly.polyval(x, a2), poly.polyval(x, a1), poly.polyval(x, a0)])
            ys = ys[np.abs(ys.imag) <= ROOT_IMAG_RTOL].real  # |y| ≲ 1: normalised
        points.extend([x, y] for y in ys)
    if not points:
        return np.zeros((0, 2))
    pts = _newton_polish(np.asarray(points, dtype=float), [a_q, b_q])
    # A shared point at infinity leaves a resultant with a vanishing leading coefficient, whose
    # root is huge: keep finite points only (these are centred and scaled coordinates).
    pts = pts[np.all(np.isfinite(pts), axis=1) & (np.max(np.abs(pts), axis=1) < 1e8)]
    return pts @ rot[:2, :2].T


def _newton_polish(x: np.ndarray, quadrics: list[np.ndarray], steps: int = 3) -> np.ndarray:
    """Gauss–Newton steps on [x;1]ᵀQ_i[x;1] = 0 (min-norm steps when under-determined)."""
    d = x.shape[1]
    for _ in range(steps):
        xh = np.hstack([x, np.ones((len(x), 1))])
        f = np.stack([np.einsum("ni,ij,nj->n", xh, q, xh) for q in quadrics], axis=1)
        jac = np.stack([2 * (xh @ q)[:, :d] for q in quadrics], axis=1)
        x = x - np.einsum("nde,ne->nd", np.linalg.pinv(jac), f)
    return x


def common_positions(
    quadrics: list[SpatialQuadric], rng: np.random.Generator, n: int, spread: float = 1.5
) -> np.ndarray:
    """Normalised positions on every position set (n', d): exact in 2D for two conics,
    otherwise Gauss–Newton from seeded starts in a ball of radius ~``spread``."""
    d = quadrics[0].space.dim
    planes = [q for q in quadrics if q.plane is not None]
    if d == 2 and len(quadrics) == 2 and not planes:
        return conic_intersections(quadrics[0].q_hat, quadrics[1].q_hat, rng)
    x = spread * rng.standard_normal((max(4 * n, 16), d))
    for _ in range(30):
        f = np.concatenate([q.values(x) for q in quadrics], axis=1)
        jac = np.concatenate([q.jacobian(x) for q in quadrics], axis=1)
        step = np.einsum("nde,ne->nd", np.linalg.pinv(jac), f)
        x = x - step
        if np.max(np.abs(step), initial=0.0) < QUADRIC_STEP_ATOL:
            break
    f = np.concatenate([q.values(x) for q in quadrics], axis=1)
    good = np.all(np.isfinite(x), axis=1) & (np.max(np.abs(f), axis=1) <= COMMON_POSITION_ATOL)
    return _distinct(x[good])[:n]


def _distinct(x: np.ndarray, tol: float = SAME_SOLUTION_ATOL) -> np.ndarray:
    """The rows of x (n, d) with no earlier row within ``tol``."""
    keep: list[np.ndarray] = []
    for p in x:
        if all(np.linalg.norm(p - q) > tol for q in keep):
            keep.append(p)
    return np.asarray(keep).reshape(-1, x.shape[1])


def _pool(x_n: np.ndarray, u_n: np.ndarray, subset: tuple[int, ...], rng, samples: int):
    """Candidates joined to ``subset`` that carry every motion: the intersection of the
    subset's position sets for all modes, each point verified on every mode's bar constraints."""
    idx = list(subset)
    quadrics = []
    for u in u_n:
        try:
            space = solution_space(x_n[idx], u[idx])
        except DomainError:
            return None
        q = spatial_quadric(space)
        if q is None:
            return None
        quadrics.append(q)
    norm = quadrics[0].space.norm  # positions are normalised identically for every mode
    local = common_positions(quadrics, rng, samples)
    if len(local) == 0:
        return None
    positions = norm.positions_out(local)
    motions = np.stack([q.motions_at(local) for q in quadrics], axis=1)  # (n, M, d)
    ok = np.ones(len(positions), dtype=bool)
    for i, q in enumerate(quadrics):
        res = q.space.residuals(positions, motions[:, i])
        ok &= np.max(np.abs(res), axis=1, initial=0.0) <= CONSTRAINT_ATOL * 10
    if not np.any(ok):
        return None
    return CandidatePool(positions[ok], motions[ok], subset)


def multi_mode_levels(
    x_n: np.ndarray, u_n: np.ndarray, rng: np.random.Generator, samples: int = 16
) -> Iterator[list[CandidatePool]]:
    """Candidate levels for M ≥ 2 motions (placement.candidate_levels): anchor sets of up to
    2d nodes, whose position sets must still meet in real points."""
    d = x_n.shape[1]
    return candidate_levels(x_n, 2 * d, rng, lambda subset: _pool(x_n, u_n, subset, rng, samples))
