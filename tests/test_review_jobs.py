"""Review probes of the jobs and sweeps engine (#16, #18): inputs an adversarial client sends,
each checked against what the endpoint or the other downloads answer for the same points.

Every app keeps its records in its own SQLite file and runs on the session's real Dask cluster.
"""

from __future__ import annotations

import io
import json
import sqlite3
import time
from collections.abc import Iterator
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from fastapi.testclient import TestClient
from test_jobs import app_client
from test_sweeps import finish, submit

from zeromode.service.rest.app import create_app
from zeromode.service.wire.settings import Settings

AUXETIC = {"dim": 2, "cells": [2, 2]}


@pytest.fixture
def client(tmp_path: Path, dask_scheduler: str) -> Iterator[TestClient]:
    with app_client(tmp_path, dask_scheduler) as c:
        yield c


def test_parquet_of_a_column_mixing_types_is_the_ndjson_points(client):
    """The endpoints accept "-0.6" for a number (lax validation), so a sweep's params column can
    mix strings and numbers; the Parquet table must still be served (it was a 500)."""
    requests = [{"poisson_ratio": -0.4}, {"poisson_ratio": "-0.6"}]
    assert client.post("/v1/design/auxetic", json={**AUXETIC, **requests[1]}).status_code == 200
    sweep_id = submit(client, {"endpoint": "/v1/design/auxetic", "template": AUXETIC, "requests": requests})["id"]
    assert finish(client.get, sweep_id)["done"] == 2
    lines = [json.loads(line) for line in client.get(f"/v1/sweeps/{sweep_id}/results.ndjson").text.splitlines()]
    by_point = {d["point"]: d for d in lines}
    answer = client.get(f"/v1/sweeps/{sweep_id}/results.parquet")
    assert answer.status_code == 200, answer.text
    table = pq.read_table(io.BytesIO(answer.content)).to_pylist()
    assert [r["point"] for r in table] == [0, 1]
    for r in table:
        doc = by_point[r["point"]]
        assert json.loads(r["param.poisson_ratio"]) == doc["params"]["poisson_ratio"]
        assert r["poisson_ratio"] == doc["result"]["poisson_ratio"]


def test_a_cursor_past_any_integer_the_store_holds_is_refused_not_a_500(client):
    sweep_id = submit(client, {"endpoint": "/v1/design/auxetic", "template": AUXETIC})["id"]
    assert client.get(f"/v1/sweeps/{sweep_id}?after={2**63 - 1}").status_code == 200
    answer = client.get(f"/v1/sweeps/{sweep_id}?after={10**23}")
    assert answer.status_code == 422, answer.text
    assert answer.json()["detail"]["code"] == "invalid_request"


def test_delete_of_a_sweep_that_finished_leaves_it_done(client):
    """Every point done: a DELETE (once or twice) cancels nothing, so the sweep stays done."""
    sweep_id = submit(client, {"endpoint": "/v1/design/auxetic", "template": AUXETIC,
                               "grid": {"poisson_ratio": [-0.4, -0.6]}})["id"]
    before = finish(client.get, sweep_id)
    assert before["status"] == "done" and before["done"] == 2
    for _ in range(2):
        answer = client.delete(f"/v1/sweeps/{sweep_id}")
        assert answer.status_code == 200
        assert answer.json()["status"] == "done" and answer.json()["cancelled"] == 0
    assert client.get(f"/v1/sweeps/{sweep_id}").json()["status"] == "done"


def test_cancelling_a_large_sweep_is_quick_and_leaves_the_engine_its_database(client):
    """DELETE of a 4000-point sweep: the points not started are cancelled within a few seconds
    (it held SQLite's write lock ~4 ms a point, 39 s for 10 000 under load 4.5, past the busy
    timeout of the engine's lease and event writes: "database is locked")."""
    grid = {"poisson_ratio": [-0.3 - 1e-3 * i for i in range(80)], "cells": [[2, 2 + i % 3] for i in range(50)]}
    sweep_id = submit(client, {"endpoint": "/v1/design/auxetic", "template": AUXETIC, "grid": grid})["id"]
    start = time.process_time()  # CPU time of this process, which serves the app: load-independent
    answer = client.delete(f"/v1/sweeps/{sweep_id}")
    took = time.process_time() - start
    assert answer.status_code == 200
    body = answer.json()
    assert body["cancelled"] > 3000 and body["queued"] == 0
    assert took < 3.0, f"DELETE took {took:.1f} s"
    status = finish(client.get, sweep_id)
    assert status["status"] == "cancelled"
    assert status["done"] + status["failed"] + status["cancelled"] == 4000


# Bodies a heavy endpoint refuses: offloaded or not, the answer is the route's own 422 (the
# offload's size test read ill-typed fields before validation: 500).
ILL_TYPED = [
    ("/v1/design/auxetic", {"dim": 2, "cells": ["a", 3]}),
    ("/v1/design/auxetic", {"dim": 2, "cells": 5}),
    ("/v1/design", {"dim": 2, "options": [1]}),
    ("/v1/design", {"dim": 2, "options": "refine"}),
    ("/v1/analyze", {"frame": [1]}),
    ("/v1/analyze", {"frame": {"positions": 5}}),
    ("/v1/motion", [1, 2]),
]


def test_ill_typed_heavy_requests_get_the_routes_own_422_when_offloaded(tmp_path: Path, dask_scheduler: str):
    answers = {}
    for offload in (False, True):
        app = create_app(Settings(database_url=f"sqlite:///{tmp_path}/{offload}.sqlite3",
                                  dask_scheduler=dask_scheduler, offload=offload))
        with TestClient(app, raise_server_exceptions=False) as c:
            deadline = time.monotonic() + 30
            while offload and c.get("/health").json()["engine"] != "running":  # started in the background
                assert time.monotonic() < deadline
                time.sleep(0.05)
            answers[offload] = [c.post(path, json=body) for path, body in ILL_TYPED]
    for (path, body), inline, offloaded in zip(ILL_TYPED, answers[False], answers[True], strict=True):
        assert inline.status_code == 422, (path, body)
        assert (offloaded.status_code, offloaded.json()) == (422, inline.json()), (path, body)


def test_a_sweeps_point_is_no_job_to_delete_either(client, tmp_path: Path):
    """GET /v1/jobs/{a point's id} is 404; DELETE answered 200 with the point's record and
    cancelled it behind the sweep's back."""
    sweep_id = submit(client, {"endpoint": "/v1/design/auxetic", "template": AUXETIC,
                               "grid": {"poisson_ratio": [-0.4, -0.6]}})["id"]
    finish(client.get, sweep_id)
    with sqlite3.connect(tmp_path / "jobs.sqlite3") as db:  # the store's own file, read directly
        point_id = db.execute("SELECT id FROM jobs WHERE sweep_id = ?", (sweep_id,)).fetchone()[0]
    assert client.get(f"/v1/jobs/{point_id}").status_code == 404
    answer = client.delete(f"/v1/jobs/{point_id}")
    assert answer.status_code == 404 and answer.json()["detail"]["code"] == "unknown_job"
