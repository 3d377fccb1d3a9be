"""PyRigi (1.3) as an independent oracle for the rigidity analysis.

PyRigi builds its own rigidity matrix from a networkx-style graph and a realization, and
computes ranks, infinitesimal flexes and equilibrium stresses with its own routines. We use
its numerical routines on generic frames at unit scale (its rank tolerance is absolute, so
it is only meaningful there) and its exact, symbolic routines on integer lattice frames,
whose degeneracies make the numerical threshold matter. Our side is also run at coordinate
scales 1e-6 and 1e6 and must agree with PyRigi's unit-scale answer.
"""

import warnings

import numpy as np
import pytest
from oracles.frames import random_frame
from oracles.rigidity import as_columns, projector, span

from zeromode.solver import Frame, analyze

pyrigi = pytest.importorskip("pyrigi")


def pyrigi_framework(positions, edges, exact=False):
    n = len(positions)
    graph = pyrigi.Graph([tuple(e) for e in edges])
    graph.add_nodes_from(range(n))  # isolated nodes are part of the frame too
    convert = int if exact else float
    return pyrigi.Framework(graph, {i: [convert(v) for v in positions[i]] for i in range(n)})


def generic_case(seed):
    """A generic frame (Gaussian positions) in 2D (even seed) or 3D (odd seed).

    Seeds ≡ 0, 1 (mod 4): a random graph near the isostatic count dN − d(d+1)/2.
    Seeds ≡ 2, 3 (mod 4): a complete K_{d+2} (one self-stress) plus fewer than d bars per
    further node (at least one nontrivial flex), so both kinds of null vector are present.
    """
    rng = np.random.default_rng(seed)
    dim = (2, 3)[seed % 2]
    if seed % 4 < 2:
        n = int(rng.integers(dim + 1, 9))
        isostatic = dim * n - dim * (dim + 1) // 2
        n_edges = int(np.clip(isostatic + rng.integers(-4, 5), 1, n * (n - 1) // 2))
        return random_frame(rng, dim, n, n_edges)  # PyRigi needs at least one bar
    n = int(rng.integers(dim + 3, 9))
    k = dim + 2
    positions, _ = random_frame(rng, dim, n, 0)
    cluster = [[i, j] for i in range(k) for j in range(i + 1, k)]
    others = [[i, j] for j in range(k, n) for i in range(j)]
    n_extra = dim * (n - k) - 1 - int(rng.integers(0, 2))
    extra = [others[m] for m in rng.choice(len(others), size=n_extra, replace=False)]
    return positions, cluster + extra


@pytest.mark.parametrize("seed", range(20))
def test_counts_and_subspaces_match_pyrigi_numerical(seed):
    positions, edges = generic_case(seed)
    n = len(positions)
    framework = pyrigi_framework(positions, edges)
    rank = int(framework.rigidity_matrix_rank(numerical=True))
    nontrivial = len(framework.nontrivial_inf_flexes(numerical=True))
    flexes = framework.inf_flexes(include_trivial=True, numerical=True, vertex_order=list(range(n)))
    stresses = framework.stresses(numerical=True, edge_order=[tuple(e) for e in edges])
    expected = (rank, nontrivial, len(stresses))

    a = analyze(Frame.build(positions, edges))
    assert (a.rank, a.nontrivial_zero_modes, a.self_stresses) == expected
    assert a.zero_modes == len(flexes)

    # Same subspaces: PyRigi's flexes span our rigid motions ⊕ nontrivial modes, its
    # stresses (in our edge order) span ours.
    ours = np.column_stack([a.rigid_basis, as_columns(a.modes)])
    assert np.abs(projector(ours) - projector(span(np.column_stack(flexes)))).max() < 1e-8
    if stresses:
        theirs = span(np.column_stack(stresses))
        assert np.abs(projector(a.stresses.T) - projector(theirs)).max() < 1e-8

    # Our side at extreme coordinate scales (and off the origin) against PyRigi at unit scale.
    for scale in (1e-6, 1e6):
        b = analyze(Frame.build(scale * (positions + 3.0), edges))
        assert (b.rank, b.nontrivial_zero_modes, b.self_stresses) == expected


@pytest.mark.parametrize("seed", range(4))
def test_degenerate_lattice_frames_match_pyrigi_exact(seed):
    # Integer coordinates on a 4^d grid: collinear and coplanar subsets, decided exactly by
    # PyRigi's symbolic routines, must come out the same after our numerical rank decision.
    rng = np.random.default_rng(100 + seed)
    dim = (2, 3)[seed % 2]
    n = int(rng.integers(dim + 1, 8))
    positions, edges = random_frame(rng, dim, n, int(rng.integers(n, 2 * n)), lattice=True)
    framework = pyrigi_framework(positions.astype(int), edges, exact=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        expected = (
            int(framework.rigidity_matrix_rank()),
            len(framework.nontrivial_inf_flexes()),
            len(framework.stresses()),
        )
    a = analyze(Frame.build(positions, edges))
    assert (a.rank, a.nontrivial_zero_modes, a.self_stresses) == expected
