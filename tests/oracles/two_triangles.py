"""The two-triangle module's map in closed form (an oracle for zeromode.solver.sequential).

Triangles (0, 2, 4) and (1, 3, 4) hinged at node 4, the input pair (0, 1), the output pair
(2, 3); turning triangle B by θ about the hinge gives d_in(θ) = |r₀ − R(θ)r₁| and
d_out(θ) = |r₂ − R(θ)r₃| (r_i = X_i − X_4), with folds where R(θ)r₁ ∥ r₀.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq


def _rot(theta: float) -> np.ndarray:
    return np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])


class TwoTriangles:
    """The closed-form map of a two-triangle module on the branch θ ∈ (θ_lo, θ_hi) ∋ 0."""

    def __init__(self, positions):
        p = np.asarray(positions, dtype=float)
        self.r = p - p[4]
        r0, r1 = self.r[0], self.r[1]
        phi = np.arctan2(r0[1], r0[0]) - np.arctan2(r1[1], r1[0])  # R(φ) r₁ ∥ r₀: a fold
        folds = np.concatenate([phi + np.pi * np.arange(-4, 5)])
        self.lo, self.hi = folds[folds < 0].max(), folds[folds > 0].min()

    def d_in(self, t):
        return np.linalg.norm(self.r[0] - _rot(t) @ self.r[1])

    def d_out(self, t):
        return np.linalg.norm(self.r[2] - _rot(t) @ self.r[3])

    def theta(self, d):
        return brentq(lambda t: self.d_in(t) - d, self.lo, self.hi, xtol=1e-15, rtol=1e-15)

    def f(self, d):
        return self.d_out(self.theta(d))

    def slope(self, d):
        t = self.theta(d)
        turn = np.array([[0.0, -1.0], [1.0, 0.0]])
        din = -(self.r[0] - _rot(t) @ self.r[1]) @ (turn @ _rot(t) @ self.r[1]) / self.d_in(t)
        dout = -(self.r[2] - _rot(t) @ self.r[3]) @ (turn @ _rot(t) @ self.r[3]) / self.d_out(t)
        return dout / din

    def range(self):
        return sorted((self.d_in(self.lo), self.d_in(self.hi)))
