"""The capability endpoints over REST (/work/shared/API.md): POST /v1/design with two motions,
POST /v1/design/auxetic (2D sheets, 3D chains) and POST /v1/design/allosteric, through the real
app (TestClient(create_app())).

Each response is checked field by field against the contract, and its content from scratch:
a compatibility matrix built here (Eq. 3) for the counts and C·u = 0, bar lengths computed here
for the finite states, ν = −ε_y/ε_x computed here from the returned mode and boundary sets, and
the allosteric response solved here (oracles.rigidity.driven_response).  No request may produce a
5xx.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from oracles.frames import FIG4_TETRAHEDRON, FIG4_TRIANGLE
from oracles.motion import boundary_strains, relative_bar_error
from oracles.rigidity import (
    COUNT_FIELDS,
    compatibility_matrix,
    driven_response,
    mode_residual,
    normalised,
    reference_counts,
)
from oracles.wire import assert_error, is_number, matrix
from test_allostery import request_body, sites


def check_frame(frame: dict, d: int) -> tuple[np.ndarray, np.ndarray]:
    assert frame["dim"] == d
    x = matrix(frame["positions"], None, d)
    edges = np.array(frame["edges"], dtype=int).reshape(-1, 2)
    assert np.all((edges >= 0) & (edges < len(x))) and np.all(edges[:, 0] != edges[:, 1])
    assert len({tuple(sorted(e)) for e in edges.tolist()}) == len(edges)
    return x, edges


def check_counts(
    counts: dict, x: np.ndarray, edges: np.ndarray, nontrivial: int, stresses: int | None = 0
):
    """The analysis fields against the reference counts."""
    expected = reference_counts(x, edges)
    assert {k: counts[k] for k in COUNT_FIELDS} == expected
    assert expected["rigid_body_modes"] == x.shape[1] * (x.shape[1] + 1) // 2
    assert expected["nontrivial_zero_modes"] == nontrivial
    if stresses is not None:
        assert expected["self_stresses"] == stresses


# --------------------------------------------------------------------------- /v1/design, M = 2
@pytest.mark.parametrize("d", [2, 3])
def test_design_with_two_motions(client, d):
    x_s = np.array(FIG4_TRIANGLE if d == 2 else FIG4_TETRAHEDRON)
    k = len(x_s)
    shear = np.zeros_like(x_s)
    shear[:, 0] = x_s[:, 1]
    motions = [(x_s - x_s.mean(axis=0)).tolist(), shear.tolist()]
    response = client.post(
        "/v1/design", json={"dim": d, "positions": x_s.tolist(), "motions": motions}
    )
    assert response.status_code == 200, response.text
    body = response.json()
    x, edges = check_frame(body["frame"], d)
    assert body["frame"]["specified"] == list(range(k))
    assert np.array_equal(x[:k], x_s)
    assert len(body["modes"]) == 2
    c = compatibility_matrix(normalised(x), edges)
    for mode, requested in zip(body["modes"], motions):
        u = matrix(mode, len(x), d)
        assert np.array_equal(u[:k], np.array(requested))
        assert mode_residual(c, u) <= 1e-9
    report = body["report"]
    check_counts(report["analysis"], x, edges, nontrivial=2)
    assert report["target_zero_modes"] == d * (d + 1) // 2 + 2 == report["analysis"]["zero_modes"]
    assert report["unspecified_nodes"] == len(x) - k == (1 if d == 2 else 4)
    assert is_number(report["timings_ms"]["total"])


# --------------------------------------------------------------------------- /v1/design/auxetic
def check_auxetic(body: dict, d: int, poisson: float, strain: float) -> None:
    assert set(body) >= {"frame", "modes", "poisson_ratio", "states", "report"}
    x, edges = check_frame(body["frame"], d)
    assert len(body["modes"]) == 1
    mode = matrix(body["modes"][0], len(x), d)
    assert mode_residual(compatibility_matrix(normalised(x), edges), mode) <= 1e-9
    report = body["report"]
    assert set(report) >= {
        "analysis",
        "boundary",
        "mode_residual",
        "max_relative_bar_error",
        "timings_ms",
    }
    check_counts(report["analysis"], x, edges, nontrivial=1, stresses=None)
    # ν from the returned mode and boundary sets, with the documented definition.
    sets = {k: np.array(sorted(set(v))) for k, v in report["boundary"].items()}
    assert set(sets) == {"left", "right", "bottom", "top"}
    # Each boundary set is a row or column of nodes (test_lattice checks which ones).
    for name, axis in (("left", 0), ("right", 0), ("bottom", 1), ("top", 1)):
        assert np.ptp(x[sets[name], axis]) <= 1e-12 * max(1.0, np.abs(x).max())
    assert x[sets["right"], 0].mean() > x[sets["left"], 0].mean()
    assert x[sets["top"], 1].mean() > x[sets["bottom"], 1].mean()
    eps_x, eps_y = boundary_strains(x, mode, sets, finite=False)
    assert (
        abs(-eps_y / eps_x - body["poisson_ratio"]) <= 1e-9
        and abs(body["poisson_ratio"] - poisson) <= 1e-9
    )
    assert sorted(s["name"] for s in body["states"]) == ["contracted", "expanded"]
    states = [matrix(state["positions"], len(x), d) for state in body["states"]]
    assert relative_bar_error(states, edges, x) <= 1e-9
    assert report["max_relative_bar_error"] <= 1e-9
    for state, y in zip(body["states"], states, strict=True):
        ex, ey = boundary_strains(x, y, sets, finite=True)
        assert (ex > 0) == (state["name"] == "expanded")
        assert is_number(state["poisson_ratio"]) and abs(state["poisson_ratio"] + ey / ex) <= 1e-9


@pytest.mark.parametrize(
    "request_",
    [
        {"dim": 2},
        {"dim": 2, "cells": [3, 2], "poisson_ratio": -0.5, "cell": [1.0, 1.5], "strain": 0.05},
        {"dim": 3, "cells": [2], "poisson_ratio": -0.5},
    ],
)
def test_auxetic(client, request_):
    response = client.post("/v1/design/auxetic", json=request_)
    assert response.status_code == 200, response.text
    check_auxetic(
        response.json(),
        request_["dim"],
        request_.get("poisson_ratio", -1.0),
        request_.get("strain", 0.1),
    )


@pytest.mark.parametrize(
    ("request_", "codes"),
    [
        ({"dim": 2, "cells": [0, 3]}, {"invalid_size"}),
        ({"dim": 2, "cells": [-1, 3]}, {"invalid_size"}),
        ({"dim": 2, "cells": [3]}, {"invalid_size"}),
        ({"dim": 2, "cells": [60, 60]}, {"invalid_size"}),
        ({"dim": 3, "cells": [0]}, {"invalid_size"}),
        ({"dim": 3, "cells": [65]}, {"invalid_size"}),
        ({"dim": 3, "cells": [2, 2]}, {"invalid_size"}),
        ({"dim": 2, "cells": []}, {"invalid_size", "invalid_request"}),
        ({"dim": 2, "cells": [1, 2, 3]}, {"invalid_size", "invalid_request"}),
        ({"dim": 2, "cell": [1.0]}, {"invalid_cell"}),
        ({"dim": 2, "cell": [1.0, -1.0]}, {"invalid_cell"}),
        ({"dim": 3, "cells": [1], "cell": [1.0, 1.0]}, {"invalid_cell"}),
        ({"dim": 2, "poisson_ratio": 1.5}, {"no_solution"}),
        ({"dim": 2, "strain": 0.0}, {"invalid_request"}),
        ({"dim": 4}, {"invalid_request"}),
    ],
)
def test_auxetic_bad_requests(client, request_, codes):
    assert_error(client.post("/v1/design/auxetic", json=request_), codes)


# Mostly valid requests (so the 200 path is exercised), mixed with out-of-range ones (strains
# below the schema's 1e-4 among them, see test_auxetic_tiny_strain_is_refused_by_the_schema).
@settings(
    max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    cells=st.lists(st.integers(1, 6), min_size=2, max_size=2)
    | st.lists(st.integers(-2, 7), max_size=3),
    poisson=st.floats(-3, 0.5) | st.floats(-1e3, 1e3),
    cell=st.none()
    | st.lists(st.floats(0.2, 3), min_size=2, max_size=2)
    | st.lists(st.floats(-2, 5), min_size=1, max_size=3),
    strain=st.floats(1e-3, 0.5) | st.floats(-1, 2) | st.floats(1e-12, 1e-3),
)
def test_auxetic_2d_never_5xx(client, cells, poisson, cell, strain):
    body = {"dim": 2, "cells": cells, "poisson_ratio": poisson, "strain": strain}
    if cell is not None:
        body["cell"] = cell
    response = client.post("/v1/design/auxetic", json=body)
    assert response.status_code in (200, 422), response.text
    event(f"status {response.status_code}")
    if response.status_code == 422:
        assert response.json()["detail"]["code"]
    else:
        check_auxetic(response.json(), 2, poisson, strain)


@pytest.mark.parametrize(
    "request_",
    [
        {"dim": 3, "cells": [2], "cell": [1.0, 1e-6, 1.0]},
        {"dim": 3, "cells": [2], "poisson_ratio": 0.0},
        {"dim": 3, "cells": [2], "poisson_ratio": -1e300},
        {"dim": 3, "cells": [2], "cell": [1e-300, 1.0, 1.0]},
        {"dim": 3, "cells": [1], "strain": 0.89},
    ],
)
def test_auxetic_3d_odd_requests_never_5xx(client, request_):
    response = client.post("/v1/design/auxetic", json=request_)
    assert response.status_code in (200, 422), response.text
    if response.status_code == 422:
        assert response.json()["detail"]["code"]


@pytest.mark.parametrize("strain", [1e-20, 1e-9, 9.9e-5])
def test_auxetic_tiny_strain_is_refused_by_the_schema(client, strain):
    """Below the schema's floor on ``strain`` (1e-4) a 422 names it."""
    response = client.post("/v1/design/auxetic", json={"dim": 2, "cells": [2, 2], "strain": strain})
    assert_error(response, {"invalid_request"})
    assert "strain" in response.json()["detail"]["message"]


def test_auxetic_strain_at_the_schema_floor_is_served(client):
    """The floor itself (1e-4) is served, with states at that strain."""
    response = client.post("/v1/design/auxetic", json={"dim": 2, "cells": [2, 2], "strain": 1e-4})
    assert response.status_code == 200, response.text
    check_auxetic(response.json(), 2, -1.0, 1e-4)


def test_auxetic_3d_chain_within_the_documented_limit(client):
    """The documented limit (lattice.MAX_CHAIN_BLOCKS) is served; one more block is refused."""
    from zeromode.solver.applications.lattice import MAX_CHAIN_BLOCKS

    response = client.post("/v1/design/auxetic", json={"dim": 3, "cells": [MAX_CHAIN_BLOCKS]})
    assert response.status_code == 200, response.text
    response = client.post("/v1/design/auxetic", json={"dim": 3, "cells": [MAX_CHAIN_BLOCKS + 1]})
    assert response.status_code == 422 and response.json()["detail"]["code"] == "invalid_size"


# --------------------------------------------------------------------------- /v1/design/allosteric
@pytest.mark.parametrize("d", [2, 3])
def test_allosteric(client, d):
    x_src, u_src, x_tgt, u_tgt = sites(d, 6.0, 3)
    response = client.post("/v1/design/allosteric", json=request_body(x_src, u_src, x_tgt, u_tgt))
    assert response.status_code == 200, response.text
    body = response.json()
    x, edges = check_frame(body["frame"], d)
    k_src, k_tgt = len(x_src), len(x_tgt)
    report = body["report"]
    assert report["source"] == list(range(k_src))
    assert report["target"] == list(range(k_src, k_src + k_tgt))
    assert body["frame"]["specified"] == report["source"] + report["target"]
    assert np.array_equal(x[:k_src], x_src) and np.array_equal(x[k_src : k_src + k_tgt], x_tgt)
    assert set(report) >= {
        "analysis",
        "source",
        "target",
        "relays",
        "achieved_target_motion",
        "target_error",
        "distance",
        "unspecified_nodes",
        "bars",
        "mode_residual",
        "timings_ms",
    }
    check_counts(report["analysis"], x, edges, nontrivial=1)
    assert report["bars"] == len(edges) and report["unspecified_nodes"] == len(x) - k_src - k_tgt
    assert len(body["modes"]) == 1
    mode = matrix(body["modes"][0], len(x), d)
    assert np.array_equal(mode[:k_src], u_src)
    assert mode_residual(compatibility_matrix(normalised(x), edges), mode) <= 1e-9
    achieved = matrix(report["achieved_target_motion"], k_tgt, d)
    response_here = driven_response(x, edges, report["source"], u_src)[report["target"]]
    scale = np.linalg.norm(u_tgt)
    assert np.linalg.norm(response_here - u_tgt) <= 1e-9 * scale
    assert np.linalg.norm(achieved - response_here) <= 1e-9 * scale
    assert 0 <= report["target_error"] <= 1e-9
    assert abs(report["distance"] - np.linalg.norm(x_tgt.mean(0) - x_src.mean(0))) <= 1e-9


# --------------------------------------------------------------------------- OpenAPI
def test_capabilities_in_openapi(client):
    spec = client.get("/openapi.json").json()
    schemas = spec["components"]["schemas"]
    for path, fields in {
        "/v1/design/auxetic": {"frame", "modes", "poisson_ratio"},
        "/v1/design/allosteric": {"frame", "modes", "report"},
    }.items():
        ok = spec["paths"][path]["post"]["responses"]["200"]["content"]["application/json"][
            "schema"
        ]
        name = ok["$ref"].rsplit("/", 1)[-1]
        assert fields <= set(schemas[name]["properties"])
    assert "achieved_target_motion" in schemas["AllostericReport"]["properties"]
