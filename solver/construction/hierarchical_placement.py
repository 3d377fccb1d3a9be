"""Hierarchical judicious placement: a module designed onto nodes whose motions an earlier frame
already ties (paper, Discussion: "hierarchical judicious constraining of networks along the
solution spaces … of specified *and* unspecified nodes"; "Combining Networks Through Judicious
Constraint Placement").

The module's own nodes are k given nodes x (k × d) with their designed motion u (k × d). Some of
them may be free; others belong to a frame built earlier, which lets them move only within a
subspace V ⊂ R^{dk} — for a port of a frame whose only nontrivial zero mode is u, V is
span(rigid motions of the port, u restricted to the port), of dimension d(d+1)/2 + 1 when the
port pins the rigid motions (d ≥ 2 points in 2D, 3 non-collinear points in 3D) and u is not
rigid on it. The placement (placement.place_nodes) starts from an orthonormal basis of that
joint subspace instead of the identity and adds unspecified nodes on the solution spaces of
anchor sets of the k nodes (Eqs. 4–7), each bar raising the rank, until dim N = ``target``.

Why the module can then be merged with the earlier frame (node by node, the given nodes being
the same points): a zero mode of the union is a zero mode w of the module whose rows on the
tied nodes are the rows of a zero mode v of the earlier frame. If v ↦ v|tied is injective
(the earlier frame moves the tied nodes in a way that determines all of it), the union's null
space is {w ∈ N(module) : w|tied ∈ V}, which is exactly the space the placement reduced to
``target`` dimensions; and since every bar placed raised the rank of that restricted problem,
the union has as many self-stresses as the earlier frame. Modules designed this way chain: each
new one keeps the union at d(d+1)/2 + 1 zero modes with no self-stress, and a similar copy (a
rotation, reflection, translation and scaling of positions, motions scaled alike) of a module is
a module of the similar ports, since the bar constraint (x_i − x_j)·(u_i − u_j) = 0 is
invariant under all of them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from zeromode.solver.analysis.normalisation import Normalisation
from zeromode.solver.analysis.rank import orthonormal_range
from zeromode.solver.analysis.rigidity import rigid_motions
from zeromode.solver.construction.design import single_mode_levels
from zeromode.solver.construction.placement import Placement, place_nodes

# Candidate points per anchor set (design.single_mode_levels uses 16): modules are small and
# designed once per chain, so a larger pool buys conditioning cheaply.
MODULE_SAMPLES = 24


@dataclass(frozen=True, eq=False)
class Module:
    """A designed module: positions (k + n, d) and motion (k + n, d) — the k given nodes first,
    then the n unspecified nodes placed — and edges (N_B, 2) in those indices."""

    positions: np.ndarray
    motion: np.ndarray
    edges: np.ndarray
    given: int

    @property
    def unspecified(self) -> int:
        return len(self.positions) - self.given


def tied_space(positions: np.ndarray, motion: np.ndarray) -> np.ndarray:
    """Orthonormal basis (dk × z) of span(rigid motions of the k nodes, ``motion``): how a port of
    a frame whose only nontrivial zero mode carries ``motion`` may still move. positions,
    motion: (k, d)."""
    x = Normalisation.of(positions).positions_in(positions)  # rigid span is translation/scale-free
    return orthonormal_range(np.column_stack([rigid_motions(x), motion.ravel() / np.max(np.abs(motion))]))


def place_module(positions: np.ndarray, motion: np.ndarray, null: np.ndarray, target: int, seed: int) -> Module:
    """Unspecified nodes on the solution spaces of anchor sets of the k given nodes, joined only by
    rank-raising bars, until the zero modes of the given nodes' allowed motions (``null``,
    orthonormal dk × z) are reduced to ``target`` (see the module docstring).

    positions, motion (k, d) in any units; decisions are taken in the normalised units of the
    given nodes (normalisation.Normalisation), so the module is the same for a similar request.
    Raises DomainError ``no_solution`` when no placement reaches ``target``.
    """
    norm = Normalisation.of(positions, motion)
    x_n, u_n = norm.positions_in(positions), norm.motions_in(motion)[None]
    rng = np.random.default_rng(seed)
    state = Placement(x_n, u_n, target, null=null)
    levels = single_mode_levels(x_n, u_n, rng, samples=MODULE_SAMPLES)
    place_nodes(x_n, u_n, levels, start=state)
    k = len(positions)
    placed = np.asarray(state.positions[k:]).reshape(-1, positions.shape[1])
    moved = np.asarray([m[0] for m in state.motions[k:]]).reshape(-1, positions.shape[1])
    return Module(
        positions=np.vstack([positions, norm.positions_out(placed)]) if len(placed) else positions.copy(),
        motion=np.vstack([motion, norm.motions_out(moved)]) if len(moved) else motion.copy(),
        edges=np.asarray(state.edges, dtype=int).reshape(-1, 2),
        given=k,
    )


def module_gap(module: Module, null: np.ndarray, target: int) -> float:
    """σ_min/σ_max of the module's unit compatibility matrix on its allowed motions past the
    ``target`` zero modes: Q·B, Q = diag(1/ℓ)·C of the module, B = blockdiag(``null`` for the
    given nodes, I for the unspecified ones); rank Q·B = dim − target when the module is right.
    The same figure as the whole frame's gap (allostery.linear_figures), for one module."""
    x = module.positions
    diff = x[module.edges[:, 0]] - x[module.edges[:, 1]]
    unit = diff / np.linalg.norm(diff, axis=1, keepdims=True)
    n, d = x.shape
    q = np.zeros((len(unit), n * d))
    rows = np.arange(len(unit))[:, None]
    q[rows, module.edges[:, :1] * d + np.arange(d)] = unit
    q[rows, module.edges[:, 1:] * d + np.arange(d)] = -unit
    allowed = np.zeros((n * d, null.shape[1] + n * d - null.shape[0]))
    allowed[: null.shape[0], : null.shape[1]] = null
    allowed[null.shape[0] :, null.shape[1] :] = np.eye(n * d - null.shape[0])
    s = np.linalg.svd(q @ allowed, compute_uv=False)
    rank = allowed.shape[1] - target
    return float(s[rank - 1] / s[0]) if rank > 0 and len(s) >= rank else 0.0
