"""Allosteric response by coupled modules (paper, "Combining Network Modes…": long-range
coupled conformational regulation, and "Combining Networks Through Judicious Constraint
Placement").

A source site (nodes x_src moving with u_src) must drive a distant target site (nodes x_tgt)
through a prescribed motion u_tgt.  Both sites become specified nodes of one design whose only
nontrivial zero mode is (u_src, u_tgt): driving the source then moves the target exactly as
prescribed, to linear order.  When the sites are far apart, relay nodes are laid along the
segment between them (a zig-zag band, so no relay module is degenerate); each relay moves with
a blend of the affine fields fitted to the source and target motions,
    u(x) = (1 − τ(x))·F_src(x) + τ(x)·F_tgt(x),   τ = position along the segment in [0, 1],
and the judicious placement couples local modules (anchor sets) from source to target.
The relays are unspecified from the user's point of view; they are listed in the report.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from zeromode.solver.design import Design, design
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import check_positions
from zeromode.solver.normalisation import rms_radius
from zeromode.solver.rigidity import rigid_motions
from zeromode.solver.tolerances import DISTINCT_RTOL


@dataclass(frozen=True, eq=False)
class AllostericDesign:
    """The design (specified = source nodes, then target nodes), and what it achieves.

    achieved_target_motion: (k_tgt, d), the target rows of the response to the source motion,
    solved independently from the frame's zero-mode space.
    """

    design: Design
    source: tuple[int, ...]
    target: tuple[int, ...]
    relays: tuple[int, ...]
    achieved_target_motion: np.ndarray
    target_error: float
    distance: float


def fit_affine(x: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-norm affine field u ≈ A x + t through the given node motions: (A (d, d), t (d,))."""
    d = x.shape[1]
    design_matrix = np.hstack([x, np.ones((len(x), 1))])
    coef, *_ = np.linalg.lstsq(design_matrix, u, rcond=None)
    return coef[:d].T, coef[d]


def relay_nodes(x_src, u_src, x_tgt, u_tgt, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Relay positions (r, d) on a zig-zag band between the sites and their blended motions."""
    d = x_src.shape[1]
    c_src, c_tgt = x_src.mean(axis=0), x_tgt.mean(axis=0)
    axis = c_tgt - c_src
    length = float(np.linalg.norm(axis))
    axis /= length
    gap_start = np.max((x_src - c_src) @ axis) + 0.5 * spacing
    gap_end = length + np.min((x_tgt - c_tgt) @ axis) - 0.5 * spacing
    count = int(np.floor((gap_end - gap_start) / spacing)) + 1 if gap_end > gap_start else 0
    if count <= 0:
        return np.zeros((0, d)), np.zeros((0, d))
    normals = np.linalg.svd(axis[None, :])[2][1:]  # (d−1, d), orthonormal ⟂ axis
    s = np.linspace(gap_start, gap_end, count)
    half = 0.5 * spacing
    offsets = [normals[0] * half, -normals[0] * half]
    if d == 3:
        offsets = [normals[0] * half, normals[1] * half, -normals[0] * half - normals[1] * half]
    positions = np.array([c_src + si * axis + off for i, si in enumerate(s) for off in np.roll(offsets, i % 2, axis=0)])
    a_src, t_src = fit_affine(x_src, u_src)
    a_tgt, t_tgt = fit_affine(x_tgt, u_tgt)
    tau = np.clip(((positions - c_src) @ axis) / length, 0.0, 1.0)[:, None]
    motions = (1 - tau) * (positions @ a_src.T + t_src) + tau * (positions @ a_tgt.T + t_tgt)
    return positions, motions


def response(design_result: Design, source: np.ndarray, source_motion: np.ndarray) -> np.ndarray:
    """The motion of every node (N, d) when the source nodes are driven with ``source_motion``:
    the zero mode u ∈ N(C) = rigid ⊕ span(modes) whose source rows best match it (least squares),
    computed from the frame's own analysis — independent of how the design was built."""
    frame, analysis = design_result.frame, design_result.analysis
    n, d = frame.n_nodes, frame.dim
    basis = np.column_stack(
        [m.ravel() for m in analysis.modes] + [rigid_motions(frame.normalised_positions())]
    )
    rows = (source[:, None] * d + np.arange(d)).ravel()
    coef, *_ = np.linalg.lstsq(basis[rows], source_motion.ravel(), rcond=None)
    return (basis @ coef).reshape(n, d)


def design_allosteric(
    source_positions,
    source_motion,
    target_positions,
    target_motion,
    dim: int | None = None,
    seed: int = 0,
    relay_spacing: float | None = None,
) -> AllostericDesign:
    """A frame whose only nontrivial mode drives the target with u_tgt when the source moves with u_src."""
    x_src = check_positions(source_positions, dim, "source_positions")
    d = x_src.shape[1]
    u_src = check_positions(source_motion, d, "source_motion")
    x_tgt = check_positions(target_positions, d, "target_positions")
    u_tgt = check_positions(target_motion, d, "target_motion")
    if u_src.shape != x_src.shape or u_tgt.shape != x_tgt.shape:
        raise InvalidInput("invalid_shape", "each site needs one motion row per node.")
    gaps = np.linalg.norm(x_src[:, None] - x_tgt[None], axis=2)
    size = max(rms_radius(np.vstack([x_src, x_tgt])), 1e-300)
    if np.min(gaps) <= DISTINCT_RTOL * size:
        i, j = np.unravel_index(np.argmin(gaps), gaps.shape)
        raise DomainError(
            "overlapping_sites", f"source node {i} and target node {j} coincide; the sites must be apart."
        )
    if np.linalg.norm(u_src) == 0:
        raise DomainError("rigid_target", "the source motion is zero: nothing drives the target.")
    site = max(rms_radius(x_src), rms_radius(x_tgt), 1e-300)
    spacing = relay_spacing if relay_spacing is not None else 2.0 * site
    if not spacing > 0:
        raise InvalidInput("invalid_options", "relay_spacing must be positive.")
    x_rel, u_rel = relay_nodes(x_src, u_src, x_tgt, u_tgt, spacing)
    x_all = np.vstack([x_src, x_tgt, x_rel])
    u_all = np.vstack([u_src, u_tgt, u_rel])
    result = design(x_all, u_all, seed=seed)
    k_src, k_tgt = len(x_src), len(x_tgt)
    source = np.arange(k_src)
    target = np.arange(k_src, k_src + k_tgt)
    driven = response(result, source, u_src)
    achieved = driven[target]
    error = float(np.linalg.norm(achieved - u_tgt) / max(np.linalg.norm(u_tgt), 1e-300))
    return AllostericDesign(
        design=result,
        source=tuple(source.tolist()),
        target=tuple(target.tolist()),
        relays=tuple(range(k_src + k_tgt, k_src + k_tgt + len(x_rel))),
        achieved_target_motion=achieved,
        target_error=error,
        distance=float(np.linalg.norm(x_tgt.mean(0) - x_src.mean(0))),
    )
