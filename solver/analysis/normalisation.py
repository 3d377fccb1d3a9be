"""Scale normalisation: the one reversible change of units behind every rank and tolerance.

Every decision zeromode makes (a rank, a coincidence, a rigid motion) is taken on inputs made
scale-free first: positions centred at their centroid and divided by their RMS radius, motions
(where there are any) centred and divided by theirs. The bar constraint (x_i − x_j)·(u_i − u_j)
= 0 and the rank of the compatibility matrix are invariant under both maps, so decisions taken
in normalised units hold in the caller's, and do not depend on translation, rotation or scale.

Like a cvxpy ``Reduction``, the map is applied (``positions_in``, ``motions_in``) and inverted
(``positions_out``, ``motions_out``) with the same object, so results go back exactly to the
caller's units. Magnitudes from 1e-300 to 1e300 neither overflow nor underflow: sums of squares
are formed only after dividing by max |x|.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from zeromode.solver.analysis.compiled import compiled, kernel_array


def unit_scaled(x: np.ndarray) -> tuple[np.ndarray, float]:
    """(x / m, m) with m = max |x_ia|, so sums of squares can neither overflow nor underflow."""
    m = float(np.max(np.abs(x))) if x.size else 0.0
    return (x / m, m) if m > 0 else (x, 1.0)


def _centre_and_rms(x: np.ndarray) -> tuple[np.ndarray, float]:
    """Centroid (d,) and RMS distance from it of points (n, d); (0, 0) for no points."""
    if len(x) == 0:
        return np.zeros(x.shape[1] if x.ndim == 2 else 0), 0.0
    y, m = unit_scaled(x)
    centre = y.mean(axis=0)
    return m * centre, m * float(np.sqrt(np.mean(np.sum((y - centre) ** 2, axis=1))))


def rms_radius(x: np.ndarray) -> float:
    """Root-mean-square distance of the points (n, d) from their centroid (0 for one point)."""
    return _centre_and_rms(x)[1]


@dataclass(frozen=True)
class Normalisation:
    """x' = (x − x0)/L and u' = (u − u0)/U, with L, U the RMS radii (1 where a radius is 0).

    x0 (d,), u0 (d,): centroids of the positions and motions; length L, speed U: scalars.
    Without motions, u0 = 0 and U = 1 (motions are then only rescaled with the positions'
    frame left alone, which keeps rigid motions rigid).
    """

    x0: np.ndarray
    length: float
    u0: np.ndarray
    speed: float

    @classmethod
    def of(cls, positions: np.ndarray, motions: np.ndarray | None = None) -> Normalisation:
        x0, length = _centre_and_rms(positions)
        if motions is None:
            return cls(x0, length or 1.0, np.zeros_like(x0), 1.0)
        u0, speed = _centre_and_rms(motions)
        # All rows equal (a translation): scale by their size so u' is still O(1).
        speed = speed or float(np.sqrt(np.mean(motions**2))) or 1.0
        return cls(x0, length or 1.0, u0, speed)

    def positions_in(self, x: np.ndarray) -> np.ndarray:
        return (x - self.x0) / self.length

    def motions_in(self, u: np.ndarray) -> np.ndarray:
        return (u - self.u0) / self.speed

    def positions_out(self, x: np.ndarray) -> np.ndarray:
        return self.x0 + self.length * x

    def motions_out(self, u: np.ndarray) -> np.ndarray:
        return self.u0 + self.speed * u


def normalised(positions: np.ndarray) -> np.ndarray:
    """Positions (n, d) centred and divided by their RMS radius (unchanged scale for one point).

    The same map as ``Normalisation.of(positions).positions_in``, evaluated in units of max |x|
    (centre, then divide), the order every stored design and certificate was verified with.
    Compiled: every analysis starts here, and at 10² nodes the eight NumPy calls it took cost
    about 60 µs inside a count of 0.5 ms (each call's overhead, on a few hundred numbers).
    """
    return _normalised(kernel_array(positions, float))


@compiled
def _normalised(positions):
    n, d = positions.shape
    largest = 0.0
    for i in range(n):
        for a in range(d):
            largest = max(largest, abs(positions[i, a]))
    y = positions / largest if largest > 0 else positions.copy()
    if n == 0:
        return y
    centre = np.zeros(d)
    for i in range(n):
        centre += y[i]
    centre /= n
    square_sum = 0.0
    for i in range(n):
        for a in range(d):
            y[i, a] -= centre[a]
            square_sum += y[i, a] * y[i, a]
    radius = np.sqrt(square_sum / n)
    return y / radius if radius > 0 else y
