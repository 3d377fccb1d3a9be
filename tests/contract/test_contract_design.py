"""API.md "POST /v1/design": the frame, the modes, the report, and the promise of the design.

The promise (exactly d(d+1)/2 + M zero modes, no self-stress, C·modes[i] = 0) is recomputed
here from an SVD of the compatibility matrix of the returned frame (paper, Eq. 3).
"""

from __future__ import annotations

import numpy as np
import pytest
from oracles.frames import CUBE_CORNERS, SQUARE_CORNERS, arrays
from oracles.motion import bar_lengths
from oracles.rigidity import (
    COUNT_FIELDS,
    compatibility_matrix,
    mode_residual,
    rank_gap,
    reference_counts,
)
from oracles.wire import assert_error, is_int, is_number, matrix

SQUARE = SQUARE_CORNERS
CUBE = CUBE_CORNERS


def two_motions(d: int, k: int, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    x, u1, u2 = (rng.standard_normal((k, d)).tolist() for _ in range(3))
    return {"dim": d, "positions": x, "motions": [u1, u2], "options": {"seed": 0}}


REQUESTS = {
    # Fig. 3b: four corners moving outward; Fig. 3d: the cube.
    "outward_square": {"dim": 2, "positions": SQUARE, "motions": [SQUARE], "options": {"seed": 0}},
    "outward_cube": {"dim": 3, "positions": CUBE, "motions": [CUBE], "options": {"seed": 0}},
    "two_motions_2d": two_motions(2, 5, 0),
    "shear_square": {
        "dim": 2,
        "positions": SQUARE,
        "motions": [[[1.0, 0.0], [1.0, 0.0], [-1.0, 0.0], [-1.0, 0.0]]],
        "options": {"seed": 3},
    },
}


@pytest.fixture(scope="module")
def answers(client) -> dict[str, dict]:
    out = {}
    for name, request in REQUESTS.items():
        response = client.post("/v1/design", json=request)
        assert response.status_code == 200, (name, response.text[:300])
        out[name] = response.json()
    return out


CASES = list(REQUESTS)


@pytest.mark.parametrize("name", CASES)
def test_every_field_is_present(answers, name):
    body = answers[name]
    assert {"frame", "modes", "report"} <= set(body)
    assert {"dim", "positions", "edges", "specified"} <= set(body["frame"])
    assert {"analysis", "target_zero_modes", "unspecified_nodes", "timings_ms"} <= set(
        body["report"]
    )


@pytest.mark.parametrize("name", CASES)
def test_the_first_k_nodes_are_the_specified_nodes_at_exactly_the_requested_positions(
    answers, name
):
    request, frame = REQUESTS[name], answers[name]["frame"]
    k, d = len(request["positions"]), request["dim"]
    assert frame["dim"] == d
    positions = matrix(frame["positions"], len(frame["positions"]), d)
    assert positions[:k].tolist() == [[float(v) for v in p] for p in request["positions"]]


@pytest.mark.parametrize("name", CASES)
def test_specified_is_0_to_k_minus_1(answers, name):
    k = len(REQUESTS[name]["positions"])
    assert answers[name]["frame"]["specified"] == list(range(k))


@pytest.mark.parametrize("name", CASES)
def test_frame_is_a_valid_frame(answers, name):
    x, edges = arrays(answers[name]["frame"])
    assert all(is_int(i) for e in answers[name]["frame"]["edges"] for i in e)
    assert np.all((edges >= 0) & (edges < len(x))) and np.all(edges[:, 0] != edges[:, 1])
    assert len({tuple(sorted(e)) for e in edges.tolist()}) == len(edges)
    assert bar_lengths(x, edges).min() > 0


@pytest.mark.parametrize("name", CASES)
def test_modes_are_M_full_zero_modes_whose_specified_rows_equal_the_motions_exactly(answers, name):
    request, body = REQUESTS[name], answers[name]
    n, d, k = len(body["frame"]["positions"]), request["dim"], len(request["positions"])
    assert isinstance(body["modes"], list) and len(body["modes"]) == len(request["motions"])
    for mode, motion in zip(body["modes"], request["motions"], strict=True):
        mode = matrix(mode, n, d)
        assert mode[:k].tolist() == [[float(v) for v in row] for row in motion]


@pytest.mark.parametrize("name", CASES)
def test_c_times_every_mode_is_zero(answers, name):
    body = answers[name]
    x, edges = arrays(body["frame"])
    c = compatibility_matrix(x, edges)
    assert len(body["modes"]) == len(REQUESTS[name]["motions"])
    for mode in body["modes"]:
        assert mode_residual(c, np.array(mode)) <= 1e-9


@pytest.mark.parametrize("name", CASES)
def test_exactly_d_d_plus_1_over_2_plus_M_zero_modes_and_no_self_stress(answers, name):
    request, body = REQUESTS[name], answers[name]
    d, n_motions = request["dim"], len(request["motions"])
    recomputed = reference_counts(*arrays(body["frame"]))
    assert recomputed["zero_modes"] == d * (d + 1) // 2 + n_motions
    assert recomputed["self_stresses"] == 0
    assert recomputed["rigid_body_modes"] == d * (d + 1) // 2
    assert recomputed["nontrivial_zero_modes"] == n_motions


@pytest.mark.parametrize("name", CASES)
def test_report_analysis_is_the_analyze_fields_without_the_bases(answers, name):
    analysis = answers[name]["report"]["analysis"]
    assert {*COUNT_FIELDS, "rank_gap"} <= set(analysis)
    assert {"modes", "stresses"}.isdisjoint(analysis)
    x, edges = arrays(answers[name]["frame"])
    recomputed = reference_counts(x, edges)
    assert {k: analysis[k] for k in COUNT_FIELDS} == recomputed
    assert all(is_int(analysis[k]) for k in COUNT_FIELDS)
    gap = analysis["rank_gap"]
    assert is_number(gap["last_nonzero"]) and is_number(gap["first_zero"])
    assert np.isclose(gap["last_nonzero"], rank_gap(x, edges)["last_nonzero"], rtol=1e-6)


@pytest.mark.parametrize("name", CASES)
def test_target_zero_modes_is_d_d_plus_1_over_2_plus_M(answers, name):
    request = REQUESTS[name]
    d, n_motions = request["dim"], len(request["motions"])
    target = answers[name]["report"]["target_zero_modes"]
    assert is_int(target) and target == d * (d + 1) // 2 + n_motions


@pytest.mark.parametrize("name", CASES)
def test_unspecified_nodes_is_N_minus_k(answers, name):
    body = answers[name]
    unspecified = body["report"]["unspecified_nodes"]
    assert is_int(unspecified)
    assert unspecified == len(body["frame"]["positions"]) - len(REQUESTS[name]["positions"])


@pytest.mark.parametrize("name", CASES)
def test_timings_ms_are_non_negative_numbers(answers, name):
    timings = answers[name]["report"]["timings_ms"]
    assert isinstance(timings, dict) and timings
    assert all(isinstance(k, str) and is_number(v) and v >= 0 for k, v in timings.items())


def test_the_same_request_gives_the_same_design(client, answers):
    again = client.post("/v1/design", json=REQUESTS["two_motions_2d"]).json()
    assert again["frame"] == answers["two_motions_2d"]["frame"]
    assert again["modes"] == answers["two_motions_2d"]["modes"]


def test_targets_with_no_design_are_no_solution_with_a_reason(client):
    """Two motions of the square, the second moving one corner alone: no real placement."""
    request = {
        "dim": 2,
        "positions": SQUARE,
        "motions": [SQUARE, [[1.0, 0.0], [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]]],
    }
    detail = assert_error(client.post("/v1/design", json=request), "no_solution", status=422)
    assert len(detail["message"].split()) >= 6
