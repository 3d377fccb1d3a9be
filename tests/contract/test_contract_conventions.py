"""API.md "Conventions" and "Frame": one test per statement.

All endpoints under /v1/, GET /health, /openapi.json naming every endpoint and field, row-list
points, 0-based indices, an edge equal to its reverse, dim 2 or 3, every kind of bad input a
4xx whose body names the problem, domain failures as 422 {"detail": {"code", "message"}} with
snake_case codes, and never a 5xx.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from oracles.frames import K4_PLANE, SQUARE_CORNERS, SQUARE_LINKAGE, TETRAHEDRON, TRIANGLE
from oracles.rigidity import COUNT_FIELDS, RANK_GAP_FIELDS
from oracles.wire import assert_error

from zeromode.service import __version__
from zeromode.service.wire.settings import Settings

SETTINGS = Settings()  # the defaults the test app is built with

SQUARE = SQUARE_CORNERS
DESIGN = {"dim": 2, "positions": SQUARE, "motions": [SQUARE], "options": {"seed": 0}}
SOLUTION_SPACE = {"dim": 2, "positions": SQUARE[:3], "motions": SQUARE[:3], "samples": 3}
API_ENDPOINTS = [
    ("get", "/health"),
    ("post", "/v1/analyze"),
    ("post", "/v1/solution-space"),
    ("post", "/v1/design"),
    ("post", "/v1/design/auxetic"),
    ("post", "/v1/design/allosteric"),
    ("post", "/v1/motion"),
    ("post", "/v1/refine"),
    ("post", "/v1/certify"),
]
FRAME_FIELDS = ["dim", "positions", "edges", "specified"]
ANALYSIS_FIELDS = [*COUNT_FIELDS, *(f"rank_gap.{f}" for f in RANK_GAP_FIELDS)]
# Every field API.md names, as dotted paths into the request and 200-response schemas.
REQUEST_FIELDS = {
    "/v1/analyze": ["frame"] + [f"frame.{f}" for f in FRAME_FIELDS],
    "/v1/solution-space": ["dim", "positions", "motions", "samples"],
    "/v1/design": ["dim", "positions", "motions", "options", "options.seed"],
}
RESPONSE_FIELDS = {
    "/health": ["status", "version"],
    "/v1/analyze": [*ANALYSIS_FIELDS, "modes", "stresses"],
    "/v1/solution-space": [
        "nullity",
        "dimension",
        "kind",
        "basis",
        "quadric",
        "samples",
        "samples.position",
        "samples.motion",
    ],
    "/v1/design": [
        "frame",
        *[f"frame.{f}" for f in FRAME_FIELDS],
        "modes",
        "report",
        *[f"report.analysis.{f}" for f in ANALYSIS_FIELDS],
        "report.target_zero_modes",
        "report.unspecified_nodes",
        "report.timings_ms",
    ],
    "/v1/design/auxetic": ["frame", "modes", "poisson_ratio"],
    "/v1/design/allosteric": ["frame", "modes", "report"],
}


# --------------------------------------------------------------------------- OpenAPI walking
def resolve(root: dict, schema: dict) -> dict:
    """``schema`` with $ref followed and anyOf/oneOf/allOf (e.g. optional fields) merged."""
    while "$ref" in schema:
        name = schema["$ref"].rsplit("/", 1)[-1]
        schema = root["components"]["schemas"][name]
    merged = {k: v for k, v in schema.items() if k not in ("anyOf", "oneOf", "allOf")}
    for key in ("anyOf", "oneOf", "allOf"):
        for part in schema.get(key, []):
            part = resolve(root, part)
            merged.setdefault("properties", {}).update(part.get("properties", {}))
            if "items" in part:
                merged.setdefault("items", part["items"])
            if "enum" in part:
                merged.setdefault("enum", part["enum"])
    return merged


def properties(root: dict, schema: dict) -> dict:
    """The properties of an object schema, or of the items of an array of objects."""
    schema = resolve(root, schema)
    while "properties" not in schema and "items" in schema:
        schema = resolve(root, schema["items"])
    return schema.get("properties", {})


def field(root: dict, schema: dict, dotted: str) -> dict:
    for name in dotted.split("."):
        props = properties(root, schema)
        assert name in props, f"{dotted}: no {name!r} among {sorted(props)}"
        schema = props[name]
    return resolve(root, schema)


def operation(openapi: dict, method: str, path: str) -> dict:
    assert path in openapi["paths"], f"{path} is not in /openapi.json"
    assert method in openapi["paths"][path], f"{method.upper()} {path} is not in /openapi.json"
    return openapi["paths"][path][method]


def request_schema(openapi: dict, path: str) -> dict:
    return operation(openapi, "post", path)["requestBody"]["content"]["application/json"]["schema"]


def response_schema(openapi: dict, method: str, path: str) -> dict:
    return operation(openapi, method, path)["responses"]["200"]["content"]["application/json"][
        "schema"
    ]


def reachable_property_names(root: dict, schema: dict, seen: set[str] | None = None) -> set[str]:
    """Every property name in ``schema`` and the schemas it refers to, at any depth."""
    seen = set() if seen is None else seen
    names: set[str] = set()
    if isinstance(schema, dict):
        ref = schema.get("$ref")
        if ref is not None and ref not in seen:
            seen.add(ref)
            names |= reachable_property_names(root, resolve(root, schema), seen)
        names.update(schema.get("properties", {}))
        for value in schema.values():
            names |= reachable_property_names(root, value, seen)
    elif isinstance(schema, list):
        for value in schema:
            names |= reachable_property_names(root, value, seen)
    return names


# --------------------------------------------------------------------------- conventions
def test_every_endpoint_is_under_v1(openapi):
    outside = [p for p in openapi["paths"] if not p.startswith("/v1/") and p != "/health"]
    assert outside == []


def test_health_answers_status_ok_and_the_version(client):
    response = client.get("/health")
    assert response.status_code == 200
    body = response.json()
    assert body["status"] == "ok" and body["version"] == __version__
    assert isinstance(body["version"], str) and body["version"]


def test_openapi_is_served_as_json(client):
    response = client.get("/openapi.json")
    assert response.status_code == 200
    assert response.headers["content-type"].startswith("application/json")
    assert response.json()["openapi"].startswith("3.")


@pytest.mark.parametrize(("method", "path"), API_ENDPOINTS)
def test_openapi_lists_every_endpoint(openapi, method, path):
    operation(openapi, method, path)


@pytest.mark.parametrize(
    ("path", "dotted"), [(p, f) for p, fs in REQUEST_FIELDS.items() for f in fs]
)
def test_openapi_names_every_request_field(openapi, path, dotted):
    field(openapi, request_schema(openapi, path), dotted)


@pytest.mark.parametrize(
    ("path", "dotted"), [(p, f) for p, fs in RESPONSE_FIELDS.items() for f in fs]
)
def test_openapi_names_every_response_field(openapi, path, dotted):
    method = "get" if path == "/health" else "post"
    field(openapi, response_schema(openapi, method, path), dotted)


def test_openapi_names_the_capability_report_fields(openapi):
    """Motion: path and the largest relative bar-length error; refine: ε before and after;
    allosteric: the achieved target motion. API.md leaves these names to the capability."""
    motion = properties(openapi, response_schema(openapi, "post", "/v1/motion"))
    assert "path" in motion
    assert any("bar" in name and "error" in name for name in motion), sorted(motion)
    refine = properties(openapi, response_schema(openapi, "post", "/v1/refine"))
    assert any("before" in n for n in refine) and any("after" in n for n in refine), sorted(refine)
    report = field(openapi, response_schema(openapi, "post", "/v1/design/allosteric"), "report")
    assert any("achieved" in name for name in report["properties"]), sorted(report["properties"])


def test_openapi_names_the_certificates(openapi):
    schema = response_schema(openapi, "post", "/v1/certify")
    names = " ".join(sorted(reachable_property_names(openapi, schema)))
    for word in ("stress", "prestress", "margin"):
        assert word in names, names


def test_openapi_kind_names_are_the_four_of_the_contract(openapi):
    kind = field(openapi, response_schema(openapi, "post", "/v1/solution-space"), "kind")
    assert set(kind["enum"]) == {"points", "conic", "quadric_surface", "quadric_hypersurface"}


def test_openapi_dim_is_2_or_3(openapi):
    for path, dotted in [
        ("/v1/analyze", "frame.dim"),
        ("/v1/design", "dim"),
        ("/v1/solution-space", "dim"),
    ]:
        assert set(field(openapi, request_schema(openapi, path), dotted)["enum"]) == {2, 3}


def test_openapi_declares_the_error_body_for_422(openapi):
    for path in ("/v1/analyze", "/v1/solution-space", "/v1/design"):
        schema = operation(openapi, "post", path)["responses"]["422"]["content"][
            "application/json"
        ]["schema"]
        detail = field(openapi, schema, "detail")
        assert {"code", "message"} <= set(detail["properties"])


# --------------------------------------------------------------------------- frames
def test_points_are_row_lists(client):
    """N points in d dimensions are N rows of d numbers; the transposed (column) list is refused."""
    rows = client.post("/v1/analyze", json={"frame": K4_PLANE})
    assert rows.status_code == 200
    assert rows.json()["nodes"] == 4 and rows.json()["dim"] == 2
    columns = {**K4_PLANE, "positions": np.array(K4_PLANE["positions"]).T.tolist()}
    assert_error(client.post("/v1/analyze", json={"frame": columns}), status=None)
    # Answers use row lists too: a mode of the 4-node linkage is 4 rows of 2.
    square = client.post("/v1/analyze", json={"frame": SQUARE_LINKAGE}).json()
    assert len(square["modes"]) == 1 and len(square["modes"][0]) == 4
    assert all(len(row) == 2 for row in square["modes"][0])


def test_node_indices_are_0_based(client):
    two = {"dim": 2, "positions": [[0.0, 0.0], [1.0, 0.0]], "edges": [[0, 1]]}
    body = client.post("/v1/analyze", json={"frame": two}).json()
    assert (body["rank"], body["self_stresses"]) == (1, 0)
    assert_error(
        client.post("/v1/analyze", json={"frame": {**two, "edges": [[1, 2]]}}), status=None
    )
    specified = client.post("/v1/analyze", json={"frame": {**two, "specified": [0, 1]}})
    assert specified.status_code == 200
    assert_error(client.post("/v1/analyze", json={"frame": {**two, "specified": [2]}}), status=None)


def test_an_edge_and_its_reverse_are_the_same_edge(client):
    reversed_edges = {**K4_PLANE, "edges": [[j, i] for i, j in K4_PLANE["edges"]]}
    a = client.post("/v1/analyze", json={"frame": K4_PLANE}).json()
    b = client.post("/v1/analyze", json={"frame": reversed_edges}).json()
    assert {k: a[k] for k in COUNT_FIELDS} == {k: b[k] for k in COUNT_FIELDS}
    twice = {**TRIANGLE, "edges": [*TRIANGLE["edges"], [1, 0]]}
    detail = assert_error(client.post("/v1/analyze", json={"frame": twice}), status=None)
    assert "edge" in detail["message"]


def test_specified_is_optional(client):
    without = client.post("/v1/analyze", json={"frame": TRIANGLE})
    with_empty = client.post("/v1/analyze", json={"frame": {**TRIANGLE, "specified": []}})
    assert without.status_code == with_empty.status_code == 200


@pytest.mark.parametrize("dim", [2, 3])
def test_dim_2_and_3_are_accepted(client, dim):
    frame = TRIANGLE if dim == 2 else TETRAHEDRON
    response = client.post("/v1/analyze", json={"frame": frame})
    assert response.status_code == 200 and response.json()["dim"] == dim


@pytest.mark.parametrize("dim", [0, 1, 4, -2, 2.5, "2", None])
def test_other_dims_are_refused(client, dim):
    frame = {"dim": dim, "positions": [[0.0] * 2, [1.0] * 2], "edges": [[0, 1]]}
    detail = assert_error(client.post("/v1/analyze", json={"frame": frame}), status=None)
    assert "dim" in detail["message"]
    design = assert_error(client.post("/v1/design", json={**DESIGN, "dim": dim}), status=None)
    assert "dim" in design["message"]


# --------------------------------------------------------------------------- bad input → 4xx
def frame_request(**changes) -> dict:
    return {"frame": {**TRIANGLE, **changes}}


RAW_NON_FINITE = ["NaN", "Infinity", "-Infinity", "1e999", "-1e999"]
BAD_FRAMES = {
    "ragged positions": (frame_request(positions=[[0, 0], [1, 0, 0], [0, 1]]), "positions"),
    "points of the wrong dimension": (
        frame_request(positions=[[0, 0, 0], [1, 0, 0], [0, 1, 0]]),
        "positions",
    ),
    "no positions": (frame_request(positions=[]), "positions"),
    "scalar positions": (frame_request(positions=[0, 1, 2]), "positions"),
    "edge with three ends": (frame_request(edges=[[0, 1, 2]]), "edges"),
    "edge with one end": (frame_request(edges=[[0]]), "edges"),
    "fractional index": (frame_request(edges=[[0, 1.5]]), "edges"),
    "string coordinate": (frame_request(positions=[[0, "a"], [1, 0], [0, 1]]), "positions"),
    "edge past the last node": (frame_request(edges=[[0, 3]]), "edge"),
    "negative index": (frame_request(edges=[[-1, 0]]), "edge"),
    "huge index": (frame_request(edges=[[0, 10**30]]), "edge"),
    "duplicate edge": (frame_request(edges=[[0, 1], [0, 1]]), "edge"),
    "edge and its reverse": (frame_request(edges=[[0, 1], [2, 0], [1, 0]]), "edge"),
    "self-loop": (frame_request(edges=[[1, 1]]), "itself"),
    "coincident joined nodes": (frame_request(positions=[[0, 0], [0, 0], [0, 1]]), "coincident"),
    "specified out of range": (frame_request(specified=[3]), "specified"),
    "specified twice": (frame_request(specified=[1, 1]), "specified"),
    "too many nodes": (
        {
            "frame": {
                "dim": 2,
                "positions": [[float(i), 0.0] for i in range(SETTINGS.max_nodes + 1)],
            }
        },
        "positions",
    ),
}


@pytest.mark.parametrize("literal", RAW_NON_FINITE)
@pytest.mark.parametrize(
    ("path", "template"),
    [
        ("/v1/analyze", {"frame": {**TRIANGLE, "positions": [[0, "X"], [1, 0], [0, 1]]}}),
        ("/v1/design", {**DESIGN, "motions": [[[1, 1], [-1, 1], [-1, "X"], [1, -1]]]}),
        ("/v1/design", {**DESIGN, "positions": [[1, 1], [-1, 1], [-1, -1], ["X", -1]]}),
        ("/v1/solution-space", {**SOLUTION_SPACE, "motions": [[1, 1], ["X", 1], [-1, -1]]}),
        ("/v1/design/auxetic", {"dim": 2, "cells": [2, 2], "poisson_ratio": "X"}),
    ],
)
def test_non_finite_numbers_are_refused(client, path, template, literal):
    body = json.dumps(template).replace('"X"', literal)
    response = client.post(path, content=body, headers={"content-type": "application/json"})
    detail = assert_error(response, status=None)
    assert "finite" in detail["message"] or "number" in detail["message"], detail


@pytest.mark.parametrize("case", list(BAD_FRAMES))
def test_bad_frames_are_a_4xx_naming_the_problem(client, case):
    request, word = BAD_FRAMES[case]
    detail = assert_error(client.post("/v1/analyze", json=request), status=None)
    assert word in detail["message"], detail


@pytest.mark.parametrize(
    ("change", "word"),
    [
        ({"motions": [[[1, 1], [-1, 1], [-1, -1]]]}, "motion"),  # k rows of motion, not k − 1
        ({"motions": [[[1, 1, 0], [-1, 1, 0], [-1, -1, 0], [1, -1, 0]]]}, "motion"),
        ({"motions": [SQUARE] * (SETTINGS.max_motions + 1)}, "motions"),
        ({"motions": []}, "motions"),
        ({"positions": [[float(i), 0.0] for i in range(SETTINGS.max_specified + 1)]}, "positions"),
        ({"positions": [[1, 1], [1, 1], [-1, -1], [1, -1]]}, "coincide"),
    ],
)
def test_bad_design_requests_are_a_4xx_naming_the_problem(client, change, word):
    detail = assert_error(client.post("/v1/design", json={**DESIGN, **change}), status=None)
    assert word in detail["message"], detail


@pytest.mark.parametrize(
    ("change", "word"),
    [
        ({"motions": SQUARE[:2]}, "motion"),
        ({"samples": SETTINGS.max_samples + 1}, "samples"),
        ({"samples": -1}, "samples"),
        ({"positions": [[0, 0, 0]] * 3}, "position"),
    ],
)
def test_bad_solution_space_requests_are_a_4xx_naming_the_problem(client, change, word):
    body = {**SOLUTION_SPACE, **change}
    detail = assert_error(client.post("/v1/solution-space", json=body), status=None)
    assert word in detail["message"], detail


def test_a_body_past_the_size_limit_is_a_413(client):
    response = client.post(
        "/v1/analyze",
        content=b"{}",
        headers={
            "content-type": "application/json",
            "content-length": str(SETTINGS.max_body_bytes + 1),
        },
    )
    detail = assert_error(response, "body_too_large", status=413)
    assert str(SETTINGS.max_body_bytes) in detail["message"]


MALFORMED = [
    b"",
    b"{",
    b"null",
    b"[]",
    b'"frame"',
    b"\xff\xfe",
    b"{}",
    b'{"frame": null}',
    b'{"dim": 2, "frame": 7}',
]
POST_ENDPOINTS = [
    "/v1/analyze",
    "/v1/solution-space",
    "/v1/design",
    "/v1/design/auxetic",
    "/v1/design/allosteric",
    "/v1/motion",
    "/v1/refine",
]


@pytest.mark.parametrize(
    ("path", "body"),
    # Every field of /v1/design/auxetic has a default, so any JSON object is a valid request.
    [
        (p, b)
        for p in POST_ENDPOINTS
        for b in MALFORMED
        if not (p.endswith("auxetic") and b[:1] == b"{" and b != b"{")
    ],
)
def test_malformed_bodies_are_a_4xx_never_a_5xx(client, path, body):
    response = client.post(path, content=body, headers={"content-type": "application/json"})
    assert_error(response, status=None)


# --------------------------------------------------------------------------- domain failures
DOMAIN_FAILURES = [
    ("/v1/design", {**DESIGN, "motions": [[[1.0, 0.0]] * 4]}, "rigid_target"),
    (
        "/v1/design",
        {**DESIGN, "motions": [SQUARE, [[1.0, 0.0], [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]]]},
        "no_solution",
    ),
    (
        "/v1/solution-space",
        {
            "dim": 2,
            "positions": np.random.default_rng(0).standard_normal((6, 2)).tolist(),
            "motions": np.random.default_rng(1).standard_normal((6, 2)).tolist(),
        },
        "no_solution",
    ),
    ("/v1/motion", {"frame": TRIANGLE}, "no_motion"),
]


@pytest.mark.parametrize(("path", "request_body", "code"), DOMAIN_FAILURES)
def test_domain_failures_are_422_with_a_fixed_snake_case_code(client, path, request_body, code):
    response = client.post(path, json=request_body)
    detail = assert_error(response, code, status=422)
    assert set(response.json()) == {"detail"}
    assert detail["message"].strip()[-1] in ".!?", "one human sentence"
