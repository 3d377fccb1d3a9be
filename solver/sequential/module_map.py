"""A module as a one-dimensional map (Rocks, Kim, Bassett et al., arXiv 1906.08400).

A module is a frame with exactly one nontrivial zero mode and two node pairs: the input pair
(a, b) and the output pair (c, e).  Along its finite motion X(τ) (finite_motion.trace_motion,
every bar kept to NEWTON_RTOL) the two distances

    d_in(τ) = |X_a(τ) − X_b(τ)|,      d_out(τ) = |X_c(τ) − X_e(τ)|

trace a curve; between two turning points of d_in (folds, where d d_in/dτ = 0) it is the graph
of a function d_out = f(d_in): the module's map.  Its usable range is the interval of d_in
between the folds on either side of the reference configuration (or the end of the traced path
there: a singular point, or the search horizon).

Slope.  With v the module's tangent (C(X) v = 0, v not a rigid motion), f′ = ∇d_out·v / ∇d_in·v,
∇d_in·v = (X_a − X_b)·(v_a − v_b)/d_in (likewise d_out).  Any basis vector of N(C) may be used:
rigid motions leave both distances unchanged, so only the nontrivial component counts.

Exact evaluation (``ModuleMap.evaluate``).  f(d) at a d in the usable range is the d_out of the
configuration Y of the module that keeps every bar and has d_in(Y) = d, on the branch of the
reference: Gauss–Newton (least squares by QR, so a module with self-stresses is handled) on

    F(Y) = [ ½(|Y_i − Y_j|² − l_e²) for every bar;  ½(|Y_a − Y_b|² − d²);  Bᵀ(Y − Y₀) ] = 0,

B the rigid motions at the warm start Y₀ (the map's sample nearest d: the branch), batched over
all requested d at once.  Its Jacobian J is C(Y) bordered by ∇½d_in² and Bᵀ; the tangent
normalised to ∇d_in·v = 1 solves J v = [0; d_in; 0], and f′(d) = ∇d_out·v.  A fold is where J
is singular (∇d_in·v = 0 for the module's mode): f′ = ±∞ there, and the range stops before it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from zeromode.solver.analysis.normalisation import rms_radius
from zeromode.solver.analysis.rank import RTOL, nullspace
from zeromode.solver.analysis.rigidity import compatibility_matrix
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.motion.finite_motion import MotionPath, curve_minimum, trace_motion
from zeromode.solver.tolerances import FIXED_POINT_RTOL, MAP_RESIDUAL_RTOL, MAP_RTOL, MAP_STEP_RTOL

# Largest module mapped (d·N): f′ at each sample takes a dense SVD of C and the exact evaluation
# dense batched least squares, both cubic in d·N — a module is a small frame.
MAP_MAX_DOF = 400
# Search horizon of the module's motion each way (finite_motion's path parameter: RMS node
# displacement over the RMS radius); a fold of a compact module comes well before.
MAP_HORIZON = 6.0
# Continuation step of the map's samples (same units): about 1 % of a module's size per sample.
MAP_MAX_STEP = 0.02
# Gauss–Newton of the exact evaluation: at most this many iterations (its tolerances:
# tolerances.MAP_STEP_RTOL, MAP_RESIDUAL_RTOL).
EVAL_MAX_ITER = 30
# Newton solves of the homotopy along d_in that finds a configuration again on the map's branch
# when the direct solve crossed to the other one (next to a fold, where the branches meet).
HOMOTOPY_STEPS = 16


@dataclass(frozen=True, eq=False)
class Module:
    """A frame with one nontrivial zero mode, its input node pair (a, b) and output pair (c, e)."""

    frame: Frame
    input_pair: tuple[int, int]
    output_pair: tuple[int, int]

    @classmethod
    def build(cls, frame: Frame, input_pair, output_pair) -> Module:
        """Validated: each pair two distinct nodes of the frame, the pairs different, and neither
        pair joined by a bar (its distance could not change). InvalidInput otherwise."""
        pairs = []
        for name, pair in (("input_pair", input_pair), ("output_pair", output_pair)):
            try:
                p = tuple(int(i) for i in pair)
            except (TypeError, ValueError):
                raise InvalidInput("invalid_pair", f"{name} must be two node indices.") from None
            if len(p) != 2 or p[0] == p[1] or not all(0 <= i < frame.n_nodes for i in p):
                raise InvalidInput("invalid_pair", f"{name} must be two distinct nodes of the frame (0…{frame.n_nodes - 1}).")
            if {p, p[::-1]} & {tuple(e) for e in frame.edges.tolist()}:
                raise InvalidInput("invalid_pair", f"{name} {list(p)} is a bar: its distance cannot change.")
            pairs.append(p)
        if set(pairs[0]) == set(pairs[1]):
            raise InvalidInput("invalid_pair", "input_pair and output_pair must differ.")
        return cls(frame, pairs[0], pairs[1])

    def distances(self, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(d_in, d_out) of configurations (..., N, d)."""
        (a, b), (c, e) = self.input_pair, self.output_pair
        d_in = np.linalg.norm(positions[..., a, :] - positions[..., b, :], axis=-1)
        return d_in, np.linalg.norm(positions[..., c, :] - positions[..., e, :], axis=-1)


@dataclass(frozen=True)
class MapEnd:
    """One end of the usable range: ``kind`` "fold" (d_in turns back there: f′ = ±∞),
    "singular_point" (the motion meets one) or "horizon" (no end within MAP_HORIZON);
    d_in, d_out at it (a fold located on the curve by Brent's method, else the last sample)."""

    kind: str
    d_in: float
    d_out: float


@dataclass(frozen=True, eq=False)
class ModuleMap:
    """The map d_out = f(d_in) of a module on its usable range.

    d_in, d_out, slope: (P,) the samples of the branch through the reference, d_in strictly
    increasing; positions: (P, N, d) their configurations (aligned to the reference);
    lower, upper: the range's ends; path: the whole traced motion; branch: sign det J on the
    branch (branch_signs; 0 for a module with self-stresses, whose J is not square)."""

    module: Module
    d_in: np.ndarray
    d_out: np.ndarray
    slope: np.ndarray
    positions: np.ndarray
    lower: MapEnd
    upper: MapEnd
    path: MotionPath
    branch: int = 0

    @property
    def range(self) -> tuple[float, float]:
        return self.lower.d_in, self.upper.d_in

    def evaluate(self, d) -> tuple[np.ndarray, np.ndarray]:
        """(f(d), f′(d)) exactly (module docstring), for d (any shape) inside the usable range;
        DomainError ``out_of_range`` for a d outside it, ``not_converged`` if Newton fails."""
        d = np.asarray(d, dtype=float)
        self._check_range(d)
        flat = d.ravel()
        start = self.positions[self._nearest(flat)]
        values, slopes, _ = pair_map(self.module, start, flat, self.branch)
        return values.reshape(d.shape), slopes.reshape(d.shape)

    def configurations(self, d) -> np.ndarray:
        """The module's configurations (K, N, d) at input distances d (K,) on the map's branch."""
        d = np.asarray(d, dtype=float).ravel()
        self._check_range(d)
        return pair_map(self.module, self.positions[self._nearest(d)], d, self.branch)[2]

    def _nearest(self, d: np.ndarray) -> np.ndarray:
        """Index of the sample nearest each d (K,) in d_in: the warm start on the branch."""
        above = np.clip(np.searchsorted(self.d_in, d), 0, len(self.d_in) - 1)
        below = np.maximum(above - 1, 0)
        return np.where(np.abs(self.d_in[below] - d) < np.abs(self.d_in[above] - d), below, above)

    def _check_range(self, d: np.ndarray) -> None:
        lo, hi = self.range
        outside = ~((d >= lo) & (d <= hi))
        if np.any(outside):
            bad = float(d[outside].flat[0])
            raise DomainError("out_of_range", f"d_in = {bad:.10g} lies outside the map's usable range [{lo:.10g}, {hi:.10g}].")

    def iterate(self, d0: float, n: int) -> np.ndarray:
        """d_0 = d0, d_{k+1} = f(d_k) for k < n while d_k lies in the usable range: n + 1
        values, fewer where one leaves the range (that one is the last)."""
        out = [float(d0)]
        lo, hi = self.range
        while len(out) <= n and lo <= out[-1] <= hi:
            out.append(float(self.evaluate(out[-1])[0]))
        return np.asarray(out)

    def fixed_points(self) -> list[tuple[float, float]]:
        """``(d*, f′(d*))`` for every sign change of f(d) − d between samples, located by Brent's
        method on the exact f."""
        from scipy.optimize import brentq

        g = self.d_out - self.d_in
        found = []
        for k in np.flatnonzero(np.sign(g[:-1]) * np.sign(g[1:]) <= 0):
            lo, hi = self.d_in[k], self.d_in[k + 1]
            if g[k] == 0:
                star = lo
            elif g[k + 1] == 0:
                continue
            else:
                star = brentq(lambda x: float(self.evaluate(x)[0]) - x, lo, hi, xtol=FIXED_POINT_RTOL * hi, rtol=FIXED_POINT_RTOL)
            found.append((float(star), float(self.evaluate(star)[1])))
        return found


def _rigid_rows(y: np.ndarray) -> np.ndarray:
    """The rigid motions of configurations y (K, N, d) as rows (K, ρ, N·d): translations and the
    rotations about the centroid (ρ = 3 in 2D, 6 in 3D)."""
    k, n, dim = y.shape
    centred = y - y.mean(axis=1, keepdims=True)
    rows = []
    for axis in range(dim):
        t = np.zeros((k, n, dim))
        t[..., axis] = 1.0
        rows.append(t)
    for p in range(dim):
        for q in range(p + 1, dim):
            r = np.zeros((k, n, dim))
            r[..., p], r[..., q] = -centred[..., q], centred[..., p]
            rows.append(r)
    return np.stack(rows, axis=1).reshape(k, len(rows), n * dim)


def _pair_row(y: np.ndarray, pair) -> np.ndarray:
    """∇½|Y_a − Y_b|² as rows (K, N·d)."""
    a, b = pair
    k, n, dim = y.shape
    row = np.zeros((k, n, dim))
    diff = y[:, a] - y[:, b]
    row[:, a], row[:, b] = diff, -diff
    return row.reshape(k, n * dim)


def _bordered_jacobian(module: Module, y: np.ndarray, gauge: np.ndarray) -> np.ndarray:
    """J (K, B + 1 + ρ, N·d): C(Y) (paper Eq. 3, rows ∇½|Y_i − Y_j|²), ∇½d_in², the gauge."""
    e = module.frame.edges
    k, n, dim = y.shape
    diff = y[:, e[:, 0]] - y[:, e[:, 1]]
    c = np.zeros((k, len(e), n, dim))
    rows = np.arange(len(e))
    c[:, rows, e[:, 0]] = diff
    c[:, rows, e[:, 1]] = -diff
    return np.concatenate([c.reshape(k, len(e), n * dim), _pair_row(y, module.input_pair)[:, None], gauge], axis=1)


def _least_squares(j: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """argmin ‖J x − rhs‖ for each of a batch (K, M, n) with M ≥ n, by reduced QR."""
    q, r = np.linalg.qr(j)
    return np.linalg.solve(r, np.einsum("kmn,km->kn", q, rhs)[..., None])[..., 0]


def _residuals(module: Module, y: np.ndarray, d: np.ndarray, lengths2: np.ndarray):
    """(½(|Y_i − Y_j|² − l_e²) (K, B), ½(d_in² − d²) (K,), whether both are met (K,))."""
    e, (a, b) = module.frame.edges, module.input_pair
    diff = y[:, e[:, 0]] - y[:, e[:, 1]]
    g = 0.5 * (np.sum(diff * diff, axis=2) - lengths2)
    h = 0.5 * (np.sum((y[:, a] - y[:, b]) ** 2, axis=1) - d**2)
    met = (np.max(np.abs(g) / lengths2, axis=1) <= MAP_RESIDUAL_RTOL) & (np.abs(h) <= MAP_RESIDUAL_RTOL * d**2)
    return g, h, met


def _solve_at(module: Module, start: np.ndarray, d: np.ndarray) -> np.ndarray:
    """The configurations (K, N, d) with d_in = d (K,) by Gauss–Newton from ``start`` (module
    docstring); DomainError ``not_converged`` naming the first d where it fails."""
    y = np.array(start, dtype=float)
    k, n, dim = y.shape
    e = module.frame.edges
    ref = module.frame.positions
    lengths2 = np.sum((ref[e[:, 0]] - ref[e[:, 1]]) ** 2, axis=1)
    scale = rms_radius(ref)
    gauge_rows = _rigid_rows(y)
    gauge_at = np.einsum("krm,km->kr", gauge_rows, y.reshape(k, -1))
    done = np.zeros(k, dtype=bool)
    for _ in range(EVAL_MAX_ITER):
        g, h, met = _residuals(module, y, d, lengths2)
        res = np.concatenate([g, h[:, None], np.einsum("krm,km->kr", gauge_rows, y.reshape(k, -1)) - gauge_at], axis=1)
        step = _least_squares(_bordered_jacobian(module, y, gauge_rows), -res)
        done |= met & (np.max(np.abs(step), axis=1) / scale <= MAP_STEP_RTOL)
        if np.all(done):
            break
        y[~done] += step[~done].reshape(-1, n, dim)
    ok = _residuals(module, y, d, lengths2)[2]
    if not np.all(ok):
        bad = float(d[~ok][0])
        raise DomainError("not_converged", f"the module's configuration at d_in = {bad:.10g} was not found by Newton's method.")
    return y


def pair_map(module: Module, start: np.ndarray, d: np.ndarray, branch: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(d_out, f′, the configurations (K, N, d)) with d_in = d (K,), from the warm starts
    ``start`` (K, N, d) (module docstring).  With ``branch`` (±1, branch_signs of the map), a
    configuration Newton's method took to the other branch (near a fold the two are close) is
    found again by HOMOTOPY_STEPS Newton solves from its start along d_in; DomainError
    ``not_converged`` if that fails too."""
    y = _solve_at(module, start, d)
    if branch:
        wrong = branch_signs(module, y) != branch
        if np.any(wrong):
            x, d0 = start[wrong], module.distances(start[wrong])[0]
            for t in np.linspace(0.0, 1.0, HOMOTOPY_STEPS + 1)[1:]:
                x = _solve_at(module, x, d0 + t * (d[wrong] - d0))
            y[wrong] = x
            if np.any(branch_signs(module, y) != branch):
                bad = float(d[branch_signs(module, y) != branch][0])
                raise DomainError("not_converged", f"the module's configuration at d_in = {bad:.10g} was not found on the map's branch.")
    k, n, dim = y.shape
    e, (c, f) = module.frame.edges, module.output_pair
    gauge_rows = _rigid_rows(y)
    rhs = np.zeros((k, len(e) + 1 + gauge_rows.shape[1]))
    rhs[:, len(e)] = module.distances(y)[0]
    v = _least_squares(_bordered_jacobian(module, y, gauge_rows), rhs).reshape(k, n, dim)
    out = y[:, c] - y[:, f]
    d_out = np.linalg.norm(out, axis=1)
    return d_out, np.sum(out * (v[:, c] - v[:, f]), axis=1) / d_out, y


def branch_signs(module: Module, positions: np.ndarray) -> np.ndarray:
    """sign det J (K,) at configurations (K, N, d), J the bordered Jacobian of the exact
    evaluation (square for a module with B = dN − ρ − 1 bars, no self-stress): J is singular
    exactly at a fold (∇d_in·v = 0) and its determinant changes sign through one, so the sign
    tells a configuration's branch, even when samples straddle the fold."""
    return np.sign(np.linalg.det(_bordered_jacobian(module, positions, _rigid_rows(positions))))


def sample_slopes(module: Module, positions: np.ndarray) -> np.ndarray:
    """f′ at each configuration (P, N, d) from a basis of N(C) (module docstring): with g_in,
    g_out the rows ∇d_in·W, ∇d_out·W over the basis W, f′ = g_out·g_in / g_in·g_in."""
    (a, b), (c, e) = module.input_pair, module.output_pair
    slopes = []
    for x in positions:
        w = nullspace(compatibility_matrix(x, module.frame.edges, dense=True), RTOL)[0]
        w = w.reshape(x.shape[0], x.shape[1], -1)
        g_in = np.einsum("d,dz->z", x[a] - x[b], w[a] - w[b]) / np.linalg.norm(x[a] - x[b])
        g_out = np.einsum("d,dz->z", x[c] - x[e], w[c] - w[e]) / np.linalg.norm(x[c] - x[e])
        slopes.append(float(g_out @ g_in) / float(g_in @ g_in))
    return np.asarray(slopes)


def check_map_size(module: Module) -> None:
    """What module_map refuses before tracing (its pairs are Module.build's): ``too_expensive``
    above MAP_MAX_DOF degrees of freedom d·N."""
    dof = module.frame.dim * module.frame.n_nodes
    if dof > MAP_MAX_DOF:
        raise DomainError("too_expensive", f"maps are computed for modules of up to {MAP_MAX_DOF} degrees of freedom (d·N); this one has {dof}.")


def has_branch(module: Module) -> bool:
    """Whether the bordered Jacobian J of the exact evaluation (module docstring) is square, so
    that sign det J tells the map's branch: B bars + 1 input row + ρ rigid motions = d·N
    (a one-mode module without self-stress)."""
    dim = module.frame.dim
    return len(module.frame.edges) + 1 + dim * (dim + 1) // 2 == dim * module.frame.n_nodes


def module_map(module: Module, horizon: float = MAP_HORIZON, max_step: float = MAP_MAX_STEP) -> ModuleMap:
    """The map of ``module`` on its usable range (module docstring): its motion traced both ways
    from the reference until d_in turns back (a fold, located on the curve between samples),
    a singular point, or ``horizon``.  DomainError from trace_motion for a frame with no or
    several nontrivial zero modes; ``input_fixed`` if d_in does not change along the motion,
    ``reference_at_fold`` if it turns back at the reference itself, ``too_expensive`` above
    MAP_MAX_DOF."""
    check_map_size(module)
    last: dict[int, tuple[float, float]] = {}
    d_ref = float(module.distances(module.frame.positions)[0])

    def passed_fold(positions: np.ndarray, sign: int) -> bool:
        d = float(module.distances(positions)[0])
        previous, trend = last.get(sign, (d_ref, 0.0))
        change = d - previous
        last[sign] = (d, change if trend == 0.0 else trend)
        return trend != 0.0 and change * trend < 0

    path = trace_motion(module.frame, amplitude=horizon, max_step=max_step, direction="both", stop=passed_fold)
    d_in, d_out = module.distances(path.positions)
    ref = path.reference_index
    spread = np.max(np.abs(d_in - d_ref))
    if not spread > MAP_RTOL * d_ref:
        raise DomainError("input_fixed", "the input distance does not change along the module's motion: it has no map.")
    if 0 < ref < len(d_in) - 1 and (d_in[ref + 1] - d_in[ref]) * (d_in[ref - 1] - d_in[ref]) > 0:
        raise DomainError("reference_at_fold", "the module's reference configuration is a fold of its map (d_in turns back there): choose one inside a branch.")
    ends, keep = [], [ref, ref]
    for side, sign in ((0, -1), (1, 1)):
        k = ref
        while 0 < k < len(d_in) - 1 and (d_in[k + sign] - d_in[k]) * (d_in[ref + sign] - d_in[ref]) > 0:
            k += sign
        keep[side] = k
        if 0 < k < len(d_in) - 1:
            ends.append(_fold(module, path, k, d_in[k + sign] < d_in[k]))
        else:
            kind = "singular_point" if any(s.step == k for s in path.singularities) else "horizon"
            ends.append(MapEnd(kind, float(d_in[k]), float(d_out[k])))
    idx = np.arange(keep[0], keep[1] + 1)
    if d_in[idx[-1]] < d_in[idx[0]]:
        idx, ends = idx[::-1], ends[::-1]
    branch = int(branch_signs(module, module.frame.positions[None])[0]) if has_branch(module) else 0
    if branch:  # a sample within round-off of a fold may lie just past it: not a warm start
        idx = idx[branch_signs(module, path.positions[idx]) == branch]
    positions = path.positions[idx]
    return ModuleMap(module, d_in[idx], d_out[idx], sample_slopes(module, positions), positions, ends[0], ends[1], path, branch)


def _fold(module: Module, path: MotionPath, k: int, maximum: bool) -> MapEnd:
    """The fold next to sample k (an extreme of d_in on the curve between samples k − 1 and
    k + 1, by finite_motion.curve_minimum), with d_out at the same configuration."""
    sign = -1.0 if maximum else 1.0
    seen: list[tuple[float, float]] = []

    def objective(positions: np.ndarray) -> float:
        d_in, d_out = module.distances(positions)
        seen.append((sign * float(d_in), float(d_out)))
        return seen[-1][0]

    found = curve_minimum(path, k, objective)
    best = min(seen) if found is not None else (sign * float(module.distances(path.positions[k])[0]), 0.0)
    return MapEnd("fold", sign * best[0], best[1])


def two_triangle_module(
    input_half: float = 1.0,
    output_half: float = 0.8,
    height: float = 1.0,
    hinge: tuple[float, float] = (0.15, 0.45),
) -> Module:
    """The two-triangle module: two rigid triangles hinged at one node, nodes 0, 1 the input pair
    at (∓input_half, 0), nodes 2, 3 the output pair at (∓output_half, height), node 4 the hinge;
    triangles (0, 2, 4) and (1, 3, 4). 5 nodes, 6 bars: one nontrivial mode (the hinge angle),
    d_in and d_out both functions of it. Chained, module k's output pair is module k + 1's
    input pair: a ladder of hinged triangles."""
    positions = [[-input_half, 0.0], [input_half, 0.0], [-output_half, height], [output_half, height], list(hinge)]
    edges = [[0, 2], [0, 4], [2, 4], [1, 3], [1, 4], [3, 4]]
    return Module.build(Frame.build(positions, edges), (0, 1), (2, 3))
