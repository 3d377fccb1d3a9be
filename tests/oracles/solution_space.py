"""The solution space of one unspecified node, rebuilt from the paper (Eqs. 1, 4–6 and the
Supplementary block formula for Q), independent of zeromode.solver.

An unspecified node (x_U, u_U) joined to the specified nodes (x_S, u_S) keeps every bar iff
(x_Si − x_U)·(u_Si − u_U) = 0 (Eq. 1), i.e. Ã ṽ = b with Ã = [u_Sᵀ, x_Sᵀ, −1],
ṽ = (x_U, u_U, c), b_i = x_Si·u_Si, together with the coupling c = x_U·u_U.
"""

from __future__ import annotations

import numpy as np

from oracles.rigidity import REFERENCE_RTOL, normalised, numerical_rank


def a_tilde(x_s, u_s) -> tuple[np.ndarray, np.ndarray]:
    """Ã (k × (2d+1)) with rows [u_Siᵀ, x_Siᵀ, −1], and b (k,) with b_i = x_Si·u_Si."""
    x_s, u_s = np.asarray(x_s, dtype=float), np.asarray(u_s, dtype=float)
    return np.hstack([u_s, x_s, -np.ones((len(x_s), 1))]), np.sum(x_s * u_s, axis=1)


def nullity(x_s, u_s) -> int:
    """dim N(Ã) on normalised positions and motions (each centred and divided by its RMS radius:
    invertible column operations on [u, x, −1], so the nullity is unchanged)."""
    a, _ = a_tilde(normalised(x_s), normalised(u_s))
    return a.shape[1] - numerical_rank(a, REFERENCE_RTOL)


def bar_residuals(x_s, u_s, x_u, u_u) -> np.ndarray:
    """|(x_Si − x_U)·(u_Si − u_U)| over the scale of its terms, for every i: (k,)."""
    x_s, u_s = np.asarray(x_s, dtype=float), np.asarray(u_s, dtype=float)
    dx, du = x_s - x_u, u_s - u_u
    scale = (np.linalg.norm(x_s, axis=1) + np.linalg.norm(x_u)) * (
        np.linalg.norm(u_s, axis=1) + np.linalg.norm(u_u)
    )
    return np.abs(np.sum(dx * du, axis=1)) / np.maximum(scale, 1e-300)


def paper_quadric(w_tilde: np.ndarray, d: int) -> np.ndarray:
    """Q = [[A, B], [Bᵀ, C]] with A = WᵀOW, B = (2ṽ*ᵀO − pᵀ)W/2, C = (ṽ*ᵀO − pᵀ)ṽ* (Supplement):
    α̃ᵀQα̃ = x_U·u_U − c for ṽ = W̃α̃, W̃ = [W, ṽ*], α̃ = (α, 1)."""
    w, v = w_tilde[:, :-1], w_tilde[:, -1]
    o = np.zeros((2 * d + 1, 2 * d + 1))
    o[:d, d : 2 * d] = o[d : 2 * d, :d] = 0.5 * np.eye(d)
    p = np.zeros(2 * d + 1)
    p[-1] = 1.0
    a = w.T @ o @ w
    b = (2 * v @ o - p) @ w / 2
    c = (v @ o - p) @ v
    return np.block([[a, b[:, None]], [b[None, :], np.array([[c]])]])


def roots_on_line(q: np.ndarray, a0: np.ndarray, delta: np.ndarray) -> list[float]:
    """Real t with (a0 + tδ, 1)ᵀ Q (a0 + tδ, 1) = 0: the quadratic along a line in α-space."""
    p0, p1 = np.append(a0, 1.0), np.append(delta, 0.0)
    qa, qb, qc = p1 @ q @ p1, 2 * p1 @ q @ p0, p0 @ q @ p0
    if abs(qa) < 1e-14 * (abs(qb) + abs(qc)):
        return [-qc / qb] if qb != 0 else []
    disc = qb * qb - 4 * qa * qc
    if disc < 0:
        return []
    return [(-qb + np.sqrt(disc)) / (2 * qa), (-qb - np.sqrt(disc)) / (2 * qa)]


def points_on_random_lines(w_tilde: np.ndarray, d: int, rng: np.random.Generator, lines: int = 20):
    """Points ṽ = W̃(α, 1) of the solution set (Q from paper_quadric) on ``lines`` random lines of
    α-space, as rows (≤ 2·lines × (2d+1)). For nullity m = 1 the line is all of α-space, so these
    are all the points; an empty result for m ≥ 2 means none was met, not that none exists."""
    m = w_tilde.shape[1] - 1
    q = paper_quadric(w_tilde, d)
    found = []
    for _ in range(1 if m == 1 else lines):
        a0 = np.zeros(m) if m == 1 else rng.standard_normal(m)
        delta = np.ones(m) if m == 1 else rng.standard_normal(m)
        found += [w_tilde @ np.append(a0 + t * delta, 1.0) for t in roots_on_line(q, a0, delta)]
    return np.array(found).reshape(-1, 2 * d + 1)
