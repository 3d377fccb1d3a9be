"""POST /v1/solution-space, POST /v1/design and GET /v1/examples against the REST contract
(/work/shared/API.md): every field with its type and shape, the error codes as 422
{"detail": {"code", "message"}}, and never a 5xx.

Values are checked from scratch: Ã = [u_Sᵀ, x_Sᵀ, −1] (paper, Eq. 5) for the basis, the bar
constraints (x_i − x_j)·(u_i − u_j) = 0 (Eq. 1) for samples and modes, and an SVD of the
compatibility matrix built here (Eq. 3) for the reported counts.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from oracles.frames import CUBE_CORNERS, SQUARE_CORNERS
from oracles.rigidity import (
    COUNT_FIELDS,
    compatibility_matrix,
    mode_residual,
    normalised,
    rank_gap,
    reference_counts,
)
from oracles.solution_space import a_tilde, bar_residuals, points_on_random_lines
from oracles.wire import assert_error, is_number, matrix

SQUARE = SQUARE_CORNERS
CUBE = CUBE_CORNERS
KINDS = {1: "points", 2: "conic", 3: "quadric_surface"}


def check_design_body(body: dict, request: dict) -> None:
    """Every /v1/design field, and its values recomputed here."""
    d = request["dim"]
    x = np.array(request["positions"], dtype=float)
    motions = np.array(request["motions"], dtype=float)
    k, n_modes = len(x), len(motions)

    frame = body["frame"]
    assert frame["dim"] == d
    n = len(frame["positions"])
    positions = matrix(frame["positions"], n, d)
    edges = np.array(frame["edges"], dtype=int).reshape(-1, 2)
    assert all(isinstance(i, int) for e in frame["edges"] for i in e)
    assert frame["specified"] == list(range(k))
    assert np.array_equal(positions[:k], x)
    assert all(min(e) < k <= max(e) for e in edges.tolist())  # bipartite
    assert len({tuple(sorted(e)) for e in edges.tolist()}) == len(edges)

    assert isinstance(body["modes"], list) and len(body["modes"]) == n_modes
    modes = np.stack([matrix(m, n, d) for m in body["modes"]])
    assert np.array_equal(modes[:, :k], motions)

    # C from Eq. 3 on the normalised frame: C·u = 0, counts and the rank gap from its SVD.
    c = compatibility_matrix(normalised(positions), edges)
    for mode in modes:
        assert mode_residual(c, mode) <= 1e-9

    report = body["report"]
    analysis = report["analysis"]
    assert {*COUNT_FIELDS, "rank_gap"} <= set(analysis)
    assert {"modes", "stresses"}.isdisjoint(analysis)
    target = d * (d + 1) // 2 + n_modes
    expected = reference_counts(positions, edges)
    assert {key: analysis[key] for key in COUNT_FIELDS} == expected
    assert (expected["zero_modes"], expected["self_stresses"]) == (target, 0)
    assert expected["rigid_body_modes"] == d * (d + 1) // 2
    gap = analysis["rank_gap"]
    assert is_number(gap["last_nonzero"]) and is_number(gap["first_zero"])
    assert math.isclose(
        gap["last_nonzero"], rank_gap(positions, edges)["last_nonzero"], rel_tol=1e-6
    )
    assert report["target_zero_modes"] == target
    assert report["unspecified_nodes"] == n - k and isinstance(report["unspecified_nodes"], int)
    assert isinstance(report["timings_ms"], dict) and report["timings_ms"]
    assert all(is_number(v) and v >= 0 for v in report["timings_ms"].values())


# --------------------------------------------------------------------------- /v1/solution-space
@pytest.mark.parametrize(
    ("d", "k", "samples"),
    [(2, 3, 8), (2, 2, 5), (2, 4, 8), (3, 4, 10), (3, 5, 6), (3, 3, 3), (2, 3, 0)],
)
def test_solution_space_fields(client, d, k, samples):
    rng = np.random.default_rng([d, k])
    x, u = rng.standard_normal((k, d)), rng.standard_normal((k, d))
    request = {
        "dim": d,
        "positions": x.tolist(),
        "motions": u.tolist(),
        "samples": samples,
        "seed": 1,
    }
    response = client.post("/v1/solution-space", json=request)
    assert response.status_code == 200, response.text
    body = response.json()
    m = body["nullity"]
    assert isinstance(m, int) and m == 2 * d + 1 - k
    assert body["dimension"] == m - 1 and isinstance(body["dimension"], int)
    assert body["kind"] == KINDS.get(m, "quadric_hypersurface")
    basis = matrix(body["basis"], 2 * d + 1, m + 1)
    q = matrix(body["quadric"], m + 1, m + 1)
    assert np.allclose(q, q.T, rtol=0, atol=1e-14 * np.abs(q).max())
    a, b = a_tilde(x, u)
    assert np.linalg.norm(a @ basis[:, :m]) <= 1e-12 * np.linalg.norm(a)
    assert np.allclose(
        a @ basis[:, m], b, atol=1e-12 * np.linalg.norm(a) * (1 + np.linalg.norm(basis[:, m]))
    )
    assert isinstance(body["samples"], list) and len(body["samples"]) <= samples
    for sample in body["samples"]:
        assert set(sample) >= {"position", "motion"}
        x_u, u_u = matrix([sample["position"]], 1, d)[0], matrix([sample["motion"]], 1, d)[0]
        assert np.all(bar_residuals(x, u, x_u, u_u) <= 1e-9)
    # Real points found here (all of them for m = 1) mean the samples cannot be empty; for
    # k ≤ d + 1, x_U = x_Si always solves the problem.
    real = points_on_random_lines(basis, d, np.random.default_rng(0))
    assert len(real) or k > d + 1
    if m == 1:
        assert len(body["samples"]) == min(samples, len(real))
    elif samples and len(real):
        assert body["samples"]


def test_solution_space_of_the_outward_square(client):
    """Paper: redundant rows (v4 = v2 + v3 − v1) → a conic, the circle through the square."""
    response = client.post(
        "/v1/solution-space", json={"dim": 2, "positions": SQUARE, "motions": SQUARE, "samples": 6}
    )
    assert response.status_code == 200
    body = response.json()
    assert (body["nullity"], body["kind"]) == (2, "conic")
    points = np.array([s["position"] for s in body["samples"]])
    assert len(points) == 6
    assert np.allclose(np.linalg.norm(points, axis=1), np.sqrt(2), rtol=1e-9)


def test_solution_space_without_solution(client):
    rng = np.random.default_rng(0)
    x, u = rng.standard_normal((6, 2)), rng.standard_normal((6, 2))
    response = client.post(
        "/v1/solution-space", json={"dim": 2, "positions": x.tolist(), "motions": u.tolist()}
    )
    assert_error(response, "no_solution")


@pytest.mark.parametrize(
    "body",
    [
        {"dim": 2, "positions": SQUARE, "motions": SQUARE[:3]},
        {"dim": 2, "positions": SQUARE, "motions": CUBE[:4]},
        {"dim": 3, "positions": SQUARE, "motions": SQUARE},
        {"dim": 2, "positions": [[0, 0], [1, 0, 2], [0, 1]], "motions": [[0, 0], [1, 0], [0, 1]]},
        {"dim": 2, "positions": SQUARE, "motions": SQUARE, "samples": -1},
        {"dim": 2, "positions": SQUARE, "motions": SQUARE, "samples": 10**9},
        {"dim": 4, "positions": SQUARE, "motions": SQUARE},
        {"dim": 2, "positions": [], "motions": []},
        {"dim": 2, "positions": [[0.0, 0.0]] * 65, "motions": [[0.0, 0.0]] * 65},
        {"dim": 2, "positions": "square", "motions": SQUARE},
        {"positions": SQUARE, "motions": SQUARE},
    ],
)
def test_solution_space_rejects_malformed_requests(client, body):
    assert_error(
        client.post("/v1/solution-space", json=body),
        {"invalid_shape", "invalid_request", "invalid_dim"},
    )


# --------------------------------------------------------------------------- /v1/design
@pytest.mark.parametrize(
    "request_body",
    [
        {"dim": 2, "positions": SQUARE, "motions": [SQUARE]},
        {
            "dim": 2,
            "positions": SQUARE,
            "motions": [SQUARE],
            "options": {"seed": 3, "n_unspecified": 4},
        },
        {"dim": 3, "positions": CUBE, "motions": [CUBE], "options": {"seed": 1}},
    ],
)
def test_design_fields(client, request_body):
    response = client.post("/v1/design", json=request_body)
    assert response.status_code == 200, response.text
    check_design_body(response.json(), request_body)


@pytest.mark.parametrize(("d", "k"), [(2, 3), (2, 4), (3, 4), (3, 5), (3, 6)])
def test_design_of_random_targets(client, d, k):
    rng = np.random.default_rng([d, k, 7])
    request = {
        "dim": d,
        "positions": rng.standard_normal((k, d)).tolist(),
        "motions": [rng.standard_normal((k, d)).tolist()],
        "options": {"seed": 2},
    }
    response = client.post("/v1/design", json=request)
    assert response.status_code == 200, response.text
    check_design_body(response.json(), request)
    assert client.post("/v1/design", json=request).json()["frame"] == response.json()["frame"]


def test_paper_counts_over_the_api(client):
    outward = client.post(
        "/v1/design", json={"dim": 2, "positions": SQUARE, "motions": [SQUARE]}
    ).json()
    assert (outward["report"]["unspecified_nodes"], len(outward["frame"]["edges"])) == (2, 8)
    four = client.post(
        "/v1/design",
        json={"dim": 2, "positions": SQUARE, "motions": [SQUARE], "options": {"n_unspecified": 4}},
    ).json()
    assert (four["report"]["unspecified_nodes"], len(four["frame"]["edges"])) == (4, 12)


def translation(k: int, d: int) -> list:
    return [[0.3, -0.2, 0.1][:d]] * k


@pytest.mark.parametrize(
    ("body", "code"),
    [
        ({"dim": 2, "positions": SQUARE, "motions": [[[0.0, 0.0]] * 4]}, "rigid_target"),
        ({"dim": 2, "positions": SQUARE, "motions": [translation(4, 2)]}, "rigid_target"),
        (
            {"dim": 2, "positions": SQUARE, "motions": [[[-y, x] for x, y in SQUARE]]},
            "rigid_target",
        ),
        (
            {"dim": 3, "positions": CUBE, "motions": [[[-y, x, 0.0] for x, y, _ in CUBE]]},
            "rigid_target",
        ),
        ({"dim": 3, "positions": CUBE, "motions": [translation(8, 3)]}, "rigid_target"),
        (
            {"dim": 2, "positions": [[0, 0], [1, 0], [0, 0], [0, 1]], "motions": [SQUARE]},
            "degenerate_specified",
        ),
        (
            {"dim": 2, "positions": SQUARE, "motions": [SQUARE], "options": {"n_unspecified": 1}},
            "no_solution",
        ),
        (
            # k = 3 in 3D: each node brings 3 coordinates and at most 3 bars, N_D stays ≥ 9.
            {
                "dim": 3,
                "positions": [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
                "motions": [[[1, 0, 0], [0, 0, 0], [0, 0, 0]]],
            },
            "no_solution",
        ),
        ({"dim": 2, "positions": SQUARE, "motions": [SQUARE[:3]]}, "invalid_shape"),
        ({"dim": 2, "positions": SQUARE, "motions": [[[1, 1, 0]] * 4]}, "invalid_shape"),
        ({"dim": 3, "positions": SQUARE, "motions": [SQUARE]}, "invalid_shape"),
        ({"dim": 2, "positions": SQUARE, "motions": []}, "invalid_request"),
        ({"dim": 2, "positions": SQUARE, "motions": [SQUARE] * 5}, "invalid_request"),
        (
            {"dim": 2, "positions": SQUARE, "motions": [SQUARE], "options": {"n_unspecified": -1}},
            "invalid_request",
        ),
        (
            {"dim": 2, "positions": SQUARE, "motions": [SQUARE], "options": {"seed": "zero"}},
            "invalid_request",
        ),
        ({"dim": 2, "positions": SQUARE, "motions": SQUARE}, "invalid_request"),
        ({"dim": "two", "positions": SQUARE, "motions": [SQUARE]}, "invalid_request"),
    ],
)
def test_design_failures_answer_422_with_a_code(client, body, code):
    assert_error(client.post("/v1/design", json=body), code)


@pytest.mark.parametrize("path", ["/v1/design", "/v1/solution-space"])
@pytest.mark.parametrize("bad", ["NaN", "Infinity", "-Infinity", "1e999"])
def test_non_finite_numbers_are_rejected(client, path, bad):
    motions = (
        "[[[1, 1], [-1, 1], [-1, -1], [1, -1]]]"
        if path == "/v1/design"
        else "[[1, 1], [-1, 1], [-1, -1], [1, -1]]"
    )
    raw = (
        f'{{"dim": 2, "positions": [[1, 1], [-1, {bad}], [-1, -1], [1, -1]], "motions": {motions}}}'
    )
    response = client.post(path, content=raw, headers={"content-type": "application/json"})
    assert_error(response, "invalid_request")
    assert "positions" in response.json()["detail"]["message"]


@pytest.mark.parametrize("raw", [b"", b"nonsense", b"[]", b"{}", b'{"dim": 2}', b"null"])
@pytest.mark.parametrize("path", ["/v1/design", "/v1/solution-space"])
def test_garbage_bodies_are_4xx(client, path, raw):
    response = client.post(path, content=raw, headers={"content-type": "application/json"})
    assert 400 <= response.status_code < 500
    assert response.json()["detail"]["code"]


@settings(max_examples=40, deadline=None, derandomize=True)
@given(
    dim=st.sampled_from([2, 3]),
    k=st.integers(1, 7),
    # Mostly well-shaped requests, sometimes one axis off by one.
    defect=st.sampled_from([None] * 5 + ["position width", "motion width", "motion rows"]),
    n_modes=st.integers(1, 2),
    values=st.sampled_from(["random", "random", "zeros", "integers", "tiny", "huge", "repeated"]),
    seed=st.integers(0, 1000),
)
def test_design_never_answers_5xx(client, dim, k, defect, n_modes, values, seed):
    """Rectangular but possibly mismatched shapes and degenerate values: always 200 or 4xx,
    and a 200 is a correct design."""
    rng = np.random.default_rng(seed)
    draw = {
        "random": lambda s: rng.standard_normal(s),
        "zeros": lambda s: np.zeros(s),
        "integers": lambda s: rng.integers(-2, 3, s).astype(float),
        "tiny": lambda s: 1e-150 * rng.standard_normal(s),
        "huge": lambda s: 1e150 * rng.standard_normal(s),
        "repeated": lambda s: np.tile(rng.standard_normal(s[-1]), s[:-1] + (1,)),
    }[values]
    off = rng.choice([-1, 1])
    position_shape = (k, dim + off) if defect == "position width" else (k, dim)
    motion_shape = (k, dim + off) if defect == "motion width" else (k, dim)
    if defect == "motion rows":
        motion_shape = (max(k + off, 0), dim)
    request = {
        "dim": dim,
        "positions": draw(position_shape).tolist(),
        "motions": [draw(motion_shape).tolist() for _ in range(n_modes)],
        "options": {"seed": seed},
    }
    response = client.post("/v1/design", json=request)
    assert response.status_code < 500, response.text
    if response.status_code == 200:
        check_design_body(response.json(), request)
    else:
        assert response.json()["detail"]["code"]


@pytest.mark.parametrize(
    "body",
    [
        {"dim": 2, "positions": [[1, 1], [-1, 1, 0], [-1, -1], [1, -1]], "motions": [SQUARE]},
        {"dim": 2, "positions": SQUARE, "motions": [[[1, 1], [-1, 1, 0], [-1, -1], [1, -1]]]},
        {"dim": 2, "positions": SQUARE, "motions": [SQUARE, SQUARE[:3]]},
    ],
)
def test_ragged_design_requests_are_4xx(client, body):
    assert_error(client.post("/v1/design", json=body), {"invalid_shape", "invalid_request"})


@pytest.mark.parametrize("scale", [1e-200, 1e200])
def test_design_is_scale_free_at_extreme_units(client, scale):
    square = (scale * np.array(SQUARE)).tolist()
    response = client.post("/v1/design", json={"dim": 2, "positions": square, "motions": [square]})
    assert response.status_code == 200, response.text
    assert (
        response.json()["report"]["unspecified_nodes"],
        len(response.json()["frame"]["edges"]),
    ) == (2, 8)


def test_solution_space_never_returns_non_numbers(client):
    square = (1e200 * np.array(SQUARE)).tolist()
    response = client.post(
        "/v1/solution-space", json={"dim": 2, "positions": square, "motions": square}
    )
    if response.status_code == 200:
        body = response.json()
        assert all(is_number(v) for row in body["basis"] + body["quadric"] for v in row)
    else:
        assert_error(response, {"no_solution", "invalid_request", "out_of_range"})


# --------------------------------------------------------------------------- /v1/examples
def test_examples_round_trip_into_design(client):
    listing = client.get("/v1/examples")
    assert listing.status_code == 200
    examples = listing.json()
    names = {e["name"] for e in examples}
    assert {"outward_2d", "outward_2d_four_nodes", "cube_outward_3d", "five_node_3d"} <= names
    assert all(isinstance(e["description"], str) and e["description"] for e in examples)
    endpoints = {e["name"]: e["endpoint"] for e in examples}
    for name in sorted(names):
        request = client.get(f"/v1/examples/{name}/request")
        assert request.status_code == 200
        body = request.json()
        response = client.post(endpoints[name], json=body)
        assert response.status_code == 200, (name, response.text)
        if endpoints[name] == "/v1/design":  # the others' answers: their own tests (test_api_multistable)
            check_design_body(response.json(), body)


def test_five_node_example_is_the_papers(client):
    """Supplementary coordinates, verbatim."""
    body = client.get("/v1/examples/five_node_3d/request").json()
    assert body["positions"] == [[2, 0, 1], [1, 0, 2], [3, 0, 3], [3.5, -1, 2.5], [3.5, 1, 2.5]]
    assert body["motions"] == [
        [[-0.8, 0, 0.8], [0.8, 0, -0.8], [-0.8, 0, 0], [0, -0.8, 0], [0, 0.8, 0]]
    ]
    report = client.post("/v1/design", json=body).json()["report"]
    assert report["analysis"]["zero_modes"] == 7 and report["analysis"]["self_stresses"] == 0


def test_unknown_example_is_404(client):
    assert_error(client.get("/v1/examples/no_such_thing/request"), "unknown_example", status=404)


def test_openapi_documents_the_contract(client):
    spec = client.get("/openapi.json").json()
    assert {"/v1/solution-space", "/v1/design", "/v1/examples"} <= set(spec["paths"])
    schemas = spec["components"]["schemas"]
    text = str(schemas)
    for field in (
        "nullity",
        "dimension",
        "kind",
        "basis",
        "quadric",
        "samples",
        "target_zero_modes",
        "unspecified_nodes",
        "timings_ms",
        "modes",
        "frame",
        "report",
    ):
        assert f"'{field}'" in text, field
