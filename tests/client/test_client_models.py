"""Frame and result dataclasses: JSON round trips, shapes, immutability (no service needed)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from oracles import frames

from zeromode_client import Frame, Result

K4_SPACE = Frame.from_json(frames.TETRAHEDRON)


def test_frame_json_round_trip_is_exact() -> None:
    rng = np.random.default_rng(0)
    frame = Frame(rng.normal(size=(5, 3)), [[0, 1], [1, 2], [2, 4]], specified=[0, 4])
    doc = json.loads(json.dumps(frame.to_json()))
    assert (
        doc["dim"] == 3 and doc["specified"] == [0, 4] and doc["edges"] == [[0, 1], [1, 2], [2, 4]]
    )
    back = Frame.from_json(doc)
    np.testing.assert_array_equal(back.positions, frame.positions)  # repr of floats round-trips
    np.testing.assert_array_equal(back.edges, frame.edges)
    assert back.specified == frame.specified


def test_frame_is_immutable_and_owns_its_arrays() -> None:
    positions = np.zeros((2, 2))
    positions[1, 0] = 1.0
    frame = Frame(positions, [[0, 1]])
    positions[1, 0] = 5.0
    assert frame.positions[1, 0] == 1.0
    with pytest.raises(ValueError):
        frame.positions[0, 0] = 1.0
    with pytest.raises(AttributeError):
        frame.specified = (0,)  # type: ignore[misc]


def test_frame_without_edges() -> None:
    frame = Frame([[0, 0, 0], [1, 1, 1]])
    assert frame.edges.shape == (0, 2) and frame.dim == 3 and frame.to_json()["edges"] == []


@pytest.mark.parametrize(
    ("positions", "edges", "match"),
    [
        ([0.0, 1.0], [], "N×d"),
        ([[0, 0], [1, 0]], [0, 1], "N_B×2"),
        ([[0, 0], [1, 0]], [[0.5, 1]], "integer"),
    ],
)
def test_frame_shapes_are_checked_locally(positions, edges, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        Frame(positions, edges)


def test_from_json_refuses_a_dim_that_contradicts_the_positions() -> None:
    with pytest.raises(ValueError, match="dim"):
        Frame.from_json({"dim": 3, "positions": [[0, 0], [1, 0]], "edges": [[0, 1]]})


def test_generic_result_parses_frame_and_modes() -> None:
    modes = np.arange(24, dtype=float).reshape(2, 4, 3)
    raw = {
        "frame": K4_SPACE.to_json(),
        "modes": modes.tolist(),
        "poisson_ratio": -0.5,
        "extra": [1, 2],
    }
    result = Result("/v1/design/auxetic", raw)
    assert result["poisson_ratio"] == -0.5 and "extra" in result
    np.testing.assert_array_equal(result.modes, modes)
    np.testing.assert_array_equal(result.frame.positions, K4_SPACE.positions)
    assert result.array("extra").tolist() == [1.0, 2.0]
    empty = Result("/v1/design/auxetic", {"frame": K4_SPACE.to_json(), "modes": []})
    assert empty.modes.shape == (0, 4, 3)
    assert Result("/v1/certify", {}).frame is None
