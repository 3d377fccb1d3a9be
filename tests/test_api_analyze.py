"""POST /v1/analyze, GET /health and /openapi.json through the real FastAPI app.

Every response of the /v1/analyze contract (shared/API.md) is checked field by field on
frames whose answers are known by hand; every malformed request must come back as a 4xx
with {"detail": {"code", "message"}} and never as a 5xx.
"""

import importlib.metadata
import json
import math

import numpy as np
import pytest
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from oracles.frames import K4_SQUARE, SQUARE, TRIANGLE
from oracles.rigidity import (
    COUNT_FIELDS,
    RANK_GAP_FIELDS,
    as_columns,
    compatibility_matrix,
    normalised,
    relative_residual,
    rigid_generators,
)
from oracles.wire import assert_error

from zeromode.service.rest.app import create_app
from zeromode.service.wire.settings import Settings

SETTINGS = Settings()  # the defaults the test app is built with

CONTRACT_FIELDS = {*COUNT_FIELDS, "rank_gap", "modes", "stresses"}
K4 = K4_SQUARE


@pytest.fixture(scope="module")
def client():
    # raise_server_exceptions=False: a bug must show up as the 500 a real client would see.
    with TestClient(create_app(), raise_server_exceptions=False) as c:
        yield c


def analyze(client, frame, **extra):
    return client.post("/v1/analyze", json={"frame": frame, **extra})


def post_raw(client, raw: str):
    return client.post("/v1/analyze", content=raw, headers={"content-type": "application/json"})


def ok(response) -> dict:
    assert response.status_code == 200, response.text
    return response.json()


def check_types(body, n, nb, d):
    for field in CONTRACT_FIELDS - {"rank_gap", "modes", "stresses"}:
        assert type(body[field]) is int, field
    assert set(body["rank_gap"]) == set(RANK_GAP_FIELDS)
    assert all(type(v) is float for v in body["rank_gap"].values())
    assert isinstance(body["modes"], list) and isinstance(body["stresses"], list)
    for mode in body["modes"]:
        assert len(mode) == n and all(len(row) == d for row in mode)
        assert all(type(v) is float for row in mode for v in row)
    for stress in body["stresses"]:
        assert len(stress) == nb and all(type(v) is float for v in stress)


# --- the contract on known frames ---------------------------------------------------------


def test_triangle_every_field(client):
    body = ok(analyze(client, TRIANGLE))
    assert CONTRACT_FIELDS <= set(body)
    check_types(body, 3, 3, 2)
    assert {k: body[k] for k in CONTRACT_FIELDS - {"rank_gap"}} == {
        "nodes": 3,
        "edges": 3,
        "dim": 2,
        "maxwell_count": 3,
        "rank": 3,
        "zero_modes": 3,
        "rigid_body_modes": 3,
        "nontrivial_zero_modes": 0,
        "self_stresses": 0,
        "modes": [],
        "stresses": [],
    }
    # Full rank with N_B = 3 < dN = 6: there is no σ_{r+1}, so first_zero is 0.
    assert body["rank_gap"]["last_nonzero"] > 0.1
    assert body["rank_gap"]["first_zero"] == 0.0


def test_k4_every_field(client):
    body = ok(analyze(client, K4))
    check_types(body, 4, 6, 2)
    assert {k: body[k] for k in CONTRACT_FIELDS - {"rank_gap", "stresses"}} == {
        "nodes": 4,
        "edges": 6,
        "dim": 2,
        "maxwell_count": 2,
        "rank": 5,
        "zero_modes": 3,
        "rigid_body_modes": 3,
        "nontrivial_zero_modes": 0,
        "self_stresses": 1,
        "modes": [],
    }
    # Equilibrium at a corner of the unit square: sides ω, diagonals −ω.
    (stress,) = body["stresses"]
    expected = np.array([1, 1, 1, 1, -1, -1]) / math.sqrt(6)
    assert abs(np.dot(stress, expected)) == pytest.approx(1.0, abs=1e-12)
    gap = body["rank_gap"]
    assert gap["first_zero"] < 1e-12 * gap["last_nonzero"]


def test_square_mode_is_an_n_by_d_list(client):
    frame = {**SQUARE, "specified": [0, 1]}
    body = ok(analyze(client, frame))
    check_types(body, 4, 4, 2)
    assert (body["nontrivial_zero_modes"], body["self_stresses"], len(body["modes"])) == (1, 0, 1)
    modes = as_columns(body["modes"])
    assert np.linalg.norm(modes) == pytest.approx(1.0)
    c = compatibility_matrix(SQUARE["positions"], SQUARE["edges"])
    assert relative_residual(c, modes) < 1e-12
    assert np.abs(rigid_generators(SQUARE["positions"]).T @ modes).max() < 1e-12


def test_tetrahedron_missing_an_edge_3d(client):
    positions = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
    edges = [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3]]  # no bar 2–3: it hinges about 0–1
    body = ok(analyze(client, {"dim": 3, "positions": positions, "edges": edges}))
    check_types(body, 4, 5, 3)
    assert (body["rank"], body["rigid_body_modes"], body["nontrivial_zero_modes"]) == (5, 6, 1)
    modes = as_columns(body["modes"])
    assert relative_residual(compatibility_matrix(positions, edges), modes) < 1e-12
    assert np.abs(rigid_generators(positions).T @ modes).max() < 1e-12


def test_options_choose_the_route(client):
    for method in ("dense", "sparse"):
        body = ok(analyze(client, K4, options={"method": method}))
        assert body["method"] == method
        assert (body["rank"], body["self_stresses"]) == (5, 1)
    body = ok(analyze(client, K4, options={"bases": False}))
    assert body["self_stresses"] == 1 and body["stresses"] == [] and body["bases_included"] is False


def test_optional_fields_default(client):
    # edges and specified are optional; no edges means every coordinate is a zero mode.
    body = ok(analyze(client, {"dim": 3, "positions": [[0, 0, 0], [1, 2, 3]]}))
    assert (body["edges"], body["rank"], body["zero_modes"], body["rigid_body_modes"]) == (
        0,
        0,
        6,
        5,
    )
    assert body["rank_gap"] == {"last_nonzero": 0.0, "first_zero": 0.0, "last_nonzero_error": 0.0}


def lattice_json(name, n):
    from benchmarks.lattices import LATTICES

    frame = LATTICES[name](n)
    return frame, {"dim": frame.dim, "positions": frame.positions.tolist(), "edges": frame.edges.tolist()}


@pytest.mark.parametrize("name, n", [("kagome", 48), ("cubic-diagonal", 27)])
def test_gap_rtol_converges_sigma_r(client, name, n):
    # σ_r of C (numpy's SVD of the normalised frame): the sparse route's Ritz value is above it,
    # with a singular value within its stated relative bound; asked for gap_rtol it is σ_r to
    # that bound.
    frame, body = lattice_json(name, n)
    s = np.linalg.svd(compatibility_matrix(normalised(frame.positions), frame.edges), compute_uv=False)
    rough = ok(analyze(client, body, options={"method": "sparse", "bases": False}))
    sigma_r = s[rough["rank"] - 1]
    gap = rough["rank_gap"]
    assert gap["last_nonzero"] >= sigma_r * (1 - 1e-12)
    assert np.min(np.abs(s[: rough["rank"]] / gap["last_nonzero"] - 1)) <= gap["last_nonzero_error"]
    exact = ok(analyze(client, body, options={"method": "sparse", "bases": False, "gap_rtol": 1e-7}))
    assert exact["rank_gap"]["last_nonzero_error"] <= 1e-7
    assert math.isclose(exact["rank_gap"]["last_nonzero"], sigma_r, rel_tol=1e-7)
    assert {k: exact[k] for k in COUNT_FIELDS} == {k: rough[k] for k in COUNT_FIELDS}


def test_gap_rtol_past_what_is_known_is_refused(client):
    # σ_r a few times the rank threshold (a node held by two bars 2e-8 off collinear): its
    # digits below ~1e-5 are round-off, so 1e-6 is refused with the bound reached; a bound of
    # 0 or 1 is no request at all.
    frame, body = lattice_json("triangulated", 100)
    x = frame.positions
    body["positions"].append(((x[0] + x[1]) / 2 + [0.0, -2e-8]).tolist())
    body["edges"] += [[0, len(x)], [1, len(x)]]
    refused = analyze(client, body, options={"method": "dense", "gap_rtol": 1e-6})
    assert_error(refused, "not_converged")
    assert "gap_rtol" in refused.json()["detail"]["message"]
    for bad in (0, 1, -1e-3):
        assert_error(analyze(client, body, options={"gap_rtol": bad}), "invalid_request")


@pytest.mark.parametrize("scale", [1e-300, 1e-6, 1e6, 1e300])
def test_extreme_but_finite_coordinates(client, scale):
    frame = {**K4, "positions": (np.array(K4["positions"]) * scale + 2 * scale).tolist()}
    body = ok(analyze(client, frame))
    assert (body["rank"], body["rigid_body_modes"], body["self_stresses"]) == (5, 3, 1)


# --- malformed requests --------------------------------------------------------------------


def frame_with(**changes):
    return {**TRIANGLE, **changes}


DOMAIN_REJECTIONS = {
    "ragged": (frame_with(positions=[[0, 0], [1], [0, 1]]), "invalid_shape", "positions"),
    "dim-mismatch": (frame_with(dim=3), "invalid_shape", "3 coordinates"),
    "empty": (frame_with(positions=[], edges=[]), "invalid_shape", "positions"),
    "out-of-range": (frame_with(edges=[[0, 1], [1, 3]]), "edge_out_of_range", "edge 1"),
    "negative": (frame_with(edges=[[0, -1]]), "edge_out_of_range", "edge 0"),
    "huge-index": (frame_with(edges=[[0, 2**70]]), "edge_out_of_range", str(2**70)),
    "self-loop": (frame_with(edges=[[0, 1], [2, 2]]), "self_loop", "edge 1"),
    "duplicate": (frame_with(edges=[[0, 1], [1, 2], [0, 1]]), "duplicate_edge", "edges 0 and 2"),
    "reversed": (frame_with(edges=[[0, 1], [1, 2], [1, 0]]), "duplicate_edge", "edges 0 and 2"),
    "zero-length": (
        frame_with(positions=[[0, 0], [1, 0], [1, 0]], edges=[[0, 1], [1, 2]]),
        "zero_length_bar",
        "edge 1",
    ),
    "specified-range": (frame_with(specified=[0, 5]), "invalid_specified", "node 5"),
    "specified-twice": (frame_with(specified=[1, 1]), "invalid_specified", "node 1"),
}


@pytest.mark.parametrize("name", sorted(DOMAIN_REJECTIONS))
def test_bad_frames_name_the_problem(client, name):
    frame, code, named = DOMAIN_REJECTIONS[name]
    assert named in assert_error(analyze(client, frame), code)["message"]


SCHEMA_REJECTIONS = {
    "dim-4": frame_with(dim=4),
    "dim-1": frame_with(dim=1),
    "dim-string": frame_with(dim="two"),
    "positions-flat": frame_with(positions=[0, 1, 2]),
    "positions-string": frame_with(positions="triangle"),
    "coordinate-string": frame_with(positions=[[0, 0], [1, "x"], [0, 1]]),
    "coordinate-null": frame_with(positions=[[0, 0], [1, None], [0, 1]]),
    "edge-triple": frame_with(edges=[[0, 1, 2]]),
    "edge-single": frame_with(edges=[[0]]),
    "edge-float": frame_with(edges=[[0, 1.5]]),
    "edge-string": frame_with(edges=[[0, "b"]]),
    "edges-object": frame_with(edges={"0": 1}),
    "specified-float": frame_with(specified=[0.5]),
    "specified-nested": frame_with(specified=[[0]]),
    "missing-dim": {k: v for k, v in TRIANGLE.items() if k != "dim"},
    "missing-positions": {k: v for k, v in TRIANGLE.items() if k != "positions"},
    "frame-number": 5,
    "frame-null": None,
}


@pytest.mark.parametrize("name", sorted(SCHEMA_REJECTIONS))
def test_wrong_types_and_missing_fields(client, name):
    detail = assert_error(analyze(client, SCHEMA_REJECTIONS[name]), "invalid_request")
    assert detail["message"].startswith("frame")  # says where the problem is


@pytest.mark.parametrize(
    "body",
    [
        {},
        {"frame": TRIANGLE, "options": {"method": "qr"}},
        {"frame": TRIANGLE, "options": {"rtol": 2}},
        {"frame": TRIANGLE, "options": {"rtol": -1e-9}},
        [TRIANGLE],
        "frame",
    ],
    ids=["no-frame", "bad-method", "rtol-2", "rtol-negative", "array", "string"],
)
def test_bad_request_bodies(client, body):
    assert_error(client.post("/v1/analyze", json=body), "invalid_request")


@pytest.mark.parametrize("token", ["NaN", "Infinity", "-Infinity", "1e400"])
def test_raw_json_non_finite_numbers(client, token):
    raw = (
        f'{{"frame": {{"dim": 2, "positions": [[0, 0], [1, {token}], [0, 1]], "edges": [[0, 1]]}}}}'
    )
    detail = assert_error(post_raw(client, raw), "invalid_request")
    assert "frame.positions.1.1" in detail["message"] and "finite" in detail["message"]


@pytest.mark.parametrize("raw", ['{"frame": ', "not json", ""], ids=["truncated", "text", "empty"])
def test_unparseable_bodies(client, raw):
    assert_error(post_raw(client, raw), "invalid_request")


def test_body_too_large():
    small = Settings(max_body_bytes=2000)
    frame = {"dim": 2, "positions": [[i, i * i] for i in range(300)], "edges": []}
    with TestClient(create_app(small), raise_server_exceptions=False) as c:
        detail = assert_error(c.post("/v1/analyze", json={"frame": frame}), "body_too_large", 413)
        assert "2000" in detail["message"]
        # The same body sent in chunks has no Content-Length, so it cannot slip past the limit.
        body = json.dumps({"frame": frame}).encode()
        chunks = (body[k : k + 500] for k in range(0, len(body), 500))
        response = c.post(
            "/v1/analyze", content=chunks, headers={"content-type": "application/json"}
        )
        assert 400 <= response.status_code < 500
        assert_error(response, status=None)
        assert ok(c.post("/v1/analyze", json={"frame": TRIANGLE}))["rank"] == 3


def test_too_many_nodes(client):
    # Built as text: json.dumps of 10^5 points would dominate the test's run time.
    points = ",".join(["[0,0]"] * (SETTINGS.max_nodes + 1))
    raw = f'{{"frame": {{"dim": 2, "positions": [{points}], "edges": []}}}}'
    detail = assert_error(post_raw(client, raw), "invalid_request")
    assert "frame.positions" in detail["message"] and str(SETTINGS.max_nodes) in detail["message"]


def test_too_many_edges(client):
    edges = ",".join(["[0,1]"] * (SETTINGS.max_edges + 1))
    raw = f'{{"frame": {{"dim": 2, "positions": [[0,0],[1,0]], "edges": [{edges}]}}}}'
    detail = assert_error(post_raw(client, raw), "invalid_request")
    assert "frame.edges" in detail["message"] and str(SETTINGS.max_edges) in detail["message"]


def test_unknown_path_and_method(client):
    for response, status, code in (
        (client.post("/v1/analyse", json={"frame": TRIANGLE}), 404, "not_found"),
        (client.get("/v1/analyze"), 405, "method_not_allowed"),
    ):
        assert response.status_code == status
        assert response.json()["detail"]["code"] == code


JSON_SCALARS = (
    st.none()
    | st.booleans()
    | st.integers(-(2**70), 2**70)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=3)
)
JSON_VALUES = st.recursive(
    JSON_SCALARS,
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=3), inner, max_size=3)
    ),
    max_leaves=12,
)
SMALL_INTS = st.integers(-2, 6)
FRAMES = st.fixed_dictionaries(
    {
        "dim": st.sampled_from([2, 3]) | JSON_SCALARS,
        "positions": st.lists(
            st.lists(
                st.sampled_from([0.0, 1.0, -1.0, 2.5, 1e-300, 1e300]) | JSON_SCALARS,
                min_size=1,
                max_size=4,
            ),
            max_size=6,
        )
        | JSON_VALUES,
        "edges": st.lists(st.lists(SMALL_INTS | JSON_SCALARS, min_size=0, max_size=3), max_size=8)
        | JSON_VALUES,
    },
    optional={"specified": st.lists(SMALL_INTS, max_size=4) | JSON_VALUES},
)


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.one_of(FRAMES.map(lambda f: {"frame": f}), JSON_VALUES))
def test_no_request_gives_a_5xx(client, body):
    response = client.post("/v1/analyze", json=body)
    if response.status_code != 200:
        assert_error(response, status=None)
        assert 400 <= response.status_code < 500


# --- health and OpenAPI --------------------------------------------------------------------


def test_health(client):
    # The kernels: ready once the warm-up its startup began has loaded them (this session's
    # start compiled them).
    assert client.app.state.kernels_ready.wait(timeout=300)
    body = ok(client.get("/health"))
    # The session's app has offloading off and has run no job: its engine is idle.
    assert body == {"status": "ok", "version": importlib.metadata.version("zeromode"), "engine": "idle",
                    "kernels": "ready"}


def resolve(schema, doc):
    while "$ref" in schema:
        schema = doc["components"]["schemas"][schema["$ref"].rsplit("/", 1)[-1]]
    return schema


def test_openapi_documents_analyze(client):
    doc = ok(client.get("/openapi.json"))
    post = doc["paths"]["/v1/analyze"]["post"]
    request = resolve(post["requestBody"]["content"]["application/json"]["schema"], doc)
    frame = resolve(request["properties"]["frame"], doc)
    assert {"dim", "positions", "edges", "specified"} <= set(frame["properties"])
    assert {"dim", "positions"} <= set(frame["required"])
    response = resolve(post["responses"]["200"]["content"]["application/json"]["schema"], doc)
    assert CONTRACT_FIELDS <= set(response["properties"])
    assert set(resolve(response["properties"]["rank_gap"], doc)["properties"]) == set(
        RANK_GAP_FIELDS
    )
    error = resolve(post["responses"]["422"]["content"]["application/json"]["schema"], doc)
    detail = resolve(error["properties"]["detail"], doc)
    assert {"code", "message"} <= set(detail["properties"])
