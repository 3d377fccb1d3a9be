"""POST /v1/design/allosteric/network — allostery inside a given network.

The contract: the answer carries the modified frame, its mode and a report of what changed
(bars removed, nodes and bars added) and of the response achieved. Checked here from the
numbers on the wire alone: the given nodes and the kept bars are the given ones, the modified
frame has d(d+1)/2 + 1 zero modes, and the zero mode that moves the source as reported moves the
target as prescribed (or strains the target pair η* times the source pair). Requests without
meaning answer 422 with a code.
"""

from __future__ import annotations

import numpy as np
import pytest
from oracles.frames import SQUARE_CORNERS
from oracles.rigidity import driven_response, reference_counts
from oracles.wire import assert_error, is_number, matrix

from benchmarks.allostery_tasks import make_task

PATH = "/v1/design/allosteric/network"
TASK = make_task(40, 0, -2.0)
GIVEN = {
    "dim": 2,
    "positions": TASK.frame.positions.tolist(),
    "edges": TASK.frame.edges.tolist(),
}
FLOPPY = {"dim": 2, "positions": SQUARE_CORNERS, "edges": [[0, 1], [1, 2], [2, 3], [3, 0]]}  # a linkage
PAIRS = {"source": list(TASK.source_pair), "target": list(TASK.target_pair)}


def strain(x, u, pair) -> float:
    i, j = pair
    return float((x[i] - x[j]) @ (u[i] - u[j]) / np.sum((x[i] - x[j]) ** 2))


@pytest.fixture(scope="module")
def by_ratio(client) -> dict:
    response = client.post(PATH, json={"frame": GIVEN, **PAIRS, "strain_ratio": -2.0})
    assert response.status_code == 200, response.text[:300]
    return response.json()


@pytest.fixture(scope="module")
def by_motion(client) -> tuple[dict, np.ndarray]:
    u = TASK.specified_motion()
    body = {"frame": GIVEN, **PAIRS, "source_motion": u[:2].tolist(), "target_motion": u[2:].tolist()}
    response = client.post(PATH, json=body)
    assert response.status_code == 200, response.text[:300]
    return response.json(), u[2:]


def check_changes(answer: dict) -> tuple[np.ndarray, np.ndarray]:
    """The modified frame is the given one less the removed bars plus the added nodes and bars,
    as the report lists them; it has rigid motions plus one zero mode."""
    frame, report = answer["frame"], answer["report"]
    x = matrix(frame["positions"], None, 2)
    edges = np.asarray(frame["edges"], dtype=int)
    n = len(GIVEN["positions"])
    np.testing.assert_array_equal(x[:n], np.asarray(GIVEN["positions"]))
    given = np.asarray(GIVEN["edges"])
    removed = report["removed_edges"]
    np.testing.assert_array_equal(given[removed], np.asarray(report["removed_bars"]).reshape(-1, 2))
    kept = np.delete(given, removed, axis=0)
    np.testing.assert_array_equal(edges, np.vstack([kept, np.asarray(report["added_edges"]).reshape(-1, 2)]))
    assert report["added_nodes"] == list(range(n, len(x)))
    assert report["bonds_changed"] == len(removed) + len(report["added_edges"])
    counts = reference_counts(x, edges)
    assert counts["zero_modes"] == 4 == report["analysis"]["zero_modes"]
    return x, edges


def test_strain_ratio_answer_lists_its_changes_and_strains_the_target_as_asked(by_ratio):
    x, edges = check_changes(by_ratio)
    report = by_ratio["report"]
    source, target = report["source"], report["target"]
    response = driven_response(x, edges, source, report["source_motion"])
    eta = strain(x, response, target) / strain(x, response, source)
    assert eta == pytest.approx(-2.0, rel=1e-9)
    assert is_number(report["strain_ratio"]) and report["strain_ratio"] == pytest.approx(-2.0, rel=1e-9)
    assert report["target_error"] <= 1e-9
    np.testing.assert_allclose(report["achieved_target_motion"], response[target], atol=1e-9)
    assert len(by_ratio["modes"]) == 1


def test_motion_answer_moves_the_target_as_prescribed(by_motion):
    answer, u_tgt = by_motion
    x, edges = check_changes(answer)
    report = answer["report"]
    response = driven_response(x, edges, report["source"], report["source_motion"])
    error = np.linalg.norm(response[report["target"]] - u_tgt) / np.linalg.norm(u_tgt)
    assert error <= 1e-9
    assert report["strain_ratio"] is None


@pytest.mark.parametrize(
    ("body", "code"),
    [
        ({"frame": FLOPPY, "source": [0, 1], "target": [2, 3], "strain_ratio": 1.0}, "floppy_network"),
        ({"frame": GIVEN, **PAIRS, "strain_ratio": 0.0}, "zero_strain"),
        ({"frame": GIVEN, **PAIRS}, "invalid_response"),
        ({"frame": GIVEN, "source": PAIRS["source"], "target": PAIRS["source"], "strain_ratio": 1.0}, "overlapping_sites"),
        ({"frame": GIVEN, "source": [0, 10_000], "target": PAIRS["target"], "strain_ratio": 1.0}, "invalid_nodes"),
        (
            {"frame": GIVEN, **PAIRS, "source_motion": [[1.0, 0.0], [1.0, 0.0]], "target_motion": [[1.0, 0.0], [0.0, 1.0]]},
            "rigid_source",
        ),
        ({"frame": GIVEN, **PAIRS, "strain_ratio": 1.0, "options": {"seeed": 1}}, "invalid_request"),
    ],
)
def test_requests_without_meaning_answer_422_with_a_code(client, body, code):
    assert_error(client.post(PATH, json=body), code)
