"""Coupling modules (paper, "Combining Network Modes for Potential Applications", Fig. 5a–b and
5e–g).

Counting (Eq. 7): merging a node of one module with a node of another removes d degrees of
freedom, a bar between them removes one.  Two 2D modules with N_D = 4 each merged at two node
pairs give 8 − 4 = 4 (one nontrivial mode); two 3D modules with N_D = 7 merged at two pairs
give 14 − 6 = 8, and one more bar brings it to 7.  The composite frames are checked with PyRigi
and a compatibility matrix built from Eq. 3 (oracles.designs.check_frame_modes); the paper's
condition that merged nodes must not move as a rigid unit is checked against rigid motions
written out here (translations and ω × x).
"""

from __future__ import annotations

import numpy as np
import pytest
from oracles.designs import check_frame_modes
from oracles.frames import SQUARE_CORNERS, random_rotation
from oracles.rigidity import outside_fraction, reference_counts, rigid_generators

from zeromode.solver.construction.coupling import Module, couple, moves_rigidly
from zeromode.solver.construction.design import design
from zeromode.solver.errors import DomainError
from zeromode.solver.frame import Frame

SQUARE = np.array(SQUARE_CORNERS)


def shifted(module: Module, shift, mode_shift=None) -> Module:
    """A copy moved by ``shift``; its mode changes by ``mode_shift`` (an affine field's change)."""
    extra = 0.0 if mode_shift is None else mode_shift
    return Module(
        Frame.build(module.frame.positions + shift, module.frame.edges), module.mode + extra
    )


@pytest.fixture(scope="module")
def outward_square() -> Module:
    """Fig. 3b: the square's corners moving outward, two unspecified nodes, N_D = 4."""
    result = design(SQUARE, [SQUARE], seed=0)
    assert result.analysis.maxwell_count == 4
    return Module(result.frame, result.modes[0])


def test_merging_two_outward_squares_2d(outward_square):
    """Fig. 5a–b: the top module's lower corners merged with the bottom module's upper corners.
    Under the outward motion those corners move apart horizontally (not rigidly), and the two
    modules' motions agree there up to a translation, so one nontrivial mode survives."""
    top = shifted(outward_square, [0.0, 2.0])
    composite = couple([outward_square, top], [((0, 0), (1, 3)), ((0, 1), (1, 2))])
    frame = composite.frame
    n, nb = frame.n_nodes, frame.n_edges
    assert (n, nb) == (2 * 6 - 2, 16)
    assert 2 * n - nb == 4  # N_D = 8 − 4
    check_frame_modes(frame.positions, frame.edges, composite.mode[None])
    # The composite moves module 0 exactly as designed, and module 1 as designed up to a
    # rigid motion (a translation by (0, 2) of the outward field) and a scale.
    m0, m1 = composite.node_map
    assert np.allclose(composite.mode[m0], outward_square.mode, atol=1e-9)
    local = np.column_stack([rigid_generators(top.frame.positions), top.mode.ravel()])
    assert outside_fraction(local, composite.mode[m1].ravel()) <= 1e-9
    # Merged nodes are shared: module 1's nodes 3 and 2 are module 0's nodes 0 and 1.
    assert m1[3] == m0[0] and m1[2] == m0[1]


def test_coupling_fails_when_merged_nodes_move_rigidly(outward_square):
    """A module whose upper corners stay still (only the lower corners move) transmits nothing
    through them: merging them with the outward square's lower corners is refused."""
    still_top = np.array([[0.0, 0.0], [0.0, 0.0], [-1.0, -1.0], [1.0, -1.0]])
    result = design(SQUARE, [still_top], seed=0)
    below = shifted(Module(result.frame, result.modes[0]), [0.0, -2.0])
    ports = below.mode[[0, 1]]
    assert np.array_equal(ports, np.zeros((2, 2)))  # rigid by construction (no motion at all)
    with pytest.raises(DomainError) as err:
        couple([outward_square, below], [((0, 3), (1, 0)), ((0, 2), (1, 1))])
    assert err.value.code == "coupling_failed"
    assert "rigid" in err.value.message


def test_coupling_fails_when_merged_nodes_do_not_coincide(outward_square):
    top = shifted(outward_square, [0.0, 2.1])
    with pytest.raises(DomainError) as err:
        couple([outward_square, top], [((0, 0), (1, 3)), ((0, 1), (1, 2))])
    assert err.value.code == "coupling_failed"
    assert "coincide" in err.value.message


BLOCK = np.array(
    [[-1, 1, 0], [-1, -1, 0], [1, 1, 0], [1, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float
)
AFFINE = np.array([1.0, 0.5, 0.5])  # u = diag(1, β, γ)·x, β = γ = 0.5


@pytest.fixture(scope="module")
def blocks() -> tuple[Module, Module]:
    """Fig. 5e: two 3D modules (N_D = 7 each); the second is the first moved by (2, 0, 0), whose
    affine motion then changes by the translation diag(1, β, γ)·(2, 0, 0)."""
    result = design(BLOCK, [BLOCK * AFFINE], seed=0)
    assert result.analysis.maxwell_count == 7
    first = Module(result.frame, result.modes[0])
    shift = np.array([2.0, 0.0, 0.0])
    return first, shifted(first, shift, shift * AFFINE)


def test_two_3d_blocks_merged_at_two_nodes_plus_one_bond(blocks):
    """Fig. 5e–g: merging the right ports of block 0 with the left ports of block 1 removes 6
    degrees of freedom (14 → 8); one bar between the upper apexes removes the last (→ 7)."""
    merges = [((0, 2), (1, 0)), ((0, 3), (1, 1))]
    composite = couple(list(blocks), merges, [((0, 4), (1, 4))])
    frame = composite.frame
    n0, nb0 = blocks[0].frame.n_nodes, blocks[0].frame.n_edges
    assert (frame.n_nodes, frame.n_edges) == (2 * n0 - 2, 2 * nb0 + 1)
    assert 3 * frame.n_nodes - frame.n_edges == 7
    check_frame_modes(frame.positions, frame.edges, composite.mode[None])
    for module, nodes in zip(blocks, composite.node_map):
        local = np.column_stack([rigid_generators(module.frame.positions), module.mode.ravel()])
        assert outside_fraction(local, composite.mode[nodes].ravel()) <= 1e-9


def test_two_3d_blocks_merged_without_the_bond_keep_two_modes(blocks):
    """Merging alone leaves N_D = 8: two nontrivial modes, which couple refuses."""
    merges = [((0, 2), (1, 0)), ((0, 3), (1, 1))]
    with pytest.raises(DomainError) as err:
        couple(list(blocks), merges)
    assert err.value.code == "coupling_failed"
    # The merged frame built here: block 1's nodes 0, 1 become block 0's nodes 2, 3.
    first, second = blocks
    n = first.frame.n_nodes + second.frame.n_nodes - 2
    positions = np.vstack([first.frame.positions, second.frame.positions[2:]])
    remap = np.concatenate([[2, 3], np.arange(first.frame.n_nodes, n)])
    edges = np.vstack([first.frame.edges, remap[second.frame.edges]])
    counts = reference_counts(positions, edges)
    assert (counts["nontrivial_zero_modes"], counts["self_stresses"]) == (2, 0)
    assert "2 nontrivial" in err.value.message


@pytest.mark.parametrize("d", [2, 3])
def test_moves_rigidly_against_rigid_motions_written_out(d):
    rng = np.random.default_rng(d)
    for _ in range(20):
        x = rng.standard_normal((int(rng.integers(2, 6)), d)) * 10 ** rng.uniform(-3, 3)
        t = rng.standard_normal(d)
        if d == 2:
            rigid = t + rng.standard_normal() * np.column_stack([-x[:, 1], x[:, 0]])
        else:
            rigid = t + np.cross(rng.standard_normal(3), x)
        assert moves_rigidly(x, rigid)
        # Adding a small stretch of the bar between nodes 0 and 1 makes it non-rigid.
        stretch = rigid.copy()
        stretch[1] += 1e-3 * np.linalg.norm(rigid) * (x[1] - x[0]) / np.linalg.norm(x[1] - x[0])
        assert not moves_rigidly(x, stretch)
    # Two nodes moving apart along their bar (Fig. 5a's merged corners) are not rigid.
    pair = np.array([[1.0, 1.0], [-1.0, 1.0]] if d == 2 else [[1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]])
    assert not moves_rigidly(pair, pair)
    q = random_rotation(np.random.default_rng(0), d)
    assert moves_rigidly(pair @ q.T, np.zeros_like(pair))
