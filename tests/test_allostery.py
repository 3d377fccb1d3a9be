"""Allosteric design (paper, "Combining Network Modes for Potential Applications": long-range
coupled conformational regulation).

The claim checked here, from scratch (oracles.rigidity.driven_response): drive the source
nodes with u_src and let the frame do what its bars allow, i.e. take the zero mode u ∈ N(C)
whose source rows equal u_src (C built from its definition, N(C) from its SVD, least squares for
the coefficients). That response must be unique (no zero mode — rigid or not — leaves the source
still while moving anything else) and its target rows must equal the prescribed u_tgt to 1e-9
relative. The designed frame itself is checked with PyRigi and the same C (one nontrivial mode,
no self-stress).
"""

from __future__ import annotations

import numpy as np
import pytest
from fastapi.testclient import TestClient
from oracles.designs import check_frame_modes
from oracles.rigidity import driven_response

from zeromode.service.app import create_app
from zeromode.solver.allostery import design_allosteric
from zeromode.solver.errors import DomainError, InvalidInput


def sites(d: int, distance: float, seed: int):
    """Source and target sites of d + 1 nodes each, the target's centroid ``distance`` + 3 away
    along x (site radii are about 1)."""
    rng = np.random.default_rng([d, seed, int(10 * distance)])
    x_src, x_tgt = rng.standard_normal((d + 1, d)), rng.standard_normal((d + 1, d))
    x_tgt[:, 0] += distance + 3.0
    return x_src, rng.standard_normal((d + 1, d)), x_tgt, rng.standard_normal((d + 1, d))


CASES = [(d, distance) for d in (2, 3) for distance in (0.0, 3.0, 6.0, 12.0)]


@pytest.mark.parametrize(("d", "distance"), CASES)
def test_driving_the_source_moves_the_target_as_prescribed(d, distance):
    x_src, u_src, x_tgt, u_tgt = sites(d, distance, 0)
    result = design_allosteric(x_src, u_src, x_tgt, u_tgt, seed=0)
    frame, modes = result.design.frame, result.design.modes
    x, edges = np.asarray(frame.positions), np.asarray(frame.edges)
    k_src, k_tgt = len(x_src), len(x_tgt)
    source, target = np.arange(k_src), np.arange(k_src, k_src + k_tgt)
    assert result.source == tuple(source) and result.target == tuple(target)
    assert np.array_equal(x[source], x_src) and np.array_equal(x[target], x_tgt)
    assert set(result.relays) == set(range(k_src + k_tgt, k_src + k_tgt + len(result.relays)))
    check_frame_modes(x, edges, modes, use_pyrigi=len(x) <= 30)

    response = driven_response(x, edges, source, u_src)
    error = np.linalg.norm(response[target] - u_tgt) / np.linalg.norm(u_tgt)
    assert error <= 1e-9
    # The report agrees with the response computed here.
    assert np.allclose(
        result.achieved_target_motion, response[target], rtol=0, atol=1e-9 * np.linalg.norm(u_tgt)
    )
    assert result.target_error <= 1e-9
    assert abs(result.distance - np.linalg.norm(x_tgt.mean(0) - x_src.mean(0))) <= 1e-12
    print(
        f"\nd={d} distance={result.distance:.2f}: N={len(x)} (relays {len(result.relays)}), N_B={len(edges)}, error {error:.1e}"
    )


def test_linear_response_scales_with_the_drive():
    """Linear order: driving with 2·u_src moves the target by 2·u_tgt; −u_src by −u_tgt."""
    x_src, u_src, x_tgt, u_tgt = sites(2, 6.0, 1)
    result = design_allosteric(x_src, u_src, x_tgt, u_tgt, seed=0)
    frame = result.design.frame
    target = list(result.target)
    for factor in (2.0, -1.0):
        response = driven_response(
            frame.positions, frame.edges, list(result.source), factor * u_src
        )
        assert np.allclose(response[target], factor * u_tgt, atol=1e-9 * np.linalg.norm(u_tgt))


def test_bad_sites_are_refused_by_the_solver():
    x_src, u_src, x_tgt, u_tgt = sites(2, 3.0, 2)
    overlapping = x_tgt.copy()
    overlapping[1] = x_src[2]
    with pytest.raises(DomainError) as err:
        design_allosteric(x_src, u_src, overlapping, u_tgt)
    assert err.value.code == "overlapping_sites"
    with pytest.raises(DomainError) as err:
        design_allosteric(x_src, np.zeros_like(u_src), x_tgt, u_tgt)
    assert err.value.code == "rigid_target"
    with pytest.raises(InvalidInput) as err:
        design_allosteric(x_src, u_src[:-1], x_tgt, u_tgt)
    assert err.value.code == "invalid_shape"


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app(), raise_server_exceptions=False)


def request_body(x_src, u_src, x_tgt, u_tgt, **options) -> dict:
    return {
        "dim": len(x_src[0]),
        "source": {"positions": np.asarray(x_src).tolist(), "motion": np.asarray(u_src).tolist()},
        "target": {"positions": np.asarray(x_tgt).tolist(), "motion": np.asarray(u_tgt).tolist()},
        "options": options,
    }


def test_bad_requests_answer_422(client):
    x_src, u_src, x_tgt, u_tgt = sites(2, 3.0, 2)
    overlapping = x_tgt.copy()
    overlapping[0] = x_src[0]
    cases = {
        "overlapping_sites": request_body(x_src, u_src, overlapping, u_tgt),
        "rigid_target": request_body(x_src, np.zeros_like(u_src), x_tgt, u_tgt),
        "invalid_shape": request_body(x_src, u_src[:-1], x_tgt, u_tgt),
    }
    for code, body in cases.items():
        response = client.post("/v1/design/allosteric", json=body)
        assert response.status_code == 422, (code, response.text)
        detail = response.json()["detail"]
        assert detail["code"] == code and len(detail["message"]) > 10
    # Schema-level problems: a 3D point in a 2D request, a non-positive relay spacing.
    wrong_dim = request_body(x_src, u_src, x_tgt, u_tgt)
    wrong_dim["source"]["positions"][0] = [0.0, 0.0, 0.0]
    spacing = request_body(x_src, u_src, x_tgt, u_tgt, relay_spacing=0.0)
    for body in (wrong_dim, spacing):
        response = client.post("/v1/design/allosteric", json=body)
        assert response.status_code == 422, response.text
        assert response.json()["detail"]["code"]
