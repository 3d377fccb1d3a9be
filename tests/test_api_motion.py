"""POST /v1/motion and POST /v1/refine through the real FastAPI app."""

import numpy as np
import pytest
from fastapi.testclient import TestClient
from oracles.mechanisms import four_bar, outward_square, parallelogram
from oracles.motion import fidelity, relative_bar_error, rigid_distance
from oracles.wire import frame_body

from zeromode.service.rest.app import create_app
from zeromode.solver.motion.finite_motion import MAX_DOF


@pytest.fixture(scope="module")
def client():
    return TestClient(create_app())


def test_motion_of_a_four_bar(client):
    frame = four_bar()
    r = client.post(
        "/v1/motion", json={"frame": frame_body(frame), "amplitude": 0.3, "max_step": 0.05}
    )
    assert r.status_code == 200
    body = r.json()
    assert body["status"] == "ok" and body["singularities"] == []
    assert len(body["path"]) == len(body["parameter"]) == body["steps"] + 1
    assert body["parameter"][body["reference_index"]] == 0.0
    assert body["path"][body["reference_index"]] == frame.positions.tolist()
    assert body["parameter"][0] == pytest.approx(-0.3) and body["parameter"][-1] == pytest.approx(
        0.3
    )
    assert body["max_relative_bar_error"] <= 1e-9
    assert relative_bar_error(body["path"], frame.edges, frame.positions) <= 1e-9


def test_singular_path_is_a_422_with_the_path_up_to_it(client):
    request = {"frame": frame_body(parallelogram()), "amplitude": 3.0, "max_step": 0.05}
    r = client.post("/v1/motion", json=request)
    assert r.status_code == 422
    detail = r.json()["detail"]
    assert detail["code"] == "singular_path"
    assert "singular point" in detail["message"]
    best = detail["best"]
    assert best["status"] == "singular_path"
    assert [s["extra_zero_modes"] for s in best["singularities"]] == [1, 1]
    assert {s["step"] for s in best["singularities"]} == {0, len(best["path"]) - 1}
    assert (
        relative_bar_error(best["path"], parallelogram().edges, parallelogram().positions) <= 1e-9
    )
    # on_singularity="report": the same answer as a 200.
    r = client.post("/v1/motion", json={**request, "on_singularity": "report"})
    assert r.status_code == 200
    assert r.json()["status"] == "singular_path"
    assert r.json()["singularities"] == best["singularities"]


@pytest.mark.parametrize(
    "change, code",
    [
        ({"mode": [[1.0, 0.0]] * 4}, "rigid_mode"),
        ({"mode": [[1.0, 0.0]] * 3}, "invalid_shape"),
        ({"amplitude": 0}, "invalid_request"),
        ({"amplitude": "NaN"}, "invalid_request"),
        ({"direction": "sideways"}, "invalid_request"),
    ],
)
def test_motion_rejects_bad_requests(client, change, code):
    r = client.post("/v1/motion", json={"frame": frame_body(four_bar()), **change})
    assert r.status_code == 422
    assert r.json()["detail"]["code"] == code


def test_motion_of_an_ambiguous_or_rigid_frame(client):
    square = {
        "dim": 2,
        "positions": [[0, 0], [1, 0], [1, 1], [0, 1], [2, 0.5]],
        "edges": [[0, 1], [1, 2], [2, 3], [3, 0], [1, 4]],
    }
    r = client.post("/v1/motion", json={"frame": square})
    assert r.status_code == 422 and r.json()["detail"]["code"] == "ambiguous_mode"
    triangle = {"dim": 2, "positions": [[0, 0], [1, 0], [0, 1]], "edges": [[0, 1], [1, 2], [0, 2]]}
    r = client.post("/v1/motion", json={"frame": triangle})
    assert r.status_code == 422 and r.json()["detail"]["code"] == "no_motion"


def test_refine_outward_square(client):
    frame = outward_square()
    r = client.post(
        "/v1/refine",
        json={"frame": frame_body(frame), "motion": frame.positions[:4].tolist(), "amplitude": 0.2},
    )
    assert r.status_code == 200
    body = r.json()
    assert body["status"] == "ok" and body["ipopt_status"] == "Solve_Succeeded"
    assert body["epsilon_after"] <= 1e-6
    assert body["epsilon_before"] > 0.05
    assert body["iterations"] > 0 and body["time_ms"] > 0
    assert len(body["path"]) == 9
    assert body["frame"]["positions"][:4] == frame.positions[:4].tolist()
    assert body["frame"]["edges"] == frame.edges.tolist() and body["frame"]["specified"] == [
        0,
        1,
        2,
        3,
    ]
    assert np.allclose(body["path"][-1][:4], 1.2 * frame.positions[:4])
    assert relative_bar_error(body["path"], frame.edges, body["path"][0]) <= 1e-6
    # ε after, measured again by an independent continuation from the refined frame.
    refined = np.array(body["frame"]["positions"])
    assert fidelity(refined, frame.edges, frame.specified, 0.2 * frame.positions[:4]) <= 1e-6
    assert body["analysis_reference"]["nontrivial_zero_modes"] == 1
    assert body["analysis_end"]["self_stresses"] == 0


def test_refinement_failure_is_a_422_with_the_best_result(client):
    frame = outward_square()
    r = client.post(
        "/v1/refine",
        json={
            "frame": frame_body(frame),
            "motion": frame.positions[:4].tolist(),
            "amplitude": 0.2,
            "options": {"stay_on_solution_space": True},
        },
    )
    assert r.status_code == 422
    detail = r.json()["detail"]
    assert detail["code"] == "refinement_failed"
    best = detail["best"]
    assert best["status"] == "refinement_failed"
    assert best["epsilon_after"] <= best["epsilon_before"]
    assert len(best["frame"]["positions"]) == 6
    kept = np.array(best["frame"]["positions"])
    measured = fidelity(kept, frame.edges, frame.specified, 0.2 * frame.positions[:4])
    assert measured == pytest.approx(best["epsilon_after"], rel=1e-6)


@pytest.mark.parametrize(
    "change, code",
    [
        ({}, "invalid_request"),  # neither motion nor targets
        ({"motion": [[1, 1]] * 4, "targets": [[1, 1]] * 4}, "invalid_request"),
        ({"motion": [[1, 1]] * 3}, "invalid_shape"),
        ({"motion": [[1, 1]] * 4, "options": {"K": 0}}, "invalid_request"),
        ({"motion": [[1, 1]] * 4, "options": {"max_time_s": 1e9}}, "invalid_request"),
    ],
)
def test_refine_rejects_bad_requests(client, change, code):
    r = client.post("/v1/refine", json={"frame": frame_body(outward_square()), **change})
    assert r.status_code == 422
    assert r.json()["detail"]["code"] == code


def test_refine_needs_specified_nodes(client):
    frame = frame_body(four_bar())
    r = client.post("/v1/refine", json={"frame": frame, "motion": []})
    assert r.status_code == 422 and r.json()["detail"]["code"] == "too_few_specified"


def test_openapi_documents_both_endpoints(client):
    spec = client.get("/openapi.json").json()
    for path in ("/v1/motion", "/v1/refine"):
        assert path in spec["paths"]
        assert "422" in spec["paths"][path]["post"]["responses"]
    props = spec["components"]["schemas"]["MotionRequest"]["properties"]
    assert {"frame", "mode", "amplitude", "max_step", "direction"} <= set(props)
    assert "description" in props["amplitude"]


def test_motion_of_a_frame_too_large_to_trace_is_refused_naming_the_limit(client):
    n = MAX_DOF // 2 + 1  # a zigzag chain one node past the continuation's limit
    positions = [[float(i), float(i % 2)] for i in range(n)]
    edges = [[i, i + 1] for i in range(n - 1)]
    r = client.post(
        "/v1/motion", json={"frame": {"dim": 2, "positions": positions, "edges": edges}}
    )
    assert r.status_code == 422 and r.json()["detail"]["code"] == "too_expensive"
    assert str(MAX_DOF) in r.json()["detail"]["message"]


@pytest.mark.parametrize("frame", [four_bar(), outward_square(), parallelogram()])
def test_configurations_are_aligned_to_the_reference(client, frame):
    """No proper rigid motion brings any returned configuration closer to the input frame
    (oracles.motion.rigid_distance, an independent alignment), and the input comes back as is."""
    r = client.post(
        "/v1/motion",
        json={"frame": frame_body(frame), "amplitude": 0.6, "on_singularity": "report"},
    )
    body = r.json()
    reference = frame.positions
    assert body["path"][body["reference_index"]] == reference.tolist()
    for configuration in np.array(body["path"]):
        plain = np.linalg.norm(configuration - reference)
        assert rigid_distance(configuration, reference) == pytest.approx(plain, rel=1e-9, abs=1e-12)
        assert np.allclose(configuration.mean(axis=0), reference.mean(axis=0), atol=1e-12)
    assert body["method"] == "dense"
