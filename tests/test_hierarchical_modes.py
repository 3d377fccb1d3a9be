"""Several motions beyond the bipartite construction (solver/construction/hierarchical_pairs.py): M = 3, 4 in
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
from oracles.rigidity import compatibility_matrix, normalised, rigid_generators
from oracles.wire import assert_error

from zeromode.solver.construction.design import design
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


def test_many_motions_in_3d_k64_m4_exact_by_numpy_svd():
    """Issue 42, item 4: 3D, k = 64 specified nodes spread as a scene's (uniform in a cube of
    volume 64), four standard-normal motions. From numpy's SVD of C built bar by bar from its
    definition (oracles.rigidity; centred frame, RMS radius 1, σ ≤ 1e-9 σ_max counted as
    zero): exactly d(d+1)/2 + 4 zero modes, rank [rigid motions | modes] = d(d+1)/2 + 4
    (exactly M = 4 nontrivial ones, the requested ones), no self-stress, ‖C u‖ ≤ 1e-9 ‖C‖‖u‖ for each motion; the rank decision is clear
    (σ_r/σ_max far above the threshold). Specified rows are the request, exactly."""
    rng = np.random.default_rng([42, 3, 64, 4])
    k, d, m = 64, 3, 4
    x = rng.uniform(-2.0, 2.0, (k, d))
    motions = rng.standard_normal((m, k, d))
    result = design(x, motions, seed=7)
    positions, edges = np.asarray(result.frame.positions), np.asarray(result.frame.edges)
    assert np.array_equal(positions[:k], x)
    for mode, wanted in zip(result.modes, motions, strict=True):
        assert np.array_equal(mode[:k], wanted)
    y = normalised(positions)
    c = compatibility_matrix(y, edges)
    s = np.linalg.svd(c, compute_uv=False)
    rank = int(np.count_nonzero(s > 1e-9 * s[0]))
    n = len(positions)
    rigid = d * (d + 1) // 2
    assert d * n - rank == rigid + m, "zero modes"
    assert len(edges) - rank == 0, "self-stresses"
    assert s[rank - 1] > 1e-7 * s[0], "rank decision not clear"
    for mode in result.modes:
        assert np.linalg.norm(c @ mode.ravel()) <= 1e-9 * s[0] * np.linalg.norm(mode)
    together = np.column_stack([rigid_generators(y), *(mode.ravel() for mode in result.modes)])
    sv = np.linalg.svd(together / np.linalg.norm(together, axis=0), compute_uv=False)
    assert np.count_nonzero(sv > 1e-8 * sv[0]) == rigid + m, "modes independent of each other and of the rigid motions"


@pytest.mark.parametrize(("d", "m", "k"), [(2, 3, 5), (3, 4, 6)])
def test_hierarchical_design_is_the_same_for_the_same_request(d, m, k):
    """Seeded: the same request gives the same frame and modes, bit for bit (the groups' starts
    are solved in one batch)."""
    x, motions = request(d, m, k, 3)
    first, second = design(x, motions, seed=3), design(x, motions, seed=3)
    assert np.array_equal(first.frame.positions, second.frame.positions)
    assert np.array_equal(first.frame.edges, second.frame.edges)
    assert np.array_equal(first.modes, second.modes)
