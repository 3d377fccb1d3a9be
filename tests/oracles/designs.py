"""Everything a design promises (paper, Eq. 7 and "Multi-Mode Construction"), checked through
routes that share nothing with the code under test: exact (==) comparison of the specified
rows, the reference counts and C·u from a C built from its definition, and PyRigi's flexes and
stresses."""

from __future__ import annotations

import numpy as np

from oracles import pyrigi_adapter
from oracles.rigidity import (
    COUNT_FIELDS,
    compatibility_matrix,
    mode_residual,
    normalised,
    numerical_rank,
    outside_fraction,
    reference_counts,
    rigid_generators,
)

# ‖C u‖ ≤ MODE_RTOL·‖C‖₂‖u‖ on the normalised frame: a designed mode is exact up to round-off.
MODE_RTOL = 1e-9
# The requested motions are independent modulo rigid motions when [rigid | modes] has full
# rank at this relative threshold (requested motions are O(1) data, not round-off).
INDEPENDENT_RTOL = 1e-8
# A mode lies in PyRigi's flex space when its part outside it is below this fraction, and is
# nontrivial when its part outside the rigid motions exceeds TRIVIAL_FRACTION.
IN_SPAN_FRACTION = 1e-8
TRIVIAL_FRACTION = 1e-6


def check_frame_modes(positions, edges, modes, use_pyrigi: bool = True) -> dict:
    """The frame has exactly d(d+1)/2 + M zero modes, no self-stress, and the M given motions
    (M, N, d) are zero modes independent of each other and of the rigid motions — from a C built
    here and from PyRigi. Returns the counts for reporting."""
    positions, edges = np.asarray(positions, dtype=float), np.asarray(edges, dtype=int)
    n, d = positions.shape
    m = len(modes)
    rigid = d * (d + 1) // 2
    target = rigid + m
    c = compatibility_matrix(normalised(positions), edges)
    for mode in modes:
        assert mode_residual(c, mode) <= MODE_RTOL
    counts = reference_counts(positions, edges)
    assert counts["zero_modes"] == target, "zero modes"
    assert counts["self_stresses"] == 0, "self-stresses"
    together = np.column_stack(
        [rigid_generators(normalised(positions))] + [np.ravel(mode) for mode in modes]
    )
    assert numerical_rank(together, INDEPENDENT_RTOL) == target
    if use_pyrigi:
        flexes = pyrigi_adapter.flexes(positions, edges)
        assert (flexes.all.shape[1], flexes.nontrivial.shape[1], flexes.stresses) == (target, m, 0)
        assert numerical_rank(flexes.trivial) == rigid
        for mode in modes:
            assert outside_fraction(flexes.all, mode) <= IN_SPAN_FRACTION
            assert outside_fraction(flexes.trivial, mode) > TRIVIAL_FRACTION
    return {"nodes": n, "bars": len(edges), "zero_modes": counts["zero_modes"]}


def check_design(result, x: np.ndarray, motions: np.ndarray, use_pyrigi: bool = True) -> dict:
    """Everything /v1/design promises about a solver design result.

    x (k, d) and motions (M, k, d) are the request; the frame must reproduce them exactly, be
    bipartite between specified and unspecified nodes, join each unspecified node to exactly its
    anchor set, and carry exactly the requested modes (check_frame_modes)."""
    frame = result.frame
    k, d = np.shape(x)
    positions, edges = np.asarray(frame.positions), np.asarray(frame.edges).reshape(-1, 2)
    n = len(positions)
    assert np.array_equal(positions[:k], x)
    assert list(frame.specified) == list(range(k))
    assert result.modes.shape == (len(motions), n, d)
    for mode, requested in zip(result.modes, motions, strict=True):
        assert np.array_equal(mode[:k], requested)
    # Bipartite: every bar joins an unspecified node to one of the specified nodes of its
    # anchor set (the module it belongs to).
    assert np.all(edges.min(axis=1) < k) and np.all(edges.max(axis=1) >= k)
    assert result.unspecified_nodes == n - k == len(result.anchor_sets)
    for j, anchors in enumerate(result.anchor_sets):
        joined = {int(a) for a, b in edges if b == k + j} | {int(b) for a, b in edges if a == k + j}
        assert joined == set(anchors) and max(anchors) < k
    counts = check_frame_modes(positions, edges, result.modes, use_pyrigi)
    expected = reference_counts(positions, edges)
    assert {f: getattr(result.analysis, f) for f in COUNT_FIELDS} == expected
    assert result.target_zero_modes == d * (d + 1) // 2 + len(motions)
    return counts
