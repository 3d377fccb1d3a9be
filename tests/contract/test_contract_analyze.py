"""API.md "POST /v1/analyze": every field, exact integers, rank_gap, the mode and stress bases.

Counts come from an SVD of the compatibility matrix C built here (paper, Eq. 3) on the
scale-normalised frame; the rigid motions are built here from their definition.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from oracles.frames import FRAMES, arrays
from oracles.rigidity import (
    COUNT_FIELDS,
    RANK_GAP_FIELDS,
    REFERENCE_RTOL,
    compatibility_matrix,
    normalised,
    rank_gap,
    rank_of,
    reference_counts,
    rigid_motions,
    singular_values,
)
from oracles.wire import is_int, is_number, matrix


@pytest.fixture(scope="module")
def answers(client) -> dict[str, dict]:
    out = {}
    for name, frame in FRAMES.items():
        response = client.post("/v1/analyze", json={"frame": frame})
        assert response.status_code == 200, (name, response.text)
        out[name] = response.json()
    return out


@pytest.mark.parametrize("name", list(FRAMES))
def test_every_field_is_present_and_every_count_is_an_exact_integer(answers, name):
    body = answers[name]
    assert {*COUNT_FIELDS, "rank_gap", "modes", "stresses"} <= set(body)
    for key in COUNT_FIELDS:
        assert is_int(body[key]), (key, body[key])
    assert set(body["rank_gap"]) >= set(RANK_GAP_FIELDS)
    assert all(is_number(body["rank_gap"][k]) for k in RANK_GAP_FIELDS)


@pytest.mark.parametrize("name", list(FRAMES))
def test_nodes_edges_dim_and_maxwell_count(answers, name):
    x, edges = arrays(FRAMES[name])
    n, d = x.shape
    body = answers[name]
    assert (body["nodes"], body["edges"], body["dim"]) == (n, len(edges), d)
    assert body["maxwell_count"] == d * n - len(edges)


@pytest.mark.parametrize("name", list(FRAMES))
def test_rank_is_the_rank_of_the_compatibility_matrix(answers, name):
    assert answers[name]["rank"] == reference_counts(*arrays(FRAMES[name]))["rank"]


@pytest.mark.parametrize("name", list(FRAMES))
def test_zero_modes_is_dN_minus_rank(answers, name):
    body = answers[name]
    assert body["zero_modes"] == body["dim"] * body["nodes"] - body["rank"]


@pytest.mark.parametrize("name", list(FRAMES))
def test_rigid_body_modes_is_the_dimension_of_the_rigid_motions(answers, name):
    assert (
        answers[name]["rigid_body_modes"]
        == reference_counts(*arrays(FRAMES[name]))["rigid_body_modes"]
    )


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("triangle", 3),
        ("tetrahedron", 6),
        ("hinged_3d", 6),
        ("collinear_3d", 5),
        ("single_node_2d", 2),
    ],
)
def test_rigid_body_modes_is_d_d_plus_1_over_2_unless_degenerate(answers, name, expected):
    assert answers[name]["rigid_body_modes"] == expected


@pytest.mark.parametrize("name", list(FRAMES))
def test_nontrivial_zero_modes_is_zero_modes_minus_rigid_body_modes(answers, name):
    body = answers[name]
    assert body["nontrivial_zero_modes"] == body["zero_modes"] - body["rigid_body_modes"]


@pytest.mark.parametrize("name", list(FRAMES))
def test_self_stresses_is_NB_minus_rank(answers, name):
    body = answers[name]
    assert body["self_stresses"] == body["edges"] - body["rank"]


@pytest.mark.parametrize(
    ("name", "nontrivial", "stresses"),
    [("triangle", 0, 0), ("square_linkage", 1, 0), ("k4_plane", 0, 1), ("tetrahedron", 0, 0)],
)
def test_counts_of_known_frames(answers, name, nontrivial, stresses):
    body = answers[name]
    assert (body["nontrivial_zero_modes"], body["self_stresses"]) == (nontrivial, stresses)


@pytest.mark.parametrize("name", list(FRAMES))
def test_rank_gap_is_sigma_r_and_sigma_r_plus_1_of_the_scale_normalised_C(answers, name):
    x, edges = arrays(FRAMES[name])
    expected = rank_gap(x, edges)
    gap = answers[name]["rank_gap"]
    assert math.isclose(gap["last_nonzero"], expected["last_nonzero"], rel_tol=1e-6, abs_tol=1e-14)
    assert math.isclose(gap["first_zero"], expected["first_zero"], rel_tol=1e-6, abs_tol=1e-12)
    if answers[name]["rank"]:
        sigma_max = singular_values(compatibility_matrix(normalised(x), edges))[0]
        assert gap["first_zero"] <= REFERENCE_RTOL * sigma_max < gap["last_nonzero"]


def test_first_zero_is_0_when_there_is_none(answers):
    """A triangle: C is 3×6 of rank 3, so no singular value follows σ_3."""
    assert answers["triangle"]["rank"] == 3
    assert answers["triangle"]["rank_gap"]["first_zero"] == 0


def test_rank_gap_is_invariant_under_scaling_and_translation(client, answers):
    frame = FRAMES["k4_plane"]
    moved = {**frame, "positions": (1e5 * np.array(frame["positions"]) + 7e5).tolist()}
    gap = client.post("/v1/analyze", json={"frame": moved}).json()["rank_gap"]
    reference = answers["k4_plane"]["rank_gap"]
    assert math.isclose(gap["last_nonzero"], reference["last_nonzero"], rel_tol=1e-6)
    assert gap["first_zero"] <= 1e-9 * gap["last_nonzero"] * 1e3


@pytest.mark.parametrize("name", list(FRAMES))
def test_modes_are_an_orthonormal_basis_of_the_nontrivial_zero_modes(answers, name):
    x, edges = arrays(FRAMES[name])
    n, d = x.shape
    body = answers[name]
    assert isinstance(body["modes"], list) and len(body["modes"]) == body["nontrivial_zero_modes"]
    if not body["modes"]:
        return
    modes = np.stack([matrix(m, n, d) for m in body["modes"]]).reshape(len(body["modes"]), -1)
    np.testing.assert_allclose(modes @ modes.T, np.eye(len(modes)), atol=1e-9)
    c = compatibility_matrix(normalised(x), edges)
    assert np.abs(c @ modes.T).max() <= 1e-9 * max(np.abs(c).max(), 1.0)
    # Orthogonal to every rigid motion of this configuration (translations, rotations).
    rigid = rigid_motions(x)
    assert np.abs(rigid.T @ modes.T).max() <= 1e-9


@pytest.mark.parametrize("name", list(FRAMES))
def test_stresses_are_a_basis_of_the_self_stresses_each_of_length_NB(answers, name):
    x, edges = arrays(FRAMES[name])
    body = answers[name]
    assert isinstance(body["stresses"], list) and len(body["stresses"]) == body["self_stresses"]
    if not body["stresses"]:
        return
    stresses = matrix(body["stresses"], body["self_stresses"], len(edges))
    c = compatibility_matrix(normalised(x), edges)
    # Cᵀ s = 0: the bar tensions balance at every node (equilibrium without load).
    assert np.abs(c.T @ stresses.T).max() <= 1e-9 * np.abs(stresses).max()
    assert rank_of(singular_values(stresses)) == len(stresses)


def test_k4_self_stress_is_the_equilibrium_of_the_six_bars(answers):
    """On the original (unnormalised) frame the equilibrium also holds: Cᵀ s = 0."""
    x, edges = arrays(FRAMES["k4_plane"])
    stress = np.array(answers["k4_plane"]["stresses"][0])
    assert np.all(np.abs(stress) > 1e-3)  # K4 in general position: every bar carries tension
    assert (
        np.abs(compatibility_matrix(x, edges).T @ stress).max() <= 1e-9 * np.abs(stress).max() * 4
    )
