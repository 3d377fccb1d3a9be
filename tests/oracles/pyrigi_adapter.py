"""PyRigi (≥ 1.3) as an independent oracle: its own rigidity matrix, flexes and stresses.

PyRigi builds its rigidity matrix from a graph and a realization and computes flexes and
stresses with its own routines. Its numerical tolerance is absolute, so numerical questions are
asked on the scale-normalised frame (centred, RMS radius 1), where the tolerance is relative to
the frame's size; exact (symbolic) questions take integer coordinates as they are.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from pyrigi import Framework, Graph

from oracles.rigidity import REFERENCE_RTOL, normalised


def framework(positions, edges, exact: bool = False) -> Framework:
    """PyRigi's framework of the frame; every node is a vertex, isolated or not.

    exact: integer coordinates (PyRigi then works symbolically); else floats."""
    n = len(positions)
    graph = Graph()
    graph.add_vertices(range(n))
    graph.add_edges([(int(i), int(j)) for i, j in edges])
    convert = int if exact else float
    return Framework(graph, {i: [convert(v) for v in positions[i]] for i in range(n)})


def _columns(vectors, rows: int) -> np.ndarray:
    if not vectors:
        return np.zeros((rows, 0))
    return np.column_stack([np.asarray(v, dtype=float).ravel() for v in vectors])


@dataclass(frozen=True)
class Flexes:
    """PyRigi's infinitesimal flexes and stresses of one frame (node-major dN columns)."""

    trivial: np.ndarray  # dN × ρ, the rigid motions
    nontrivial: np.ndarray  # dN × f
    all: np.ndarray  # dN × (ρ + f), trivial included
    stresses: int


def flexes(positions, edges, tolerance: float = REFERENCE_RTOL) -> Flexes:
    """Flexes and the number of equilibrium stresses, by PyRigi's numerical routines on the
    normalised frame (same flexes and stresses as the frame itself)."""
    x = normalised(positions)
    fw = framework(x, edges)
    order = list(range(len(x)))
    rows = x.size
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        trivial = fw.trivial_inf_flexes(vertex_order=order)
        every = fw.inf_flexes(
            include_trivial=True, vertex_order=order, numerical=True, tolerance=tolerance
        )
        nontrivial = fw.nontrivial_inf_flexes(
            vertex_order=order, numerical=True, tolerance=tolerance
        )
        stresses = fw.stresses(numerical=True, tolerance=tolerance)
    return Flexes(
        trivial=_columns(trivial, rows),
        nontrivial=_columns(nontrivial, rows),
        all=_columns(every, rows),
        stresses=len(stresses),
    )


def prestress_stable(positions, edges) -> bool:
    """PyRigi's numerical prestress stability; raises ValueError where it cannot decide."""
    fw = framework(np.asarray(positions, dtype=float), edges)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fw.is_prestress_stable(numerical=True)
