"""POST /v1/jobs, GET and DELETE /v1/jobs/{id}: long requests as jobs on the Dask engine.

Every app here keeps its records in its own SQLite file (and, in the tests of the store itself,
a database of its own on the tests' PostgreSQL server too: ``database_url`` in conftest.py) and
runs its jobs on the session's real Dask cluster (two worker processes, ``dask_scheduler``). A job's result is
compared with the answer of the endpoint called directly; failures with the code the endpoint
itself answers; what the endpoint refuses up front, the job refuses at submit.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from client.conftest import served
from fastapi.testclient import TestClient
from oracles.mechanisms import parallelogram

from zeromode.service.jobs.store import Store
from zeromode.service.rest.app import create_app
from zeromode.service.wire.settings import Settings

AUXETIC = {"dim": 2, "cells": [3, 2], "poisson_ratio": -0.5}
# Fig. 3c of the paper: four unspecified nodes.
OUTWARD_FOUR = {
    "dim": 2,
    "positions": [[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]],
    "motions": [[[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]]],
    "options": {"seed": 0, "n_unspecified": 4},
}
SINGULAR_MOTION = {
    "frame": {
        "dim": 2,
        "positions": parallelogram().positions.tolist(),
        "edges": parallelogram().edges.tolist(),
    },
    "amplitude": 3.0,
    "max_step": 0.05,
}
POLL_S = 0.02
WAIT_S = 60.0
FINISHED = ("done", "failed", "cancelled", "interrupted")


@contextmanager
def app_client(tmp_path: Path, dask_scheduler: str, **settings) -> Iterator[TestClient]:
    """An app on its own SQLite file (or the ``database_url`` given) and the session's Dask
    cluster (lifespan run: its engine closes at the end)."""
    settings = {"database_url": f"sqlite:///{tmp_path}/jobs.sqlite3", **settings}
    app = create_app(Settings(dask_scheduler=dask_scheduler, **settings))
    with TestClient(app, raise_server_exceptions=False) as client:
        yield client


@pytest.fixture
def client(tmp_path: Path, dask_scheduler: str) -> Iterator[TestClient]:
    with app_client(tmp_path, dask_scheduler) as c:
        yield c


def submit(client: TestClient, endpoint: str, request: dict, **headers) -> str:
    r = client.post("/v1/jobs", json={"endpoint": endpoint, "request": request}, headers=headers)
    assert r.status_code == 202, r.text
    body = r.json()
    assert body["status"] == "queued" and body["endpoint"] == endpoint
    assert r.headers["location"] == f"/v1/jobs/{body['id']}"
    return body["id"]


def wait(client: TestClient, job_id: str) -> dict:
    """Poll until the job ends; states only move forward and progress never falls."""
    deadline = time.monotonic() + WAIT_S
    seen, progress = [], []
    while time.monotonic() < deadline:
        r = client.get(f"/v1/jobs/{job_id}")
        assert r.status_code == 200, r.text
        status = r.json()
        seen.append(status["status"])
        progress.append(status["progress"])
        assert 0.0 <= status["progress"] <= 1.0
        if status["status"] in FINISHED:
            assert seen == sorted(seen, key=["queued", "running", status["status"]].index)
            assert progress == sorted(progress)
            return status
        time.sleep(POLL_S)
    pytest.fail(f"job {job_id} did not finish within {WAIT_S} s")


def without_timings(body):
    """Answers differ only in their measured times."""
    if isinstance(body, dict):
        return {k: without_timings(v) for k, v in body.items() if k != "timings_ms"}
    if isinstance(body, list):
        return [without_timings(v) for v in body]
    return body


def assert_error(detail: dict, code: str) -> None:
    assert detail["code"] == code, detail
    assert isinstance(detail["message"], str) and len(detail["message"]) > 10


def test_auxetic_job_result_equals_the_direct_answer(client):
    job_id = submit(client, "/v1/design/auxetic", AUXETIC)
    status = wait(client, job_id)
    assert status["status"] == "done" and status["progress"] == 1.0 and status["error"] is None
    assert status["id"] == job_id and status["endpoint"] == "/v1/design/auxetic"
    assert status["created"] <= status["started"] <= status["finished"] and status["attempts"] == 1
    direct = client.post("/v1/design/auxetic", json=AUXETIC)
    assert direct.status_code == 200
    assert without_timings(status["result"]) == without_timings(direct.json())


def test_design_job_matches_the_direct_answer(client):
    status = wait(client, submit(client, "/v1/design", OUTWARD_FOUR))
    assert status["status"] == "done"
    direct = client.post("/v1/design", json=OUTWARD_FOUR).json()
    assert without_timings(status["result"]) == without_timings(direct)
    assert direct["report"]["unspecified_nodes"] == 4


def test_a_long_jobs_progress_moves_while_it_runs(client):
    """An 30×30 auxetic job (seconds of work): polled, its progress takes values strictly
    between 0 and 1 before it is done (it does not jump from 0 to 1)."""
    job_id = submit(client, "/v1/design/auxetic", {"dim": 2, "cells": [30, 30], "poisson_ratio": -0.5})
    seen = set()
    deadline = time.monotonic() + WAIT_S
    while time.monotonic() < deadline:
        status = client.get(f"/v1/jobs/{job_id}").json()
        seen.add(status["progress"])
        if status["status"] in FINISHED:
            break
        time.sleep(POLL_S)
    assert status["status"] == "done"
    assert any(0.0 < p < 1.0 for p in seen), sorted(seen)


@pytest.mark.parametrize(
    ("endpoint", "request_body", "code", "where"),
    [
        ("/v1/design", {**OUTWARD_FOUR, "dim": 4}, "invalid_request", "request.dim"),
        ("/v1/design/auxetic", {"dim": 2, "cells": [0, 40], "poisson_ratio": -0.5}, None, None),
        ("/v1/design/auxetic", {"dim": 2, "cells": [4, 4], "poisson_ratio": 0.0}, None, None),
        ("/v1/design/auxetic", {"dim": 2, "cells": [4, 4], "poisson_ratio": -0.5, "strain": 0.3}, None, None),
        ("/v1/design", {**OUTWARD_FOUR, "options": {"seeed": 3}}, "invalid_request", "request.options.seeed"),
    ],
)
def test_a_job_refuses_at_once_what_its_endpoint_refuses(client, tmp_path, endpoint, request_body, code, where):
    """The same status and code as the endpoint's own answer, and nothing recorded."""
    direct = client.post(endpoint, json=request_body)
    assert direct.status_code == 422, direct.text
    r = client.post("/v1/jobs", json={"endpoint": endpoint, "request": request_body})
    assert r.status_code == 422, r.text
    assert r.json()["detail"]["code"] == direct.json()["detail"]["code"] == (code or direct.json()["detail"]["code"])
    if where:
        assert r.json()["detail"]["message"].startswith(where)
    assert Store(f"sqlite:///{tmp_path}/jobs.sqlite3").unfinished() == 0


def test_a_job_for_an_endpoint_that_is_not_a_job_is_refused(client):
    for body in ({"endpoint": "/v1/plot", "request": {}}, {"endpoint": "/v1/analyze"}):
        r = client.post("/v1/jobs", json=body)
        assert r.status_code == 422
        assert_error(r.json()["detail"], "invalid_request")


def test_a_job_is_validated_under_its_apps_settings(tmp_path, dask_scheduler):
    with app_client(tmp_path, dask_scheduler, max_nodes=4) as client:
        frame = SINGULAR_MOTION["frame"]  # four nodes: within the limit; five are not
        five = {**frame, "positions": [*frame["positions"], [9.0, 9.0]]}
        r = client.post("/v1/jobs", json={"endpoint": "/v1/analyze", "request": {"frame": five}})
        assert r.status_code == 422
        detail = r.json()["detail"]
        assert detail["message"].startswith("request.frame.positions") and "max_nodes" in detail["message"]
        status = wait(client, submit(client, "/v1/analyze", {"frame": frame}))
        assert status["status"] == "done", status


@pytest.mark.parametrize("job_id", ["0" * 32, "nope", "A" * 32, "'; drop table jobs; --"])
def test_unknown_job_ids_are_a_404_with_a_code(client, job_id):
    r = client.get(f"/v1/jobs/{job_id}")
    assert r.status_code == 404
    assert_error(r.json()["detail"], "unknown_job")


def test_a_job_over_its_budget_fails_with_too_expensive(tmp_path, dask_scheduler):
    with app_client(tmp_path, dask_scheduler, job_time_budget_s=0.0) as client:
        status = wait(client, submit(client, "/v1/design", OUTWARD_FOUR))
    assert status["status"] == "failed" and status["result"] is None
    assert_error(status["error"], "too_expensive")
    assert "900" not in status["error"]["message"] and "0 s" in status["error"]["message"]


def test_a_job_fails_with_the_code_its_endpoint_answers(client):
    direct = client.post("/v1/motion", json=SINGULAR_MOTION)
    assert direct.status_code == 422
    status = wait(client, submit(client, "/v1/motion", SINGULAR_MOTION))
    assert status["status"] == "failed"
    assert without_timings(status["error"]) == without_timings(direct.json()["detail"])  # with the best figures
    assert status["error"]["code"] == "singular_path"


def test_two_app_instances_on_one_store_see_each_others_jobs(tmp_path, dask_scheduler, database_url):
    with (app_client(tmp_path, dask_scheduler, database_url=database_url) as first,
          app_client(tmp_path, dask_scheduler, database_url=database_url) as second):
        job_id = submit(first, "/v1/design/auxetic", AUXETIC)
        status = wait(second, job_id)
        assert status["status"] == "done"
        assert without_timings(status["result"]) == without_timings(wait(first, job_id)["result"])


def test_a_finished_result_survives_the_app(tmp_path, dask_scheduler, database_url):
    """Records live in the database: a new app on it answers with the same result."""
    with app_client(tmp_path, dask_scheduler, database_url=database_url) as first:
        job_id = submit(first, "/v1/design/auxetic", AUXETIC)
        result = wait(first, job_id)["result"]
    with app_client(tmp_path, dask_scheduler, database_url=database_url) as again:
        status = again.get(f"/v1/jobs/{job_id}").json()
    assert status["status"] == "done" and status["result"] == result


def test_old_records_expire_and_the_store_keeps_its_row_cap(database_url):
    store = Store(database_url)
    now = time.time()
    for i in range(5):
        store.add_job({"id": f"{i:032x}", "endpoint": "/v1/analyze", "request": "{}", "client": "",
                       "status": "done", "progress": 1.0, "message": "done", "created": now - 100 + i,
                       "finished": now - 100 + i, "attempts": 1, "owner": "x", "bytes": 0})
    assert store.expire(now, ttl_s=97.5, max_jobs=10) == 3  # finished 100, 99, 98 s ago
    assert store.expire(now, ttl_s=1e6, max_jobs=1) == 1  # the oldest of the two left
    assert store.job(f"{4:032x}") is not None and store.job(f"{3:032x}") is None
    # Past the cap with no single job left to drop, whole finished sweeps go, the oldest first.
    for k in range(2):
        sweep_id = f"{k:031x}s"
        points = [{"id": f"{k}{i:031x}", "sweep_id": sweep_id, "point": i, "endpoint": "/v1/analyze",
                   "request": "{}", "client": "", "status": "done", "progress": 1.0, "message": "done",
                   "created": now, "finished": now + k, "attempts": 1, "owner": "x", "bytes": 0} for i in range(3)]
        store.add_sweep({"id": sweep_id, "endpoint": "/v1/analyze", "spec": "{}", "client": "", "total": 3,
                         "finished_count": 3, "cancelled": False, "created": now, "finished": now + k}, points)
    assert store.expire(now, ttl_s=1e6, max_jobs=4) == 1 + 3  # the last single job, the older sweep
    assert store.sweep(f"{0:031x}s") is None and store.sweep(f"{1:031x}s")["counts"] == {"done": 3}


def test_the_service_answers_429_when_its_job_slots_are_full(tmp_path, dask_scheduler):
    with app_client(tmp_path, dask_scheduler, max_pending_jobs=0) as client:
        r = client.post("/v1/jobs", json={"endpoint": "/v1/design/auxetic", "request": AUXETIC})
    assert r.status_code == 429
    assert_error(r.json()["detail"], "too_many_jobs")


def test_an_unusable_job_store_is_a_503_naming_it(tmp_path, dask_scheduler):
    blocker = tmp_path / "file"
    blocker.write_text("")
    app = create_app(Settings(database_url=f"sqlite:///{blocker}/sub/jobs.sqlite3", dask_scheduler=dask_scheduler))
    with TestClient(app, raise_server_exceptions=False) as client:
        r = client.post("/v1/jobs", json={"endpoint": "/v1/design/auxetic", "request": AUXETIC})
    assert r.status_code == 503
    assert_error(r.json()["detail"], "jobs_unavailable")
    assert str(blocker) in r.json()["detail"]["message"]


def test_an_unreachable_dask_scheduler_is_a_503_naming_it(tmp_path):
    app = create_app(Settings(database_url=f"sqlite:///{tmp_path}/jobs.sqlite3", dask_scheduler="tcp://127.0.0.1:9"))
    with TestClient(app, raise_server_exceptions=False) as client:
        r = client.post("/v1/jobs", json={"endpoint": "/v1/design/auxetic", "request": AUXETIC})
    assert r.status_code == 503
    assert_error(r.json()["detail"], "jobs_unavailable")
    assert "tcp://127.0.0.1:9" in r.json()["detail"]["message"]


def test_a_result_over_its_size_limit_fails_the_job_and_is_not_stored(tmp_path, dask_scheduler, database_url):
    with app_client(tmp_path, dask_scheduler, max_job_result_bytes=200, database_url=database_url) as client:
        request = {"frame": SINGULAR_MOTION["frame"]}
        direct = client.post("/v1/analyze", json=request)
        assert len(direct.content) > 200  # the same answer would not fit
        status = wait(client, submit(client, "/v1/analyze", request))
    assert status["status"] == "failed"
    assert_error(status["error"], "result_too_large")
    assert "200" in status["error"]["message"]
    assert Store(database_url).stored_bytes() == 0


def test_the_job_store_keeps_to_its_quota(tmp_path, dask_scheduler, database_url):
    request = {"frame": SINGULAR_MOTION["frame"]}
    size = len(TestClient(create_app()).post("/v1/analyze", json=request).content)
    quota = size * 3 // 2  # one result fits, two do not
    with app_client(tmp_path, dask_scheduler, max_job_store_bytes=quota, database_url=database_url) as client:
        assert wait(client, submit(client, "/v1/analyze", request))["status"] == "done"
        second = wait(client, submit(client, "/v1/analyze", request))
        assert_error(second["error"], "job_store_full")
        assert Store(database_url).stored_bytes() <= quota


def test_one_client_cannot_hold_every_job_slot_and_a_queued_job_can_be_cancelled(tmp_path, dask_scheduler, database_url):
    with app_client(tmp_path, dask_scheduler, max_jobs_per_client=2, max_pending_jobs=8,
                    database_url=database_url) as client:
        slow = {"dim": 2, "cells": [30, 30], "poisson_ratio": -0.5}
        first = submit(client, "/v1/design/auxetic", slow)
        second = submit(client, "/v1/design/auxetic", slow)
        r = client.post("/v1/jobs", json={"endpoint": "/v1/design/auxetic", "request": AUXETIC})
        assert r.status_code == 429
        assert_error(r.json()["detail"], "too_many_jobs_for_client")
        # Another client (another API key) still gets a slot while the first jobs run.
        other = submit(client, "/v1/design/auxetic", AUXETIC, **{"x-api-key": "other"})
        cancelled = client.delete(f"/v1/jobs/{second}").json()
        assert wait(client, first)["status"] == "done"
        assert wait(client, other)["status"] == "done"
        final = wait(client, second)
        # Cancelled if it had not started yet; a job already running finishes.
        assert final["status"] == cancelled["status"] if cancelled["status"] == "cancelled" else final["status"] == "done"
        assert client.delete(f"/v1/jobs/{'0' * 32}").status_code == 404


# --- a live service and the `zeromode job` command ---------------------------------------------


@pytest.fixture(scope="module")
def live_url(tmp_path_factory: pytest.TempPathFactory, dask_scheduler: str) -> Iterator[str]:
    db = tmp_path_factory.mktemp("live") / "jobs.sqlite3"
    with served(create_app(Settings(database_url=f"sqlite:///{db}", dask_scheduler=dask_scheduler))) as url:
        yield url


def zeromode_job(url: str, endpoint: str, request: Path) -> subprocess.CompletedProcess:
    command = [sys.executable, "-m", "zeromode.service.cli", "job", endpoint, str(request)]
    run = subprocess.run(
        [*command, "--url", url, "--poll", "0.05"], check=False, capture_output=True, timeout=60
    )
    # Decoded by hand: text mode would turn the progress bar's carriage returns into newlines.
    return subprocess.CompletedProcess(run.args, run.returncode, run.stdout.decode(), run.stderr.decode())


def test_cli_job_prints_the_result_and_draws_a_progress_bar(live_url, tmp_path):
    import httpx

    request = tmp_path / "auxetic.json"
    request.write_text(json.dumps(AUXETIC))
    run = zeromode_job(live_url, "design/auxetic", request)
    assert run.returncode == 0, run.stderr
    direct = httpx.post(f"{live_url}/v1/design/auxetic", json=AUXETIC, timeout=60)
    assert without_timings(json.loads(run.stdout)) == without_timings(direct.json())
    bars = run.stderr.rstrip("\n").split("\r")[1:]
    assert bars and "\n" not in "".join(bars)  # one line, redrawn in place
    assert bars[-1].startswith("[" + "#" * 30 + "] 100%  done")


def test_cli_job_failures_exit_2_with_the_error_sentence(live_url, tmp_path):
    singular = tmp_path / "singular.json"
    singular.write_text(json.dumps(SINGULAR_MOTION))
    run = zeromode_job(live_url, "/v1/motion", singular)
    assert run.returncode == 2 and run.stdout == ""
    assert "error [singular_path]:" in run.stderr
    invalid = tmp_path / "invalid.json"
    invalid.write_text(json.dumps({**AUXETIC, "dim": 5}))
    run = zeromode_job(live_url, "/v1/design/auxetic", invalid)
    assert run.returncode == 2 and "error [invalid_request]: request.dim" in run.stderr


def test_python_client_jobs(live_url):
    """submit_job, job, wait and cancel_job: the same result as the direct call, failures as
    ZeromodeError."""
    from zeromode_client import Client, ZeromodeError

    with Client(live_url) as client:
        ids = [client.submit_job("/v1/design/auxetic", AUXETIC) for _ in range(3)]
        results = [client.wait(i, poll=0.05, timeout=60) for i in ids]
        direct = client.design_auxetic(**AUXETIC)
        for result in results:
            assert result.path == "/v1/design/auxetic"
            assert without_timings(result.raw) == without_timings(direct.raw)
        status = client.job(ids[0])
        assert status.status == "done" and status.progress == 1.0 and status.finished_running
        assert client.cancel_job(ids[0]).status == "done"  # finished work is not cancelled
        failing = client.submit_job("/v1/motion", SINGULAR_MOTION)
        with pytest.raises(ZeromodeError) as failure:
            client.wait(failing, poll=0.05, timeout=60)
        assert failure.value.code == "singular_path"
        with pytest.raises(ZeromodeError) as unknown:
            client.job("0" * 32)
        assert unknown.value.status == 404 and unknown.value.code == "unknown_job"
