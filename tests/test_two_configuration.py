"""Finite two-configuration design: both configurations are exact realisations of one frame.

Checked independently: bar lengths recomputed in both configurations, the specified rows exact,
the counts of the first configuration from the reference rank, and the reported ε measured again
by the continuation of oracles.motion.
"""

import numpy as np
import pytest
from oracles.frames import SQUARE_CORNERS
from oracles.motion import bar_lengths, fidelity
from oracles.rigidity import reference_counts

from zeromode.solver.construction.two_configuration import design_two_configurations
from zeromode.solver.errors import DomainError

SQUARE = np.array(SQUARE_CORNERS)
# ε by two continuations agrees to round-off; below ROUND_OFF_EPSILON both are "zero".
SAME_EPSILON, ROUND_OFF_EPSILON = 1e-6, 1e-9


@pytest.mark.parametrize("d,k,seed", [(2, 3, 0), (2, 4, 1), (3, 4, 2), (3, 5, 3)])
def test_both_configurations_keep_every_bar(d, k, seed):
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((k, d))
    y = x + 0.3 * rng.standard_normal((k, d))
    r = design_two_configurations(x, y, seed=seed)
    first, second, edges = r.frame.positions, r.final_positions, r.frame.edges
    assert np.array_equal(first[:k], x) and np.array_equal(second[:k], y)
    l1, l2 = bar_lengths(first, edges), bar_lengths(second, edges)
    assert np.max(np.abs(l1 - l2) / l1) <= 1e-12
    # The design's promise for the first configuration: one motion and no self-stress, so its
    # ε towards the second was traced, and is what an independent continuation measures.
    counts = reference_counts(first, edges)
    assert (counts["nontrivial_zero_modes"], counts["self_stresses"]) == (1, 0)
    measured = fidelity(first, edges, r.frame.specified, y - x)
    assert measured == pytest.approx(r.epsilon, rel=SAME_EPSILON, abs=ROUND_OFF_EPSILON)


def test_outward_square_scaled_is_reached_by_one_motion():
    r = design_two_configurations(SQUARE, 1.5 * SQUARE)
    assert r.epsilon is not None and r.epsilon <= 1e-6
    counts = reference_counts(r.frame.positions, r.frame.edges)
    assert counts["nontrivial_zero_modes"] == 1 and counts["self_stresses"] == 0
    assert fidelity(r.frame.positions, r.frame.edges, r.frame.specified, 0.5 * SQUARE) <= 1e-6


def test_a_rigid_motion_has_no_design():
    theta = 0.7
    rot = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
    with pytest.raises(DomainError) as err:
        design_two_configurations(SQUARE, SQUARE @ rot.T + [3.0, -1.0])
    assert err.value.code == "rigid_target"


def test_api_two_configuration(client):
    body = {"dim": 2, "initial": SQUARE.tolist(), "final": (1.2 * SQUARE).tolist()}
    response = client.post("/v1/design/two-configuration", json=body)
    assert response.status_code == 200, response.text
    out = response.json()
    first = np.asarray(out["frame"]["positions"])
    second = np.asarray(out["final_positions"])
    edges = np.asarray(out["frame"]["edges"])
    assert np.allclose(bar_lengths(first, edges), bar_lengths(second, edges), rtol=1e-12)
    assert out["report"]["epsilon"] <= 1e-6
    bad = client.post("/v1/design/two-configuration", json={**body, "final": SQUARE.tolist()})
    assert bad.status_code == 422 and bad.json()["detail"]["code"] == "rigid_target"
