"""Requests the service answers in its own threads cannot overrun their time budget (issue #18).

A request is answered in process only when ``service.jobs.heavy.heavy`` says it is cheap; there the
budget is checked between steps only, so every such class must stay far below the budget at its
largest. Here, for each class, the largest request left inline (just under its threshold) is
timed in process and must take at most a quarter of the default 60 s budget in CPU time (the
process's, every thread: what a loaded machine does not inflate); the same request one step
larger is heavy. Heavy requests to routes that are not job
endpoints (two-configuration, network allostery, plots, exports) run on a worker, where a long
library call is stopped at the budget: a plot of 5·10⁴ nodes (one long drawing loop, no budget
check) under a 2 s budget is answered too_expensive within 10 % (net of the upload).
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import numpy as np
import pytest
from fastapi.testclient import TestClient
from test_offload import numbers_close, running_service, upload_time

from benchmarks.bench_adversarial import chain, scattered
from benchmarks.bench_offload import big_frame
from zeromode.service.jobs.heavy import (
    HEAVY_CELLS,
    HEAVY_DENSE_SIDE,
    HEAVY_DESIGN,
    HEAVY_DOF,
    HEAVY_EDGES,
    HEAVY_NODES,
    heavy,
)
from zeromode.service.rest.app import create_app
from zeromode.service.rest.offload import VALIDATE_HERE_BYTES
from zeromode.service.wire.settings import Settings

RNG = np.random.default_rng(0)


def design(k: int, m: int) -> dict:
    return {"dim": 2, "positions": RNG.standard_normal((k, 2)).tolist(),
            "motions": [RNG.standard_normal((k, 2)).tolist() for _ in range(m)]}


# (endpoint, the largest request answered inline, the same one step larger)
LARGEST_INLINE = [
    # floppy frames (hundreds of zero modes: their bases are the cost) and rigid ones
    *(("/v1/analyze", {"frame": scattered(HEAVY_DOF // 2, bars_per_node=k)},
       {"frame": scattered(HEAVY_DOF // 2 + 1, bars_per_node=k)}) for k in (2, 5, 6)),
    ("/v1/analyze", {"frame": scattered(HEAVY_DOF // 3, dim=3, bars_per_node=4)},
     {"frame": scattered(HEAVY_DOF // 3 + 1, dim=3, bars_per_node=4)}),
    ("/v1/analyze", {"frame": scattered(HEAVY_DOF // 3, dim=3, bars_per_node=HEAVY_EDGES * 3 // HEAVY_DOF)},
     {"frame": scattered(HEAVY_DOF // 3, dim=3, bars_per_node=HEAVY_EDGES * 3 // HEAVY_DOF + 1)}),
    ("/v1/analyze", {"frame": scattered(HEAVY_DENSE_SIDE // 5, bars_per_node=5), "options": {"method": "dense"}},
     {"frame": scattered(HEAVY_DENSE_SIDE // 5, bars_per_node=6), "options": {"method": "dense"}}),
    ("/v1/design", design(16, HEAVY_DESIGN // 16), design(17, HEAVY_DESIGN // 16)),
    ("/v1/design/auxetic", {"dim": 2, "cells": [20, HEAVY_CELLS // 20], "poisson_ratio": -0.5},
     {"dim": 2, "cells": [21, HEAVY_CELLS // 20], "poisson_ratio": -0.5}),
    ("/v1/design/allosteric/network",
     {"frame": chain(HEAVY_DOF // 2), "source": [0, 1], "target": [HEAVY_DOF // 2 - 2, HEAVY_DOF // 2 - 1], "strain_ratio": 2.0},
     {"frame": chain(HEAVY_DOF // 2 + 1), "source": [0, 1], "target": [HEAVY_DOF // 2 - 1, HEAVY_DOF // 2], "strain_ratio": 2.0}),
    ("/v1/plot", {"frame": big_frame(HEAVY_NODES)}, {"frame": big_frame(HEAVY_NODES + 2)}),
    ("/v1/export", {"format": "graphml", "frame": big_frame(HEAVY_NODES)},
     {"format": "graphml", "frame": big_frame(HEAVY_NODES + 2)}),
    ("/v1/solution-space", {"dim": 3, "positions": RNG.standard_normal((64, 3)).tolist(),
                            "motions": RNG.standard_normal((64, 3)).tolist(), "samples": 1000}, None),
]


@pytest.mark.parametrize(("endpoint", "largest", "larger"), LARGEST_INLINE, ids=[c[0] for c in LARGEST_INLINE])
def test_the_largest_inline_request_of_each_class_stays_far_below_the_budget(endpoint, largest, larger, tmp_path):
    assert not heavy(endpoint, largest)
    assert larger is None or heavy(endpoint, larger)
    app = create_app(Settings(offload=False, database_url=f"sqlite:///{tmp_path}/jobs.sqlite3"))
    client = TestClient(app, raise_server_exceptions=False)
    t0 = time.process_time()
    r = client.post(endpoint, json=largest)
    elapsed = time.process_time() - t0
    assert r.status_code < 500, r.text
    assert elapsed <= Settings().time_budget_s / 4, (endpoint, elapsed)


@pytest.mark.parametrize("endpoint", ["/v1/motion", "/v1/refine", "/v1/certify", "/v1/design/allosteric",
                                      "/v1/design/two-configuration", "/v1/design/multistable", "/v1/design/sequential"])
def test_endpoints_without_a_cheap_class_are_always_heavy(endpoint):
    assert heavy(endpoint, {})


@contextmanager
def offloading_service(tmp: Path, budget_s: float) -> Iterator[str]:
    """`zeromode serve` with offloading on, one Dask worker and a budget of ``budget_s``: (URL)."""
    env = {"ZEROMODE_DATABASE_URL": f"sqlite:///{tmp}/jobs.sqlite3", "ZEROMODE_OFFLOAD": "true",
           "ZEROMODE_TIME_BUDGET_S": str(budget_s), "ZEROMODE_DASK_WORKERS": "1"}
    with running_service(tmp, env, "offloading") as (url, _, _):
        yield url


@pytest.fixture(scope="module")
def short_budget(tmp_path_factory: pytest.TempPathFactory):
    """A service whose 2 s budget a large plot passes."""
    with offloading_service(tmp_path_factory.mktemp("short-budget"), 2.0) as url:
        yield url


@pytest.fixture(scope="module")
def ample_budget(tmp_path_factory: pytest.TempPathFactory):
    """A service whose budget (an hour) no request of these tests comes near on any machine, however
    loaded: its answers never depend on the clock."""
    with offloading_service(tmp_path_factory.mktemp("ample-budget"), 3600.0) as url:
        yield url


def test_large_bodies_validated_on_a_worker_answer_as_the_route(ample_budget, tmp_path):
    """Bodies past VALIDATE_HERE_BYTES are validated by the worker (inside the budget): valid or
    not, the answer is the route's own, compared with the app in process (both under budgets
    their work cannot reach: with 2 s, a loaded machine answered the valid frame too_expensive)."""
    frame = big_frame(30_000)
    ragged = {**frame, "positions": [*frame["positions"][:-1], [1.0]]}
    out_of_range = {**frame, "edges": [*frame["edges"], [0, 30_000]]}
    cases = [
        ("/v1/analyze", {"frame": frame, "options": {"bases": False}}),
        ("/v1/analyze", {"frame": ragged}),
        ("/v1/analyze", {"frame": out_of_range}),
        ("/v1/plot", {"frame": ragged}),
    ]
    inline = TestClient(create_app(Settings(offload=False, time_budget_s=3600.0,
                                            database_url=f"sqlite:///{tmp_path}/jobs.sqlite3")))
    for path, body in cases:
        assert len(json.dumps(body)) > VALIDATE_HERE_BYTES and heavy(path, body)
        offloaded = httpx.post(ample_budget + path, json=body, timeout=600)
        direct = inline.post(path, json=body)
        assert offloaded.status_code == direct.status_code, (path, offloaded.text)
        numbers_close(offloaded.json(), direct.json())


def test_a_heavy_plot_is_stopped_at_the_budget(short_budget):
    frame = big_frame(50_000)
    t0 = time.perf_counter()
    r = httpx.post(short_budget + "/v1/plot", json={"frame": frame}, timeout=120)
    elapsed = time.perf_counter() - t0
    if r.status_code == 200:
        pytest.skip(f"this machine drew 5·10⁴ nodes within the budget ({elapsed:.1f} s)")
    assert r.status_code == 422 and r.json()["detail"]["code"] == "too_expensive", r.text
    assert elapsed <= 2.0 * 1.1 + upload_time(short_budget, frame), elapsed
    # A small plot is answered on (inline: it is cheap).
    assert httpx.post(short_budget + "/v1/plot", json={"frame": big_frame(10)}, timeout=60).status_code == 200
