"""A soliton: a bistable chain of modules with springs in which a switched region, bounded by a
domain wall, travels along the chain when the input is driven (arXiv 1906.08400's soliton).

The map.  The module is designed (design.design_module) for two fixed points of its map f: an
unstable one d_u with f′(d_u) = λ_u > 1 and a stable one d_s with 0 < f′(d_s) = λ_s < 1, f
increasing and without another fixed point between them (checked on the designed map).  Every
orbit d_{k+1} = f(d_k) from a d_0 strictly between them then runs monotonically from d_u to d_s:
it stays near d_u while |d_k − d_u| ≈ λ_u^k |d_0 − d_u| is small, and switches to d_s within a
few modules.  Copy k is **switched** when its input distance is past the midpoint,
s_k = (d_k − d_u)/(d_s − d_u) ≥ ½.  The **domain wall** is where s crosses ½, the fractional
index

    w(d_0) = k + (½ − s_k)/(s_{k+1} − s_k)     (s_k < ½ ≤ s_{k+1}),

undefined when the whole chain is on one side (w < 0 or w > n).  On the chain, the wall is at
the pairs' midpoints m_k = (x_{a_k} + x_{b_k})/2 (pair k = (a_k, b_k) the input pair of copy k)
interpolated as w interpolates s: with φ = w − k,

    c(w) = (1 − φ) m_k + φ m_{k+1}.                                            (wall point)

Linearised at d_u,
w ≈ const − ln|d_0 − d_u| / ln λ_u: as the drive d_0 approaches d_u the wall walks to the far end
of the chain, as it approaches d_s the wall walks to the input; the switched region is the part
of the chain beyond the wall.  ``wall_slope`` is the least-squares slope of w against
ln|d_0 − d_u| over the samples with the wall in the bulk (1 ≤ w ≤ n − 1), against −1/ln λ_u.

The springs.  One spring per copy, of stiffness k and rest length L, from an anchor node P to a
node j of the module: P is joined by two rods to the ends of a bar (p, q) (a dyad: no degree of
freedom added, P moves rigidly with the bar), and placed, in the frame of that bar, on the
perpendicular bisector of j's positions at d_u and at d_s, so that the spring's length ℓ is the
same, L, at both fixed points.  The chain's energy

    E = Σ_k k (ℓ_k − L)²/2,    ℓ_k = |x_{P_k} − x_{j_k}|                      (elastic energy)

is then exactly zero in the two **uniform states** (every copy at d_u, every copy at d_s), which
are therefore global minima of E; they are strict — the chain is bistable — when ℓ changes along
the module's motion there (ℓ′ ≠ 0).  Between them, the copies inside the wall are stretched or
compressed (ℓ ≠ L strictly inside (d_u, d_s), checked on the designed map's samples), so every
intermediate conformation costs energy: about the wall's energy while the wall is in the bulk
(the soliton), falling to zero as it leaves either end.  Among the candidates (every bar (p, q),
every node j not on it, P at one RMS radius either way along the bisector) the one chosen has
the largest max |ℓ − L| over (d_u, d_s) times the sine of the dyad's angle at P.

Reach.  The drive cannot come closer to d_u than the round-off ε·d_u of d_0, so the wall reaches
at most copy ln(|d_s − d_u|/(2ε·d_u))/ln λ_u (≈ 59 for the deployable map, λ_u = 1.8); a chain
that would need it further is refused before any work (``soliton_out_of_reach``).

Verification (every answer): the chain of n copies of the module with its anchors, built at the
orbit from the midpoint, is traced by continuation and compared with f at every sample
(chain.verify_chain: max |d_{k+1} − f(d_k)|/d_{k+1} ≤ MAP_RTOL); the samples with d_u < d_0 < d_s
are the drive.  The wall must move strictly monotonically with d_0 and over at least
n − TRAVEL_MARGIN modules; each uniform state must be a strict minimum of the full energy with
the rods as stiff springs (K = ROD_STIFFNESS_RATIO · k, verify.StiffRodEnergy): its Hessian
positive definite modulo rigid motions.  Otherwise DomainError ``soliton_not_verified`` with the
figures as ``best``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from zeromode.solver.analysis.normalisation import Normalisation, rms_radius
from zeromode.solver.analysis.rank import complement_within
from zeromode.solver.analysis.rigidity import rigid_motions
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.multistable.springs import Springs
from zeromode.solver.multistable.verify import ROD_STIFFNESS_RATIO, StiffRodEnergy
from zeromode.solver.sequential.chain import (
    MAX_MODULES,
    ChainVerification,
    SequentialDesign,
    chain_at,
    chain_of,
    verify_chain,
)
from zeromode.solver.sequential.design import REACH, design_module, fixed_point
from zeromode.solver.sequential.module_map import Module, ModuleMap, module_map
from zeromode.solver.tolerances import FIXED_POINT_RTOL, MAP_RTOL

# The wall must travel over at least n − TRAVEL_MARGIN modules of an n-module chain along the
# drive (it enters and leaves the chain within about a module of either end).
TRAVEL_MARGIN = 2
# Search horizon of the soliton chain's motion per copy (chain.CHAIN_HORIZON's units, at least
# 4): the uniform state at d_u lies at the end of a long approach (the wall walks through every
# copy, and the copies beyond it swing as it passes), past the ordinary chain's horizon.
SOLITON_HORIZON_PER_MODULE = 0.25
SOLITON_MIN_HORIZON = 4.0
# Fewest copies of a soliton chain (a wall needs room to travel).
MIN_SOLITON_MODULES = 4
# Newton steps refining a designed fixed point d* of f (f(d*) = d*) to FIXED_POINT_RTOL.
FIXED_POINT_NEWTON_STEPS = 8
# Drive samples kept as snapshots of the whole chain: those whose wall is nearest to
# k·n/(SNAPSHOTS + 1), k = 1…SNAPSHOTS (the wall at evenly spaced places along the chain).
SNAPSHOTS = 4
# A dyad whose angle at the anchor has a sine below this is refused as a candidate (nearly
# collinear: the anchor would be barely held).
MIN_DYAD_SINE = 0.3


@dataclass(frozen=True, eq=False)
class Soliton:
    """A soliton chain and the figures of its checks (module docstring; ``verified`` whether all
    hold).

    module: the designed module with its anchor (node N − 1, joined to ``anchor_bar``), spring
    from the anchor to node ``spring_node``; unstable, stable: (d*, f′(d*)); springs: on the
    chain's nodes, one per copy; drive: (P,) d_0 at the drive samples (ordered from d_u towards
    d_s; ``rows`` their indices in the verification's distances); distances: (P, n + 1); wall: (P,)
    (NaN where the chain is on one side); wall_point: (P, 2) c(w) in the chain's conformation at
    each drive sample (NaN with the wall); energy: (P,) E; travel: max − min of the wall;
    uniform: (2, N_chain, 2) the uniform states (at d_u, at d_s); uniform_energy: (2,) E there;
    uniform_hessian: (2,) the smallest eigenvalue of the stiff-rod Hessian there modulo rigid
    motions; wall_slope: dw/d ln|d_0 − d_u| fitted over the bulk; barrier: max E along the drive;
    snapshots: (SNAPSHOTS,) drive indices with the wall nearest k·n/(SNAPSHOTS + 1)."""

    module: Module
    anchor_bar: tuple[int, int]
    spring_node: int
    unstable: tuple[float, float]
    stable: tuple[float, float]
    springs: Springs
    drive: np.ndarray
    rows: np.ndarray
    distances: np.ndarray
    wall: np.ndarray
    wall_point: np.ndarray
    energy: np.ndarray
    travel: float
    required_travel: float
    monotone: bool
    uniform: np.ndarray
    uniform_energy: np.ndarray
    uniform_hessian: np.ndarray
    wall_slope: float
    barrier: float
    stiffness: float
    rod_stiffness_ratio: float
    snapshots: np.ndarray

    @property
    def verified(self) -> bool:
        return bool(self.monotone and self.travel >= self.required_travel and np.all(self.uniform_hessian > 0))


@dataclass(frozen=True, eq=False)
class SolitonDesign(SequentialDesign):
    """The designed module, its soliton chain's verification (``chain``) and the Soliton."""

    soliton: Soliton


def wall_position(distances: np.ndarray, unstable: float, stable: float) -> np.ndarray:
    """w (…,) of the module docstring for distances (…, n + 1): the fractional index where the
    switched fraction s_k = (d_k − d_u)/(d_s − d_u) first reaches ½; NaN if it never crosses."""
    s = (np.asarray(distances, dtype=float) - unstable) / (stable - unstable)
    flat = s.reshape(-1, s.shape[-1])
    out = np.full(len(flat), np.nan)
    for i, row in enumerate(flat):
        up = np.flatnonzero((row[:-1] < 0.5) & (row[1:] >= 0.5))
        if len(up):
            k = up[0]
            out[i] = k + (0.5 - row[k]) / (row[k + 1] - row[k])
    return out.reshape(s.shape[:-1])


def wall_point(positions: np.ndarray, pairs: np.ndarray, wall: np.ndarray) -> np.ndarray:
    """c(w) (…, 2) of the module docstring for conformations ``positions`` (…, N, 2) of a chain
    with ``pairs`` (n + 1, 2) and walls ``wall`` (…,); NaN where w is."""
    positions, wall = np.asarray(positions, dtype=float), np.asarray(wall, dtype=float)
    out = np.full(wall.shape + (2,), np.nan)
    finite = np.isfinite(wall)
    k = np.minimum(np.floor(wall[finite]).astype(int), len(pairs) - 2)
    phi = (wall[finite] - k)[:, None]
    middles = positions[finite][:, pairs].mean(axis=2)  # (F, n + 1, 2): m_k
    rows = np.arange(len(middles))
    out[finite] = (1 - phi) * middles[rows, k] + phi * middles[rows, k + 1]
    return out


def _refined(the_map: ModuleMap, d: float) -> tuple[float, float]:
    """(d*, f′(d*)): Newton on f(d) − d = 0 from the designed d (met to MAP_RTOL) to
    FIXED_POINT_RTOL."""
    for _ in range(FIXED_POINT_NEWTON_STEPS):
        value, slope = (float(v) for v in the_map.evaluate(d))
        step = (value - d) / (slope - 1.0)
        d -= step
        if abs(step) <= FIXED_POINT_RTOL * d:
            break
    return d, float(the_map.evaluate(d)[1])


def _bar_frame(y: np.ndarray, p: int, q: int) -> tuple[np.ndarray, np.ndarray]:
    """(origin, rotation (…, 2, 2) whose columns are the unit bar direction and its normal) of
    bar (p, q) in configurations y (…, N, 2)."""
    e = y[..., q, :] - y[..., p, :]
    e = e / np.linalg.norm(e, axis=-1, keepdims=True)
    normal = np.stack([-e[..., 1], e[..., 0]], axis=-1)
    return y[..., p, :], np.stack([e, normal], axis=-1)


def _choose_anchor(the_map: ModuleMap, d_u: float, d_s: float):
    """(bar (p, q), node j, the anchor's position in (p, q)'s frame (2,), L) by the rule of the
    module docstring; DomainError ``soliton_not_verified`` if no candidate keeps ℓ ≠ L strictly
    between the fixed points."""
    module = the_map.module
    ends = the_map.configurations([d_u, d_s])
    lo, hi = sorted((d_u, d_s))
    inner = the_map.positions[(the_map.d_in > lo * (1 + MAP_RTOL)) & (the_map.d_in < hi * (1 - MAP_RTOL))]
    if len(inner) == 0:
        inner = the_map.configurations(np.linspace(lo, hi, 9)[1:-1])
    r = rms_radius(module.frame.positions)
    best, best_score = None, 0.0
    for p, q in module.frame.edges.tolist():
        origin, rot = _bar_frame(ends, p, q)
        for j in range(module.frame.n_nodes):
            if j in (p, q):
                continue
            j_local = np.einsum("kdc,kd->kc", rot, ends[:, j] - origin)  # j at d_u, d_s in the bar's frame
            chord = j_local[1] - j_local[0]
            if np.linalg.norm(chord) <= MAP_RTOL * r:  # j rigid with the bar: no spring length changes
                continue
            across = np.array([-chord[1], chord[0]]) / np.linalg.norm(chord)
            middle = 0.5 * (j_local[0] + j_local[1])
            for sign in (1.0, -1.0):
                anchor = middle + sign * r * across  # on the bisector: equidistant from both
                rest = float(np.linalg.norm(anchor - j_local[0]))
                ell = _anchor_lengths(inner, p, q, j, anchor)
                gap = ell - rest
                if not (np.all(gap > 0) or np.all(gap < 0)):
                    continue
                bar = np.linalg.norm(module.frame.positions[q] - module.frame.positions[p])
                to_p, to_q = -anchor, np.array([bar, 0.0]) - anchor
                sine = abs(to_p[0] * to_q[1] - to_p[1] * to_q[0]) / (np.linalg.norm(to_p) * np.linalg.norm(to_q))
                score = float(np.max(np.abs(gap))) * sine
                if sine >= MIN_DYAD_SINE and score > best_score:
                    best, best_score = ((p, q), j, anchor, rest), score
    if best is None:
        raise DomainError("soliton_not_verified", "no spring from an anchor on a bar to a node of the module has "
                          "the same length at both fixed points and another length between them.")
    return best


def _anchor_lengths(y: np.ndarray, p: int, q: int, j: int, anchor: np.ndarray) -> np.ndarray:
    """|P − x_j| (K,) in configurations y (K, N, 2), P at ``anchor`` in bar (p, q)'s frame."""
    origin, rot = _bar_frame(y, p, q)
    placed = origin + np.einsum("kdc,c->kd", rot, anchor)
    return np.linalg.norm(placed - y[:, j], axis=1)


def _with_anchor(module: Module, bar: tuple[int, int], anchor: np.ndarray) -> Module:
    """The module with the anchor node appended (last), joined by rods to both ends of ``bar``."""
    y = module.frame.positions
    origin, rot = _bar_frame(y[None], *bar)
    placed = origin[0] + rot[0] @ anchor
    n = module.frame.n_nodes
    edges = np.vstack([module.frame.edges, [[bar[0], n], [bar[1], n]]])
    return Module.build(Frame.build(np.vstack([y, placed]), edges), module.input_pair, module.output_pair)


def _hessian_floor(energy: StiffRodEnergy, x: np.ndarray) -> float:
    """The smallest eigenvalue of U's Hessian at x (N, d) on the complement of the rigid motions."""
    q = complement_within(np.eye(x.size), rigid_motions(Normalisation.of(x).positions_in(x)))
    return float(np.linalg.eigvalsh(q.T @ energy.hessian(x.ravel()) @ q)[0])


def check_soliton_points(points) -> tuple[tuple[float, float], tuple[float, float]]:
    """((d_u, λ_u), (d_s, λ_s)) of the request's map points: exactly two fixed points, one with
    slope > 1 and one with slope in (0, 1); InvalidInput ``invalid_soliton`` otherwise."""
    fixed = [(p.d_in, p.slope) for p in points if p.slope is not None and p.d_in == p.d_out]
    if len(fixed) != 2 or len(points) != 2:
        raise InvalidInput("invalid_soliton", "a soliton needs exactly two fixed-point features: one unstable (slope > 1) and one stable (slope between 0 and 1).")
    unstable = [f for f in fixed if f[1] > 1]
    stable = [f for f in fixed if 0 < f[1] < 1]
    if len(unstable) != 1 or len(stable) != 1:
        raise InvalidInput("invalid_soliton", "a soliton needs one fixed point with slope > 1 (unstable) and one with slope between 0 and 1 (stable).")
    return unstable[0], stable[0]


def check_soliton(points, n_modules: int, stiffness: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """What design_soliton refuses before any work (the service's submission calls it too):
    the two fixed points (check_soliton_points, returned), the number of copies, the stiffness,
    and a chain longer than the wall can reach from the requested slope (module docstring;
    the designed module meets that slope to the design's 1e-8): DomainError
    ``soliton_out_of_reach``."""
    (d_u, s_u), stable = check_soliton_points(points)
    if not (isinstance(n_modules, (int, np.integer)) and MIN_SOLITON_MODULES <= n_modules <= MAX_MODULES):
        raise InvalidInput("invalid_modules", f"a soliton chain has {MIN_SOLITON_MODULES} to {MAX_MODULES} modules.")
    if not (np.isfinite(stiffness) and stiffness > 0):
        raise InvalidInput("invalid_stiffness", "the springs' stiffness must be a positive number.")
    reachable = np.log(abs(stable[0] - d_u) / (2 * np.finfo(float).eps * d_u)) / np.log(s_u)
    if n_modules - TRAVEL_MARGIN > reachable:
        raise DomainError(
            "soliton_out_of_reach",
            f"the wall reaches copy ln(|d_s − d_u|/(2ε·d_u))/ln f′(d_u) = {reachable:.1f} when the drive d_0 is within "
            f"round-off (ε) of d_u; {n_modules} copies need it at {n_modules - TRAVEL_MARGIN}: ask for fewer copies or a "
            "steeper unstable fixed point.")
    return (d_u, s_u), stable


def design_soliton(points, start: Module | None = None, reach: float = REACH, n_modules: int = 16,
                   stiffness: float = 1.0) -> SolitonDesign:
    """The soliton of the module docstring for map ``points`` (two fixed points, see
    check_soliton_points): the module designed for them (FeatureOutOfReach as design_module's;
    ``soliton_out_of_reach`` for more copies than the wall can reach, module docstring),
    its anchor and spring, the chain of ``n_modules`` copies verified by continuation, the drive,
    the wall and the energy.  DomainError ``soliton_not_verified`` (``best``: the SolitonDesign
    with its figures) when a check of the module docstring fails."""
    (d_u, s_u), (d_s, s_s) = check_soliton(points, n_modules, stiffness)
    design = design_module(fixed_point(d_u, s_u) + fixed_point(d_s, s_s), start, reach)
    bare = design.map
    d_u, s_u = _refined(bare, d_u)
    d_s, s_s = _refined(bare, d_s)
    lo, hi = sorted((d_u, d_s))
    between = (bare.d_in > lo * (1 + MAP_RTOL)) & (bare.d_in < hi * (1 - MAP_RTOL))  # not the fixed points' own samples
    g = bare.d_out[between] - bare.d_in[between]
    if np.any(bare.slope[between] <= 0) or not (np.all(g * (d_s - d_u) > 0)):
        raise DomainError("soliton_not_verified", "the designed map is not increasing, or has another fixed point, "
                          "between the two fixed points: orbits would not run from one to the other.")
    bar, node, anchor, rest = _choose_anchor(bare, d_u, d_s)
    module = _with_anchor(design.module, bar, anchor)
    the_map = module_map(module)
    anchor_node = module.frame.n_nodes - 1
    chain = chain_of(the_map, n_modules, 0.5 * (d_u + d_s))
    verification = verify_chain(chain, the_map, horizon=max(SOLITON_MIN_HORIZON, SOLITON_HORIZON_PER_MODULE * n_modules))
    springs = Springs(chain.nodes[:, [anchor_node, node]], np.full(n_modules, float(stiffness)), np.full(n_modules, rest))
    soliton = _drive(verification, springs, the_map, (d_u, s_u), (d_s, s_s), float(stiffness), module, bar, node)
    result = SolitonDesign(design, verification, soliton)
    if not soliton.verified:
        error = DomainError(
            "soliton_not_verified",
            f"the wall travels over {soliton.travel:.3g} modules ({'monotonically' if soliton.monotone else 'not monotonically'}; "
            f"at least {soliton.required_travel:g} required) and the uniform states' stiff-rod Hessians have smallest "
            f"eigenvalues {soliton.uniform_hessian[0]:.3g}, {soliton.uniform_hessian[1]:.3g} (both must be positive).",
        )
        error.best = result
        raise error
    return result


def _drive(verification: ChainVerification, springs: Springs, the_map: ModuleMap, unstable, stable,
           stiffness: float, module: Module, bar, node) -> Soliton:
    """The drive samples of the verified chain (d_u < d_0 < d_s, ordered from d_u), their wall
    and energy, and the uniform states' checks."""
    chain = verification.chain
    d_u, d_s = unstable[0], stable[0]
    d0 = verification.distances[:, 0]
    keep = np.flatnonzero((d0 - d_u) * (d_s - d0) > 0)
    keep = keep[np.argsort(np.abs(d0[keep] - d_u))]
    distances = verification.distances[keep]
    positions = verification.positions[keep]
    wall = wall_position(distances, d_u, d_s)
    energy = np.array([springs.energy(x) for x in positions])
    n = chain.n_modules
    finite = np.isfinite(wall)
    travel = float(np.ptp(wall[finite])) if np.any(finite) else 0.0
    monotone = bool(np.all(np.diff(wall[finite]) < 0))
    bulk = finite & (wall >= 1) & (wall <= n - 1)
    slope = float(np.polyfit(np.log(np.abs(distances[bulk, 0] - d_u)), wall[bulk], 1)[0]) if np.sum(bulk) >= 2 else float("nan")
    targets = n * np.arange(1, SNAPSHOTS + 1) / (SNAPSHOTS + 1)
    placed = np.where(finite, wall, np.inf)
    snapshots = np.array([int(np.argmin(np.abs(placed - t))) for t in targets]) if np.any(finite) else np.zeros(0, dtype=int)
    frame = chain.frame
    rods = np.linalg.norm(frame.positions[frame.edges[:, 0]] - frame.positions[frame.edges[:, 1]], axis=1)
    stiff = StiffRodEnergy(frame.edges, rods, springs, 2, ROD_STIFFNESS_RATIO * stiffness)
    uniform = np.stack([chain_at(the_map, np.full(n + 1, d)).frame.positions for d in (d_u, d_s)])
    return Soliton(
        module, tuple(bar), int(node), tuple(unstable), tuple(stable), springs, d0[keep], keep, distances, wall,
        wall_point(positions, chain.pairs, wall), energy, travel, float(n - TRAVEL_MARGIN), monotone, uniform,
        np.array([springs.energy(x) for x in uniform]), np.array([_hessian_floor(stiff, x) for x in uniform]),
        slope, float(energy.max()) if len(energy) else 0.0, stiffness, ROD_STIFFNESS_RATIO, snapshots,
    )
