"""Settings injected into create_app govern every limit at request time.

Each limit is exercised twice through the real app: a small setting refuses a request that the
default settings accept (200), with a 422 (413 for the body) naming the field and the limit. Two
apps with different settings serve side by side, so nothing is read from a global at import time.
"""

import json

import pytest
from fastapi.testclient import TestClient
from oracles.frames import SQUARE_CORNERS, SQUARE_LINKAGE

from zeromode.service.rest.app import create_app
from zeromode.service.wire.examples import example_request
from zeromode.service.wire.settings import Settings

TRIANGLE = {"dim": 2, "positions": [[0, 0], [1, 0], [0, 1]], "edges": [[0, 1], [1, 2], [0, 2]]}
PENTAGON = {
    "dim": 2,
    "positions": [[0, 0], [1, 0], [1.5, 1], [0.5, 1.7], [-0.5, 1]],
    "edges": [[0, 1], [1, 2], [2, 3], [3, 4], [4, 0]],
}


def app_with(**limits) -> TestClient:
    return TestClient(create_app(Settings(**limits)), raise_server_exceptions=False)


@pytest.fixture(scope="module")
def default_app() -> TestClient:
    return app_with()


def assert_refused(response, field: str, bound) -> None:
    assert response.status_code == 422, response.text
    detail = response.json()["detail"]
    assert detail["code"] == "invalid_request"
    assert field in detail["message"] and str(bound) in detail["message"], detail["message"]


@pytest.mark.parametrize(
    ("limits", "path", "body", "field", "bound"),
    [
        ({"max_nodes": 3}, "/v1/analyze", {"frame": PENTAGON}, "frame.positions", 3),
        ({"max_edges": 4}, "/v1/analyze", {"frame": PENTAGON}, "frame.edges", 4),
        (
            {"max_specified": 3},
            "/v1/design",
            {"dim": 2, "positions": SQUARE_CORNERS, "motions": [SQUARE_CORNERS]},
            "positions",
            3,
        ),
        # Fig. 4 of the paper: three specified nodes, two motions.
        ({"max_motions": 1}, "/v1/design", example_request("two_mode_2d"), "motions", 1),
        (
            {"max_samples": 2},
            "/v1/solution-space",
            {"dim": 2, "positions": SQUARE_CORNERS, "motions": SQUARE_CORNERS, "samples": 3},
            "samples",
            2,
        ),
    ],
    ids=["nodes", "edges", "specified", "motions", "samples"],
)
def test_each_size_limit_follows_the_injected_settings(default_app, limits, path, body, field, bound):
    assert_refused(app_with(**limits).post(path, json=body), field, bound)
    assert default_app.post(path, json=body).status_code == 200


def test_body_size_follows_the_injected_settings(default_app):
    body = json.dumps({"frame": TRIANGLE})
    small = app_with(max_body_bytes=len(body) - 1)
    response = small.post("/v1/analyze", content=body, headers={"content-type": "application/json"})
    assert response.status_code == 413
    assert response.json()["detail"]["code"] == "body_too_large"
    assert str(len(body) - 1) in response.json()["detail"]["message"]
    assert default_app.post("/v1/analyze", content=body, headers={"content-type": "application/json"}).status_code == 200


def test_time_budget_follows_the_injected_settings(default_app):
    body = {"dim": 2, "positions": SQUARE_CORNERS, "motions": [SQUARE_CORNERS]}
    response = app_with(time_budget_s=1e-9).post("/v1/design", json=body)
    assert response.status_code == 422
    assert response.json()["detail"]["code"] == "too_expensive"
    assert default_app.post("/v1/design", json=body).status_code == 200


def test_refinement_time_is_bounded_by_the_injected_budget():
    frame = {"dim": 2, "positions": SQUARE_CORNERS, "edges": [[0, 1]], "specified": [0, 1, 2, 3]}
    body = {"frame": frame, "motion": SQUARE_CORNERS, "options": {"max_time_s": 3.0}}
    assert_refused(app_with(time_budget_s=2.0).post("/v1/refine", json=body), "max_time_s", 2)


def test_answers_are_not_held_to_the_request_limits():
    """Four specified nodes within max_nodes=4; the designed frame has more nodes, and is answered."""
    body = {"dim": 2, "positions": SQUARE_CORNERS, "motions": [SQUARE_CORNERS]}
    response = app_with(max_nodes=4, max_edges=4).post("/v1/design", json=body)
    assert response.status_code == 200, response.text
    frame = response.json()["frame"]
    assert len(frame["positions"]) > 4 and len(frame["edges"]) > 4


def test_the_openapi_document_states_the_serving_apps_limits():
    limits = {
        "max_nodes": 3, "max_edges": 5, "max_specified": 6, "max_motions": 2, "max_samples": 7, "time_budget_s": 8.0
    }
    for settings in (Settings(), Settings(**limits)):
        schemas = app_with(**settings.model_dump()).get("/openapi.json").json()["components"]["schemas"]
        design = schemas["DesignRequest"]["properties"]
        assert {
            "max_nodes": schemas["FrameModel"]["properties"]["positions"]["maxItems"],
            "max_edges": schemas["FrameModel"]["properties"]["edges"]["maxItems"],
            "max_specified": design["positions"]["maxItems"],
            "max_motions": design["motions"]["maxItems"],
            "max_samples": schemas["SolutionSpaceRequest"]["properties"]["samples"]["maximum"],
            "time_budget_s": schemas["RefineOptions"]["properties"]["max_time_s"]["maximum"],
        } == {name: getattr(settings, name) for name in limits}
        assert "maxItems" not in schemas["ResultFrame"]["properties"]["positions"]


def test_two_apps_with_different_settings_serve_side_by_side():
    small, large = app_with(max_nodes=4), app_with(max_nodes=5)
    assert small.post("/v1/analyze", json={"frame": PENTAGON}).status_code == 422
    assert large.post("/v1/analyze", json={"frame": PENTAGON}).status_code == 200
    assert small.post("/v1/analyze", json={"frame": TRIANGLE}).status_code == 200


def test_settings_come_from_the_environment(monkeypatch):
    monkeypatch.setenv("ZEROMODE_MAX_NODES", "7")
    monkeypatch.setenv("ZEROMODE_CORS_ORIGINS", "https://a.example, https://b.example")
    monkeypatch.setenv("ZEROMODE_API_KEY", "")
    settings = Settings()
    assert settings.max_nodes == 7
    assert settings.cors_origins == ("https://a.example", "https://b.example")
    assert settings.api_key is None
    monkeypatch.setenv("ZEROMODE_DASK_SCHEDULER", "")  # empty is unset: the embedded cluster
    assert Settings().dask_scheduler is None
    assert_refused(
        TestClient(create_app(), raise_server_exceptions=False).post(
            "/v1/analyze", json={"frame": {"dim": 2, "positions": [[float(i), 0.0] for i in range(8)]}}
        ),
        "frame.positions",
        7,
    )


def test_settings_refuse_nonsense_and_are_immutable():
    with pytest.raises(ValueError):
        Settings(max_nodes=0)
    with pytest.raises(ValueError):
        Settings(max_nodez=5)  # a typo is an error, not a silently ignored option
    settings = Settings()
    with pytest.raises(ValueError):
        settings.max_nodes = 3


VALID_BODIES = {
    "/v1/analyze": {"frame": TRIANGLE},
    "/v1/solution-space": {"dim": 2, "positions": SQUARE_CORNERS, "motions": SQUARE_CORNERS},
    "/v1/design": {"dim": 2, "positions": SQUARE_CORNERS, "motions": [SQUARE_CORNERS]},
    "/v1/design/two-configuration": {
        "dim": 2,
        "initial": SQUARE_CORNERS,
        "final": [[1.1, 1.1], [-1.1, 1.1], [-1.1, -1.1], [1.1, -1.1]],
    },
    "/v1/design/auxetic": {"dim": 2, "cells": [2, 2], "poisson_ratio": -0.5},
    "/v1/design/multistable": {
        "dim": 2,
        "conformations": [[[0.0, 0.0], [1.0, 0.0], [0.3, 0.8]], [[0.0, 0.0], [1.0, 0.0], [0.45, 1.0]]],
    },
    "/v1/motion": {"frame": SQUARE_LINKAGE},
    "/v1/certify": {"frame": TRIANGLE},
    "/v1/plot": {"frame": TRIANGLE},
}


# A nested object of each endpoint where a typo could hide.
NESTED = {
    "/v1/analyze": "options",
    "/v1/design": "options",
    "/v1/design/two-configuration": "options",
    "/v1/design/multistable": "options",
    "/v1/certify": "options",
    "/v1/motion": "frame",
    "/v1/plot": "frame",
}


@pytest.mark.parametrize(
    ("path", "key"),
    [(path, None) for path in sorted(VALID_BODIES)] + sorted(NESTED.items()),
)
def test_unknown_fields_are_refused_by_name(default_app, path, key):
    body = json.loads(json.dumps(VALID_BODIES[path]))
    (body.setdefault(key, {}) if key else body)["seeed"] = 3
    name = f"{key}.seeed" if key else "seeed"
    assert default_app.post(path, json=VALID_BODIES[path]).status_code == 200
    response = default_app.post(path, json=body)
    assert response.status_code == 422, response.text
    detail = response.json()["detail"]
    assert detail["code"] == "invalid_request" and name in detail["message"], detail
