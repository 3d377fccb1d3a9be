"""Allostery inside a given network: the smallest change to a rigid frame that makes a prescribed
response exact (paper: solution spaces, Eqs. 4–6, and judicious placement, Eq. 7, applied
hierarchically to nodes of a frame that is already there — the Discussion's "judicious
constraint addition on non-bipartite networks").

Task. A rigid frame (no nontrivial zero mode), source nodes S and target nodes T, and the
response: either motions u_S, u_T (drive S with u_S, T must move with u_T), or for two pairs a
strain ratio η* = ε_T/ε_S with ε_p = (x_i − x_j)·(u_i − u_j)/|x_i − x_j|² (the tuning-by-pruning
literature's target; benchmarks/pruning.py). Exact means: the modified frame has exactly one
nontrivial zero mode, it carries the response, and so driving the source gives the target's
motion (or strain) to round-off, whatever the bars' stiffnesses.

Construction. The rest of the network — the ground — stays still (u = 0); only the moving nodes
M move:
  * motions: M = S ∪ T with u_S, u_T; or, for a strain ratio, one node of each pair, which keeps
    d − 1 of its bars to the ground and so swings perpendicular to them (1 degree of freedom),
    scaled so that ε_S = 1 and ε_T = η* (the other node of each pair is ground);
  * removed: every bar the motion strains, (x_i − x_j)·(u_i − u_j) ≠ 0 — none else is touched;
  * added: unspecified nodes on solution spaces (hierarchy.place_module), first around a site
    whose nodes kept more than one degree of freedom relative to the ground (anchors: the site
    and its ground neighbours), until the site moves only along its prescribed motion; then one
    coupler joining a source node, a target node and d − 1 ground nodes (d + 1 bars), which
    ties the two one-degree-of-freedom sites into the single nontrivial mode.
The ground is the given frame less the bars removed; it must stay rigid (the frame's own analysis
decides, see ``verify``). The response is verified from the modified frame alone
(allostery.response, a least-squares solve with the source rows fixed) and so is the count of
zero modes. A strain ratio tries the pair nodes and kept bars with the fewest changes first.
A similar request (the network and motions translated, rotated, rescaled) gets the similar answer:
added nodes are placed in their anchors' own canonical frame (``_similar_module``).
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from zeromode.solver.analysis.eigen import smallest_eigenpairs
from zeromode.solver.analysis.normalisation import Normalisation, rms_radius
from zeromode.solver.analysis.rank import nullspace, orthonormal_range
from zeromode.solver.analysis.rigidity import (
    Analysis,
    analyze,
    compatibility_matrix,
    rigid_motions,
    zero_mode_residual,
)
from zeromode.solver.applications.allostery import _polish, check_source_pins, on_grid, response
from zeromode.solver.budget import check_budget
from zeromode.solver.construction.design import check_motions_nonrigid
from zeromode.solver.construction.hierarchical_placement import Module, place_module
from zeromode.solver.construction.placement import target_zero_modes
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame, check_positions
from zeromode.solver.progress import progress_stage, report_progress
from zeromode.solver.tolerances import (
    DESIGN_MODE_RTOL,
    LOOSE_RTOL,
    SWING_RTOL,
    TARGET_ERROR_MAX,
    UNSTRAINED_RTOL,
)

# Ground neighbours offered to the coupler, per site (it takes d − 1 of them).
COUPLER_GROUND = 2
# Pair nodes × kept-bar choices tried for a strain ratio before giving up.
MAX_PLANS = 12
# Counts and null spaces dense up to this many degrees of freedom, sparse above (rigidity's
# measurements: counts alone are 2–70× faster sparse from dN = 200).
COUNTS_DENSE_MAX_DOF = 200


@dataclass(frozen=True, eq=False)
class NetworkAllostery:
    """Allostery in a given network as one mechanism: the modified frame and what changed.

    Attributes
    ----------
    frame : Frame
        The given nodes first (same indices), then the added nodes; its edges are the kept given
        edges (in their order) then the added ones.
    mode : np.ndarray
        (N′, d): its one nontrivial zero mode, zero on the ground.
    analysis : Analysis
        The modified frame's analysis.
    source, target : tuple of int
        The sites' node indices.
    source_motion, target_motion : np.ndarray
        The prescribed motions of the sites' nodes (k, d).
    removed_edges : tuple of int
        Indices into the given frame's edges.
    added_nodes : tuple of int
        Frame indices of the added nodes.
    added_edges : np.ndarray
        (n_add, 2) frame indices.
    moving : tuple of int
        Given nodes that move relative to the ground.
    achieved_target_motion : np.ndarray
        Target rows of the response to the source motion (solved from the modified frame).
    target_error : float
        Its error relative to the prescribed target motion.
    strain_ratio : float or None
        ε_T/ε_S of that response for pairs (None for motions).
    mode_residual : float
        ‖C u‖ / (‖C‖_F ‖u‖) of the mode on the modified frame (0 for an exact zero mode).
    timings_ms : dict
        Wall time of each step.
    """

    frame: Frame
    mode: np.ndarray
    analysis: Analysis
    source: tuple[int, ...]
    target: tuple[int, ...]
    source_motion: np.ndarray
    target_motion: np.ndarray
    removed_edges: tuple[int, ...]
    added_nodes: tuple[int, ...]
    added_edges: np.ndarray
    moving: tuple[int, ...]
    achieved_target_motion: np.ndarray
    target_error: float
    strain_ratio: float | None
    mode_residual: float
    timings_ms: dict

    @property
    def bonds_changed(self) -> int:
        """Bars removed plus bars added."""
        return len(self.removed_edges) + len(self.added_edges)


def pair_strain(x: np.ndarray, u: np.ndarray) -> float:
    """ε of a node pair: (x_0 − x_1)·(u_0 − u_1)/|x_0 − x_1|² for x, u of shape (2, d)."""
    dx = x[0] - x[1]
    return float(dx @ (u[0] - u[1]) / (dx @ dx))


def _nodes(frame: Frame, nodes, name: str) -> np.ndarray:
    try:
        raw = np.asarray(nodes, dtype=float).ravel()
    except (TypeError, ValueError):
        raw = np.full(1, np.nan)
    if raw.size == 0 or not np.all(np.isfinite(raw)) or not np.all(raw == np.round(raw)):
        raise InvalidInput("invalid_nodes", f"{name} must be a non-empty list of node indices.")
    index = raw.astype(int)
    if np.any((index < 0) | (index >= frame.n_nodes)):
        raise InvalidInput("invalid_nodes", f"{name} names a node outside 0..{frame.n_nodes - 1}.")
    if len(set(index.tolist())) != len(index):
        raise InvalidInput("invalid_nodes", f"{name} lists a node twice.")
    return index


def tune_network(
    frame: Frame,
    source,
    target,
    source_motion=None,
    target_motion=None,
    strain_ratio: float | None = None,
    seed: int = 0,
) -> NetworkAllostery:
    """The smallest change found that makes ``frame`` respond exactly (module docstring).

    Give either source_motion and target_motion ((k, d) rows for the source and target nodes),
    or strain_ratio η* with source and target pairs. Raises InvalidInput for malformed input;
    DomainError ``floppy_network`` (the frame has nontrivial zero modes), ``overlapping_sites``
    (a node in both sites), ``rigid_source``, ``rigid_target``, ``underdetermined_source`` (motions
with a source that does not fix the rigid motions, allostery.check_source_pins), ``zero_strain`` (η* = 0 asks the
    target not to respond), ``no_solution`` (no plan verified).
    """
    started = time.perf_counter()
    src = _nodes(frame, source, "source")
    tgt = _nodes(frame, target, "target")
    if set(src.tolist()) & set(tgt.tolist()):
        raise DomainError("overlapping_sites", "a node belongs to both the source and the target.")
    d = frame.dim
    if strain_ratio is None:
        if source_motion is None or target_motion is None:
            raise InvalidInput("invalid_response", "give source and target motions, or a strain ratio.")
        u_src = check_positions(source_motion, d, "source_motion")
        u_tgt = check_positions(target_motion, d, "target_motion")
        if u_src.shape != (len(src), d) or u_tgt.shape != (len(tgt), d):
            raise InvalidInput("invalid_shape", "each site needs one motion row per node.")
        x = frame.positions
        check_source_pins(x[src])
        for name, code, nodes, u in (("source", "rigid_source", src, u_src), ("target", "rigid_target", tgt, u_tgt)):
            try:
                check_motions_nonrigid(x[nodes], u[None])
            except DomainError:
                raise DomainError(
                    code, f"the {name} motion is zero or a rigid motion of the {name} nodes: nothing to transmit."
                ) from None
    else:
        if source_motion is not None or target_motion is not None:
            raise InvalidInput("invalid_response", "give motions or a strain ratio, not both.")
        if not np.isfinite(strain_ratio):
            raise InvalidInput("invalid_response", "the strain ratio must be finite.")
        if strain_ratio == 0:
            raise DomainError("zero_strain", "a strain ratio of 0 asks the target not to respond; give a nonzero ratio.")
        if len(src) != 2 or len(tgt) != 2:
            raise InvalidInput("invalid_nodes", "a strain ratio needs a source pair and a target pair.")
    with progress_stage(0.0, 0.1, "the network's counts", detail=True):
        floppy = _counts(frame).nontrivial_zero_modes
    if floppy:
        raise DomainError(
            "floppy_network", "the given frame has nontrivial zero modes, so its response is not unique."
        )
    plans = (
        [(src, u_src, tgt, u_tgt)] if strain_ratio is None else _pair_plans(frame, src, tgt, float(strain_ratio))
    )
    failures = []
    for i, (moving_src, u_ms, moving_tgt, u_mt) in enumerate(plans):
        check_budget()
        try:
            with progress_stage(0.1 + 0.9 * i / len(plans), 0.1 + 0.9 * (i + 1) / len(plans), f"plan {i + 1}"):
                result = _build(frame, src, tgt, moving_src, u_ms, moving_tgt, u_mt, seed)
        except DomainError as exc:
            if exc.code == "too_expensive":
                raise
            failures.append(exc.message)
            continue
        if result.target_error <= TARGET_ERROR_MAX:
            report_progress(1.0, "tuned")
            return _timed(result, started)
        failures.append(f"a target error of {result.target_error:.1e}")
    raise DomainError(
        "no_solution",
        f"none of the {len(plans)} ways tried gives an exact response"
        + (f" (first: {failures[0]})" if failures else "")
        + ".",
    )


def _timed(result: NetworkAllostery, started: float) -> NetworkAllostery:
    result.timings_ms["total"] = 1e3 * (time.perf_counter() - started)
    return result


def _neighbours(frame: Frame) -> list[list[tuple[int, int]]]:
    """For each node, its (neighbour, edge index) pairs."""
    out: list[list[tuple[int, int]]] = [[] for _ in range(frame.n_nodes)]
    for e, (i, j) in enumerate(frame.edges.tolist()):
        out[i].append((j, e))
        out[j].append((i, e))
    return out


def _pair_plans(frame: Frame, src: np.ndarray, tgt: np.ndarray, ratio: float):
    """Moving nodes and motions for a strain ratio, fewest removals first: for each pair, a node
    that keeps d − 1 bars to other nodes of the frame swings along their common perpendicular,
    with ε_S = 1 and ε_T = η*; among kept bars, those whose perpendicular strains the pair most
    (|cos| to the pair's axis) come first."""
    x, d = frame.positions, frame.dim
    near = _neighbours(frame)
    sites = (set(src.tolist()) | set(tgt.tolist()))

    def swings(pair, strain):
        options = []
        for node, partner in ((pair[0], pair[1]), (pair[1], pair[0])):
            ground = [j for j, _ in near[node] if j not in sites]
            axis = x[node] - x[partner]
            for kept in itertools.combinations(ground, d - 1):
                direction = nullspace((x[node] - x[list(kept)]).reshape(d - 1, d))[0]
                if direction.shape[1] != 1:
                    continue
                n = direction[:, 0]
                along = float(axis @ n)
                if abs(along) <= SWING_RTOL * np.linalg.norm(axis):
                    continue  # the swing does not strain the pair
                motion = (strain * (axis @ axis) / along) * n
                removed = len(near[node]) - (d - 1)
                options.append((removed, -abs(along) / np.linalg.norm(axis), node, motion))
        return sorted(options, key=lambda o: (o[0], o[1]))

    plans = []
    for (r_s, c_s, node_s, m_s), (r_t, c_t, node_t, m_t) in itertools.product(swings(src, 1.0), swings(tgt, ratio)):
        plans.append((r_s + r_t, c_s + c_t, node_s, m_s, node_t, m_t))
    plans.sort(key=lambda p: (p[0], p[1]))
    return [(np.array([p[2]]), p[3][None], np.array([p[4]]), p[5][None]) for p in plans[:MAX_PLANS]]


def _strained(frame: Frame, motion: np.ndarray) -> np.ndarray:
    """Mask of the bars that ``motion`` (N, d; zero on the ground) strains."""
    x, e = frame.positions, frame.edges
    dx = x[e[:, 0]] - x[e[:, 1]]
    du = motion[e[:, 0]] - motion[e[:, 1]]
    scale = UNSTRAINED_RTOL * np.linalg.norm(dx, axis=1) * float(np.max(np.abs(motion)))
    return np.abs(np.einsum("ij,ij->i", dx, du)) > scale


def _counts(frame: Frame) -> Analysis:
    """The frame's counts (rigidity.analyze without bases): by the sparse route from
    COUNTS_DENSE_MAX_DOF degrees of freedom, where it is the faster one for counts alone."""
    method = "dense" if frame.dim * frame.n_nodes <= COUNTS_DENSE_MAX_DOF else "sparse"
    return analyze(frame, method=method, bases=False)


class _Pinned:
    """Zero modes of frames on the given nodes' positions (and nodes added later), with the rigid
    motions removed by pinning ρ = d(d+1)/2 coordinates of the nodes farthest from the moving ones
    (chosen by pivoted QR of the rigid motions there): N(C) = rigid ⊕ N(C with the pinned
    columns deleted), and a pinned zero mode vanishes on every node that moves rigidly with the
    pins — so its support is exactly what has come loose."""

    def __init__(self, frame: Frame, moving: np.ndarray):
        d = frame.dim
        self.d = d
        self.norm = Normalisation.of(frame.positions)
        x = self.norm.positions_in(frame.positions)
        far = np.argsort(-np.min(np.linalg.norm(x[:, None] - x[moving][None], axis=2), axis=1))[: 2 * d]
        far_rows = (far[:, None] * d + np.arange(d)).ravel()
        rigid = rigid_motions(x)
        self.pins = far_rows[sla.qr(rigid[far_rows].T, pivoting=True, mode="r")[1][: rigid.shape[1]]]

    def modes(self, positions: np.ndarray, edges: np.ndarray) -> np.ndarray:
        """Basis (dN × m) of the pinned zero modes of the frame (positions, edges), m its number
        of nontrivial zero modes (rigidity.analyze)."""
        n, d = positions.shape
        count = _counts(Frame.build(positions, edges)).nontrivial_zero_modes
        keep = np.setdiff1d(np.arange(n * d), self.pins)
        c = compatibility_matrix(self.norm.positions_in(positions), edges)[:, keep]
        if count == 0:
            basis = np.zeros((len(keep), 0))
        elif n * d <= COUNTS_DENSE_MAX_DOF:
            basis = nullspace(c.toarray())[0]
        else:
            basis = smallest_eigenpairs(sp.csc_matrix(c.T @ c), count).vectors
        full = np.zeros((n * d, basis.shape[1]))
        full[keep] = basis
        return full

    def allowed(self, positions: np.ndarray, modes: np.ndarray, state: np.ndarray) -> np.ndarray:
        """Orthonormal basis of how the ``state`` nodes may move: rigid ⊕ the modes' rows there."""
        d = self.d
        rows = (state[:, None] * d + np.arange(d)).ravel()
        rigid = rigid_motions(self.norm.positions_in(positions[state]))
        return orthonormal_range(np.column_stack([rigid, modes[rows] / max(np.abs(modes).max(), 1e-300)]))


def _ground_near(frame: Frame, nodes, moving: set, count: int) -> list[int]:
    """Up to ``count`` ground nodes per given node: its ground neighbours, then the nearest."""
    x = frame.positions
    near = _neighbours(frame)
    out: list[int] = []
    for node in nodes:
        picked = [j for j, _ in near[node] if j not in moving and j not in out]
        if len(picked) < count:
            dist = np.linalg.norm(x - x[node], axis=1)
            picked += [int(j) for j in np.argsort(dist) if j not in moving and j not in out and j not in picked]
        out.extend(picked[:count])
    return out


def _principal_axes(x: np.ndarray) -> np.ndarray:
    """Rows: a proper rotation (d, d) from the centred points' (n, d) principal axes, largest
    spread first, each signed by its positive third moment (2D: e_2 ⟂ e_1; 3D: e_3 = e_1 × e_2).
    Rotating the points rotates these axes with them."""
    _, vectors = np.linalg.eigh(x.T @ x)
    axes = vectors[:, ::-1].T
    skew = np.sum((x @ axes.T) ** 3, axis=0)
    axes = np.where(skew[:, None] < 0, -axes, axes)
    if len(axes) == 2:
        return np.array([axes[0], [-axes[0, 1], axes[0, 0]]])
    return np.array([axes[0], axes[1], np.cross(axes[0], axes[1])])


# Placement sees the given nodes' canonical positions and motions rounded to 2^-GRID_BITS of
# their largest magnitude: the round-off by which similar requests differ there (~1e-13 for a
# network shifted 1e3 of its size away) must not cross a grid line, and polishing restores
# exactness afterwards. The allowed-motion basis (entries ≤ 1) is rounded to 2^-NULL_GRID_BITS:
# it differs by ~1e-15 between similar requests, and placement's rank decisions need it far
# finer than 1e-9 (2^-24 already made a 3D tie module miss a zero mode).
GRID_BITS = 30
NULL_GRID_BITS = 40


def _similar_module(positions: np.ndarray, motion: np.ndarray, null: np.ndarray, target: int, seed: int) -> Module:
    """hierarchy.place_module in the given nodes' own frame, so that a similar request gets the
    similar module (as allostery._attempt does for a chain): positions centred, scaled by their
    RMS radius and turned to their principal axes (``_principal_axes``), motions turned and
    scaled alike, all rounded to a grid (``_grid``); ``null`` (orthonormal, dk × z)
    replaced by a basis that depends on its span only — its projector applied to a fixed probe,
    orthonormalised (QR, positive diagonal), on a coarser grid — since placement samples
    solution spaces in the basis it is given. The placed nodes joined to given nodes are then
    polished onto the exact solution spaces (allostery._polish)."""
    k, d = positions.shape
    centre = positions.mean(axis=0)
    length = rms_radius(positions) or 1.0
    turn = _principal_axes((positions - centre) / length)
    speed = rms_radius(motion) or float(np.sqrt(np.mean(motion**2))) or 1.0
    y = (positions - centre) @ turn.T / length
    v = motion @ turn.T / speed
    z = null.shape[1]
    span = np.einsum("ab,kbz->kaz", turn, null.reshape(k, d, z)).reshape(k * d, z)
    probe = np.random.default_rng(0).standard_normal((k * d, z))
    basis, r = np.linalg.qr(span @ (span.T @ probe))
    basis = basis * np.where(np.diag(r) < 0, -1.0, 1.0)
    basis = np.round(basis * 2.0**NULL_GRID_BITS) / 2.0**NULL_GRID_BITS
    module = place_module(on_grid(y, GRID_BITS), on_grid(v, GRID_BITS), basis, target, seed)
    placed, moved = module.positions.copy(), module.motion.copy()
    placed[:k], moved[:k] = y, v
    _polish(placed, moved, module.edges, k)
    return Module(
        positions=np.vstack([positions, centre + length * placed[k:] @ turn]),
        motion=np.vstack([motion, speed * moved[k:] @ turn]),
        edges=module.edges,
        given=k,
    )


def _build(frame, src, tgt, moving_src, u_ms, moving_tgt, u_mt, seed) -> NetworkAllostery:
    """One plan: remove the strained bars, tie each site (with the ground nodes that came loose
    near it) to one degree of freedom, couple the sites."""
    x, d = frame.positions, frame.dim
    n = frame.n_nodes
    target_modes = target_zero_modes(d, 1)
    moving = np.concatenate([moving_src, moving_tgt])
    motion = np.zeros_like(x)
    motion[moving_src], motion[moving_tgt] = u_ms, u_mt
    strained = _strained(frame, motion)
    added_x, added_u, added_edges = [], [], []

    def attach(state: np.ndarray, null: np.ndarray, target: int) -> None:
        """Unspecified nodes on the solution spaces of ``state`` nodes (given or added), each bar
        raising the rank, until ``null`` — how they may move — has ``target`` dimensions."""
        at = np.vstack([x, np.asarray(added_x).reshape(-1, d)])
        moved = np.vstack([motion, np.asarray(added_u).reshape(-1, d)])
        module = _similar_module(at[state], moved[state], null, target, seed)
        k = module.given
        index = np.concatenate([state, n + len(added_x) + np.arange(module.unspecified)])
        added_x.extend(module.positions[k:])
        added_u.extend(module.motion[k:])
        added_edges.extend(index[module.edges].tolist())

    alive = frame.edges[~strained]
    pinned = _Pinned(frame, moving)

    def current() -> tuple[np.ndarray, np.ndarray]:
        positions = np.vstack([x, np.asarray(added_x).reshape(-1, d)])
        edges = np.vstack([alive, np.asarray(added_edges, dtype=int).reshape(-1, 2)])
        return positions, pinned.modes(positions, edges)

    # Each site, with the ground nodes that came loose nearer to it, is tied to one degree of
    # freedom: its state holds no node of the other site, whose motion is zero there, so the
    # other site's motion survives the placement untouched.
    positions, modes = current()
    amplitude = np.linalg.norm(modes[: n * d].reshape(n, d, -1), axis=(1, 2))
    loose = np.setdiff1d(np.flatnonzero(amplitude > LOOSE_RTOL * amplitude.max()), moving)
    for share, site, other in (((0.1, 0.4), moving_src, moving_tgt), ((0.4, 0.7), moving_tgt, moving_src)):
        nearer = np.linalg.norm(x[loose] - x[site].mean(0), axis=1) <= np.linalg.norm(x[loose] - x[other].mean(0), axis=1)
        free = np.concatenate([site, loose[nearer]]).astype(int)
        touching = alive[np.isin(alive, free).any(axis=1)]
        excluded = set(free.tolist()) | set(other.tolist())
        core = sorted(set(touching.ravel().tolist()) - excluded)
        core += [j for j in _ground_near(frame, free, excluded, d + 1) if j not in core]
        state = np.concatenate([free, core]).astype(int)
        null = pinned.allowed(positions, modes, state)
        if null.shape[1] > target_modes:
            with progress_stage(*share, "tying a site"):
                attach(state, null, target_modes)
                positions, modes = current()
    # The coupler: the source node and target node that move most, and ground nodes near them.
    s_rep = moving_src[np.argmax(np.linalg.norm(u_ms, axis=1))]
    t_rep = moving_tgt[np.argmax(np.linalg.norm(u_mt, axis=1))]
    ground = _ground_near(frame, (s_rep, t_rep), set(moving.tolist()), COUPLER_GROUND)
    state = np.array([s_rep, t_rep, *ground], dtype=int)
    with progress_stage(0.7, 0.8, "the coupler"):
        attach(state, pinned.allowed(positions, modes, state), target_modes)

    positions = np.vstack([x, np.asarray(added_x).reshape(-1, d)])
    mode = np.vstack([motion, np.asarray(added_u).reshape(-1, d)])
    edges = np.vstack([frame.edges[~strained], np.asarray(added_edges, dtype=int).reshape(-1, 2)])
    modified = Frame.build(positions, edges, specified=np.concatenate([src, tgt]))
    with progress_stage(0.8, 0.9, "the modified network's counts", detail=True):
        analysis = _counts(modified)
    residual = zero_mode_residual(modified, mode)
    if analysis.zero_modes != target_modes or not residual <= DESIGN_MODE_RTOL:
        raise DomainError(
            "no_solution",
            f"the modified frame has {analysis.zero_modes} zero modes (wanted {target_modes}) and a mode "
            f"residual of {residual:.1e}: the ground did not stay rigid.",
        )
    u_src, u_tgt = mode[src], mode[tgt]
    if rigid_motions(Normalisation.of(x[src]).positions_in(x[src])).shape[1] == target_modes - 1:
        driven = response(modified, src, u_src)
    else:
        # A 3D source pair leaves the rotation about its line free: the response is the mode up to
        # that rotation, which strains nothing, so the counts and the mode residual checked above
        # decide the strain ratio; the mode's target rows are its representative.
        driven = mode
    achieved = driven[tgt]
    error = float(np.linalg.norm(achieved - u_tgt) / np.linalg.norm(u_tgt))
    ratio = None
    if len(src) == 2 and len(tgt) == 2 and len(moving_src) == 1:
        ratio = pair_strain(x[tgt], achieved) / pair_strain(x[src], driven[src])
    return NetworkAllostery(
        frame=modified,
        mode=mode,
        analysis=analysis,
        source=tuple(src.tolist()),
        target=tuple(tgt.tolist()),
        source_motion=u_src,
        target_motion=u_tgt,
        removed_edges=tuple(np.flatnonzero(strained).tolist()),
        added_nodes=tuple(range(n, len(positions))),
        added_edges=np.asarray(added_edges, dtype=int).reshape(-1, 2),
        moving=tuple(moving.tolist()),
        achieved_target_motion=achieved,
        target_error=error,
        strain_ratio=ratio,
        mode_residual=residual,
        timings_ms={},
    )
