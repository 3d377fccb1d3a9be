"""POST /v1/certify through the real FastAPI app.

Answers are checked from scratch (tests/oracles/rigidity.py): the certifying stress is an
equilibrium whose stress energy on the reference flex basis has the reported margin as its
smallest eigenvalue; the returned stiffness attains the reported optimal margin. Failures must
be 422s with a code — certificate_failed, too_expensive, invalid_modes, invalid_request.
"""

from __future__ import annotations

import numpy as np
import pytest
from fastapi.testclient import TestClient
from oracles.frames import triangle_with_taut_sides
from oracles.mechanisms import outward_square
from oracles.rigidity import (
    compatibility_matrix,
    kernel,
    nontrivial_flexes,
    normalised,
    rigid_generators,
    span,
)
from oracles.wire import frame_body

from zeromode.service.rest.app import create_app
from zeromode.service.wire.settings import Settings
from zeromode.solver.applications.lattice import auxetic_sheet
from zeromode.solver.certificates.prestress import OPTIMAL_MAX_DIM
from zeromode.solver.frame import Frame

# A triangle whose three sides each carry a taut midpoint joint: 3 flexes, 3 stresses.
_TAUT_X, _TAUT_E = triangle_with_taut_sides(3)
TAUT_TRIANGLE = {"dim": 2, "positions": _TAUT_X.tolist(), "edges": [list(e) for e in _TAUT_E]}
# The paper's outward module (Fig. 3b): corners (±1, ±1) with u_S = x_S, two unspecified
# nodes on the circumcircle with u_U = −x_U, each joined to all four corners.
OUTWARD = frame_body(outward_square())
OUTWARD_MODE = (np.array([[1.0]] * 4 + [[-1.0]] * 2) * OUTWARD["positions"]).tolist()


@pytest.fixture(scope="module")
def client():
    # raise_server_exceptions=False: a bug must show up as the 500 a real client would see.
    with TestClient(create_app(), raise_server_exceptions=False) as c:
        yield c


def certify(client, frame, **extra):
    return client.post("/v1/certify", json={"frame": frame, **extra})


def ok(response) -> dict:
    assert response.status_code == 200, response.text
    return response.json()


def error_code(response) -> str:
    assert response.status_code == 422, response.text
    detail = response.json()["detail"]
    assert detail["message"]
    return detail["code"]


def test_general_case_prestress_certificate(client):
    body = ok(certify(client, TAUT_TRIANGLE, options={"stiffness": False}))
    ps = body["prestress"]
    assert ps["prestress_stable"] is True and ps["decided_by"] == "sdp"
    assert (ps["flexes"], ps["stresses"]) == (3, 3)
    assert ps["sdp"]["solver"] == "clarabel" and ps["sdp"]["status"] == "optimal"
    assert ps["sdp"]["time_ms"] > 0 and body["timings_ms"]["total"] >= ps["sdp"]["time_ms"]
    assert ps["margin"] <= ps["margin_upper_bound"] <= ps["margin"] + 1e-6
    # From scratch: the stress is an equilibrium and stiffens every flex by at least the margin.
    x, e = normalised(TAUT_TRIANGLE["positions"]), TAUT_TRIANGLE["edges"]
    c = compatibility_matrix(x, e)
    omega = np.array(ps["stress"])
    assert np.linalg.norm(c.T @ omega) <= 1e-8 * np.linalg.norm(c)
    flexes = nontrivial_flexes(x, e)
    q = flexes.reshape(-1, 2, flexes.shape[1])
    energy = sum(w * (q[i] - q[j]).T @ (q[i] - q[j]) for w, (i, j) in zip(omega, e))
    assert np.linalg.eigvalsh(energy)[0] == pytest.approx(ps["margin"], rel=1e-6)
    ss = body["self_stress"]
    assert ss["count"] == 3 and len(ss["basis"]) == 3 and len(ss["basis"][0]) == 9
    assert ss["singular_values"]["largest_zero"] < 1e-12 < ss["singular_values"]["smallest_nonzero"]
    assert body["analysis"]["self_stresses"] == 3


def test_design_margin_with_designed_mode(client):
    body = ok(certify(client, OUTWARD, modes=[OUTWARD_MODE]))
    rm = body["rigidity_margin"]
    assert (rm["designed_modes"], rm["complement_dim"], rm["undesigned_zero_modes"]) == (1, 8, 0)
    assert 0 < rm["uniform"] <= rm["optimal"] <= rm["optimal_upper_bound"]
    assert rm["gain"] == pytest.approx(rm["optimal"] / rm["uniform"])
    k = np.array(rm["stiffness"])
    assert np.all(k >= 0) and k.sum() == pytest.approx(8)
    # From scratch: the allocation attains the optimal margin on the complement.
    x = normalised(OUTWARD["positions"])
    c = compatibility_matrix(x, OUTWARD["edges"])
    p = kernel(span(np.column_stack([rigid_generators(x), np.ravel(OUTWARD_MODE)])).T)
    assert np.linalg.eigvalsh(p.T @ c.T @ np.diag(k) @ c @ p)[0] == pytest.approx(
        rm["optimal"], rel=1e-7
    )
    assert rm["sdp"]["solver"] == "clarabel" and rm["sdp"]["attempts"][-1]["status"] == "optimal"
    # The outward module has no self-stress and one flex: the designed one.
    assert body["prestress"]["decided_by"] == "no_self_stress"


def test_scs_is_selectable(client):
    body = ok(certify(client, OUTWARD, modes=[OUTWARD_MODE], options={"solver": "scs"}))
    rm = body["rigidity_margin"]
    assert rm["sdp"]["solver"] == "scs" and rm["optimal"] >= rm["uniform"] * (1 - 1e-6)


def test_solver_failure_is_422_certificate_failed(client):
    # One iteration leaves the prestress SDP of Connelly's frame (t* ≈ 0) undecided for both solvers.
    from test_certificates import connelly_second_order_rigid

    r = certify(client, frame_body(Frame.build(*connelly_second_order_rigid())), options={"max_iters": 1, "stiffness": False})
    assert error_code(r) == "certificate_failed"
    assert "clarabel" in r.json()["detail"]["message"] and "scs" in r.json()["detail"]["message"]


def test_allocation_the_conic_solvers_leave_open_is_answered_by_the_interior_point_route(client):
    body = ok(certify(client, OUTWARD, modes=[OUTWARD_MODE], options={"max_iters": 1}))
    sdp = body["rigidity_margin"]["sdp"]
    assert [a["solver"] for a in sdp["attempts"]] == ["clarabel", "scs", "interior_point"]
    assert sdp["solver"] == "interior_point" and sdp["status"] == "optimal"


def test_a_sheet_with_default_options_gets_its_optimal_margin_with_a_verified_bracket(client):
    # A 3 × 3 auxetic sheet: p = 2N − 3 − 1 = 64 > SDP_MAX_DIM, so the interior-point route.
    lattice = auxetic_sheet(3, 3, poisson=-0.5)
    frame = {"dim": 2, "positions": lattice.frame.positions.tolist(), "edges": lattice.frame.edges.tolist()}
    body = ok(certify(client, frame, modes=[lattice.mode.tolist()]))
    rm = body["rigidity_margin"]
    assert rm["complement_dim"] == 64 and rm["sdp"]["solver"] == "interior_point"
    assert rm["sdp"]["status"] == "optimal"
    assert rm["uniform"] <= rm["optimal"] <= rm["optimal_upper_bound"]
    assert rm["optimal_upper_bound"] - rm["optimal"] <= 1e-3 * rm["optimal_upper_bound"]
    # From scratch: the returned allocation attains the lower bound (λ_min with numpy) ...
    x = normalised(frame["positions"])
    c = compatibility_matrix(x, frame["edges"])
    p = kernel(span(np.column_stack([rigid_generators(x), lattice.mode.ravel()])).T)
    k = np.array(rm["stiffness"])
    assert np.all(k >= 0) and k.sum() == pytest.approx(len(frame["edges"]))
    attained = np.linalg.eigvalsh(p.T @ c.T @ np.diag(k) @ c @ p)[0]
    assert rm["optimal"] <= attained * (1 + 1e-9) and rm["optimal"] == pytest.approx(attained, rel=1e-6)
    # ... and no allocation beats the upper bound.
    for trial in np.random.default_rng(0).dirichlet(np.ones(len(k)), size=50) * len(k):
        assert np.linalg.eigvalsh(p.T @ c.T @ np.diag(trial) @ c @ p)[0] <= rm["optimal_upper_bound"]


def test_a_frame_beyond_the_allocation_limit_is_refused_naming_it(client):
    n = OPTIMAL_MAX_DIM // 2 + 4  # a triangulated strip: p = 2n − 3 > OPTIMAL_MAX_DIM
    strip = {
        "dim": 2,
        "positions": [[i // 2, i % 2 + 0.01 * i] for i in range(n)],
        "edges": [[i, i + 1] for i in range(n - 1)] + [[i, i + 2] for i in range(n - 2)],
    }
    response = certify(client, strip)
    assert error_code(response) == "too_expensive"
    assert str(OPTIMAL_MAX_DIM) in response.json()["detail"]["message"]
    body = ok(certify(client, strip, options={"stiffness": False}))
    assert body["rigidity_margin"]["uniform"] > 0 and body["rigidity_margin"]["optimal"] is None


def test_spent_time_budget_is_422_too_expensive():
    with TestClient(create_app(Settings(time_budget_s=1e-9)), raise_server_exceptions=False) as c:
        assert error_code(certify(c, TAUT_TRIANGLE)) == "too_expensive"


@pytest.mark.parametrize(
    "extra, code",
    [
        ({"modes": [[[0.0, 0.0]] * 5]}, "invalid_modes"),  # 5 rows for 6 nodes
        ({"modes": [np.ones((6, 2)).tolist()]}, "invalid_modes"),  # a translation: rigid
        ({"modes": [[[1.0, 0.0]] + [[0.0, 0.0]] * 5]}, "invalid_modes"),  # not a zero mode
        ({"options": {"solver": "mosek"}}, "invalid_request"),
        ({"options": {"max_iters": 0}}, "invalid_request"),
        ({"modes": [[["nan", 0.0]] * 6]}, "invalid_request"),
    ],
)
def test_bad_requests_name_the_problem(client, extra, code):
    assert error_code(certify(client, OUTWARD, **extra)) == code


def test_openapi_documents_certify(client):
    spec = client.get("/openapi.json").json()
    assert "/v1/certify" in spec["paths"]
    schemas = spec["components"]["schemas"]
    for model in ("PrestressModel", "RigidityMarginModel", "SelfStressModel", "CertifyOptions"):
        for name, prop in schemas[model]["properties"].items():
            assert prop.get("description") or "$ref" in prop or "allOf" in prop, (model, name)
