"""The first event along a sheet's finite motion, by continuation of the whole tiled frame,
independent of zeromode.solver.

The frame (every node and bar of the sheet, as a response returns it) is followed along its one
nontrivial motion with motion._Curve (pseudo-arclength predictor, Newton corrector on the bar
lengths, tangents from numpy's SVD of [C; Gᵀ]) in steps of about STRAIN_STEP in ε_x.  After
each step every node pair without a bar and every (node, bar) pair with the node off the bar is
examined directly on the sheet:
  * node proximity: |x_p − x_q| < fraction·ℓ_min;
  * a node passing through a bar: the signed area of (node, bar) changes sign while the node's
    projection lies on the bar;
  * a singular point: the tangent is no longer unique (_Curve.tangent is None) or Newton fails.
An event between two steps is located by bisection on the pseudo-arclength to EVENT_TOL in ε_x
(the corrector is exact to 1e-14 on squared lengths).  ε_x is measured from the boundary sets'
mean positions after the configuration is rotated onto the reference (Kabsch).
"""

from __future__ import annotations

import numpy as np

from oracles.motion import _Curve, boundary_strains

STRAIN_STEP = 0.004
EVENT_TOL = 1e-11
SEARCH_LIMIT = 0.9


def _aligned(x: np.ndarray, x0: np.ndarray) -> np.ndarray:
    """x rotated (about its centroid) and translated onto x0 in the least-squares sense (2D)."""
    p, q = x - x.mean(axis=0), x0 - x0.mean(axis=0)
    theta = np.arctan2(np.sum(p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]), np.sum(p * q))
    c, s = np.cos(theta), np.sin(theta)
    return p @ np.array([[c, s], [-s, c]]) + x0.mean(axis=0)


class SheetEvents:
    """Events of the frame (positions (N, 2), edges) at a configuration, brute force."""

    def __init__(self, positions, edges, fraction: float):
        self.edges = np.asarray(edges, dtype=int)
        x0 = np.asarray(positions, dtype=float)
        n = len(x0)
        self.shortest = float(np.linalg.norm(x0[self.edges[:, 0]] - x0[self.edges[:, 1]], axis=1).min())
        self.fraction = fraction
        joined = np.eye(n, dtype=bool)
        joined[self.edges[:, 0], self.edges[:, 1]] = joined[self.edges[:, 1], self.edges[:, 0]] = True
        self.apart = np.argwhere(np.triu(~joined))
        p, b = np.meshgrid(np.arange(n), np.arange(len(self.edges)), indexing="ij")
        p, b = p.ravel(), b.ravel()
        off = (p != self.edges[b, 0]) & (p != self.edges[b, 1])
        self.node, self.bar = p[off], b[off]

    def gap(self, x: np.ndarray) -> float:
        """min |x_p − x_q| / ℓ_min − fraction over pairs without a bar."""
        d = np.linalg.norm(x[self.apart[:, 0]] - x[self.apart[:, 1]], axis=1)
        return float(d.min() / self.shortest - self.fraction)

    def sides(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(signed area of each (node, bar), whether the node projects onto the bar)."""
        qa, qb = x[self.edges[self.bar, 0]], x[self.edges[self.bar, 1]]
        along, rel = qb - qa, x[self.node] - qa
        norm2 = np.sum(along * along, axis=1)
        area = (along[:, 0] * rel[:, 1] - along[:, 1] * rel[:, 0]) / norm2
        t = np.sum(rel * along, axis=1) / norm2
        return np.sign(area), (t >= 0) & (t <= 1)


def first_event(positions, edges, boundary: dict, sign: int, fraction: float) -> tuple[float, str]:
    """(ε_x, reason) of the first event along the motion in the direction where ε_x has
    ``sign``; reason one of node_proximity, bar_crossing, singular_point, search_limit."""
    x0 = np.asarray(positions, dtype=float)
    events = SheetEvents(x0, edges, fraction)
    curve = _Curve(x0, events.edges)
    assert events.gap(x0) > 0, "the reference already collides"

    def strain(y: np.ndarray) -> float:
        return boundary_strains(x0, _aligned(y.reshape(x0.shape), x0), boundary, finite=True)[0]

    def at(y, t, s) -> np.ndarray:
        return curve.correct(y, t, s).reshape(x0.shape)

    y = x0.ravel().copy()
    t = curve.tangent(y, None)
    assert t is not None, "the sheet has no single motion to follow"
    if np.sign(strain(curve.correct(y, t, 1e-6))) != sign:
        t = -t
    side0, inside0 = events.sides(x0)
    h, eps = 1e-3, 0.0
    while True:
        nxt = curve.correct(y, t, h)
        t_next = None if nxt is None else curve.tangent(nxt, t)
        eps_next = None if t_next is None else strain(nxt)
        if t_next is None or abs(eps_next - eps) > 2 * STRAIN_STEP:
            if h < 1e-9:  # a singular point stops the shrinking steps
                return eps, "singular_point"
            h /= 4
            continue
        x = nxt.reshape(x0.shape)
        located = []
        if events.gap(x) < 0:
            located.append((_bisect(lambda s, y=y, t=t: events.gap(at(y, t, s)) < 0, h), "node_proximity"))
        side, inside = events.sides(x)
        candidates = np.flatnonzero((side != side0) & (inside | inside0))
        while candidates.size:
            first = candidates

            def flipped(s, first=first, y=y, t=t, side0=side0):
                return bool(np.any(events.sides(at(y, t, s))[0][first] != side0[first]))

            s = _bisect(flipped, h)
            side_s, inside_s = events.sides(at(y, t, s))
            through = first[side_s[first] != side0[first]]
            if np.any(inside_s[through]):
                located.append((s, "bar_crossing"))
                break
            candidates = np.setdiff1d(candidates, through)  # crossed a bar's line beyond its ends
        if located:
            s, reason = min(located)
            return strain(curve.correct(y, t, s)), reason
        rate = (eps_next - eps) / h
        y, t, eps, side0, inside0 = nxt, t_next, eps_next, side, inside
        if abs(eps) >= SEARCH_LIMIT:
            return eps, "search_limit"
        h = min(2 * h, STRAIN_STEP / max(abs(rate), 1e-12))


def _bisect(test, h: float) -> float:
    """The smallest σ ∈ (0, h] at which ``test`` holds (it holds at h), to EVENT_TOL·h."""
    lo, hi = 0.0, h
    while hi - lo > EVENT_TOL * h:
        mid = 0.5 * (lo + hi)
        if test(mid):
            hi = mid
        else:
            lo = mid
    return hi
