"""The elastic response model over the wire: the client's design_allosteric_network with
response="elastic" against a live service (real uvicorn on loopback). The edited network is
rebuilt from the body alone (given edges less the removed ones, the returned stiffnesses) and its
η recomputed by the spring oracle (tests/oracles/springs.py); a ratio out of reach is a 422 whose
best figures the oracle confirms; the mechanism stays the default."""

from __future__ import annotations

import asyncio

import numpy as np
import pytest
from oracles.springs import spring_ratio, spring_zero_modes

from benchmarks.allostery_tasks import make_task
from zeromode_client import AsyncClient, Client, Frame, ZeromodeError

TASK = make_task(100, 1, -1.0)
GIVEN = Frame(TASK.frame.positions, TASK.frame.edges)
PAIRS = {"source": list(TASK.source_pair), "target": list(TASK.target_pair)}


def check(result, ratio: float) -> None:
    x, given = TASK.frame.positions, TASK.frame.edges
    report = result["report"]
    kept = np.delete(given, report["removed_edges"], axis=0)
    np.testing.assert_array_equal(result.frame.edges, kept)
    k = np.asarray(result["stiffness"])
    tuned = report["tuned"]
    assert tuned is not None and report["changes"] == len(report["removed_edges"]) + 1
    (changed,) = np.flatnonzero(k != 1.0)
    assert list(kept[changed]) == tuned["bar"] == list(given[tuned["edge"]]) and k[changed] == tuned["stiffness"]
    eta = spring_ratio(x, kept, k, TASK.source_pair, TASK.target_pair)
    assert abs(eta - ratio) <= 1e-9 * max(1.0, abs(ratio))
    assert report["strain_ratio"] == pytest.approx(eta, abs=1e-9)
    assert spring_zero_modes(x, kept, k) == 3
    u = np.asarray(result["displacement"])
    i, j = TASK.source_pair
    assert (x[i] - x[j]) @ (u[i] - u[j]) / np.sum((x[i] - x[j]) ** 2) == pytest.approx(1.0, rel=1e-9)


def test_sync_client_tunes_a_spring_network_exactly(service_url: str) -> None:
    with Client(service_url, timeout=60.0) as client:
        check(client.design_allosteric_network(GIVEN, response="elastic", strain_ratio=-1.0, **PAIRS), -1.0)
        mechanism = client.design_allosteric_network(GIVEN, strain_ratio=-1.0, **PAIRS)
        assert len(mechanism["modes"]) == 1 and "tuned" not in mechanism["report"]
        with pytest.raises(ZeromodeError) as err:
            client.design_allosteric_network(GIVEN, response="elastic", strain_ratio=1e6, **PAIRS)
    assert err.value.status == 422 and err.value.code == "ratio_out_of_reach"
    best = err.value.detail["best"]
    k = np.ones(TASK.frame.n_edges)
    if best["tuned_edge"] is not None:
        k[best["tuned_edge"]] = best["tuned_stiffness"][1]
    k[best["removed_edges"]] = 0.0
    keep = k > 0
    eta = spring_ratio(TASK.frame.positions, TASK.frame.edges[keep], k[keep], TASK.source_pair, TASK.target_pair)
    assert best["strain_ratio"] == pytest.approx(eta, rel=1e-6) and eta < 1e6


def test_async_client_tunes_a_spring_network_exactly(service_url: str) -> None:
    async def run():
        async with AsyncClient(service_url, timeout=60.0) as client:
            return await client.design_allosteric_network(
                GIVEN, response="elastic", strain_ratio=-1.0, options={"seed": 0}, **PAIRS
            )

    check(asyncio.run(run()), -1.0)


@pytest.mark.parametrize(
    ("fields", "code"),
    [
        ({"response": "elastic", "source_motion": [[0.0, 0.0], [1.0, 0.0]], "target_motion": [[0.0, 0.0], [1.0, 0.0]]},
         "invalid_response"),
        ({"strain_ratio": 1.0, "options": {"stiffness": [1.0] * TASK.frame.n_edges}}, "invalid_options"),
        ({"response": "elastic", "strain_ratio": 1.0, "options": {"stiffness": [1.0, 2.0]}}, "invalid_stiffness"),
        ({"response": "elastic", "strain_ratio": 1.0, "options": {"max_stiffness": 0.5}}, "invalid_request"),
    ],
)
def test_requests_without_meaning_are_refused(service_url: str, fields, code) -> None:
    with Client(service_url, timeout=60.0) as client, pytest.raises(ZeromodeError) as err:
        client.design_allosteric_network(GIVEN, **PAIRS, **fields)
    assert 400 <= err.value.status < 500 and err.value.code == code
