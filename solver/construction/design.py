"""Zero-mode design by judicious constraint placement (paper, "Network Construction Through
Judicious Constraint Placement", "Multi-Mode Construction" and "Combining Networks Through
Judicious Constraint Placement"): validation, candidate levels, verification.

Candidates come from the solution space of all k specified nodes when it has real points, and
otherwise (or when geometry stalls the count, as for the coplanar 5-node case in 3D, or when
k > 2d leaves no single-layer solution) from the solution spaces of subsets of them — the
"anchor sets", largest first.  Each anchor set is a module of the paper's partitioned
construction: a primary module when it is disjoint from the others, a coupling module when it
overlaps them.  The engine is in ``placement``; the multi-mode candidates in ``multimode``.
Every design is verified by a full analysis before it is returned.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import numpy as np

from zeromode.solver.analysis.normalisation import Normalisation, normalised
from zeromode.solver.analysis.rigidity import Analysis, analyze, rigid_motions, zero_mode_residual
from zeromode.solver.construction.hierarchical_pairs import check_motion_count, place_groups
from zeromode.solver.construction.multimode import multi_mode_levels
from zeromode.solver.construction.placement import (
    CandidatePool,
    Placement,
    candidate_levels,
    place_nodes,
    target_zero_modes,
)
from zeromode.solver.construction.solution_space import check_targets, solution_space
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame, check_positions
from zeromode.solver.tolerances import DESIGN_MODE_RTOL, DISTINCT_RTOL, REPORT_GAP_RTOL, RIGID_RTOL


@dataclass(frozen=True, eq=False)
class Design:
    """A verified design. modes: (M, N, d); rows 0..k−1 of modes[i] equal the requested u_S^(i)."""

    frame: Frame
    modes: np.ndarray
    analysis: Analysis
    target_zero_modes: int
    anchor_sets: tuple[tuple[int, ...], ...]
    conditioning: float
    mode_residual: float
    notes: tuple[str, ...] = field(default=())

    @property
    def unspecified_nodes(self) -> int:
        return self.frame.n_nodes - len(self.frame.specified)


def check_motions_nonrigid(positions: np.ndarray, motions: np.ndarray) -> None:
    """Raise ``rigid_target`` unless the motions are independent modulo rigid motions.

    positions (k, d); motions (M, k, d). Each u^(i) must have a component outside the rigid
    motions of x_S, and the M components must be linearly independent.
    """
    norm = Normalisation.of(positions, motions[0])
    rigid = rigid_motions(norm.positions_in(positions))
    flat = motions.reshape(len(motions), -1).T  # (k·d, M)
    peak = np.max(np.abs(flat), axis=0)
    if np.any(peak == 0):
        raise DomainError("rigid_target", f"motion {int(np.argmin(peak))} is zero everywhere.")
    flat = flat / peak  # scale-free before any sum of squares (1e±200 must not under/overflow)
    scale = np.linalg.norm(flat, axis=0)
    residual = (flat - rigid @ (rigid.T @ flat)) / scale
    norms = np.linalg.norm(residual, axis=0)
    if np.any(norms <= RIGID_RTOL):
        i = int(np.argmin(norms))
        raise DomainError(
            "rigid_target",
            f"motion {i} is a rigid motion (translation/rotation) of the specified nodes; "
            "only non-rigid motions can be designed.",
        )
    s = np.linalg.svd(residual / norms, compute_uv=False)
    if len(motions) > 1 and s[-1] <= RIGID_RTOL * s[0]:
        raise DomainError(
            "rigid_target", "the requested motions are linearly dependent modulo rigid motions."
        )


def check_specified_distinct(positions: np.ndarray) -> None:
    """Raise ``degenerate_specified`` if two specified nodes coincide (relative to the set's size)."""
    k = len(positions)
    if k < 2:
        return
    y = normalised(positions)  # RMS radius 1, or all points equal (then every distance is 0)
    scale = float(np.sqrt(np.mean(np.sum(y**2, axis=1))))
    dist = np.linalg.norm(y[:, None, :] - y[None, :, :], axis=-1)
    np.fill_diagonal(dist, np.inf)
    i, j = np.unravel_index(np.argmin(dist), dist.shape)
    if scale == 0 or dist[i, j] <= DISTINCT_RTOL * scale:
        raise DomainError(
            "degenerate_specified", f"specified nodes {min(i, j)} and {max(i, j)} coincide."
        )


def single_mode_levels(
    x_n: np.ndarray, u_n: np.ndarray, rng: np.random.Generator, samples: int = 16
) -> Iterator[list[CandidatePool]]:
    """Candidate levels for one motion (placement.candidate_levels): anchor sets of up to
    2d + 1 nodes, each with its solution space sampled (Eqs. 4–6)."""
    d = x_n.shape[1]
    return candidate_levels(
        x_n, 2 * d + 1, rng, lambda subset: _pool(x_n, u_n[0], subset, rng, samples)
    )


def _pool(
    x_n: np.ndarray, u: np.ndarray, subset: tuple[int, ...], rng: np.random.Generator, samples: int
) -> CandidatePool | None:
    idx = list(subset)
    try:
        space = solution_space(x_n[idx], u[idx])
    except DomainError:
        return None
    positions, motions = space.sample(samples, rng)
    return CandidatePool(positions, motions[:, None, :], subset) if len(positions) else None


def design_targets(
    positions, motions, dim: int | None = None, n_unspecified: int | None = None, hierarchical_allowed: bool = True
) -> tuple[np.ndarray, np.ndarray, bool]:
    """design's refusals before any placement (O(k²·M) work): x_S (k, d), the motions (M, k, d)
    and whether past M = d hierarchical groups take over (when ``hierarchical_allowed``: no
    custom levels).  Raises InvalidInput for shapes and options, DomainError
    ``degenerate_specified``, ``rigid_target``, ``too_many_motions``."""
    x = check_positions(positions, dim, "positions")
    if isinstance(motions, np.ndarray) and motions.ndim == 2:
        motions = [motions]  # one k×d motion
    if len(motions) == 0:
        raise InvalidInput("invalid_shape", "motions must hold at least one motion.")
    u_all = np.stack([check_targets(x, u)[1] for u in motions])
    check_specified_distinct(x)
    check_motions_nonrigid(x, u_all)
    if n_unspecified is not None and n_unspecified < 0:
        raise InvalidInput("invalid_options", "n_unspecified must be non-negative.")
    hierarchical = len(u_all) > x.shape[1] and hierarchical_allowed  # past M = d (hierarchical_modes)
    if hierarchical:
        check_motion_count(x.shape[1], len(u_all))
        if n_unspecified is not None:
            raise InvalidInput("invalid_options", "n_unspecified is available for up to d motions.")
    return x, u_all, hierarchical


def design(
    positions,
    motions,
    dim: int | None = None,
    seed: int = 0,
    n_unspecified: int | None = None,
    levels: Callable[[np.ndarray, np.ndarray, np.random.Generator], Iterator[list[CandidatePool]]] | None = None,
) -> Design:
    """Design a frame whose only non-rigid zero modes are the requested motions.

    positions: x_S (k, d); motions: a sequence of M motions, each (k, d), or one (k, d) array.
    Past M = d motions the bipartite construction has no solution in general; hierarchical
    groups of unspecified nodes take over (hierarchical_modes), up to M = 2d (``too_many_motions``
    beyond).
    Raises DomainError: ``rigid_target``, ``degenerate_specified``, ``no_solution``,
    ``too_many_motions``.
    """
    x, u_all, hierarchical = design_targets(positions, motions, dim, n_unspecified, levels is None)
    norm = Normalisation.of(x, u_all[0])
    x_n = norm.positions_in(x)
    u_n = np.stack([norm.motions_in(u) for u in u_all])
    rng = np.random.default_rng(seed)
    if hierarchical:
        return _finish(x, u_all, norm, place_groups(x_n, u_n, rng))
    make_levels = levels or (single_mode_levels if len(u_all) == 1 else multi_mode_levels)
    state = place_nodes(x_n, u_n, make_levels(x_n, u_n, rng), n_unspecified)
    return _finish(x, u_all, norm, state)


def _finish(x: np.ndarray, u_all: np.ndarray, norm: Normalisation, state: Placement) -> Design:
    """Map back to the caller's coordinates, keep the specified rows exact, and verify."""
    k = len(x)
    xs = np.asarray(state.positions)
    frame_positions = np.vstack([x, norm.positions_out(xs[k:])]) if len(xs) > k else x.copy()
    modes = np.stack(
        [
            np.vstack([u_all[i], norm.motions_out(np.asarray([m[i] for m in state.motions[k:]]))])
            if len(xs) > k
            else u_all[i].copy()
            for i in range(len(u_all))
        ]
    )
    edges = np.asarray(state.edges, dtype=int).reshape(-1, 2)
    frame = Frame.build(frame_positions, edges, specified=range(k))
    return verify(frame, modes, state.anchor_sets)


def verify(frame: Frame, modes: np.ndarray, anchor_sets=()) -> Design:
    """Check a design through a full analysis: exactly d(d+1)/2 + M zero modes, no self-stress,
    d(d+1)/2 rigid motions, and ‖C u‖ ≤ DESIGN_MODE_RTOL‖C‖‖u‖ for every mode (normalised C);
    σ_r (the report's conditioning) converged to REPORT_GAP_RTOL where it can be."""
    d = frame.dim
    target = target_zero_modes(d, len(modes))
    analysis = analyze(frame, gap_rtol=REPORT_GAP_RTOL, require_gap=False)
    residual = max((zero_mode_residual(frame, m) for m in modes), default=0.0)
    problems = []
    if analysis.zero_modes != target:
        problems.append(f"{analysis.zero_modes} zero modes instead of {target}")
    if analysis.self_stresses:
        problems.append(f"{analysis.self_stresses} self-stresses")
    if analysis.rigid_body_modes != d * (d + 1) // 2:
        problems.append("a degenerate configuration")
    if not residual <= DESIGN_MODE_RTOL:  # also catches NaN
        problems.append(f"a mode residual of {residual:.1e}")
    if problems:
        raise DomainError(
            "no_solution", "the construction did not verify: " + ", ".join(problems) + "."
        )
    return Design(
        frame=frame,
        modes=modes,
        analysis=analysis,
        target_zero_modes=target,
        anchor_sets=tuple(anchor_sets),
        conditioning=analysis.rank_gap.last_nonzero,
        mode_residual=residual,
    )
