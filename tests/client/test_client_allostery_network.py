"""The client's design_allosteric_network (sync and async) against a live service: the given
network comes back changed so that driving the source pair strains the target pair η* times as
much, recomputed here from the returned frame (tests/oracles)."""

from __future__ import annotations

import asyncio

import numpy as np
import pytest
from oracles.rigidity import driven_response, reference_counts

from benchmarks.allostery_tasks import make_task
from zeromode_client import AsyncClient, Client, Frame, ZeromodeError

TASK = make_task(40, 1, 3.0)
GIVEN = Frame(TASK.frame.positions, TASK.frame.edges)


def strain(x, u, pair) -> float:
    i, j = pair
    return float((x[i] - x[j]) @ (u[i] - u[j]) / np.sum((x[i] - x[j]) ** 2))


def check(result) -> None:
    frame, report = result.frame, result["report"]
    assert frame is not None
    x, edges = frame.positions, frame.edges
    assert reference_counts(x, edges)["zero_modes"] == 4
    response = driven_response(x, edges, report["source"], report["source_motion"])
    eta = strain(x, response, report["target"]) / strain(x, response, report["source"])
    assert eta == pytest.approx(3.0, rel=1e-9)
    kept = np.delete(TASK.frame.edges, report["removed_edges"], axis=0)
    np.testing.assert_array_equal(edges[: len(kept)], kept)


def test_sync_client_tunes_a_given_network(service_url: str) -> None:
    with Client(service_url, timeout=60.0) as client:
        result = client.design_allosteric_network(
            GIVEN, source=list(TASK.source_pair), target=list(TASK.target_pair), strain_ratio=3.0
        )
        check(result)
        with pytest.raises(ZeromodeError) as err:
            client.design_allosteric_network(GIVEN, source=[0, 1], target=[2, 3], strain_ratio=0.0)
        assert err.value.status == 422 and err.value.code == "zero_strain"


def test_async_client_tunes_a_given_network(service_url: str) -> None:
    async def run():
        async with AsyncClient(service_url, timeout=60.0) as client:
            return await client.design_allosteric_network(
                GIVEN, source=list(TASK.source_pair), target=list(TASK.target_pair), strain_ratio=3.0
            )

    check(asyncio.run(run()))
