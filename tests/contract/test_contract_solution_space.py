"""API.md "POST /v1/solution-space": nullity, dimension, kind, basis W̃, quadric Q, samples.

Ã = [u_Sᵀ, x_Sᵀ, −1] and b_i = x_Si·u_Si are built here (paper, Eq. 5); the quadric is checked
against its meaning c = x_U·u_U on points W̃α̃, and the samples against every bar constraint
(x_Si − x_U)·(u_Si − u_U) = 0.
"""

from __future__ import annotations

import numpy as np
import pytest
from oracles.frames import SQUARE_CORNERS
from oracles.rigidity import numerical_rank
from oracles.solution_space import a_tilde, bar_residuals, nullity, points_on_random_lines
from oracles.wire import assert_error, is_int, matrix

KINDS = {1: "points", 2: "conic", 3: "quadric_surface"}
SQUARE = SQUARE_CORNERS
# (d, k): generic targets give m = 2d + 1 − k: points, conics, surfaces and hypersurfaces.
CASES = [(2, 4), (2, 3), (2, 2), (2, 1), (3, 6), (3, 5), (3, 4), (3, 3)]


def targets(d: int, k: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng([d, k, 7])
    return rng.standard_normal((k, d)), rng.standard_normal((k, d))


@pytest.fixture(scope="module")
def answers(client) -> dict[tuple[int, int], dict]:
    out = {}
    for d, k in CASES:
        x, u = targets(d, k)
        request = {"dim": d, "positions": x.tolist(), "motions": u.tolist(), "samples": 6}
        response = client.post("/v1/solution-space", json=request)
        assert response.status_code == 200, ((d, k), response.text)
        out[d, k] = response.json()
    return out


@pytest.mark.parametrize("case", CASES)
def test_every_field_is_present(answers, case):
    assert {"nullity", "dimension", "kind", "basis", "quadric", "samples"} <= set(answers[case])


@pytest.mark.parametrize("case", CASES)
def test_nullity_is_the_dimension_of_the_null_space_of_a_tilde(answers, case):
    expected = nullity(*targets(*case))
    assert is_int(answers[case]["nullity"]) and answers[case]["nullity"] == expected


@pytest.mark.parametrize("case", CASES)
def test_dimension_is_nullity_minus_one(answers, case):
    body = answers[case]
    assert is_int(body["dimension"]) and body["dimension"] == body["nullity"] - 1


@pytest.mark.parametrize("case", CASES)
def test_kind_names_the_solution_set(answers, case):
    body = answers[case]
    assert body["kind"] == KINDS.get(body["nullity"], "quadric_hypersurface")


def test_every_kind_occurs(answers):
    assert {b["kind"] for b in answers.values()} == {
        "points",
        "conic",
        "quadric_surface",
        "quadric_hypersurface",
    }


@pytest.mark.parametrize("case", CASES)
def test_basis_is_w_tilde_with_rows_x_u_u_u_c(answers, case):
    """(2d+1)×(m+1): m columns spanning N(Ã), then a particular solution ṽ* of Ã ṽ = b."""
    d, _ = case
    x, u = targets(*case)
    a, b = a_tilde(x, u)
    m = answers[case]["nullity"]
    w = matrix(answers[case]["basis"], 2 * d + 1, m + 1)
    scale = np.linalg.norm(a) * np.linalg.norm(w)
    assert np.linalg.norm(a @ w[:, :m]) <= 1e-10 * scale
    assert numerical_rank(w[:, :m]) == m
    assert np.linalg.norm(a @ w[:, m] - b) <= 1e-10 * (scale + np.linalg.norm(b))


@pytest.mark.parametrize("case", CASES)
def test_quadric_is_symmetric_and_vanishes_exactly_where_c_equals_x_u_dot_u_u(answers, case):
    """α̃ᵀQα̃ = 0 ⇔ x_U·u_U = c for ṽ = W̃α̃, α̃ = (α, 1): Q is the form x_U·u_U − c in α̃."""
    d, _ = case
    m = answers[case]["nullity"]
    w = np.array(answers[case]["basis"])
    q = matrix(answers[case]["quadric"], m + 1, m + 1)
    np.testing.assert_allclose(q, q.T, rtol=0, atol=1e-12 * np.abs(q).max())
    rng = np.random.default_rng(0)
    alphas = np.hstack([rng.standard_normal((20, m)), np.ones((20, 1))])
    v = alphas @ w.T
    form = np.einsum("ni,ij,nj->n", alphas, q, alphas)
    constraint = np.sum(v[:, :d] * v[:, d : 2 * d], axis=1) - v[:, 2 * d]
    # Q may be scaled: the two must be proportional by one nonzero factor.
    factor = (form @ constraint) / (constraint @ constraint)
    assert abs(factor) > 0
    np.testing.assert_allclose(
        form, factor * constraint, rtol=1e-8, atol=1e-10 * np.abs(form).max()
    )


@pytest.mark.parametrize("case", CASES)
def test_samples_satisfy_every_bar_constraint(answers, case):
    d, _ = case
    x, u = targets(*case)
    samples = answers[case]["samples"]
    assert isinstance(samples, list) and len(samples) <= 6
    for sample in samples:
        assert {"position", "motion"} <= set(sample)
        x_u = matrix([sample["position"]], 1, d)[0]
        u_u = matrix([sample["motion"]], 1, d)[0]
        assert np.abs(bar_residuals(x, u, x_u, u_u)).max() <= 1e-9
    # Real points found here (all of them for m = 1) mean the samples cannot be empty.
    m = answers[case]["nullity"]
    w = matrix(answers[case]["basis"], 2 * d + 1, m + 1)
    real = points_on_random_lines(w, d, np.random.default_rng(0))
    if m == 1:
        assert len(samples) == min(6, len(real))
    else:
        assert samples or not len(real)


def test_samples_are_returned_up_to_n(client):
    """The outward square (Fig. 3b): the circumcircle, so every sample is real."""
    for n in (0, 1, 5):
        request = {"dim": 2, "positions": SQUARE, "motions": SQUARE, "samples": n}
        body = client.post("/v1/solution-space", json=request).json()
        assert len(body["samples"]) == n
        for sample in body["samples"]:
            assert np.isclose(np.linalg.norm(sample["position"]), np.sqrt(2), rtol=1e-9)


def test_b_outside_the_range_of_a_tilde_is_no_solution(client):
    """k = 2d + 2 generic rows: Ã is (2d+2)×(2d+1), so b is generically not in R(Ã)."""
    x, u = targets(2, 6)
    a, b = a_tilde(x, u)
    residual = b - a @ np.linalg.lstsq(a, b, rcond=None)[0]
    assert np.linalg.norm(residual) > 1e-3 * np.linalg.norm(b)
    response = client.post(
        "/v1/solution-space", json={"dim": 2, "positions": x.tolist(), "motions": u.tolist()}
    )
    assert_error(response, "no_solution", status=422)
