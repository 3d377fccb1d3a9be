"""Plane geometry of pictures, numpy only: the 3D view, arrow and marker outlines, the window
solution spaces are traced in, and the spacing rules of nodes and arrows.

Screen coordinates have y up; the layout (layout.py) maps them to pixels (y down).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from zeromode.viz.style import ARROW_GRID

# Solution-space geometry is computed inside the nodes' bounding box (in view coordinates) grown
# by this fraction of its largest screen side on every side — larger than any panel, whose border
# then clips it — and, in depth, by DEPTH_GROWTH of it, so curves leave the picture sideways.
WINDOW_GROWTH, DEPTH_GROWTH = 0.6, 3.0


def view_basis(azimuth: float, elevation: float) -> np.ndarray:
    """Rows: screen right, screen up, and the direction towards the viewer (3 × 3, orthonormal)."""
    a, e = np.radians(azimuth), np.radians(elevation)
    right = np.array([-np.sin(a), np.cos(a), 0.0])
    toward = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    return np.vstack([right, np.cross(toward, right), toward])


def project(x: np.ndarray, basis: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Orthographic projection of points x (n, d): screen coordinates (n, 2) and depth (n,)
    (larger = farther). ``basis`` from view_basis for d = 3; None in 2D (depth 0)."""
    if basis is None:
        return x, np.zeros(len(x))
    return x @ basis[:2].T, -(x @ basis[2])


@dataclass(frozen=True, eq=False)
class Window:
    """The box lo ≤ axes·x ≤ hi: axes (d × d) orthonormal rows, the first two spanning the screen."""

    axes: np.ndarray
    lo: np.ndarray
    hi: np.ndarray

    @classmethod
    def around(cls, x: np.ndarray, axes: np.ndarray | None = None) -> Window:
        """The box around points x (n × d) grown by WINDOW_GROWTH (DEPTH_GROWTH in depth)."""
        axes = np.eye(x.shape[1]) if axes is None else axes
        y = x @ axes.T
        lo, hi = y.min(axis=0), y.max(axis=0)
        side = max(float(np.max((hi - lo)[:2])), float(np.max(np.abs(y)))) or 1.0
        grow = np.full(x.shape[1], WINDOW_GROWTH * side)
        grow[2:] = DEPTH_GROWTH * side
        return cls(axes, lo - grow, hi + grow)

    def contains(self, x: np.ndarray) -> np.ndarray:
        y = x @ self.axes.T
        return np.all((y >= self.lo) & (y <= self.hi), axis=1)

    @property
    def screen_size(self) -> float:
        return float(np.linalg.norm((self.hi - self.lo)[:2]))


def arrow_polygon(base: np.ndarray, vec: np.ndarray, shaft: float, head_w: float, head_l: float) -> np.ndarray:
    """The 7 corners (7, 2) of an arrow from base along vec: shaft half-width, head half-width
    and head length (the head at most 55 % of the arrow). Corners 0 and 6 flank the base, 3 is
    the tip."""
    length = float(np.hypot(*vec))
    e = vec / length
    n = np.array([-e[1], e[0]])
    head_l = min(head_l, 0.55 * length)
    neck = base + e * (length - head_l)
    return np.array([
        base + n * shaft, neck + n * shaft, neck + n * head_w, base + vec,
        neck - n * head_w, neck - n * shaft, base - n * shaft,
    ])


def marker_polygon(centre: np.ndarray, size: float, kind: str) -> np.ndarray:
    """A square of half-side ``size`` ("source") or a diamond 1.35 times larger ("target")."""
    if kind == "source":
        return centre + size * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]])
    return centre + 1.35 * size * np.array([[0, -1], [1, 0], [0, 1], [-1, 0]])


def spread_subsample(points: np.ndarray, cells: int = ARROW_GRID) -> np.ndarray:
    """Indices (sorted) of a spread subset of points (n, 2): square cells, ``cells`` across the
    longer side of the points' bounding box; in each occupied cell the point nearest its centre."""
    lo = points.min(axis=0)
    side = float(np.max(np.ptp(points, axis=0))) / cells or 1.0
    cell = np.minimum(np.floor((points - lo) / side), cells - 1)
    dist = np.linalg.norm(points - (lo + (cell + 0.5) * side), axis=1)
    key = cell[:, 0] * cells + cell[:, 1]
    order = np.lexsort((dist, key))
    first = np.r_[True, key[order][1:] != key[order][:-1]]
    return np.sort(order[first])


def typical_gap(points: np.ndarray, k: int = 1) -> float:
    """Median distance from a point (n ≥ 2, any dimension) to its k-th nearest other point
    (the farthest one when there are fewer), ignoring coincident points."""
    k = min(k, len(points) - 1)
    dist, _ = cKDTree(points).query(points, k=k + 1)
    gap = dist[:, k]
    gap = gap[gap > 0]
    return float(np.median(gap)) if len(gap) else 0.0
