"""Coupling modules (paper, "Combining Network Modes for Potential Applications").

Two operations compose modules into larger frames with the same number of nontrivial modes:
  * merging a node of one module with a node of another removes d degrees of freedom;
  * adding a bar between nodes of different modules removes one.
A module is a frame with one designed nontrivial zero mode.  The paper's conditions, checked
here: the merged nodes of each module must not move as a rigid unit under its mode (otherwise
the coupling transmits nothing), and the composite must keep exactly the intended number of
nontrivial zero modes and — unless symmetry makes some constraints redundant on purpose, as in
tiled sheets — no self-stress.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from zeromode.solver.analysis.normalisation import normalised
from zeromode.solver.analysis.rigidity import Analysis, analyze, rigid_motions
from zeromode.solver.errors import DomainError
from zeromode.solver.frame import Frame
from zeromode.solver.tolerances import DISTINCT_RTOL, RIGID_RTOL


@dataclass(frozen=True, eq=False)
class Module:
    """A frame with its designed zero mode (N, d)."""

    frame: Frame
    mode: np.ndarray


@dataclass(frozen=True, eq=False)
class Composite:
    """The coupled frame, its single nontrivial mode (N, d) and its analysis.

    node_map[m][i] is the composite index of node i of module m.
    """

    frame: Frame
    mode: np.ndarray
    analysis: Analysis
    node_map: tuple[np.ndarray, ...]


def moves_rigidly(positions: np.ndarray, motion: np.ndarray, rtol: float = RIGID_RTOL) -> bool:
    """True when ``motion`` (n, d) restricted to these nodes is a rigid motion of them."""
    if len(positions) < 2:
        return True
    rigid = rigid_motions(normalised(positions))
    flat = motion.ravel()
    norm = np.linalg.norm(flat)
    if norm == 0:
        return True
    return bool(np.linalg.norm(flat - rigid @ (rigid.T @ flat)) <= rtol * norm)


def check_transmission(parts: list[tuple[np.ndarray, np.ndarray]], merges) -> None:
    """DomainError ``coupling_failed`` when the merged nodes of a part — (positions (n, d),
    mode (n, d)) of each module, the merges as in couple — move as a rigid unit under its mode:
    the coupling would not transmit the motion.  Needs only the merged nodes' positions and
    motions, so a chain of designed modules can be checked from their targets before any design."""
    for m_index, (positions, mode) in enumerate(parts):
        ports = sorted({i for pair in merges for (m, i) in pair if m == m_index})
        if len(ports) >= 2 and moves_rigidly(positions[ports], mode[ports]):
            raise DomainError(
                "coupling_failed",
                f"the merged nodes of module {m_index} move as a rigid unit under its mode, so "
                "the coupling would not transmit the motion.",
            )


def couple(
    modules: list[Module],
    merges: list[tuple[tuple[int, int], tuple[int, int]]],
    bonds: list[tuple[tuple[int, int], tuple[int, int]]] = (),
    nontrivial_modes: int = 1,
    allow_self_stress: bool = False,
    specified: list[tuple[int, int]] = (),
) -> Composite:
    """Merge nodes ((module, node), (module, node)) and add bonds between modules.

    Merged nodes must coincide. The composite's modes come from its own analysis (N(C) ⊖ rigid);
    the returned mode is the one nontrivial mode, scaled to agree with module 0's designed mode.
    Raises DomainError ``coupling_failed`` when a condition of the paper fails.
    """
    frame, node_map = merged_frame(modules, merges, bonds, specified)
    check_transmission([(m.frame.positions, m.mode) for m in modules], merges)
    analysis = analyze(frame, bases=True)
    if analysis.nontrivial_zero_modes != nontrivial_modes or (
        analysis.self_stresses and not allow_self_stress
    ):
        raise DomainError(
            "coupling_failed",
            f"the coupled frame has {analysis.nontrivial_zero_modes} nontrivial zero modes and "
            f"{analysis.self_stresses} self-stresses (wanted {nontrivial_modes} and 0).",
        )
    mode = _aligned_mode(frame, analysis, modules[0], node_map[0])
    return Composite(frame, mode, analysis, node_map)


def merged_frame(
    modules: list[Module],
    merges: list[tuple[tuple[int, int], tuple[int, int]]],
    bonds: list[tuple[tuple[int, int], tuple[int, int]]] = (),
    specified: list[tuple[int, int]] = (),
) -> tuple[Frame, tuple[np.ndarray, ...]]:
    """The frame of the modules with merged nodes made one (they must coincide: DomainError
    ``coupling_failed`` otherwise) and the bonds added, with the specified (module, node) pairs,
    and each module's node indices in it; no analysis (couple analyses it)."""
    offsets = np.cumsum([0] + [m.frame.n_nodes for m in modules])
    parent = np.arange(offsets[-1])

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    positions = np.vstack([m.frame.positions for m in modules])
    scale = max(float(np.max(np.abs(positions - positions.mean(0)))), 1e-300)
    for (ma, ia), (mb, ib) in merges:
        a, b = offsets[ma] + ia, offsets[mb] + ib
        if np.linalg.norm(positions[a] - positions[b]) > DISTINCT_RTOL * scale:
            raise DomainError("coupling_failed", f"merged nodes {ma}:{ia} and {mb}:{ib} do not coincide.")
        parent[root(b)] = root(a)
    roots = np.array([root(i) for i in range(offsets[-1])])
    unique, new_index = np.unique(roots, return_inverse=True)
    edges = np.vstack(
        [new_index[offsets[m] + mod.frame.edges] for m, mod in enumerate(modules) if mod.frame.n_edges]
        + [np.array([[new_index[offsets[ma] + ia], new_index[offsets[mb] + ib]] for (ma, ia), (mb, ib) in bonds]).reshape(-1, 2)]
    )
    spec = sorted({int(new_index[offsets[m] + i]) for m, i in specified})
    node_map = tuple(new_index[offsets[m] : offsets[m + 1]] for m in range(len(modules)))
    return Frame.build(positions[unique], edges, spec), node_map


def _aligned_mode(frame: Frame, analysis: Analysis, reference: Module, nodes: np.ndarray) -> np.ndarray:
    """The nontrivial mode plus the rigid motion and scale that best match ``reference``'s mode
    on its nodes (least squares), so the composite moves module 0 as designed."""
    n, d = frame.n_nodes, frame.dim
    mode = analysis.modes[0].ravel()
    rigid = rigid_motions(frame.normalised_positions())
    cols = np.column_stack([mode, rigid])
    sel = (nodes[:, None] * d + np.arange(d)).ravel()
    coef, *_ = np.linalg.lstsq(cols[sel], reference.mode.ravel(), rcond=None)
    return (cols @ coef).reshape(n, d)
