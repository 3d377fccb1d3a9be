"""A finite motion aimed in the user's terms: continued until a quantity of the configuration
reaches a target value, and ended exactly there.

Quantities q(X) of a configuration X (N, d), each invariant under proper rigid motions, with
their gradients ∇q (N, d):
  * ``distance`` |X_j − X_i| between two nodes:  ∇ = ±(X_j − X_i)/|X_j − X_i| at j, i.
  * ``angle`` at node j between the arms a = X_i − X_j and b = X_k − X_j.  In 2D the signed
    angle from a to b (counter-clockwise positive), θ = arg b − arg a, followed continuously
    along the path (its value in (−π, π] at the reference, then unwrapped: a full turn adds
    2π), ∂θ/∂b = b^⊥/|b|², ∂θ/∂a = −a^⊥/|a|² (v^⊥ = (−v_y, v_x)).  In 3D the unsigned angle
    θ = atan2(|a × b|, a·b) ∈ [0, π], ∂θ/∂a = (cos θ â − b̂)/(|a| sin θ) (and a ↔ b).
  * ``strain`` ε_x or ε_y of a lattice (boundary_strain.boundary_strains): the change of the extent
    between the mean positions of two opposite boundary sets of the configuration aligned to
    the reference (Kabsch, as /v1/motion returns it), over the reference's extent.  It is
    linear in the aligned configuration, ε = ⟨G, A(X)⟩ − 1, A(X) = (X − X̄)R + x̄ with R the
    Kabsch rotation (pR ≈ q, p = X − X̄, q = x − x̄, H = pᵀq = R S, S symmetric).  Its
    gradient: ∇ε = centred(G Rᵀ + q Eᵀ), E = R(Z − Zᵀ), Z = U[(Uᵀ Rᵀ pᵀG U) ⊘ (λ_i + λ_j)]Uᵀ
    with S = U Λ Uᵀ (the rotation's derivative δR = RΩ solves the Sylvester equation
    SΩ + ΩS = Rᵀ δH − δHᵀ R that keeps Rᵀ H symmetric).
  * ``fraction`` f ∈ [−1, 1] \\ {0} of the usable range of the motion in the direction sign(f)
    of the mode: the range ends at the first singular point, where two nodes without a bar come
    closer than PROXIMITY_FRACTION of the shortest bar (located by bisection), or
    at the search horizon TARGET_HORIZON of the path parameter; the path ends at the parameter
    f·τ_end (pseudo-arclength, finite_motion's units), exactly by the definition of τ.

Aiming (aim_motion).  The motion is continued (finite_motion.trace_motion, or
periodic.trace_motion_through_cell for a lattice) in each direction asked until q crosses the
target or |q − target| grows (q turned back, or moves away from the start), a singular point,
or the horizon.  A crossing between two samples is bracketed on the curve between them
(Brent's method on q along the corrector's chart, every point with exact bar lengths), then
finished by Newton's method on the augmented system — the bar constraints, the gauge, and
q(Y) = target (finite_motion.aimed_correction) — to TARGET_RTOL in q and NEWTON_RTOL in every
bar.  Where q turned back, its extreme on the curve between the neighbouring samples
(finite_motion.curve_minimum) decides: past the target, the crossing before it is landed on;
short of it, the target cannot be reached that way.  The nearest landing (smallest |τ|) is
returned; otherwise TargetUnreachable names why, from the side whose extreme came nearest:
``target_past_turning_point`` (dq/dτ changes sign first), ``target_past_singular_point``, or
``target_out_of_range`` (the horizon, or q moves away from the target in the only direction
asked), with that extreme.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import brentq
from scipy.spatial import cKDTree

from zeromode.solver.analysis.normalisation import Normalisation
from zeromode.solver.analysis.rigidity import DENSE_MAX_DOF
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.motion.boundary_strain import boundary_sets
from zeromode.solver.motion.finite_motion import (
    BarConstraints,
    MotionPath,
    aimed_correction,
    align_to,
    bar_lengths,
    chart_at,
    curve_minimum,
    regular_point,
    relative_bar_error,
    trace_motion,
)
from zeromode.solver.motion.periodic import STOP_BISECTIONS, trace_motion_through_cell
from zeromode.solver.tolerances import (
    DISTINCT_RTOL,
    PROXIMITY_FRACTION,
    TARGET_BRACKET_RTOL,
    TARGET_RTOL,
)

# The search horizon: the largest path parameter (/v1/motion's largest amplitude) up to which a
# target is looked for, and the end of the usable range when nothing ends it before.
TARGET_HORIZON = 10.0

KINDS = ("distance", "angle", "strain", "fraction")
REASONS = {
    "target_past_turning_point": "the quantity turns back (its derivative along the path changes sign) before the target",
    "target_past_singular_point": "the path meets a singular point before the target",
    "target_out_of_range": "the target lies outside the usable range searched",
}


@dataclass(frozen=True)
class MotionTarget:
    """What to aim at: ``kind`` one of KINDS; ``value`` the target (a length in the frame's
    units; radians; a strain; a fraction in [−1, 1]); ``nodes`` (i, j) for a distance, (i, j, k)
    for the angle at j; ``axis`` "x" or "y" and ``boundary`` (the node sets "left", "right",
    "bottom", "top") for a strain."""

    kind: str
    value: float
    nodes: tuple[int, ...] = ()
    axis: str | None = None
    boundary: dict | None = None


class Quantity:
    """q(X) and ∇q(X) (N, d) of a configuration; ``scale`` the size TARGET_RTOL is relative to.
    ``value(x, near)``: the value nearest ``near`` among the equivalent ones (a 2D angle modulo
    2π), so that it is followed continuously along a path."""

    scale = 1.0

    def value(self, x: np.ndarray, near: float | None = None) -> float:
        raise NotImplementedError

    def gradient(self, x: np.ndarray) -> np.ndarray:
        raise NotImplementedError


@dataclass(frozen=True)
class NodeDistance(Quantity):
    i: int
    j: int
    scale: float = 1.0

    def value(self, x, near=None):
        return float(np.linalg.norm(x[self.j] - x[self.i]))

    def gradient(self, x):
        e = (x[self.j] - x[self.i]) / np.linalg.norm(x[self.j] - x[self.i])
        g = np.zeros_like(x)
        g[self.j], g[self.i] = e, -e
        return g


@dataclass(frozen=True)
class NodeAngle(Quantity):
    i: int
    j: int
    k: int

    def _arms(self, x):
        return x[self.i] - x[self.j], x[self.k] - x[self.j]

    def value(self, x, near=None):
        a, b = self._arms(x)
        if x.shape[1] == 2:
            theta = float(np.arctan2(a[0] * b[1] - a[1] * b[0], a @ b))
            return theta if near is None else theta + 2 * np.pi * round((near - theta) / (2 * np.pi))
        return float(np.arctan2(np.linalg.norm(np.cross(a, b)), a @ b))

    def gradient(self, x):
        a, b = self._arms(x)
        g = np.zeros_like(x)
        if x.shape[1] == 2:
            ga = -np.array([-a[1], a[0]]) / (a @ a)
            gb = np.array([-b[1], b[0]]) / (b @ b)
        else:
            na, nb = np.linalg.norm(a), np.linalg.norm(b)
            theta = self.value(x)
            sin = np.sin(theta)
            ga = (np.cos(theta) * a / na - b / nb) / (na * sin)
            gb = (np.cos(theta) * b / nb - a / na) / (nb * sin)
        g[self.i], g[self.k], g[self.j] = ga, gb, -(ga + gb)
        return g


@dataclass(frozen=True, eq=False)
class BoundaryStrain(Quantity):
    """ε = ⟨G, A(X)⟩ − 1 of the configuration aligned to ``reference`` (module docstring)."""

    weights: np.ndarray
    reference: np.ndarray

    @classmethod
    def of(cls, reference: np.ndarray, sets: dict, axis: str) -> BoundaryStrain:
        lo, hi = (sets["left"], sets["right"]) if axis == "x" else (sets["bottom"], sets["top"])
        a = 0 if axis == "x" else 1
        extent = reference[hi, a].mean() - reference[lo, a].mean()
        if not abs(extent) > DISTINCT_RTOL * np.max(np.abs(reference - reference.mean(axis=0))):
            raise InvalidInput("invalid_target", f"the boundary sets have no extent along {axis}: no strain is defined.")
        g = np.zeros_like(reference)
        np.add.at(g[:, a], hi, 1.0 / (len(hi) * extent))
        np.add.at(g[:, a], lo, -1.0 / (len(lo) * extent))
        return cls(g, reference)

    def value(self, x, near=None):
        return float(np.sum(self.weights * align_to(x, self.reference))) - 1.0

    def gradient(self, x):
        p = x - x.mean(axis=0)
        q = self.reference - self.reference.mean(axis=0)
        u, _, vt = np.linalg.svd(p.T @ q)
        flip = np.ones(x.shape[1])
        flip[-1] = np.sign(np.linalg.det(u @ vt)) or 1.0
        rotation = (u * flip) @ vt
        lam, basis = np.linalg.eigh(rotation.T @ (p.T @ q))
        inner = basis.T @ rotation.T @ (p.T @ self.weights) @ basis
        z = basis @ (inner / (lam[:, None] + lam[None, :])) @ basis.T
        e = rotation @ (z - z.T)
        g = self.weights @ rotation.T + q @ e.T
        return g - g.mean(axis=0)


def target_quantity(target: MotionTarget, frame: Frame) -> Quantity | None:
    """The quantity of ``target`` on ``frame`` (None for a fraction), after InvalidInput
    ``invalid_target`` (one sentence) for nodes out of range or repeated, coincident arms of an
    angle, a distance between coincident nodes, a strain without boundary sets, a value out of
    its domain."""
    n, value = frame.n_nodes, target.value
    if target.kind not in KINDS:
        raise InvalidInput("invalid_target", f"target kind must be one of {', '.join(KINDS)}.")
    if not np.isfinite(value):
        raise InvalidInput("invalid_target", "target value must be a finite number.")
    wanted = {"distance": 2, "angle": 3}.get(target.kind, 0)
    nodes = tuple(int(i) for i in target.nodes)
    if len(nodes) != wanted:
        raise InvalidInput("invalid_target", f"a {target.kind} target takes {wanted} node indices, got {len(nodes)}.")
    if any(not 0 <= i < n for i in nodes):
        raise InvalidInput("invalid_target", f"target nodes must be node indices in [0, {n}), got {list(nodes)}.")
    if len(set(nodes)) != len(nodes):
        raise InvalidInput("invalid_target", f"target nodes must be distinct, got {list(nodes)}.")
    x = frame.positions
    size = float(np.max(np.abs(x - x.mean(axis=0)))) or 1.0
    if target.kind == "fraction":
        if not (0 < abs(value) <= 1):
            raise InvalidInput("invalid_target", "a fraction target must lie in [−1, 1] and not be 0.")
        return None
    if target.kind == "strain":
        if target.boundary is None or target.axis not in ("x", "y"):
            raise InvalidInput("invalid_target", "a strain target needs `boundary` and an axis 'x' or 'y'.")
        if frame.dim < 2 or not value > -1:
            raise InvalidInput("invalid_target", "a strain target must be above −1 on a frame of 2 or 3 dimensions.")
        return BoundaryStrain.of(x, boundary_sets(target.boundary, n), target.axis)
    j = nodes[1] if target.kind == "angle" else nodes[0]
    others = [i for i in nodes if i != j]
    if any(np.linalg.norm(x[i] - x[j]) <= DISTINCT_RTOL * size for i in others):
        raise InvalidInput(
            "invalid_target", f"target nodes {list(nodes)} include coincident nodes: the {target.kind} is not defined."
        )
    if target.kind == "distance":
        if not value > 0:
            raise InvalidInput("invalid_target", "a distance target must be positive.")
        return NodeDistance(nodes[0], nodes[1], scale=value)
    if frame.dim == 3 and not 0 < value < np.pi:
        raise InvalidInput("invalid_target", "an angle target in 3D (unsigned) must lie in (0, π).")
    return NodeAngle(*nodes)


@dataclass(frozen=True, eq=False)
class AimedMotion:
    """A motion ending exactly at its target: ``path`` the reference and the configurations on
    the way, the last one (index ``index``: 0 or the end) where the quantity is ``reached``
    (the unwrapped angle for a 2D angle; for a fraction, τ/τ_end); ``range_end`` (parameter,
    reason) of the usable range for a fraction, else None."""

    path: MotionPath
    target: MotionTarget
    reached: float
    index: int
    range_end: tuple[float, str] | None = None

    @property
    def error(self) -> float:
        """|reached − target|."""
        return abs(self.reached - self.target.value)


class TargetUnreachable(DomainError):
    """The target cannot be reached (``code`` a key of REASONS); ``best`` the path traced
    towards it, its ``reached`` the quantity's value nearest the target found on it."""

    def __init__(self, code: str, detail: str, best: AimedMotion):
        super().__init__(code, f"{REASONS[code]}: {detail}")
        self.best = best


def aim_motion(
    frame: Frame,
    target: MotionTarget,
    mode=None,
    max_step: float = 0.02,
    direction: str = "both",
    max_steps: int = 5000,
    periodic: bool = False,
) -> AimedMotion:
    """The finite motion of ``frame`` along ``mode`` (as trace_motion) continued until
    ``target`` is reached, ending exactly there (module docstring); ``periodic``: a lattice
    followed through one cell where it is tiled (periodic.trace_motion_through_cell).
    ``direction`` "both" looks both ways and keeps the nearer landing; a fraction's sign is its
    direction. InvalidInput ``invalid_target`` for a malformed target; TargetUnreachable."""
    quantity = target_quantity(target, frame)

    def trace(direction: str, stop, bisections: int = 0):
        """The motion up to TARGET_HORIZON, each direction ended where ``stop`` turns true (its
        last step shortened by ``bisections`` bisections; the cell's always by periodic's)."""
        if periodic:
            return trace_motion_through_cell(frame, mode, TARGET_HORIZON, max_step, direction, max_steps, stop)
        return trace_motion(
            frame, mode, TARGET_HORIZON, max_step, direction, max_steps, stop=stop, stop_bisections=bisections
        )

    if quantity is None:
        return _aim_fraction(frame, target, direction, trace)
    return _aim_quantity(frame, target, quantity, direction, trace)


def _aim_quantity(frame: Frame, target: MotionTarget, quantity: Quantity, direction: str, trace) -> AimedMotion:
    goal = target.value
    atol = TARGET_RTOL * quantity.scale
    q0 = quantity.value(frame.positions)
    last = {1: q0, -1: q0}  # per direction, the value where stop last said "go on"

    def stop(x, sign):
        q = quantity.value(x, last[sign])
        if (q - goal) * (last[sign] - goal) <= 0 or abs(q - goal) > abs(last[sign] - goal):
            return True
        last[sign] = q
        return False

    path = trace(direction, stop)
    ref = path.reference_index
    if abs(q0 - goal) <= atol:
        return _ending(path, target, [ref], None, q0)
    lander = _Lander(frame, path, quantity, goal)
    sides = {1: list(range(ref, len(path.parameter))), -1: list(range(ref, -1, -1))}
    landings, ends = [], []
    for sign, idx in sides.items():
        if len(idx) < 2:
            continue
        values = _followed(quantity, path.positions[idx], q0)
        if (values[-1] - goal) * (values[-2] - goal) <= 0:
            landings.append(lander.land(idx, len(idx) - 2, (0.0, None), values))
            continue
        singular = any(np.sign(s.parameter) == sign for s in path.singularities)
        turned = abs(values[-1] - goal) > abs(values[-2] - goal)
        if turned:
            found = lander.extreme(idx, len(idx) - 2, values)
            if found is not None:
                landings.append(found)
                continue
            extreme = lander.last_extreme
        else:
            extreme = values[-1]
        moved_away = len(idx) == 2 and turned and direction != "both"
        code = (
            "target_past_singular_point" if singular and not turned
            else "target_past_turning_point" if turned and not moved_away
            else "target_out_of_range"
        )
        ends.append((abs(extreme - goal), code, extreme, sign, idx))
    landings = [got for got in landings if got is not None]
    if landings:
        sign, idx, y, tau, reached = min(landings, key=lambda got: abs(got[3]))
        return _ending(path, target, [i for i in idx if abs(path.parameter[i]) < abs(tau)], (sign, y, tau), reached)
    if not ends:
        raise DomainError("not_converged", "the continuation could not leave the reference configuration.")
    _, code, extreme, sign, idx = min(ends, key=lambda e: e[0])
    best = _ending(path, target, idx, None, extreme, sign=sign)
    raise TargetUnreachable(
        code,
        f"{target.kind} {goal:.10g} asked, {extreme:.10g} the nearest reached "
        f"(along {'+' if sign > 0 else '−'}mode, path parameter up to {abs(path.parameter[idx[-1]]):.6g}).",
        best,
    )


def _aim_fraction(frame: Frame, target: MotionTarget, direction: str, trace) -> AimedMotion:
    sign = 1 if target.value > 0 else -1
    way = "forward" if sign > 0 else "backward"
    if direction not in ("both", way):
        raise InvalidInput("invalid_target", f"a fraction of sign {sign:+d} goes {way}, but direction is {direction!r}.")
    threshold = PROXIMITY_FRACTION * float(bar_lengths(frame.positions, frame.edges).min())
    joined = {tuple(sorted(e)) for e in frame.edges.tolist()}
    already = set(cKDTree(frame.positions).query_pairs(threshold))
    met = []

    def close(x, _sign):
        pairs = [p for p in cKDTree(x).query_pairs(threshold) if p not in already and tuple(sorted(p)) not in joined]
        met.extend(pairs[:1])
        return bool(pairs)

    path = trace(way, close, STOP_BISECTIONS)
    ref = path.reference_index
    idx = list(range(ref, len(path.parameter))) if sign > 0 else list(range(ref, -1, -1))
    tau_end = float(path.parameter[idx[-1]])
    reason = "singular_point" if path.singularities else "node_proximity" if met else "search_limit"
    if len(idx) < 2 or tau_end == 0.0:
        raise DomainError("not_converged", "the continuation could not leave the reference configuration.")
    tau = abs(target.value) * tau_end
    k = max(i for i, j in enumerate(idx) if abs(path.parameter[j]) <= abs(tau))
    if path.parameter[idx[k]] == tau:
        return _ending(path, target, idx[: k + 1], None, target.value, (tau_end, reason), sign)
    lander = _Lander(frame, path, None, 0.0)
    y = lander.at(idx, k, abs(tau) - abs(float(path.parameter[idx[k]])))
    if y is None:
        raise DomainError("not_converged", f"the corrector failed at path parameter {tau:.6g}.")
    return _ending(path, target, idx[: k + 1], (sign, y, tau), tau / tau_end, (tau_end, reason))


def _followed(quantity: Quantity, positions: np.ndarray, start: float) -> list[float]:
    """The quantity along consecutive configurations, each value nearest the previous one."""
    values = [start]
    for x in positions[1:]:
        values.append(quantity.value(x, values[-1]))
    return values


class _Lander:
    """Landing on the target between samples of a traced path, on the frame's own bar
    constraints (normalised by the reference: the path's parameter units)."""

    def __init__(self, frame: Frame, path: MotionPath, quantity: Quantity, goal: float):
        self.path, self.quantity, self.goal = path, quantity, goal
        ref = path.positions[path.reference_index]
        self.norm = Normalisation.of(ref)
        method = "dense" if frame.dim * frame.n_nodes <= DENSE_MAX_DOF else "sparse"
        self.cons = BarConstraints(frame.edges, self.norm.positions_in(ref), method)
        self.last_extreme = None

    def _chart(self, idx: list[int], k: int):
        """(point at sample idx[k] with its tangent towards idx[k + 1], its normalised
        configuration, the pseudo-arclength of idx[k + 1] along that tangent)."""
        xs = self.norm.positions_in(self.path.positions[idx[k]])
        ahead = self.norm.positions_in(self.path.positions[idx[k + 1]])
        point = regular_point(self.cons, xs, (ahead - xs).ravel())
        return point, xs, float(point.t @ (ahead - xs).ravel()) / np.sqrt(self.cons.measured_nodes)

    def at(self, idx: list[int], k: int, s: float):
        """The configuration (frame coordinates) at pseudo-arclength s from sample idx[k]
        towards idx[k + 1], or None."""
        point, _, _ = self._chart(idx, k)
        y = chart_at(self.cons, point, s)
        return None if y is None else self.norm.positions_out(y)

    def land(self, idx: list[int], k: int, bracket: tuple[float, float | None], values):
        """From sample idx[k] towards idx[k + 1] (away from the reference): the crossing of the
        goal at pseudo-arclength s in ``bracket`` (None: up to the next sample).  Returns
        (sign, idx, Y in the frame's coordinates, its parameter, q(Y)) or None."""
        point, xs, next_s = self._chart(idx, k)
        sqrt_n = np.sqrt(self.cons.measured_nodes)
        lo, hi = bracket
        hi = next_s if hi is None else hi
        near = values[k]
        q_of = lambda y: self.quantity.value(self.norm.positions_out(y), near)

        def miss(s):
            y = chart_at(self.cons, point, s)
            if y is None:
                raise _OffTheCurve
            return q_of(y) - self.goal

        try:
            ends = miss(lo), miss(hi)
            if ends[0] * ends[1] < 0:
                s = brentq(miss, lo, hi, xtol=TARGET_BRACKET_RTOL * abs(hi - lo))
            else:  # a sample within round-off of the goal: Newton starts from it
                s = hi if abs(ends[1]) <= abs(ends[0]) else lo
            start = chart_at(self.cons, point, s)
        except _OffTheCurve:
            return None

        def quantity(y):
            x = self.norm.positions_out(y)
            return self.quantity.value(x, near), self.norm.length * self.quantity.gradient(x)

        y = aimed_correction(self.cons, point, start, quantity, self.goal, 1e-2 * TARGET_RTOL * self.quantity.scale)
        if y is None:
            return None
        s_y = float(point.t @ (y - xs).ravel()) / sqrt_n
        sign = 1 if idx[-1] >= idx[0] else -1
        tau = float(self.path.parameter[idx[k]]) + sign * s_y
        x = self.norm.positions_out(y)
        return sign, idx, x, tau, quantity(y)[0]

    def extreme(self, idx: list[int], k: int, values):
        """Where q turned back near sample idx[k]: its extreme on the curve between the samples
        beside it (finite_motion.curve_minimum); the landing before it if the extreme passes
        the goal, else None with the extreme kept in ``last_extreme``."""
        toward = np.sign(self.goal - values[0])
        near = values[k]
        found = curve_minimum(self.path, idx[k], lambda x: -toward * self.quantity.value(x, near))
        extreme = values[k] if found is None else max(values[k], -found[1], key=lambda v: toward * v)
        self.last_extreme = extreme
        if found is None or toward * (extreme - self.goal) < 0:
            return None
        sign = 1 if idx[-1] >= idx[0] else -1
        offset = sign * (found[0] - float(self.path.parameter[idx[k]]))  # along the side, from idx[k]
        if offset >= 0:
            return self.land(idx, k, (0.0, offset), values)
        if k == 0:  # before the side's first sample, the start: the other side's trace holds it
            return None
        # The extreme lies before idx[k]: land between idx[k − 1] and it.
        before = float(self.path.parameter[idx[k]] - self.path.parameter[idx[k - 1]]) * sign
        return self.land(idx, k - 1, (0.0, before + offset), values)


class _OffTheCurve(Exception):
    """The corrector failed inside a bracket."""


def _ending(path: MotionPath, target: MotionTarget, kept: list[int], landed, reached: float, range_end=None, sign=1):
    """The AimedMotion of ``path`` restricted to the samples ``kept`` (path indices on the side
    ``sign`` of the reference, the reference first) and the landed (sign, Y, τ) if any, ordered
    by parameter; its ``index`` the end of that side."""
    ref = path.reference_index
    kept = sorted(set(kept) | {ref})
    positions = [path.positions[i] for i in kept]
    params = [float(path.parameter[i]) for i in kept]
    if landed is not None:
        sign, y, tau = landed
        y = align_to(y, path.positions[ref])
        if sign > 0:
            positions, params = positions + [y], params + [tau]
        else:
            positions, params = [y] + positions, [tau] + params
    order = np.argsort(params, kind="stable")
    positions = np.stack([positions[i] for i in order])
    params = np.asarray(params)[order]
    reference_index = int(np.flatnonzero(params == 0.0)[0])
    where = {float(t): i for i, t in enumerate(params)}
    lengths = bar_lengths(path.positions[ref], path.edges)
    trimmed = replace(
        path,
        positions=positions,
        parameter=params,
        reference_index=reference_index,
        max_relative_bar_error=max(relative_bar_error(p, path.edges, lengths) for p in positions),
        singularities=tuple(
            replace(s, step=where[s.parameter]) for s in path.singularities if landed is None and s.parameter in where
        ),
        singular_start=None if path.singular_start is None else replace(path.singular_start, step=reference_index),
    )
    sign = sign if landed is None else landed[0]
    index = 0 if sign < 0 else len(params) - 1
    return AimedMotion(trimmed, target, reached, index, range_end)
