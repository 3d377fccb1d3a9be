"""Finite motion from scratch: bar lengths, rigid alignment, the fidelity ε by a continuation
written here, and the strains of a motion; independent of zeromode.solver.motion.finite_motion.

The fidelity (paper, finite-motion error) of a frame with one nontrivial zero mode for the
target x_S + Δ_S is ε = min_τ min_R ‖R·X_S(τ) − (x_S + Δ_S)‖ / ‖Δ_S‖: the closest approach of
the specified nodes, along the frame's configuration curve X(τ) (every bar at its length), to
the target, up to proper rigid motions R.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.spatial.transform import Rotation

from oracles.rigidity import compatibility_matrix, normalised, rigid_generators


def bar_lengths(positions, edges) -> np.ndarray:
    x, e = np.asarray(positions, dtype=float), np.asarray(edges, dtype=int).reshape(-1, 2)
    return np.linalg.norm(x[e[:, 0]] - x[e[:, 1]], axis=1)


def relative_bar_error(path, edges, reference) -> float:
    """max over the configurations of ``path`` (T × N × d) and the bars of |ℓ − ℓ₀| / ℓ₀, ℓ₀ the
    lengths in ``reference``."""
    ref = bar_lengths(reference, edges)
    return max(float(np.max(np.abs(bar_lengths(x, edges) - ref) / ref)) for x in path)


def rigid_distance(moving, target) -> float:
    """min over proper rigid motions R of ‖R·moving − target‖_F, for (k, d) point sets.

    2D: the optimal angle is atan2(Σ p×q, Σ p·q) of the centred sets, in closed form; 3D: scipy's
    Rotation.align_vectors (Wahba's problem, proper rotations only). The residual is formed
    explicitly."""
    p = np.asarray(moving, dtype=float)
    q = np.asarray(target, dtype=float)
    p, q = p - p.mean(axis=0), q - q.mean(axis=0)
    if p.shape[1] == 2:
        theta = np.arctan2(np.sum(p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]), np.sum(p * q))
        c, s = np.cos(theta), np.sin(theta)
        rotated = p @ np.array([[c, s], [-s, c]])
    else:
        rotated = Rotation.align_vectors(q, p)[0].apply(p)
    return float(np.linalg.norm(rotated - q))


class _Curve:
    """The configuration curve of a one-degree-of-freedom frame in normalised coordinates y.

    Bars: g(y) = |y_i − y_j|² − ℓ_ij² = 0, with Jacobian 2C(y). Steps leave no rigid motion of the
    current configuration (G(y_k)ᵀ(y − y_k) = 0, G the rigid generators) and keep a fixed
    pseudo-arclength along the tangent t_k, the null vector of [C(y_k); G(y_k)ᵀ]."""

    def __init__(self, y0: np.ndarray, edges: np.ndarray):
        self.edges = np.asarray(edges, dtype=int).reshape(-1, 2)
        self.shape = y0.shape
        self.lengths2 = bar_lengths(y0, self.edges) ** 2

    def bars(self, y: np.ndarray) -> np.ndarray:
        return bar_lengths(y.reshape(self.shape), self.edges) ** 2 - self.lengths2

    def tangent(self, y: np.ndarray, previous: np.ndarray | None) -> np.ndarray | None:
        """Unit tangent at y oriented like ``previous``; None where the curve is singular."""
        x = y.reshape(self.shape)
        jac = np.vstack([compatibility_matrix(x, self.edges), rigid_generators(x).T])
        _, s, vt = np.linalg.svd(jac)
        # One null vector, clearly separated: rank dN − 1 (a lower rank is a branch point).
        if int(np.count_nonzero(s > 1e-6 * s[0])) != y.size - 1:
            return None
        t = vt[-1]
        return -t if previous is not None and t @ previous < 0 else t

    def correct(self, y_k: np.ndarray, t_k: np.ndarray, sigma: float) -> np.ndarray | None:
        """The point of the curve at pseudo-arclength σ from y_k along t_k (Newton), or None."""
        x_k = y_k.reshape(self.shape)
        gauge = rigid_generators(x_k).T
        y = y_k + sigma * t_k
        for _ in range(30):
            residual = np.concatenate([self.bars(y), gauge @ (y - y_k), [t_k @ (y - y_k) - sigma]])
            if np.max(np.abs(residual)) <= 1e-14:
                return y
            c = compatibility_matrix(y.reshape(self.shape), self.edges)
            jac = np.vstack([2 * c, gauge, t_k])
            y = y - np.linalg.lstsq(jac, residual, rcond=None)[0]
        return y if np.max(np.abs(self.bars(y))) <= 1e-12 else None


def fidelity(positions, edges, specified, displacement) -> float:
    """ε of a one-degree-of-freedom frame for the target x_S + Δ_S (``displacement`` = Δ_S).

    The curve is followed both ways from the frame in steps of 1/40 of the linear estimate τ_lin
    of where the target is reached, to 3·τ_lin and on while the closest sample is the last one;
    the best sample is then polished on the curve itself (bounded minimisation over the
    pseudo-arclength between its neighbours)."""
    x0 = np.asarray(positions, dtype=float)
    spec = np.asarray(specified, dtype=int)
    delta = np.asarray(displacement, dtype=float)
    centre = x0.mean(axis=0)
    radius = np.sqrt(np.mean(np.sum((x0 - centre) ** 2, axis=1)))
    y0 = normalised(x0)
    target = (x0[spec] + delta - centre) / radius
    scale = np.linalg.norm(delta) / radius
    curve = _Curve(y0, edges)

    def distance(y: np.ndarray) -> float:
        return rigid_distance(y.reshape(x0.shape)[spec], target)

    t0 = curve.tangent(y0.ravel(), None)
    assert t0 is not None, "the frame has no single motion to follow"
    speed = np.linalg.norm(t0.reshape(x0.shape)[spec])  # of the specified nodes, per arclength
    tau_lin = scale / speed
    h = tau_lin / 40
    best = (distance(y0.ravel()), y0.ravel(), t0)
    for sign in (1.0, -1.0):
        y, t, travelled = y0.ravel(), sign * t0, 0.0
        while True:
            nxt = curve.correct(y, t, h)
            t_next = None if nxt is None else curve.tangent(nxt, t)
            if t_next is None:
                break
            y, t, travelled = nxt, t_next, travelled + h
            d = distance(y)
            if d < best[0]:
                best = (d, y, t)
            elif travelled >= 3 * tau_lin:
                break
            if travelled >= 50 * tau_lin:
                break
    _, y_best, t_best = best

    def along(sigma: float) -> float:
        y = curve.correct(y_best, t_best, sigma)
        return np.inf if y is None else distance(y)

    polished = minimize_scalar(along, bounds=(-h, h), method="bounded", options={"xatol": 1e-13})
    return min(best[0], float(polished.fun)) / scale


def boundary_strains(positions, moved, boundary: dict, finite: bool) -> tuple[float, float]:
    """(ε_x, ε_y): the relative change of the x-extent between the mean positions of the
    left/right boundary sets, and of the y-extent between bottom/top. ``moved`` is a motion
    (finite=False: a rate) or a configuration (finite=True: a secant strain)."""
    x, m = np.asarray(positions, dtype=float), np.asarray(moved, dtype=float)
    out = []
    for lo, hi, axis in (("left", "right", 0), ("bottom", "top", 1)):
        low, high = list(boundary[lo]), list(boundary[hi])
        extent = x[high, axis].mean() - x[low, axis].mean()
        change = m[high, axis].mean() - m[low, axis].mean()
        out.append((change - extent) / extent if finite else change / extent)
    return out[0], out[1]


def poisson_ratio(positions, moved, boundary: dict, finite: bool = False) -> float:
    """ν = −ε_y/ε_x of a motion (linear) or of a configuration (secant)."""
    ex, ey = boundary_strains(positions, moved, boundary, finite)
    return -ey / ex
