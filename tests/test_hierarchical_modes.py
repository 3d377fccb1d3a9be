"""Several motions beyond the bipartite construction (solver/hierarchical_modes.py): M = 3, 4 in
2D and M = 4 in 3D, where no single unspecified node can be joined by d + 1 bars to nodes with
fixed motions ((d + 1)·M > d·(M + 1) equations).

Checked from scratch (oracles.designs.check_frame_modes: C from its definition, numpy SVD and
PyRigi): exactly d(d+1)/2 + M zero modes, no self-stress, every requested motion a zero mode and
the M independent of each other and of the rigid motions; the specified rows are the request,
exactly; the frame is not bipartite (some unspecified node is joined to another). Past M = 2d
the request is refused up front with the bound.
"""

from __future__ import annotations

import numpy as np
import pytest
from oracles.designs import check_frame_modes
from oracles.wire import assert_error

from zeromode.solver.design import design
from zeromode.solver.errors import DomainError, InvalidInput

CASES = [(2, 3, 4), (2, 4, 4), (2, 3, 5), (3, 4, 5)]


def request(d: int, m: int, k: int, seed: int):
    rng = np.random.default_rng([d, m, k, seed])
    return rng.standard_normal((k, d)), rng.standard_normal((m, k, d))


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize(("d", "m", "k"), CASES)
def test_motions_past_d_are_designed_exactly(d, m, k, seed):
    x, motions = request(d, m, k, seed)
    result = design(x, motions, seed=seed)
    frame = result.frame
    positions, edges = np.asarray(frame.positions), np.asarray(frame.edges)
    assert np.array_equal(positions[:k], x)
    for mode, wanted in zip(result.modes, motions, strict=True):
        assert np.array_equal(mode[:k], wanted)
    check_frame_modes(positions, edges, result.modes, use_pyrigi=len(positions) <= 20)
    assert np.any(edges.min(axis=1) >= k), "some unspecified node joins another (hierarchical)"


def test_more_than_2d_motions_are_refused_with_the_bound():
    x, motions = request(2, 5, 5, 0)
    with pytest.raises(DomainError) as err:
        design(x, motions)
    assert err.value.code == "too_many_motions"
    assert "2d = 4" in err.value.message


def test_a_fixed_node_count_is_refused_past_d_motions():
    x, motions = request(2, 3, 4, 0)
    with pytest.raises(InvalidInput) as err:
        design(x, motions, n_unspecified=4)
    assert err.value.code == "invalid_options"


def test_the_api_designs_three_motions_in_2d(client):
    """Through /v1/design: the answer's modes are the requested ones on the specified rows."""
    x, motions = request(2, 3, 4, 1)
    body = {"dim": 2, "positions": x.tolist(), "motions": motions.tolist(), "options": {"seed": 1}}
    response = client.post("/v1/design", json=body)
    assert response.status_code == 200, response.text[:300]
    answer = response.json()
    frame = answer["frame"]
    modes = np.asarray(answer["modes"])
    assert modes.shape[0] == 3 and answer["report"]["target_zero_modes"] == 6
    np.testing.assert_array_equal(modes[:, :4], motions)
    check_frame_modes(np.asarray(frame["positions"]), np.asarray(frame["edges"]), modes, use_pyrigi=False)


def test_the_api_refuses_more_motions_than_its_limit(client):
    x, motions = request(2, 5, 5, 0)
    body = {"dim": 2, "positions": x.tolist(), "motions": motions.tolist()}
    assert_error(client.post("/v1/design", json=body), {"invalid_request", "too_many_motions"})
