"""Hand-made mechanisms: frames with one chosen nontrivial zero mode.

Built independently of zeromode.solver.construction.design: the paper's bipartite construction, solved
numerically from its own equations, and qualified by the reference counts.  For specified positions x_S and motions u_S (k × d), an
unspecified node (x_U, u_U) joined to every specified node keeps the bars iff
    A ṽ = b,   A = [u_Siᵀ  x_Siᵀ  −1],  ṽ = (x_U, u_U, c),  b_i = x_Si·u_Si,
together with the coupling c = x_U·u_U (the quadric).  Points on it are found by intersecting
random lines ṽ = ṽ* + W(α₀ + s·δ) (W a null-space basis of A) with the quadric: a quadratic in s.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import null_space

from oracles.rigidity import reference_counts
from oracles.solution_space import a_tilde
from zeromode.solver import Frame


def solution_points(x_s: np.ndarray, u_s: np.ndarray, count: int, rng: np.random.Generator):
    """``count`` points (x_U, u_U) of the solution space, each (d,), from seeded random lines."""
    d = x_s.shape[1]
    a, b = a_tilde(x_s, u_s)
    v_star = np.linalg.lstsq(a, b, rcond=None)[0]
    w = null_space(a)

    def coupling(alpha):
        v = v_star + w @ alpha
        return v[:d] @ v[d : 2 * d] - v[2 * d]

    points = []
    while len(points) < count:
        alpha0, delta = rng.standard_normal(w.shape[1]), rng.standard_normal(w.shape[1])
        f = [coupling(alpha0 + s * delta) for s in (-1.0, 0.0, 1.0)]
        qa, qb, qc = (f[0] + f[2]) / 2 - f[1], (f[2] - f[0]) / 2, f[1]
        roots = np.roots([qa, qb, qc])
        for s in roots[np.isreal(roots)].real[:1]:
            v = v_star + w @ (alpha0 + s * delta)
            points.append((v[:d], v[d : 2 * d]))
    return points


def bipartite_design(x_s, u_s, n_unspecified: int, seed: int = 0, scale_limit: float = 3.0):
    """A bipartite frame (specified nodes 0..k−1, each unspecified node joined to all of them)
    with u_S its single nontrivial zero mode and no self-stress; the first seeded draw that
    qualifies (unspecified nodes within ``scale_limit`` RMS radii of the specified centroid, no
    two nodes closer than 0.2 of it)."""
    x_s, u_s = np.asarray(x_s, float), np.asarray(u_s, float)
    k = len(x_s)
    rng = np.random.default_rng(seed)
    centre = x_s.mean(axis=0)
    size = np.sqrt(np.mean(np.sum((x_s - centre) ** 2, axis=1)))
    edges = [[i, k + j] for j in range(n_unspecified) for i in range(k)]
    for _ in range(200):
        pts = solution_points(x_s, u_s, n_unspecified, rng)
        x_u = np.array([p[0] for p in pts])
        positions = np.vstack([x_s, x_u])
        gaps = np.linalg.norm(positions[:, None] - positions[None], axis=2)[
            np.triu_indices(k + n_unspecified, 1)
        ]
        # The conic passes through every specified node: keep clear of them (and of each other).
        if (
            np.max(np.linalg.norm(x_u - centre, axis=1)) > scale_limit * size
            or gaps.min() < 0.2 * size
        ):
            continue
        counts = reference_counts(positions, edges)
        if counts["nontrivial_zero_modes"] == 1 and counts["self_stresses"] == 0:
            return Frame.build(positions, edges, specified=list(range(k)))
    raise RuntimeError("no qualifying design found")


def random_targets(k: int, d: int, seed: int):
    """Seeded random specified positions and motions (k × d each)."""
    rng = np.random.default_rng(seed)
    return rng.standard_normal((k, d)), rng.standard_normal((k, d))


def outward_square(angles_deg=(20.0, 230.0)) -> Frame:
    """The paper's 2D outward module (Fig. 3b): specified nodes at (±1, ±1) with u_S = x_S and
    two unspecified nodes on the solution conic, joined to all four (N = 6, N_B = 8).

    For these targets A ṽ = b + c·1 reads x_Si·(x_U + u_U) = 2 + c for all four corners, so
    u_U = −x_U and c = −2 = x_U·u_U: the conic is the circle |x_U|² = 2 (the circumcircle).
    """
    x_s = np.array([[1.0, 1.0], [1.0, -1.0], [-1.0, 1.0], [-1.0, -1.0]])
    ang = np.deg2rad(np.asarray(angles_deg, float))
    x_u = np.sqrt(2.0) * np.column_stack([np.cos(ang), np.sin(ang)])
    edges = [[i, 4 + j] for j in range(len(ang)) for i in range(4)]
    return Frame.build(np.vstack([x_s, x_u]), edges, specified=[0, 1, 2, 3])


def four_bar(points=((0.0, 0.0), (1.0, 0.2), (2.2, 1.1), (3.0, 0.0))) -> Frame:
    """A 2D four-bar linkage 0–1–2–3–0: one nontrivial zero mode."""
    return Frame.build(list(points), [[0, 1], [1, 2], [2, 3], [3, 0]])


def parallelogram(theta: float = np.pi / 3) -> Frame:
    """A parallelogram four-bar (sides 2 and 1) at angle θ; it flattens at θ = 0 and θ = π,
    where it meets the anti-parallelogram branch (a branch point)."""
    c, s = np.cos(theta), np.sin(theta)
    return Frame.build([[0, 0], [2, 0], [2 + c, s], [c, s]], [[0, 1], [1, 2], [2, 3], [3, 0]])


def in_ground_frame(positions) -> np.ndarray:
    """A four-bar configuration moved rigidly so that node 0 is at the origin and node 3 on +x."""
    x = np.asarray(positions, float) - np.asarray(positions, float)[0]
    angle = np.arctan2(x[3, 1], x[3, 0])
    c, s = np.cos(-angle), np.sin(-angle)
    return x @ np.array([[c, s], [-s, c]])


def four_bar_at_crank_angle(reference, phi: float) -> np.ndarray:
    """Closed-form position analysis of the four-bar 0–1–2–3–0 (ground 0–3, crank 0–1, coupler
    1–2, rocker 2–3) of ``reference`` (4 × 2) with the crank at signed angle ``phi`` from the
    ground (at node 0, from node 3 to node 1): B = a(cos φ, sin φ), C the intersection of the
    circles |C − B| = b and |C − D| = c on the side of BD where the reference has it (the
    assembly mode, kept along a continuous motion). In the ground frame (in_ground_frame)."""
    x = in_ground_frame(reference)
    a, b = np.linalg.norm(x[1] - x[0]), np.linalg.norm(x[2] - x[1])
    c, g = np.linalg.norm(x[3] - x[2]), np.linalg.norm(x[3] - x[0])

    def cross(u, v):
        return u[0] * v[1] - u[1] * v[0]

    side = np.sign(cross(x[3] - x[1], x[2] - x[1]))
    B, D = a * np.array([np.cos(phi), np.sin(phi)]), np.array([g, 0.0])
    e = D - B
    dist = np.linalg.norm(e)
    along = (b * b - c * c + dist * dist) / (2 * dist)
    h = np.sqrt(b * b - along * along)
    normal = np.array([-e[1], e[0]]) / dist
    C = B + along * e / dist + side * h * normal
    return np.array([[0.0, 0.0], B, C, D])


def crank_angle(positions) -> float:
    """The four-bar's signed crank angle at node 0, from the ground (node 3) to node 1."""
    x = in_ground_frame(positions)
    return float(np.arctan2(x[1, 1], x[1, 0]))


def crank_angle_limit(reference) -> float:
    """The largest crank angle of a four-bar whose crank cannot turn fully (a rocker): coupler and
    rocker collinear, |B − D| = b + c, so cos φ_max = (a² + g² − (b + c)²)/(2ag)."""
    x = np.asarray(reference, float)
    a, b = np.linalg.norm(x[1] - x[0]), np.linalg.norm(x[2] - x[1])
    c, g = np.linalg.norm(x[3] - x[2]), np.linalg.norm(x[3] - x[0])
    return float(np.arccos((a * a + g * g - (b + c) ** 2) / (2 * a * g)))
