"""A one-degree-of-freedom linkage whose finite motion passes through two or three given
conformations of the specified nodes (beyond the seed paper: its published version, Nature
Physics 15, 714 (2019), designs frames from prescribed initial and final conformations).

Two conformations a, b are the two-configuration design (``two_configuration``: the averaging
principle turns them into the paper's infinitesimal design).  Three conformations a, b, c are
built node by node, as in the paper's construction: an unspecified node at p^a, p^b, p^c joined
to an existing node i (positions x_i^a, x_i^b, x_i^c) keeps its bar iff

    ‖p^a − x_i^a‖² = ‖p^b − x_i^b‖² = ‖p^c − x_i^c‖².

With the unknowns z = (p^a, p^b, p^c, s_ab, s_ac) ∈ R^{3d+2} these are, per anchor i, two
*linear* equations (the analogue of the paper's Eq. 4)

    s_ab − 2 x_i^a·p^a + 2 x_i^b·p^b = ‖x_i^b‖² − ‖x_i^a‖²,
    s_ac − 2 x_i^a·p^a + 2 x_i^c·p^c = ‖x_i^c‖² − ‖x_i^a‖²,

and two quadrics common to every anchor (the analogue of Eq. 6)

    s_ab = ‖p^a‖² − ‖p^b‖²,   s_ac = ‖p^a‖² − ‖p^c‖².

A node joined to m anchors has 2m linear equations in 3d + 2 unknowns: z = z₀ + N t on an
affine space of dimension 3d + 2 − 2m, cut by the two quadrics.  zeromode joins each new node to
m = 3 anchors in 2D (finitely many points: two conics in a plane, at most 4) and m = 4 in 3D
(a curve, sampled by cutting it with random planes); either way a node removes one degree of
freedom (m − d = 1), so 2k − 4 (2D) or 3k − 7 (3D) nodes leave one nontrivial mode.  A new node
is kept only if its m bars raise the rank of C by m in all three conformations (no
self-stress, one degree of freedom fewer in each), and among those the best conditioned.

Equal bar lengths make a, b, c realisations of one frame, not points of one motion: the path is
verified by continuation of the exact finite motion (``finite_motion.trace_motion``) from a,
which must meet b and then c (ε ≤ REACHED_EPS, over all nodes, in that order) with exactly one
nontrivial zero mode at every sample of the way; its smallest σ_r/σ_max is reported as the gap.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np

from zeromode.solver.analysis.normalisation import Normalisation
from zeromode.solver.analysis.rank import decide_rank
from zeromode.solver.analysis.rigidity import Analysis, analyze, compatibility_matrix, rigid_motions
from zeromode.solver.budget import check_budget
from zeromode.solver.construction.design import check_specified_distinct
from zeromode.solver.construction.multimode import conic_intersections
from zeromode.solver.construction.two_configuration import design_two_configurations
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame, check_extent, check_positions
from zeromode.solver.motion.finite_motion import (
    MotionPath,
    align_to,
    bar_lengths,
    fidelity,
    kabsch_distance,
    trace_motion,
)
from zeromode.solver.tolerances import (
    CONSTRAINT_ATOL,
    PLACEMENT_RTOL,
    REACHED_EPS,
    RIGID_RTOL,
)

# Specified nodes a request may have: the construction adds 2k − 4 (2D) or 3k − 7 (3D) nodes and
# SPRING_ANCHORS more, and the spring program has a variable pair per two nodes not joined by a
# rod; k = 10 in 2D (34 nodes) took 7.9 s CPU at load 10, so 16 stays within a request's budget.
MAX_SPECIFIED = 16
# Bars of each added node (m): 3d + 2 − 2m ≥ 2 keeps a real solution set generic, and m − d = 1
# removes one degree of freedom per node.
ANCHORS = {2: 3, 3: 4}
# Anchor sets tried per added node (random order, seeded); candidates of the first
# CHOICE_SETS sets that qualify compete on conditioning.
MAX_ANCHOR_SETS = 200
CHOICE_SETS = 6
# Random planes cutting a one-dimensional solution curve (3D) per anchor set.
PLANES = 3
# Bars shorter or longer than these multiples of the RMS radius (normalised units) are refused:
# a very short bar nearly merges two nodes, a very long one sits far outside the design.
BAR_RANGE = (0.05, 4.0)
# Spring anchors: nodes joined by d rods to d existing nodes (a dyad in 2D, a tripod in 3D),
# count-neutral (d new coordinates, d rods), placed at random near their anchors in conformation
# a and carried rigidly by them into b and c.  They give springs points to act between whose
# distances vary along the motion in many ways: the specified nodes and the one-freedom
# construction alone leave a handful of pairs (4 for three nodes in 2D), too few for three minima.
SPRING_ANCHORS = 8
# Whole designs tried (different random anchor orders) before the path is declared unreachable.
ATTEMPTS = 6
# Newton polish of a placement on the full system (linear rows and the two quadrics).
POLISH_ITERATIONS = 6
# Continuation: the path is traced to this multiple of the chordal estimate, doubled at most
# EXTENSIONS times while the last conformation sits at its end.
PATH_MARGIN = 1.6
EXTENSIONS = 3
# The motion is also traced this far before the first conformation (as a fraction of the mean
# parameter distance between neighbouring conformations), for the energy landscape's view.
OUTER_MARGIN = 0.3
# Samples of the path between consecutive conformations (for the energy chart and the springs).
SAMPLES_PER_LEG = 60


@dataclass(frozen=True, eq=False)
class Linkage:
    """frame: the linkage in conformation a (specified nodes first, at x_S^a exactly);
    conformations: (C, N, d) every node in each conformation (rows of the specified nodes
    exact); path: the traced finite motion through a, b, c (and OUTER_MARGIN before a); parameters: (C,)
    path parameter τ of each conformation (τ_a = 0); epsilons: (C,) finite-motion fidelity of
    each (over all nodes; 0 for a); gap: smallest σ_r/σ_max of C (normalised) over the path
    samples from a to the last conformation, every one with exactly one nontrivial zero mode;
    max_length_mismatch: largest relative difference of a bar's length between conformations;
    construction: how it was built; analysis: the counts of the frame in conformation a."""

    frame: Frame
    conformations: np.ndarray
    path: MotionPath
    parameters: np.ndarray
    epsilons: np.ndarray
    gap: float
    max_length_mismatch: float
    construction: str
    analysis: Analysis

    @property
    def arclength_scale(self) -> float:
        """ds/dτ: the path parameter τ (RMS node displacement over the RMS radius r) times r√N
        is the Euclidean arc length s of the motion in R^{dN} (caller's units)."""
        return Normalisation.of(self.frame.positions).length * np.sqrt(self.frame.n_nodes)


class NoPath(DomainError):
    """``no_path``: linkages realise the conformations but no continuous motion found visits
    them in order; ``best`` (dict or None): the closest attempt's finite-motion fidelity ε of
    each conformation on the motion traced from the first (``epsilons``), their path
    parameters, how far it was traced and where it met a singular point (None: nowhere)."""

    def __init__(self, message: str, best: dict | None):
        super().__init__("no_path", message)
        self.best = best


def check_conformations(conformations, dim: int | None = None) -> np.ndarray:
    """(C, k, d) specified positions in C ∈ {2, 3} conformations, or InvalidInput/DomainError:
    equal shapes, d + 1 ≤ k ≤ MAX_SPECIFIED (``too_expensive``) distinct nodes in each, no two
    conformations related by a rigid motion (``rigid_target``)."""
    if not isinstance(conformations, (list, tuple, np.ndarray)) or len(conformations) not in (2, 3):
        raise InvalidInput("invalid_conformations", "conformations must list 2 or 3 conformations of the specified nodes.")
    first = check_positions(conformations[0], dim, "conformations[0]")
    confs = [first] + [check_positions(c, first.shape[1], f"conformations[{j}]") for j, c in enumerate(conformations[1:], 1)]
    k, d = first.shape
    for j, c in enumerate(confs):
        if c.shape != first.shape:
            raise InvalidInput("invalid_shape", f"conformations[{j}] must have {k} points like conformations[0], got {len(c)}.")
        check_extent(c, f"conformations[{j}]")
        check_specified_distinct(c)
    if k < d + 1:
        raise InvalidInput("too_few_nodes", f"a {d}D multistable design needs at least {d + 1} specified nodes, got {k}.")
    if k > MAX_SPECIFIED:
        raise DomainError(
            "too_expensive", f"a multistable design takes up to {MAX_SPECIFIED} specified nodes; this one has {k}."
        )
    x = np.stack(confs)
    for i, j in itertools.combinations(range(len(x)), 2):
        scale = max(np.linalg.norm(x[i] - x[i].mean(axis=0)), np.finfo(float).tiny)
        if kabsch_distance(x[j], x[i]) <= RIGID_RTOL * scale:
            raise DomainError(
                "rigid_target",
                f"conformations {i} and {j} differ only by a rigid motion (or are equal): a motion must deform the nodes between them.",
            )
    return x


def design_linkage(conformations, dim: int | None = None, seed: int = 0) -> Linkage:
    """A verified linkage through the conformations (C, k, d), C ∈ {2, 3} (see the module
    docstring).  DomainError ``no_linkage`` (no node can be placed), ``no_path`` (the frames
    found realise every conformation but no continuous motion visits them in order)."""
    x = check_conformations(conformations, dim)
    k = x.shape[1]
    if len(x) == 2:
        two = design_two_configurations(x[0], x[1], seed=seed)
        two_frame = (np.stack([two.frame.positions, two.final_positions]), two.frame.edges)
        construction = "two-configuration design (averaging principle)"
    else:
        construction = "three conformations (2 linear equations per anchor and two quadrics per node)"
    best_why, best, placed_any = "no node could be placed", None, False
    for attempt in range(ATTEMPTS):
        check_budget()
        rng = np.random.default_rng([seed, attempt])
        if len(x) == 2:
            positions, edges = two_frame
        else:
            norm = Normalisation.of(x[0])
            built = _build(norm.positions_in(x), rng)
            if built is None:
                continue
            positions, edges = norm.positions_out(built[0]), built[1]
        placed_any = True
        norm = Normalisation.of(positions[0])
        positions, edges = _with_spring_anchors(norm.positions_in(positions), edges, rng)
        positions = norm.positions_out(positions)
        positions[:, :k] = x  # exact, not rounded through the normalisation
        frame = Frame.build(positions[0], edges, specified=range(k))
        linkage, why, figures = _verified(frame, positions, construction)
        if linkage is not None:
            return linkage
        if best is None or (figures is not None and max(figures["epsilons"]) < max(best["epsilons"])):
            best_why, best = why, figures
    if not placed_any:
        raise DomainError(
            "no_linkage",
            "no node can be joined to the specified nodes with equal bar lengths in all three conformations "
            "(the two quadrics have no admissible real common point on any anchor set): no linkage of this construction passes through them.",
        )
    raise NoPath(f"every linkage found realises the conformations but {best_why}.", best)


def _build(xn: np.ndarray, rng: np.random.Generator):
    """Greedy placement on normalised conformations xn (3, k, d): ((3, N, d), edges (E, 2)) with one
    nontrivial mode and no self-stress in every conformation, or None."""
    d = xn.shape[2]
    m = ANCHORS[d]
    positions, edges = xn.copy(), []
    rigid = d * (d + 1) // 2
    rank = 0
    while d * positions.shape[1] - rigid - rank > 1:
        chosen = _next_node(positions, edges, rank, m, rng)
        if chosen is None:
            return None
        p, anchors = chosen
        n = positions.shape[1]
        positions = np.concatenate([positions, p[:, None, :]], axis=1)
        edges += [(a, n) for a in anchors]
        rank += m
    return positions, np.asarray(edges, dtype=np.int64).reshape(-1, 2)


def _with_spring_anchors(positions: np.ndarray, edges: np.ndarray, rng: np.random.Generator):
    """Add SPRING_ANCHORS nodes, each joined to d random existing nodes: placed at random
    within the RMS radius of its anchors' centre in conformation a, and in every other
    conformation at the point with the same rod lengths on the same side of its anchors
    (the orientation of (x_1 − x_0, …, p − x_0) kept).  Candidates whose rods are outside
    BAR_RANGE, or that cannot be carried (the rods no longer meet), are drawn again."""
    d = positions.shape[2]
    added = 0
    for _ in range(50 * SPRING_ANCHORS):
        if added == SPRING_ANCHORS:
            break
        n = positions.shape[1]
        anchors = rng.choice(n, size=d, replace=False)
        p_a = positions[0, anchors].mean(axis=0) + rng.uniform(-1, 1, d)
        radii = np.linalg.norm(p_a - positions[0, anchors], axis=1)
        side = np.sign(_orientation(positions[0, anchors], p_a))
        points = [p_a] + [_carried(positions[j, anchors], radii, side) for j in range(1, len(positions))]
        if any(p is None for p in points):
            continue
        p = np.stack(points)
        lengths = np.linalg.norm(p[:, None, :] - positions[:, anchors, :], axis=-1)
        nearest = np.min(np.linalg.norm(p[:, None, :] - positions, axis=-1))
        if np.all(lengths >= BAR_RANGE[0]) and np.all(lengths <= BAR_RANGE[1]) and nearest >= BAR_RANGE[0]:
            positions = np.concatenate([positions, p[:, None, :]], axis=1)
            edges = np.concatenate([edges, [(int(a), n) for a in anchors]])
            added += 1
    return positions, edges


def _orientation(anchors: np.ndarray, p: np.ndarray) -> float:
    """det(x_1 − x_0, …, x_{d−1} − x_0, p − x_0) for anchors (d, d): the side of p."""
    return float(np.linalg.det(np.vstack([anchors[1:] - anchors[0], p - anchors[0]])))


def _carried(anchors: np.ndarray, radii: np.ndarray, side: float) -> np.ndarray | None:
    """The point at distances ``radii`` from the d anchors (d, d) with orientation sign
    ``side``: the d − 1 differences of the sphere equations fix a line p₀ + t·n (n ⟂ the
    anchors' span), the first sphere a quadratic in t; None when the rods cannot meet."""
    spans = anchors[1:] - anchors[0]
    rhs = 0.5 * (radii[0] ** 2 - radii[1:] ** 2 + np.sum(spans**2, axis=1))
    offset = np.linalg.lstsq(spans, rhs, rcond=None)[0] if len(spans) else np.zeros(anchors.shape[1])
    normal = np.linalg.svd(spans, full_matrices=True)[2][-1] if len(spans) else None
    along = radii[0] ** 2 - offset @ offset
    if normal is None or along <= 0:
        return None
    for t in (np.sqrt(along), -np.sqrt(along)):
        p = anchors[0] + offset + t * normal
        if np.sign(_orientation(anchors, p)) == side:
            return p
    return None


def _next_node(positions: np.ndarray, edges: list, rank: int, m: int, rng):
    """The best-conditioned admissible new node ((3, d), anchors) over random anchor sets."""
    n = positions.shape[1]
    sets = list(itertools.combinations(range(n), m))
    order = rng.permutation(len(sets))[:MAX_ANCHOR_SETS]
    best, best_score, qualified = None, -np.inf, 0
    for idx in order:
        anchors = sets[idx]
        found = False
        for p in placements(positions[:, list(anchors), :], rng):
            score = _admissible(positions, edges, rank, anchors, p)
            if score is not None:
                found = True
                if score > best_score:
                    best, best_score = (p, anchors), score
        qualified += found
        if qualified >= CHOICE_SETS:
            break
    return best


def _admissible(positions, edges, rank, anchors, p) -> float | None:
    """min over conformations of σ_min/σ_max of C with the new node's bars, or None when the
    bars are too short or long, or do not raise the rank by len(anchors) in every one."""
    lengths = np.linalg.norm(p[:, None, :] - positions[:, list(anchors), :], axis=-1)
    if not (np.all(lengths >= BAR_RANGE[0]) and np.all(lengths <= BAR_RANGE[1])):
        return None
    n = positions.shape[1]
    new_edges = np.asarray(edges + [(a, n) for a in anchors], dtype=np.int64)
    score = np.inf
    for j in range(len(positions)):
        y = np.concatenate([positions[j], p[j][None]], axis=0)
        s = np.linalg.svd(compatibility_matrix(y, new_edges, dense=True), compute_uv=False)
        r, _ = decide_rank(s, PLACEMENT_RTOL)
        if r != rank + len(anchors):
            return None
        score = min(score, s[r - 1] / s[0])
    return score


def placements(anchor_positions: np.ndarray, rng: np.random.Generator) -> list[np.ndarray]:
    """Real points (3, d) joined to every anchor (anchor_positions (3, m, d)) with equal bar
    lengths in the three conformations: the linear system and the two quadrics of the module
    docstring, the affine solution set cut to a plane (random when its dimension exceeds 2)
    and the two conics intersected there (multimode.conic_intersections: the quartic resultant),
    each point polished by Newton on the full system."""
    d = anchor_positions.shape[2]
    a, b = _linear_system(anchor_positions)
    u, s, vt = np.linalg.svd(a)
    r, _ = decide_rank(s, PLACEMENT_RTOL)
    z0 = vt[:r].T @ ((u[:, :r].T @ b) / s[:r])
    if np.linalg.norm(a @ z0 - b) > CONSTRAINT_ATOL * max(1.0, np.linalg.norm(b)):
        return []
    null = vt[r:].T
    if null.shape[1] < 2:
        return []
    planes = 1 if null.shape[1] == 2 else PLANES
    out = []
    for _ in range(planes):
        if null.shape[1] == 2:
            origin, basis = z0, null
        else:
            origin = z0 + null @ rng.standard_normal(null.shape[1])
            basis = null @ np.linalg.qr(rng.standard_normal((null.shape[1], 2)))[0]
        conics = [_homogeneous(*_restricted(q, origin, basis)) for q in _quadrics(d)]
        for tau in conic_intersections(*conics, rng):
            z = _polish(a, b, origin + basis @ tau, d)
            if z is not None:
                out.append(z[: 3 * d].reshape(3, d))
    return out


def _linear_system(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A z = b (2m × (3d + 2)) of the module docstring for anchors x (3, m, d)."""
    _, m, d = x.shape
    a = np.zeros((2 * m, 3 * d + 2))
    b = np.zeros(2 * m)
    for i in range(m):
        for row, other in ((2 * i, 1), (2 * i + 1, 2)):
            a[row, :d] = -2 * x[0, i]
            a[row, other * d : (other + 1) * d] = 2 * x[other, i]
            a[row, 3 * d + other - 1] = 1.0
            b[row] = x[other, i] @ x[other, i] - x[0, i] @ x[0, i]
    return a, b


def _quadrics(d: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """(Q, g) with q(z) = zᵀQz + gᵀz for q₁ = ‖p^a‖² − ‖p^b‖² − s_ab, q₂ = ‖p^a‖² − ‖p^c‖² − s_ac."""
    out = []
    for other in (1, 2):
        q = np.zeros((3 * d + 2, 3 * d + 2))
        q[:d, :d] = np.eye(d)
        q[other * d : (other + 1) * d, other * d : (other + 1) * d] = -np.eye(d)
        g = np.zeros(3 * d + 2)
        g[3 * d + other - 1] = -1.0
        out.append((q, g))
    return out


def _homogeneous(a: np.ndarray, g: np.ndarray, c: float) -> np.ndarray:
    """The conic τᵀAτ + gᵀτ + c = 0 as the 3 × 3 matrix Q of [τ 1] Q [τ 1]ᵀ = 0."""
    q = np.zeros((3, 3))
    q[:2, :2], q[:2, 2], q[2, :2], q[2, 2] = a, g / 2, g / 2, c
    return q


def _restricted(quadric, origin: np.ndarray, basis: np.ndarray):
    """A quadric q(z) restricted to z = origin + basis·τ: (A (2×2), g (2,), c) with
    q = τᵀAτ + gᵀτ + c."""
    q, g = quadric
    return basis.T @ q @ basis, basis.T @ (2 * q @ origin + g), float(origin @ q @ origin + g @ origin)


def _polish(a: np.ndarray, b: np.ndarray, z: np.ndarray, d: int) -> np.ndarray | None:
    """Gauss–Newton on [A z − b; q₁(z); q₂(z)] = 0 from z (the conic roots carry the
    quartic's round-off); z once every equation is within CONSTRAINT_ATOL, else None."""
    quadrics = _quadrics(d)
    for _ in range(POLISH_ITERATIONS):
        residual = np.concatenate([a @ z - b, [z @ q @ z + g @ z for q, g in quadrics]])
        jacobian = np.vstack([a] + [2 * q @ z + g for q, g in quadrics])
        z = z - np.linalg.lstsq(jacobian, residual, rcond=None)[0]
    residual = np.concatenate([a @ z - b, [z @ q @ z + g @ z for q, g in quadrics]])
    return z if np.all(np.isfinite(z)) and np.max(np.abs(residual)) <= CONSTRAINT_ATOL else None


def _verified(frame: Frame, conformations: np.ndarray, construction: str):
    """(Linkage, "", None) when the continuation from conformation a (``frame``) meets every
    later conformation in order with one nontrivial mode all the way; (None, why, figures)
    otherwise, figures (NoPath.best) once the motion was traced, else None."""
    lengths = [bar_lengths(c, frame.edges) for c in conformations]
    mismatch = float(max(np.max(np.abs(ell - lengths[0]) / lengths[0]) for ell in lengths[1:]))
    a = conformations[0]
    n = frame.n_nodes
    scale = Normalisation.of(a).length * np.sqrt(n)
    chord = sum(kabsch_distance(conformations[j + 1], conformations[j]) for j in range(len(conformations) - 1)) / scale
    try:
        mode = _mode_towards(frame, conformations[1])
    except DomainError as exc:
        return None, exc.message, None
    amplitude = PATH_MARGIN * chord
    for _ in range(EXTENSIONS + 1):
        step = amplitude / (SAMPLES_PER_LEG * (len(conformations) - 1))
        try:
            path = trace_motion(frame, mode=mode, amplitude=amplitude, max_step=step, direction="forward")
        except DomainError as exc:
            return None, f"the motion cannot be traced ({exc.message})", None
        fids = [fidelity(path, range(n), a, c - a, 1.0) for c in conformations[1:]]
        if not fids[-1].at_end or path.singularities:
            break
        amplitude *= 2
    eps = np.array([0.0] + [f.epsilon for f in fids])
    taus = np.array([0.0] + [f.parameter for f in fids])
    figures = {
        "epsilons": eps.tolist(), "parameters": taus.tolist(), "traced_to": float(path.parameter[-1]),
        "singular_at": path.singularities[0].parameter if path.singularities else None,
    }
    if not np.all(eps <= REACHED_EPS):
        j = int(np.argmax(eps))
        where = f"at a singular point (parameter {path.singularities[0].parameter:.4g})" if path.singularities else "without meeting it"
        return None, f"the motion from conformation 0 passes conformation {j} at ε = {eps[j]:.2e} (> {REACHED_EPS:g}) and ends {where}", figures
    if not np.all(np.diff(taus) > 0):
        return None, f"the motion from conformation 0 meets the conformations out of order (parameters {np.round(taus, 6).tolist()})", figures
    gap = _gap_along(path, frame.edges, taus[-1])
    if gap is None:
        return None, "the frame has more than one nontrivial zero mode somewhere along the motion", figures
    path = _with_lead_in(frame, mode, path, OUTER_MARGIN * taus[-1] / (len(taus) - 1), step)
    return Linkage(frame, conformations, path, taus, eps, gap, mismatch, construction, analyze(frame, bases=False)), "", None


def _with_lead_in(frame: Frame, mode: np.ndarray, path: MotionPath, amplitude: float, step: float) -> MotionPath:
    """``path`` (forward from conformation a) with the motion before a prepended, traced
    backward to parameter −``amplitude`` (the energy landscape's view before the first
    minimum); ``path`` unchanged if that stretch meets a singular point or cannot be traced."""
    try:
        back = trace_motion(frame, mode=mode, amplitude=amplitude, max_step=step, direction="backward")
    except DomainError:
        return path
    if back.singularities:
        return path
    lead = back.reference_index  # samples before a, ordered by parameter
    return replace(
        path,
        positions=np.concatenate([back.positions[:lead], path.positions]),
        parameter=np.concatenate([back.parameter[:lead], path.parameter]),
        reference_index=path.reference_index + lead,
        max_relative_bar_error=max(path.max_relative_bar_error, back.max_relative_bar_error),
        singularities=tuple(replace(x, step=x.step + lead) for x in path.singularities),
    )


def flexes(x: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, int, np.ndarray]:
    """(C dense (N_B × dN), its rank, an orthonormal basis (dN × f) of the nontrivial zero
    modes: N(C) with the rigid motions projected out) at positions x (N, d), normalised."""
    c = compatibility_matrix(x, edges, dense=True)
    _, s, vt = np.linalg.svd(c, full_matrices=True)
    rank, _ = decide_rank(s)
    rigid = rigid_motions(x)
    null = vt[rank:].T
    u, sv, _ = np.linalg.svd(null - rigid @ (rigid.T @ null), full_matrices=False)
    return c, rank, u[:, sv > 0.5]  # singular values 1 (nontrivial) or 0 (rigid)


def _mode_towards(frame: Frame, target: np.ndarray) -> np.ndarray:
    """The frame's nontrivial zero mode (N, d), signed towards ``target`` (its first-order
    displacement dotted with the aligned target's); DomainError unless there is exactly one."""
    x = frame.normalised_positions()
    _, r, modes = flexes(x, frame.edges)
    f = modes.shape[1]
    if f != 1 or r != frame.n_edges:
        raise DomainError("no_path", f"the linkage has {f} nontrivial zero modes and {frame.n_edges - r} self-stresses in conformation 0, not one mode")
    mode = modes[:, 0].reshape(x.shape)
    towards = align_to(target, frame.positions) - frame.positions
    return mode if np.sum(mode * towards) >= 0 else -mode


def _gap_along(path: MotionPath, edges: np.ndarray, until: float) -> float | None:
    """gap_along over the path samples from τ = 0 to the one nearest ``until``."""
    last = int(np.argmin(np.abs(path.parameter - until)))
    return gap_along(path.positions[path.reference_index : last + 1], edges)


def gap_along(positions: np.ndarray, edges: np.ndarray) -> float | None:
    """Smallest σ_r/σ_max of C (normalised positions) over configurations (P, N, d), or None
    when one of them has other than one nontrivial zero mode."""
    gap = np.inf
    for x in positions:
        y = Normalisation.of(x).positions_in(x)
        s = np.linalg.svd(compatibility_matrix(y, edges, dense=True), compute_uv=False)
        r, _ = decide_rank(s)
        if y.size - r - rigid_motions(y).shape[1] != 1:
            return None
        gap = min(gap, s[r - 1] / s[0])
    return float(gap)
