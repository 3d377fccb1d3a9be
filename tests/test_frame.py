"""Frame validation: every malformed input is refused with a fixed code and a message naming the element."""

import math

import numpy as np
import pytest

from zeromode.solver.errors import InvalidInput
from zeromode.solver.frame import Frame

TRIANGLE = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
TRIANGLE_EDGES = [[0, 1], [1, 2], [0, 2]]


def refused(positions, edges=(), specified=(), dim=None) -> InvalidInput:
    with pytest.raises(InvalidInput) as info:
        Frame.build(positions, edges, specified, dim=dim)
    err = info.value
    assert err.code == err.code.lower() and " " not in err.code
    assert err.message and err.message.endswith(".")
    return err


# --- positions -------------------------------------------------------------------------


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_coordinate_is_named(bad):
    positions = [[0.0, 0.0], [1.0, 0.0], [0.0, bad]]
    err = refused(positions, TRIANGLE_EDGES)
    assert err.code == "not_finite"
    assert "positions[2][1]" in err.message


def test_non_finite_coordinate_in_3d_is_named():
    err = refused([[0, 0, 0], [1, 0, math.nan], [0, 1, 0]], [[0, 1]])
    assert err.code == "not_finite"
    assert "positions[1][2]" in err.message


@pytest.mark.parametrize(
    "positions",
    [
        [0.0, 1.0, 2.0],  # a flat list, not points
        [[[0.0, 0.0]], [[1.0, 0.0]]],  # one nesting level too many
        [[0.0, 0.0], [1.0]],  # ragged
        [["a", 0.0], [1.0, 0.0]],  # not numbers
        [],  # no nodes at all
        [[10**400, 0.0], [1.0, 0.0]],  # an integer too large for a float
    ],
    ids=["flat", "nested", "ragged", "strings", "empty", "huge-int"],
)
def test_malformed_positions(positions):
    err = refused(positions)
    assert err.code == "invalid_shape"
    assert "positions" in err.message


def test_points_must_match_declared_dim():
    err = refused(TRIANGLE, TRIANGLE_EDGES, dim=3)
    assert err.code == "invalid_shape"
    assert "3 coordinates" in err.message and "got 2" in err.message


@pytest.mark.parametrize("dim", [1, 4, 0])
def test_declared_dim_outside_2_3(dim):
    err = refused([[0.0] * max(dim, 1)] * 2, dim=dim)
    assert err.code == "invalid_dim"
    assert str(dim) in err.message


@pytest.mark.parametrize("width", [1, 4])
def test_inferred_dim_outside_2_3(width):
    err = refused([[float(i)] * width for i in range(3)])
    assert err.code == "invalid_dim"
    assert f"got {width}" in err.message


# --- edges -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "edges",
    [
        [0, 1],  # a flat pair
        [[0, 1, 2]],  # a triple
        [[0, 1], [2]],  # ragged
        [[0, "a"]],  # not a number
        None,
        [[0, 10**400]],  # too large to be a number of this kind
    ],
    ids=["flat", "triple", "ragged", "string", "none", "huge-int"],
)
def test_malformed_edges(edges):
    err = refused(TRIANGLE, edges)
    assert err.code == "invalid_edges"
    assert "edges" in err.message


@pytest.mark.parametrize("bad", [1.5, math.nan, math.inf])
def test_non_integer_node_index_names_the_edge(bad):
    err = refused(TRIANGLE, [[0, 1], [1, bad]])
    assert err.code == "invalid_edges"
    assert "edge 1" in err.message


@pytest.mark.parametrize("pair", [[0, 3], [-1, 2], [3, 0], [0, 2**70]])
def test_edge_out_of_range_names_edge_and_node(pair):
    err = refused(TRIANGLE, [[0, 1], [1, 2], pair])
    assert err.code == "edge_out_of_range"
    assert "edge 2" in err.message and "0..2" in err.message
    bad = next(i for i in pair if not 0 <= i <= 2)
    # The offending index is quoted exactly, not wrapped by an integer overflow.
    assert str(bad) in err.message


def test_self_loop_names_the_edge():
    err = refused(TRIANGLE, [[0, 1], [2, 2]])
    assert err.code == "self_loop"
    assert "edge 1" in err.message and "[2, 2]" in err.message


def test_duplicate_edge_names_both():
    err = refused(TRIANGLE, [[0, 1], [1, 2], [0, 1]])
    assert err.code == "duplicate_edge"
    assert "edges 0 and 2" in err.message and "[0, 1]" in err.message


def test_reversed_duplicate_edge_names_both():
    err = refused(TRIANGLE, [[1, 2], [0, 1], [2, 1]])
    assert err.code == "duplicate_edge"
    assert "edges 0 and 2" in err.message and "[1, 2]" in err.message


def test_zero_length_bar_names_the_edge():
    positions = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.0]]
    err = refused(positions, [[0, 1], [1, 2]])
    assert err.code == "zero_length_bar"
    assert "edge 1" in err.message and "[1, 2]" in err.message


@pytest.mark.parametrize("scale", [1e-300, 1.0, 1e300])
def test_coincidence_is_relative_to_the_frame_size(scale):
    # 1e-13 of the frame size is coincident at every magnitude; 1e-6 is not.
    near = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1e-13], [0.0, 1.0]]) * scale
    err = refused(near, [[0, 1], [1, 2]])
    assert err.code == "zero_length_bar" and "edge 1" in err.message
    apart = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1e-6], [0.0, 1.0]]) * scale
    assert Frame.build(apart, [[0, 1], [1, 2]]).n_edges == 2


def test_coincident_nodes_without_a_bar_are_allowed():
    frame = Frame.build([[0, 0], [0, 0], [1, 0]], [[0, 2], [1, 2]])
    assert frame.n_nodes == 3


# --- specified -------------------------------------------------------------------------


@pytest.mark.parametrize("spec, named", [([0, 3], "3"), ([-1], "-1"), ([0, 2**70], str(2**70))])
def test_specified_out_of_range_names_the_node(spec, named):
    err = refused(TRIANGLE, TRIANGLE_EDGES, spec)
    assert err.code == "invalid_specified"
    assert f"node {named}" in err.message and "0..2" in err.message


def test_specified_twice_names_the_node():
    err = refused(TRIANGLE, TRIANGLE_EDGES, [2, 0, 2])
    assert err.code == "invalid_specified"
    assert "node 2" in err.message


@pytest.mark.parametrize(
    "spec", [[0.5], [math.nan], [[0], [1]], [[0], [1, 2]], ["a"], None], ids=str
)
def test_specified_must_be_a_list_of_integers(spec):
    err = refused(TRIANGLE, TRIANGLE_EDGES, spec)
    assert err.code == "invalid_specified"
    assert "specified" in err.message


# --- what a valid frame keeps --------------------------------------------------------


def test_valid_frame_keeps_input_order_and_is_read_only():
    frame = Frame.build(TRIANGLE, [[2, 1], [0, 1], [2, 0]], [1, 0], dim=2)
    assert frame.edges.tolist() == [[2, 1], [0, 1], [2, 0]]
    assert frame.specified == (1, 0)
    assert (frame.n_nodes, frame.n_edges, frame.dim, frame.maxwell_count) == (3, 3, 2, 3)
    assert frame.edges.dtype.kind == "i"
    for array in (frame.positions, frame.edges):
        with pytest.raises(ValueError):
            array[0, 0] = 7


def test_input_array_is_copied():
    positions = np.array(TRIANGLE)
    frame = Frame.build(positions, TRIANGLE_EDGES)
    positions[0, 0] = 99.0
    assert frame.positions[0, 0] == 0.0


def test_no_edges_and_array_edges_are_accepted():
    assert Frame.build(TRIANGLE, []).n_edges == 0
    assert Frame.build(TRIANGLE, np.zeros((0, 2), dtype=int)).n_edges == 0
    assert Frame.build(TRIANGLE, np.array(TRIANGLE_EDGES)).n_edges == 3


@pytest.mark.parametrize("scale", [1e-300, 1e-6, 1e6, 1e300])
def test_normalised_positions_are_centred_unit_rms_at_any_scale(scale):
    frame = Frame.build(np.array([[0, 0], [4, 0], [4, 3], [1, 5]]) * scale + 3 * scale, [[0, 1]])
    x = frame.normalised_positions()
    assert np.all(np.isfinite(x))
    np.testing.assert_allclose(x.mean(axis=0), 0, atol=1e-12)
    assert np.sqrt(np.mean(np.sum(x**2, axis=1))) == pytest.approx(1.0, rel=1e-12)
    # Same shape as the unit-scale frame: normalisation removes the scale exactly.
    ref = Frame.build(np.array([[0, 0], [4, 0], [4, 3], [1, 5]]), [[0, 1]]).normalised_positions()
    np.testing.assert_allclose(x, ref, atol=1e-12)
