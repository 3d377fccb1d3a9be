"""The solution space of the paper's Eqs. 4–6 as something to draw: curves and point sets of
positions x_U, traced inside a window.

An unspecified node joined to every specified node may sit at x_U exactly when some u_U
satisfies all k bar constraints (x_Si − x_U)·(u_Si − u_U) = 0. zeromode.solver.construction.solution_space
gives these (x_U, u_U) as α ↦ W̃[α; 1] on the quadric α̃ᵀQα̃ = 0; here they are traced densely
enough to draw: a conic (m = dim N(Ã) = 2) as ordered polylines, a quadric surface in 3D
(m = 3) as a wireframe of such conics, a region (m = 3 in 2D, m ≥ 4) as a point cloud, and
isolated solutions (m ≤ 1) as points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from zeromode.solver.construction.solution_space import (
    SolutionSpace,
    real_roots_on_lines,
    solution_space,
)
from zeromode.solver.tolerances import CONSTRAINT_ATOL
from zeromode.viz.geometry import Window

# A plane or a centre computed from a matrix of condition number above this is too ill-posed to
# place a wireframe on (a degenerate quadric): the cloud of samples is drawn instead.
MAX_CONDITION = 1e8
# The fan of lines tracing a conic radiates from a point whose quadric value exceeds this
# fraction of the conic's largest coefficient: on the conic itself, half the roots would be
# the fan's centre.
FAN_CENTRE_RTOL = 1e-6
# Bisection of the sweep angle (in units of π) stops at this step: below it the two ends of an
# interval are the same line to double precision.
MIN_ANGLE_STEP = 1e-12
# Consecutive points of a traced curve are at most this fraction of the window's screen size
# apart; points farther apart than JOIN_STEPS such steps belong to different arcs.
STEP_FRACTION, JOIN_STEPS = 1 / 320, 4


@dataclass(frozen=True, eq=False)
class SolutionDrawing:
    """The positions x_U of one solution space, ready to draw (caller's coordinates, d columns).

    kind: SolutionSpace.kind, or "empty" when no node can join every specified node;
    curves: ordered branches of a conic, each (n_i, d) with consecutive points close together;
    points: (n, d) isolated solutions (m ≤ 1) or a cloud on a quadric surface (m ≥ 3).
    Every point satisfies all k bar constraints (x_Si − x_U)·(u_Si − u_U) = 0 for some u_U.
    """

    kind: str
    curves: tuple[np.ndarray, ...]
    points: np.ndarray


def solution_drawing(
    positions, motions, window: Window | None = None, seed: int = 0, cloud: int = 700
) -> SolutionDrawing:
    """Trace the solution space of x_S, u_S (k × d each) inside the window (default: around x_S).

    A conic (m = 2) is traced exactly: a fan of lines through a point c of α-space is cut with
    the conic α̃ᵀQα̃ = 0; the larger root t(θ) of each line at angle θ ∈ [0, 2π) sweeps every
    point of the conic once (the line at θ + π is the line at θ reversed), and the sweep is
    refined by bisection until consecutive positions are close.  A quadric surface in 3D
    (m = 3) becomes a wireframe of such conics: its sections by horizontal planes z = h
    (parallels) and by vertical planes through its centre (meridians).  Position sets that
    fill a region (m = 3 in 2D, m ≥ 4) become a point cloud of ``cloud`` points from
    ``SolutionSpace.sample`` (seeded); isolated solutions (m ≤ 1) their points.  Raises
    DomainError ``no_solution`` when b ∉ R(Ã) (nothing to draw).
    """
    space = solution_space(positions, motions)
    if window is None:
        window = Window.around(space.positions)
    empty = np.zeros((0, space.dim))
    if space.nullity == 2:
        return SolutionDrawing(space.kind, _trace_conic(space, space.quadric_n, lambda s: s, window), empty)
    rng = np.random.default_rng(seed)
    x_u, _ = space.sample(4 * cloud if space.nullity > 2 else 8, rng)
    x_u = x_u[window.contains(x_u)]
    linear = space.w_tilde_n[: space.dim, : space.nullity]  # x'_U = P α + p0 (normalised)
    if space.nullity == 3 and space.dim == 3 and len(x_u) and np.linalg.cond(linear) < MAX_CONDITION:
        return SolutionDrawing(space.kind, _wireframe(space, x_u, window), empty)
    return SolutionDrawing(space.kind, (), x_u[:cloud])


def _wireframe(space: SolutionSpace, cloud: np.ndarray, window: Window, parallels: int = 7, meridians: int = 8):
    """Plane sections of a quadric surface of positions (d = m = 3), each traced as a conic.

    A plane n·x = h of position space is, in α-space, the plane (Pᵀn)·α = n·x'_h − n·p0, where
    x' = Pα + p0 are the normalised positions and x'_h the normalised image of the plane's point
    h·n; with α = α0 + E s (E an orthonormal basis of that plane, α0 its point nearest the
    origin) the section is the conic s̃ᵀ(TᵀQT)s̃ = 0, T = [[E, α0], [0, 1]].  Parallels are
    spread over the cloud's height; meridians pass through the quadric's centre (the cloud's
    centroid when it has none).
    """
    m = space.nullity
    p, p0 = space.w_tilde_n[:3, :m], space.w_tilde_n[:3, m]
    q = space.quadric_n
    a, b = q[:m, :m], q[:m, m]
    if np.linalg.cond(a) < MAX_CONDITION:
        centre = space.norm.positions_out(p @ np.linalg.solve(a, -b) + p0)
    else:
        centre = cloud.mean(axis=0)
    z_lo, z_hi = cloud[:, 2].min(), cloud[:, 2].max()
    planes = [(np.array([0.0, 0.0, 1.0]), z_lo + (z_hi - z_lo) * (i + 0.5) / parallels) for i in range(parallels)]
    for j in range(meridians):
        n = np.array([np.cos(np.pi * j / meridians), np.sin(np.pi * j / meridians), 0.0])
        planes.append((n, float(n @ centre)))
    curves: list[np.ndarray] = []
    for n, h in planes:
        nu = p.T @ n
        h_alpha = n @ space.norm.positions_in(h * n) - n @ p0
        alpha0 = nu * h_alpha / (nu @ nu)
        e = np.linalg.svd(nu[None, :])[2][1:].T  # m × 2, orthonormal, ⟂ ν
        t = np.zeros((m + 1, 3))
        t[:m, :2], t[:m, 2], t[m, 2] = e, alpha0, 1.0
        curves += _trace_conic(space, t.T @ q @ t, lambda s, e=e, a0=alpha0: a0 + s @ e.T, window)
    return tuple(curves)


def _trace_conic(space: SolutionSpace, conic: np.ndarray, to_alpha, window: Window):
    """Branches of a conic s̃ᵀ conic s̃ = 0 (s ∈ R², α = to_alpha(s)) inside the window, as ordered
    (n, d) polylines of positions; points failing the bar constraints are dropped."""
    scale = float(np.max(np.abs(conic))) or 1.0
    centre = next(
        (c for c in np.array([[0.0, 0.0], [0.31, 0.17], [-0.23, 0.41]])
         if abs(np.append(c, 1.0) @ conic @ np.append(c, 1.0)) > FAN_CENTRE_RTOL * scale),
        np.array([0.31, 0.17]),
    )
    step = STEP_FRACTION * window.screen_size  # target spacing of consecutive points

    def evaluate(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        delta = np.column_stack([np.cos(np.pi * s), np.sin(np.pi * s)])
        t, ok = real_roots_on_lines(conic, np.broadcast_to(centre, delta.shape), delta)
        t_big = np.where(ok, t, -np.inf).max(axis=1)
        real = np.isfinite(t_big)
        x_u, u_u = space.points(to_alpha(centre + np.where(real, t_big, 0.0)[:, None] * delta))
        on = real & (np.max(np.abs(space.residuals(x_u, u_u)), axis=1) <= CONSTRAINT_ATOL)
        return x_u, on

    s = np.linspace(0.0, 2.0, 721)
    x, on = evaluate(s)
    for _ in range(40):
        inside = on & window.contains(x)
        gap = np.linalg.norm(np.diff(x, axis=0), axis=1)
        # Refine where the curve moves fast, and bisect towards tangencies (on/off boundaries),
        # where the arc must end on the tangent point to meet its partner arc.
        need = ((inside[:-1] | inside[1:]) & on[:-1] & on[1:] & (gap > step)) | (on[:-1] != on[1:])
        need &= np.diff(s) > MIN_ANGLE_STEP
        if not need.any():
            break
        mid = 0.5 * (s[:-1] + s[1:])[need]
        x_mid, on_mid = evaluate(mid)
        order = np.argsort(np.concatenate([s, mid]), kind="stable")
        s = np.concatenate([s, mid])[order]
        x = np.concatenate([x, x_mid])[order]
        on = np.concatenate([on, on_mid])[order]
    inside = on & window.contains(x)
    gap = np.r_[np.linalg.norm(np.diff(x, axis=0), axis=1), np.inf]
    pieces, run = [], [0] if inside[0] else []
    for i in range(1, len(s)):
        if inside[i] and inside[i - 1] and gap[i - 1] <= JOIN_STEPS * step:
            run.append(i)
            continue
        if len(run) > 1:
            pieces.append(x[run])
        run = [i] if inside[i] else []
    if len(run) > 1:
        pieces.append(x[run])
    return _stitch(pieces, JOIN_STEPS * step)


def _stitch(pieces: list[np.ndarray], tol: float) -> tuple[np.ndarray, ...]:
    """Join polylines whose ends meet (arcs of one branch split at a tangency or a sweep seam)."""
    pieces = list(pieces)
    i = 0
    while i < len(pieces):
        for j in range(i + 1, len(pieces)):
            joined = _join(pieces[i], pieces[j], tol)
            if joined is not None:
                pieces[i] = joined
                del pieces[j]
                break
        else:
            i += 1
    return tuple(pieces)


def _join(a: np.ndarray, b: np.ndarray, tol: float) -> np.ndarray | None:
    for a2, b2 in ((a, b), (a, b[::-1]), (a[::-1], b), (a[::-1], b[::-1])):
        if np.linalg.norm(a2[-1] - b2[0]) <= tol:
            return np.vstack([a2, b2])
    return None
