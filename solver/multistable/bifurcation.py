"""Branched motions: a linkage whose one-parameter configuration space branches at a chosen
conformation (beyond the seed paper; its published version, Nature Physics 15, 714 (2019),
shows networks whose motion passes through a bifurcation).

Second-order condition.  At a configuration x, C is the compatibility matrix of Eq. 3 (row e
holds x_i − x_j at node i and x_j − x_i at node j).  A smooth motion x(t) = x + t u + t² w/2 + …
keeps every bar length iff, order by order in t,

    (x_i − x_j)·(u_i − u_j) = 0                          (C u = 0: a first-order zero mode)
    (x_i − x_j)·(w_i − w_j) + |u_i − u_j|² = 0           (C w = −q(u), q_e(u) = |u_i − u_j|²).

The second is solvable for w iff q(u) ⟂ N(Cᵀ), i.e. for every self-stress ω (Cᵀω = 0)

    Σ_e ω_e |u_i − u_j|² = 0.                                               (second order)

A branch point has two nontrivial zero modes u₁, u₂ (orthonormal, ⟂ the rigid motions) and one
self-stress ω: C lost one rank there.  For u = a u₁ + b u₂ the condition is the binary form

    Q(a, b) = A a² + 2B ab + D b² = 0,   A = Σ ω|Δu₁|²,  B = Σ ω Δu₁·Δu₂,  D = Σ ω|Δu₂|²

(Δu_e = u_i − u_j).  Rigid motions add nothing to Q: an equilibrium stress has
Σ_e ω_e Δx_e⊗Δx_e = Σ_e ω_e Δx_e⊗Δu_e = 0, so a rotation's terms cancel.  Q has two real root
lines iff M = [[A, B], [B, D]] is indefinite (B² > AD; eigenvalues λ₋ < 0 < λ₊, unit eigenvectors
e₋, e₊): (a, b) = √λ₊ e₋ ± √(−λ₋) e₊, since Q of those is λ₋λ₊ + λ₊(−λ₋) = 0.  The configuration
space near x is then two smooth curves crossing with these tangents (the reduced equation of
the Lyapunov–Schmidt reduction is Q/2 plus higher order, a non-degenerate saddle); Q definite
would make x an isolated, rigid point.

Construction (2D): the branching dyad.  A one-freedom linkage through the conformations
(linkage.design_linkage) moves with tangent x′ at conformation j.  A node q is fixed to a rod
(u, v) (two rods: count-neutral, rigid on (u, v)); the body's velocity field is
v(y) = x′_u + θ J(y − x_u) (J the quarter turn, θ its angular speed).  The distance d = |q − x_w|
to another node w has d d′ = (q − x_w)·(v(q) − x′_w) = (q − x_w)·g with g = v(x_w) − x′_w
(the term θ(q − x_w)·J(q − x_w) vanishes), so d is stationary at j iff q lies on the line through
x_w perpendicular to g: q is placed there (a random distance along it).  A node p then joins q
and w: if d has its largest value over the motion at j, p sits on the segment between them
(|p − q| + |p − w| = d_j, "stretched"); if its smallest, beyond q on the ray from w
(|p − w| − |p − q| = d_j, "folded").  At j the dyad's rods are parallel; the load they put on q
and w along the line is resolved by the rest (d′ = 0: the virtual rod q–w's row lies in C's row
space), so the frame gains one self-stress and one mode (p across the line).  Near j, p's offset
s from the line obeys s² ∝ ±(d_j − d(τ)) ≈ ∓d″(τ − τ_j)²/2: two branches s = ±κ(τ − τ_j), every
other node moving alike on both.  The motion through the conformations takes the branch that
carries p from side σ of the line (before j) to −σ (after); the other carries it from −σ to σ,
so a motion arriving on the first could leave along the second's half with p back on side σ
(p touches the line and returns).  Among the candidates (rod, w, distance, p's split) the one with the
largest min(σ_kept/σ_max at j, σ_min/σ_max at the other conformations)·sin(angle) is tried
first: far from a second rank drop at j, the dyad well bent where the springs must hold a
minimum (nearly straight, its rods hold p across the line only to second order: a soft
direction the springs' prestress buckles, measured as relaxations sliding 0.2–0.3 of the
radius away), branches well apart.  Why a dyad: a node of the three-conformation construction made stationary there would
need one more equation than its unknowns allow (2D: its placements are already a finite set).

Verification: at j an SVD of C gives the rank drop (σ_dropped/σ_max, the smallest kept σ/σ_max)
and the two tangents; each is continued (_through: a short step off the branch point, then
finite_motion.trace_motion both ways).  The branch taken must meet every other conformation in
order (ε ≤ REACHED_EPS); the other is followed BRANCH_FOLLOW of the way to the nearest
conformation, without a singular point, its bars at their lengths, its configurations apart
from the taken branch's.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from zeromode.solver.analysis.normalisation import Normalisation
from zeromode.solver.analysis.rigidity import analyze, compatibility_matrix
from zeromode.solver.budget import check_budget
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame
from zeromode.solver.motion.finite_motion import (
    BarConstraints,
    MotionPath,
    align_to,
    fidelity,
    kabsch_distance,
    trace_motion,
)
from zeromode.solver.multistable.linkage import (
    BAR_RANGE,
    EXTENSIONS,
    PATH_MARGIN,
    SAMPLES_PER_LEG,
    Linkage,
    _carried,
    _orientation,
    design_linkage,
    flexes,
    gap_along,
)
from zeromode.solver.tolerances import NEWTON_RTOL, REACHED_EPS, STATIONARY_RTOL

# Linkages (design_linkage with seeds seed, seed + 1, …) tried for a branching dyad.
LINKAGES = 3
# Candidate dyads tried per linkage, and how many qualified ones compete on conditioning.
CANDIDATES = 60
CHOICE = 8
# q's distance from w along the line of stationary d (normalised units: RMS radius 1).
REACH = (0.3, 1.2)
# Where p splits the stretched dyad (|p − q| / d_j), or how far beyond q it sits (folded).
SPLIT = (0.3, 0.7)
# The dyad must stay this far (relative to d_j) from its other bound along the whole motion.
BOUND_MARGIN = 0.05
# Smallest angle between the two branches' tangents accepted (degrees): nearly tangent branches
# are not told apart by a continuation.
MIN_ANGLE = 10.0
# Each way along a branch starts this fraction of the nearest conformation's parameter distance
# from the branch point (see _through), and Gauss–Newton takes START_NEWTON steps to get there.
START_FRACTION = 0.05
START_NEWTON = 12
# The other branch is followed this fraction of the parameter distance to the nearest conformation.
BRANCH_FOLLOW = 0.25


@dataclass(frozen=True, eq=False)
class BranchPoint:
    """The branch analysis of a frame at one configuration (normalised positions):
    singular_values (N_B,) of C over σ_max; rank; modes (dN, 2) u₁, u₂; stress (N_B,) ω, unit;
    form (A, B, D) of Q; tangents (2, N, d) unit, the two root lines of Q; angle (degrees, in
    (0, 90]) between them as lines."""

    singular_values: np.ndarray
    rank: int
    modes: np.ndarray
    stress: np.ndarray
    form: tuple[float, float, float]
    tangents: np.ndarray
    angle: float

    @property
    def sigma_kept(self) -> float:
        """Smallest kept σ/σ_max (the gap to the dropped one)."""
        return float(self.singular_values[self.rank - 1])

    @property
    def sigma_dropped(self) -> float:
        """σ/σ_max of the singular value lost at the branch point."""
        return float(self.singular_values[self.rank])


@dataclass(frozen=True, eq=False)
class BranchFollowed:
    """One branch continued from the branch point: parameters (lo, hi) reached (normalised
    units of the branch point), the largest relative bar-length error on it, and its
    separation: the smallest Kabsch distance of its end configurations from the other branch's
    path, over their distance from the branch point (0 would mean the same curve)."""

    reach: tuple[float, float]
    max_relative_bar_error: float
    separation: float
    singular: bool


@dataclass(frozen=True, eq=False)
class Bifurcation:
    """index: the conformation where the motion branches; point: its BranchPoint; taken: the
    index (0/1) of point.tangents the motion follows (signed towards the next conformation, or
    away from the previous one at the last); taken_path, other: the two branches continued;
    dyad: (q, p) the added nodes, rod (u, v) and w, and ``kind`` ("stretched" or "folded")."""

    index: int
    point: BranchPoint
    taken: int
    taken_tangent: np.ndarray
    other_tangent: np.ndarray
    taken_branch: BranchFollowed
    other_branch: BranchFollowed
    dyad_nodes: tuple[int, int]
    dyad_kind: str


class NoBifurcation(DomainError):
    """``no_bifurcation``: no linkage found branches at the conformation; ``best`` (dict or
    None) the best candidate's figures."""

    def __init__(self, message: str, best: dict | None):
        super().__init__("no_bifurcation", message)
        self.best = best


def branch_point(x: np.ndarray, edges: np.ndarray) -> BranchPoint | None:
    """The BranchPoint of the frame at normalised positions x (N, d) (module docstring), or None
    unless C has exactly two nontrivial zero modes and one self-stress with Q indefinite."""
    c, rank, modes = flexes(x, edges)
    if modes.shape[1] != 2 or c.shape[0] - rank != 1:
        return None
    u, s, _ = np.linalg.svd(c)
    omega = u[:, -1]
    du = [m.reshape(x.shape)[edges[:, 0]] - m.reshape(x.shape)[edges[:, 1]] for m in modes.T]
    a, b, d = (float(np.sum(omega * np.sum(p * q, axis=1))) for p, q in ((du[0], du[0]), (du[0], du[1]), (du[1], du[1])))
    lam, vec = np.linalg.eigh(np.array([[a, b], [b, d]]))
    if not (lam[0] < 0 < lam[1]):
        return None
    roots = [np.sqrt(lam[1]) * vec[:, 0] + sign * np.sqrt(-lam[0]) * vec[:, 1] for sign in (1.0, -1.0)]
    tangents = np.stack([(modes @ r / np.linalg.norm(r)).reshape(x.shape) for r in roots])
    cos = abs(float(np.sum(tangents[0] * tangents[1])))
    padded = np.concatenate([s / s[0], np.zeros(max(0, c.shape[0] - s.size))])
    return BranchPoint(padded, rank, modes, omega, (a, b, d), tangents, float(np.degrees(np.arccos(min(1.0, cos)))))


def design_branched_linkage(conformations: np.ndarray, index: int, seed: int = 0) -> tuple[Linkage, Bifurcation]:
    """A one-freedom linkage through the conformations (C, k, 2) whose motion branches at
    conformation ``index`` (module docstring): (Linkage with the motion along the branch taken,
    Bifurcation).  NoBifurcation when no candidate branches there and continues to every
    conformation; DomainError from design_linkage (``no_linkage``, ``no_path``) for the linkage."""
    best: dict | None = None
    why = "no dyad makes the distance it spans extremal over the motion at the conformation"
    for attempt in range(LINKAGES):
        base = design_linkage(conformations, seed=seed + attempt)
        rng = np.random.default_rng([seed, attempt, index])
        for candidate in _dyads(base, index, rng):
            check_budget()
            got, figures = _verified(base, index, candidate)
            if got is not None:
                return got
            if best is None or figures["score"] > best["score"]:
                best, why = figures, figures["why"]
    raise NoBifurcation(f"no linkage found branches at conformation {index}: {why}.", best)


def check_bifurcation(index, x: np.ndarray) -> None:
    """InvalidInput ``invalid_bifurcation`` unless ``index`` names one of three 2D conformations x
    (the branching dyad is planar; the other two conformations become the minima)."""
    if len(x) != 3 or x.shape[2] != 2:
        raise InvalidInput(
            "invalid_bifurcation",
            "a branched design takes three 2D conformations: the branch point and two minima of the springs' energy.",
        )
    if not (isinstance(index, (int, np.integer)) and 0 <= index < 3):
        raise InvalidInput("invalid_bifurcation", f"bifurcation must be the index of a conformation (0, 1 or 2), got {index!r}.")



@dataclass(frozen=True, eq=False)
class _Dyad:
    """positions (C, N + 2, d) normalised, every node in each conformation with q, p last; edges
    with the dyad's four rods; point: the BranchPoint at the conformation; kind; score."""

    positions: np.ndarray
    edges: np.ndarray
    point: BranchPoint
    kind: str
    score: float


def _dyads(base: Linkage, j: int, rng: np.random.Generator) -> list[_Dyad]:
    """Qualified branching dyads on ``base`` at conformation j, best first (module docstring)."""
    norm = Normalisation.of(base.frame.positions)
    x = norm.positions_in(base.conformations)
    samples = norm.positions_in(base.path.positions)
    before = base.path.parameter < base.parameters[j]  # samples on the first side of j
    edges = base.frame.edges
    _, _, modes = flexes(x[j], edges)
    t = modes[:, 0].reshape(x[j].shape)
    n = x.shape[1]
    found = []
    for _ in range(CANDIDATES):
        if len(found) >= CHOICE:
            break
        u, v = edges[rng.integers(len(edges))]
        w = int(rng.choice([i for i in range(n) if i not in (u, v)]))
        span = x[j, v] - x[j, u]
        theta = (t[v] - t[u]) @ _quarter(span) / (span @ span)
        g = t[u] + theta * _quarter(x[j, w] - x[j, u]) - t[w]
        if np.linalg.norm(g) <= STATIONARY_RTOL:
            continue
        q_j = x[j, w] + rng.choice([-1.0, 1.0]) * rng.uniform(*REACH) * _quarter(g) / np.linalg.norm(g)
        dyad = _placed(x, samples, before, j, (int(u), int(v), w), q_j, rng.uniform(*SPLIT), rng.choice([-1.0, 1.0]))
        if dyad is None:
            continue
        positions, kind = dyad
        full = np.concatenate([edges, [(u, n), (v, n), (n, n + 1), (w, n + 1)]]).astype(np.int64)
        point = branch_point(positions[j], full)
        if point is None or point.angle < MIN_ANGLE:
            continue
        # Elsewhere the dyad must be well bent: nearly straight, its rods hold p across the line
        # q–w only to second order, a soft direction the springs' prestress can buckle.
        regular = min(_smallest_sigma(positions[i], full) for i in range(len(positions)) if i != j)
        found.append(_Dyad(positions, full, point, kind, min(point.sigma_kept, regular) * np.sin(np.radians(point.angle))))
    return sorted(found, key=lambda c: -c.score)


def _smallest_sigma(x: np.ndarray, edges: np.ndarray) -> float:
    """σ_min/σ_max of C at normalised positions x (N, d) (rows = bars ≤ dN)."""
    s = np.linalg.svd(compatibility_matrix(x, edges, dense=True), compute_uv=False)
    return float(s[-1] / s[0])


def _quarter(y: np.ndarray) -> np.ndarray:
    """J y: y turned a quarter counter-clockwise."""
    return np.array([-y[1], y[0]])


def _placed(x, samples, before, j, nodes, q_j, split, side):
    """((C, N + 2, d) positions with q, p appended, kind) or None: q carried rigidly by rod
    (u, v) into every conformation and path sample; p stretched or folded at j as d(τ) = |q − w|
    is largest or smallest there over the path, on side ``side`` of q→w before j and −side after."""
    u, v, w = nodes
    anchors = [u, v]
    radii = np.linalg.norm(q_j - x[j, anchors], axis=1)
    turn = np.sign(_orientation(x[j, anchors], q_j))
    carry = lambda y: _carried(y[anchors], radii, turn)
    q = [carry(y) for y in x]
    q_path = [carry(y) for y in samples]
    if any(p is None for p in q + q_path):
        return None
    q, q_path = np.stack(q), np.stack(q_path)
    d_j = float(np.linalg.norm(q[j] - x[j, w]))
    d = np.linalg.norm(q_path - samples[:, w], axis=1)
    if np.all(d <= d_j * (1 + STATIONARY_RTOL)):
        kind, r_q, r_w = "stretched", split * d_j, (1 - split) * d_j
        clear = np.all(d >= abs(r_q - r_w) + BOUND_MARGIN * d_j)
    elif np.all(d >= d_j * (1 - STATIONARY_RTOL)):
        kind, r_q, r_w = "folded", split * d_j, (1 + split) * d_j
        clear = np.all(d <= r_q + r_w - BOUND_MARGIN * d_j)
    else:
        return None
    if not clear or not (BAR_RANGE[0] <= min(r_q, r_w, *radii) and max(r_q, r_w, *radii) <= BAR_RANGE[1]):
        return None
    p = []
    for i, y in enumerate(x):
        sign = 0.0 if i == j else (side if i < j else -side)
        p.append(_dyad_point(q[i], y[w], r_q, r_w, sign))
    positions = np.concatenate([x, q[:, None, :], np.stack(p)[:, None, :]], axis=1)
    gaps = np.linalg.norm(positions[:, -2:, None, :] - positions[:, None, :-2, :], axis=-1)
    if np.min(gaps[:, 0, [i for i in range(x.shape[1]) if i not in anchors]]) < BAR_RANGE[0]:
        return None
    others = [i for i in range(x.shape[1]) if i != w]
    if np.min(gaps[:, 1, others]) < BAR_RANGE[0]:
        return None
    return positions, kind


def _dyad_point(q: np.ndarray, w: np.ndarray, r_q: float, r_w: float, sign: float) -> np.ndarray:
    """The point at distances r_q from q and r_w from w on side ``sign`` of q→w (0: on the
    line; the law of cosines clipped to [−1, 1] where the distance sits at its bound)."""
    span = w - q
    d = np.linalg.norm(span)
    along = np.clip((r_q**2 + d**2 - r_w**2) / (2 * r_q * d), -1.0, 1.0)
    e = span / d
    return q + r_q * (along * e + sign * np.sqrt(1 - along**2) * _quarter(e))


def _verified(base: Linkage, j: int, dyad: _Dyad):
    """((Linkage, Bifurcation), figures) when the branch taken from conformation j meets every
    other conformation in order and the other branch continues; (None, figures) otherwise."""
    norm = Normalisation.of(base.frame.positions)
    conformations = norm.positions_out(dyad.positions)
    k = len(base.frame.specified)
    conformations[:, :k] = base.conformations[:, :k]
    frame_j = Frame.build(conformations[j], dyad.edges, specified=range(k))
    point = dyad.point
    figures = {
        "score": dyad.score, "angle_degrees": point.angle, "sigma_kept": point.sigma_kept,
        "sigma_dropped": point.sigma_dropped, "kind": dyad.kind,
    }
    others = [i for i in range(len(conformations)) if i != j]
    # The base path's parameters (normalised by conformation a) say how far the others lie.
    legs = np.abs(np.delete(base.parameters, j) - base.parameters[j])
    reach = PATH_MARGIN * float(np.max(legs))
    step = reach / (SAMPLES_PER_LEG * (len(conformations) - 1))
    start = START_FRACTION * float(np.min(legs))
    # The branch whose tangent points more nearly at the neighbouring conformation is traced
    # first; the other only if that one does not meet them all (p is on one side of q–w in
    # each conformation, so at most one branch can).
    neighbour = conformations[j + 1] if j + 1 < len(conformations) else conformations[j - 1]
    towards = align_to(neighbour, conformations[j]) - conformations[j]
    order = np.argsort([-abs(float(np.sum(t * towards))) for t in point.tangents])
    taken, worst = None, []
    for candidate in order:
        path, got = _traced(frame_j, point.tangents[candidate], conformations, j, start, reach, step)
        if got is not None and all(f.epsilon <= REACHED_EPS for f in got) and _in_order(np.array([f.parameter for f in got]), j):
            taken = int(candidate)
            break
        worst.append(np.inf if got is None else max(f.epsilon for f in got))
    if taken is None:
        figures.update(epsilons=worst, why=(
            f"neither branch's continuation meets every other conformation in order (smallest worst ε {min(worst):.2e}, "
            f"{REACHED_EPS:g} needed)"
        ))
        return None, figures
    taus = np.array([f.parameter for f in got])
    towards = taus[others.index(j + 1)] if j + 1 < len(conformations) else -taus[others.index(j - 1)]
    sign = 1.0 if towards > 0 else -1.0
    follow = BRANCH_FOLLOW * float(np.min(np.abs(taus)))
    other = _through(frame_j, point.tangents[1 - taken], start, follow, follow / 10)
    if other is None or other.singularities:
        figures.update(why="the other branch is not continued past its first steps")
        return None, figures
    other_followed = _followed(other, path)
    if not other_followed.separation > 0:
        figures.update(why="the other branch's continuation falls back onto the branch taken")
        return None, figures
    parameters = np.insert(sign * taus, j, 0.0)
    eps = np.insert(np.array([f.epsilon for f in got]), j, 0.0)
    linkage = _linkage(base, j, frame_j, conformations, path if sign > 0 else _reversed(path), parameters, eps)
    if linkage is None:
        figures.update(why="the motion has more than one nontrivial zero mode away from the branch point")
        return None, figures
    bifurcation = Bifurcation(
        j, point, taken, sign * point.tangents[taken], point.tangents[1 - taken], _followed(path, other), other_followed,
        (base.frame.n_nodes, base.frame.n_nodes + 1), dyad.kind,
    )
    return (linkage, bifurcation), figures


def _traced(frame_j: Frame, tangent: np.ndarray, conformations: np.ndarray, j: int, start: float, reach: float, step: float):
    """(path along the branch with ``tangent`` through conformation j, the Fidelity of every
    other conformation on it), the amplitude doubled at most EXTENSIONS times while one of them
    sits at an end; (None, None) when the branch cannot be traced."""
    others = [i for i in range(len(conformations)) if i != j]
    amplitude, path, got = reach, None, None
    for _ in range(EXTENSIONS + 1):
        path = _through(frame_j, tangent, start, amplitude, step)
        if path is None:
            return None, None
        got = [fidelity(path, range(frame_j.n_nodes), conformations[j], conformations[i] - conformations[j], 1.0) for i in others]
        if not any(f.at_end for f in got) or path.singularities:
            break
        amplitude *= 2
    return path, got


def _through(frame: Frame, tangent: np.ndarray, start: float, amplitude: float, step: float) -> MotionPath | None:
    """The branch with unit ``tangent`` (N, d) through the branch point ``frame`` (its reference,
    parameter 0), traced to ±``amplitude``: the continuation cannot leave a branch point itself
    (its corrector holds both first-order modes fixed), so each way starts at the configuration
    y± = x ± start·√N·t corrected by Gauss–Newton with minimum-norm steps (⟂ N(C(y)), so it does
    not slide along the branch), where C has one nontrivial mode again, and is traced from there
    onwards (finite_motion.trace_motion).  None when a start does not converge."""
    norm = Normalisation.of(frame.positions)
    x = norm.positions_in(frame.positions)
    cons = BarConstraints(frame.edges, x, "dense")
    sides = []
    for sign in (-1.0, 1.0):
        y = x + sign * start * np.sqrt(frame.n_nodes) * tangent
        for _ in range(START_NEWTON):
            y = y - np.linalg.lstsq(cons.jacobian(y), cons.residual(y), rcond=None)[0].reshape(y.shape)
        if not cons.error(y) <= NEWTON_RTOL:
            return None
        _, _, modes = flexes(y, frame.edges)
        if modes.shape[1] != 1:
            return None
        mode = modes[:, 0].reshape(y.shape)
        mode = mode if np.sum(mode * (y - x)) > 0 else -mode
        offset = np.sqrt(np.mean(np.sum((y - x) ** 2, axis=1)))  # RMS displacement: τ of y
        try:
            leg = trace_motion(Frame.build(norm.positions_out(y), frame.edges), mode=mode, amplitude=amplitude - offset,
                               max_step=step, direction="forward")
        except DomainError:
            return None
        sides.append((leg, offset, cons.error(y)))
    (back, b_off, b_err), (ahead, a_off, a_err) = sides
    positions = np.concatenate([back.positions[::-1], frame.positions[None], ahead.positions])
    parameter = np.concatenate([-(b_off + back.parameter[::-1]), [0.0], a_off + ahead.parameter])
    reference = len(back.parameter)
    return MotionPath(
        positions, parameter, reference, max(back.max_relative_bar_error, ahead.max_relative_bar_error, b_err, a_err),
        tuple(replace(s, step=reference - s.step, parameter=-(b_off + s.parameter)) for s in back.singularities)
        + tuple(replace(s, step=reference + 1 + s.step, parameter=a_off + s.parameter) for s in ahead.singularities),
        frame.edges, ahead.method,
    )


def _in_order(taus: np.ndarray, j: int) -> bool:
    """The other conformations' parameters on one side of j each, monotone in their index."""
    signed = np.insert(taus, j, 0.0)
    steps = np.diff(signed)
    return bool(np.all(steps > 0) or np.all(steps < 0))


def _reversed(path: MotionPath) -> MotionPath:
    """The same path parametrised the other way (τ → −τ)."""
    return replace(
        path, positions=path.positions[::-1], parameter=-path.parameter[::-1],
        reference_index=len(path.parameter) - 1 - path.reference_index,
        singularities=tuple(replace(s, step=len(path.parameter) - 1 - s.step, parameter=-s.parameter) for s in path.singularities),
    )


def _followed(path: MotionPath, against: MotionPath) -> BranchFollowed:
    """BranchFollowed of ``path`` (from the branch point) measured against the other branch."""
    ref = path.positions[path.reference_index]
    seps = []
    for end in (path.positions[0], path.positions[-1]):
        moved = kabsch_distance(end, ref)
        if moved > 0:
            seps.append(min(kabsch_distance(end, y) for y in against.positions) / moved)
    return BranchFollowed(
        (float(path.parameter[0]), float(path.parameter[-1])), float(path.max_relative_bar_error),
        float(min(seps)) if seps else 0.0, bool(path.singularities),
    )


def _linkage(base: Linkage, j: int, frame_j: Frame, conformations: np.ndarray, path: MotionPath, parameters: np.ndarray, eps: np.ndarray):
    """The branched Linkage: the frame in conformation a, the path re-based to τ_a = 0 (its
    parameter rescaled from the branch point's RMS radius to a's), the gap over the samples
    between the first and last conformations without the branch point; None if one of them
    has other than one nontrivial mode."""
    ratio = Normalisation.of(frame_j.positions).length / Normalisation.of(conformations[0]).length
    tau = (path.parameter - parameters[0]) * ratio
    parameters = (parameters - parameters[0]) * ratio
    first, last = (int(np.argmin(np.abs(tau - t))) for t in (parameters[0], parameters[-1]))
    inside = [i for i in range(first, last + 1) if i != path.reference_index]
    gap = gap_along(path.positions[inside], frame_j.edges)
    if gap is None:
        return None
    start = int(np.argmin(np.abs(tau)))
    path = replace(path, parameter=tau, reference_index=start)
    frame = Frame.build(conformations[0], frame_j.edges, specified=frame_j.specified)
    lengths = [np.linalg.norm(c[frame.edges[:, 0]] - c[frame.edges[:, 1]], axis=1) for c in conformations]
    mismatch = float(max(np.max(np.abs(ell - lengths[0]) / lengths[0]) for ell in lengths[1:]))
    construction = base.construction + f"; a branching dyad makes conformation {j} a bifurcation"
    return Linkage(frame, conformations, path, parameters, eps, gap, mismatch, construction, analyze(frame, bases=False))


def minima_view(linkage: Linkage, minima: tuple[int, ...]) -> Linkage:
    """The linkage as the springs see it: only the conformations ``minima`` (their rows of
    conformations, parameters and ε), the path's parameter shifted so that the first of them
    is at τ = 0 (springs.design_springs measures the landscape from there)."""
    keep = list(minima)
    t0 = float(linkage.parameters[keep[0]])
    path = replace(
        linkage.path, parameter=linkage.path.parameter - t0,
        reference_index=int(np.argmin(np.abs(linkage.path.parameter - t0))),
    )
    return replace(
        linkage, conformations=linkage.conformations[keep], path=path,
        parameters=linkage.parameters[keep] - t0, epsilons=linkage.epsilons[keep],
    )
