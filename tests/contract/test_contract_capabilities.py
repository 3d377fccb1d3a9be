"""API.md "Capabilities that get their own endpoints": the fields each answer must carry, and
what they mean, recomputed here.

auxetic: frame, modes, poisson_ratio (ν = −ε_y/ε_x of the mode, from the boundary sets);
allosteric: frame, modes and the achieved target motion (the zero mode that carries the source
motion, solved here from N(C)); motion: path and the largest relative bar-length error;
refine: the finite-motion error before and after; certify: self-stress, prestress stability
and rigidity margins.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from oracles.frames import K4_PLANE, SQUARE_CORNERS, SQUARE_LINKAGE, arrays
from oracles.motion import boundary_strains, relative_bar_error
from oracles.rigidity import compatibility_matrix, driven_response, mode_residual, reference_counts
from oracles.wire import is_number, matrix

AUXETIC = {"dim": 2, "cells": [3, 2], "poisson_ratio": -0.5}
ALLOSTERIC = {
    "dim": 2,
    "source": {"positions": [[0, 0], [1, 0], [0, 1]], "motion": [[0, 0], [1, 0], [0, 1]]},
    "target": {"positions": [[5, 0], [6, 0], [5, 1]], "motion": [[0, 0], [-1, 0], [0, -1]]},
}
SQUARE = SQUARE_CORNERS


def assert_zero_modes(frame: dict, modes: list) -> np.ndarray:
    x, edges = arrays(frame)
    n, d = x.shape
    c = compatibility_matrix(x, edges)
    stacked = np.stack([matrix(m, n, d) for m in modes])
    for mode in stacked:
        assert mode_residual(c, mode) <= 1e-9
    return stacked


# --------------------------------------------------------------------------- auxetic
@pytest.fixture(scope="module")
def auxetic(client) -> dict:
    response = client.post("/v1/design/auxetic", json=AUXETIC)
    assert response.status_code == 200, response.text[:300]
    return response.json()


def test_auxetic_carries_frame_modes_and_poisson_ratio(auxetic):
    assert {"frame", "modes", "poisson_ratio"} <= set(auxetic)
    assert {"dim", "positions", "edges"} <= set(auxetic["frame"])
    assert isinstance(auxetic["modes"], list) and auxetic["modes"]
    assert is_number(auxetic["poisson_ratio"])


def test_auxetic_modes_are_zero_modes_of_a_frame_with_one_nontrivial_mode(auxetic):
    assert_zero_modes(auxetic["frame"], auxetic["modes"])
    counts = reference_counts(*arrays(auxetic["frame"]))
    assert counts["nontrivial_zero_modes"] == len(auxetic["modes"]) == 1


def test_auxetic_poisson_ratio_is_negative_and_is_the_mode_s(auxetic):
    """ν = −ε_y/ε_x, ε the rate of change of the distance between opposite boundary means."""
    x, _ = arrays(auxetic["frame"])
    u = np.array(auxetic["modes"][0])
    eps_x, eps_y = boundary_strains(x, u, auxetic["report"]["boundary"], finite=False)
    nu = -eps_y / eps_x
    assert auxetic["poisson_ratio"] < 0
    assert np.isclose(auxetic["poisson_ratio"], nu, rtol=1e-6)
    assert np.isclose(nu, AUXETIC["poisson_ratio"], rtol=1e-6)


# --------------------------------------------------------------------------- allosteric
@pytest.fixture(scope="module")
def allosteric(client) -> dict:
    response = client.post("/v1/design/allosteric", json=ALLOSTERIC)
    assert response.status_code == 200, response.text[:300]
    return response.json()


def test_allosteric_carries_frame_modes_and_a_report_of_the_achieved_target_motion(allosteric):
    assert {"frame", "modes", "report"} <= set(allosteric)
    assert isinstance(allosteric["report"], dict)
    achieved = [k for k in allosteric["report"] if "achieved" in k]
    assert achieved, sorted(allosteric["report"])
    k_target = len(ALLOSTERIC["target"]["positions"])
    matrix(allosteric["report"][achieved[0]], k_target, ALLOSTERIC["dim"])


def test_allosteric_modes_are_zero_modes(allosteric):
    assert_zero_modes(allosteric["frame"], allosteric["modes"])


def test_driving_the_source_moves_the_target_as_prescribed(allosteric):
    """Solve u ∈ N(C) with u[source] = source motion, here; its target rows are the achieved
    motion, which must be the prescribed one (up to the solver's round-off)."""
    x, edges = arrays(allosteric["frame"])
    report = allosteric["report"]
    source, target = report["source"], report["target"]
    np.testing.assert_array_equal(x[source], np.array(ALLOSTERIC["source"]["positions"], float))
    np.testing.assert_array_equal(x[target], np.array(ALLOSTERIC["target"]["positions"], float))
    # Unique, and exact on the source rows (asserted inside driven_response).
    u = driven_response(x, edges, source, ALLOSTERIC["source"]["motion"])
    achieved = np.array(report["achieved_target_motion"])
    np.testing.assert_allclose(achieved, u[target], atol=1e-8)
    np.testing.assert_allclose(achieved, ALLOSTERIC["target"]["motion"], atol=1e-8)


# --------------------------------------------------------------------------- motion
@pytest.fixture(scope="module")
def motion(client) -> dict:
    request = {"frame": SQUARE_LINKAGE, "amplitude": 0.2, "max_step": 0.05}
    response = client.post("/v1/motion", json=request)
    assert response.status_code == 200, response.text[:300]
    return response.json()


def test_motion_carries_the_path_and_the_largest_relative_bar_length_error(motion):
    assert "path" in motion and "max_relative_bar_error" in motion
    assert is_number(motion["max_relative_bar_error"])
    x, _ = arrays(SQUARE_LINKAGE)
    assert len(motion["path"]) >= 2
    for configuration in motion["path"]:
        matrix(configuration, *x.shape)


def test_motion_bar_length_error_is_the_largest_along_the_path(motion):
    x, edges = arrays(SQUARE_LINKAGE)
    path = np.array(motion["path"])
    recomputed = relative_bar_error(path, edges, x)
    assert recomputed <= 1e-9
    assert abs(motion["max_relative_bar_error"] - recomputed) <= 1e-12
    # A real motion: the square linkage shears, so the nodes move.
    assert np.abs(path - x).max() > 1e-2


# --------------------------------------------------------------------------- refine
@pytest.fixture(scope="module")
def refine(client) -> tuple[dict, dict]:
    design = client.post("/v1/design", json={"dim": 2, "positions": SQUARE, "motions": [SQUARE]})
    assert design.status_code == 200
    request = {"frame": design.json()["frame"], "motion": SQUARE, "amplitude": 0.1}
    response = client.post("/v1/refine", json=request)
    assert response.status_code == 200, response.text[:300]
    return request, response.json()


def test_refine_reports_the_finite_motion_error_before_and_after(refine):
    _, body = refine
    before = [k for k in body if "before" in k]
    after = [k for k in body if "after" in k]
    assert before and after, sorted(body)
    assert is_number(body[before[0]]) and is_number(body[after[0]])
    assert 0 <= body["epsilon_after"] <= body["epsilon_before"]


def test_refine_moves_only_the_unspecified_nodes(refine):
    request, body = refine
    frame = request["frame"]
    specified = frame["specified"]
    refined, _ = arrays(body["frame"])
    original, _ = arrays(frame)
    np.testing.assert_array_equal(refined[specified], original[specified])
    assert body["frame"]["edges"] == frame["edges"]


# --------------------------------------------------------------------------- certify
def keys(value: Any) -> set[str]:
    if isinstance(value, dict):
        return set(value) | {k for v in value.values() for k in keys(v)}
    if isinstance(value, list):
        return {k for v in value for k in keys(v)}
    return set()


def test_certify_carries_self_stress_prestress_stability_and_rigidity_margins(client):
    response = client.post("/v1/certify", json={"frame": K4_PLANE})
    assert response.status_code == 200, response.text[:300]
    names = " ".join(sorted(keys(response.json()))).lower()
    for word in ("stress", "prestress", "margin"):
        assert word in names, names
