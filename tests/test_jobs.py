"""POST /v1/jobs and GET /v1/jobs/{id}: long requests as background jobs with progress.

A job's result is compared with the answer of the endpoint called directly; failures with the
code the endpoint itself answers. The job store is a directory shared by uvicorn's worker
processes: two app instances on one directory see each other's jobs, and the ``zeromode job``
command and the Python client run against a live two-worker uvicorn (the command opens a new
connection per request, so its polls reach either worker).
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import httpx
import numpy as np
import pytest
from fastapi.testclient import TestClient
from oracles.mechanisms import parallelogram

from zeromode.service import jobs
from zeromode.service.app import create_app
from zeromode.service.settings import Settings
from zeromode.solver.design import design
from zeromode.solver.progress import progress_scope, report_progress

AUXETIC = {"dim": 2, "cells": [3, 2], "poisson_ratio": -0.5}
# Fig. 3c of the paper: four unspecified nodes, so the placement loop reports four times.
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
WAIT_S = 30.0


def app_client(job_dir: Path, **settings) -> TestClient:
    return TestClient(
        create_app(Settings(job_dir=str(job_dir), **settings)), raise_server_exceptions=False
    )


@pytest.fixture
def client(tmp_path: Path) -> TestClient:
    return app_client(tmp_path)


def submit(client: TestClient, endpoint: str, request: dict) -> str:
    r = client.post("/v1/jobs", json={"endpoint": endpoint, "request": request})
    assert r.status_code == 202, r.text
    body = r.json()
    assert body["status"] == "queued" and body["endpoint"] == endpoint
    assert r.headers["location"] == f"/v1/jobs/{body['id']}"
    return body["id"]


def wait(client: TestClient, job_id: str) -> dict:
    deadline = time.monotonic() + WAIT_S
    seen = []
    while time.monotonic() < deadline:
        r = client.get(f"/v1/jobs/{job_id}")
        assert r.status_code == 200, r.text
        status = r.json()
        seen.append(status["status"])
        assert 0.0 <= status["progress"] <= 1.0
        if status["status"] in ("done", "failed"):
            assert seen == sorted(seen, key=["queued", "running", status["status"]].index)
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
    assert status["created"] <= status["started"] <= status["finished"]
    direct = client.post("/v1/design/auxetic", json=AUXETIC)
    assert direct.status_code == 200
    assert without_timings(status["result"]) == without_timings(direct.json())


def test_design_job_reports_placement_progress_and_matches_the_direct_answer(client):
    status = wait(client, submit(client, "/v1/design", OUTWARD_FOUR))
    assert status["status"] == "done"
    direct = client.post("/v1/design", json=OUTWARD_FOUR).json()
    assert without_timings(status["result"]) == without_timings(direct)
    assert direct["report"]["unspecified_nodes"] == 4


def test_placement_reports_monotone_progress_up_to_one():
    """One report per unspecified node placed, the fraction of degrees of freedom removed."""
    reports: list[tuple[float, str]] = []
    with progress_scope(lambda fraction, message: reports.append((fraction, message))):
        result = design(OUTWARD_FOUR["positions"], OUTWARD_FOUR["motions"], dim=2, n_unspecified=4)
    fractions = [f for f, _ in reports]
    assert len(reports) == result.unspecified_nodes == 4
    assert fractions == sorted(fractions) and 0.0 < fractions[0] and fractions[-1] == 1.0
    # N_D = d·N − N_B starts at d·k = 8 and must reach d(d+1)/2 + M = 4; a node joined by b
    # bars removes b − d of the 4.
    removed = np.cumsum([len(anchors) - 2 for anchors in result.anchor_sets])
    expected = removed / (2 * 4 - (3 + 1))
    np.testing.assert_allclose(fractions, expected)
    assert reports[-1][1] == "placed 4 unspecified nodes"


def test_progress_outside_a_scope_goes_nowhere_and_is_clamped():
    report_progress(0.5, "nobody listens")  # must not raise
    seen = []
    with progress_scope(lambda f, m: seen.append(f)):
        report_progress(-1.0)
        report_progress(2.0)
    assert seen == [0.0, 1.0]


def test_progress_reports_reach_the_status_file_and_running_jobs_keep_it_fresh(
    tmp_path, monkeypatch
):
    monkeypatch.setattr(jobs, "HEARTBEAT_S", 0.1)
    store = jobs.JobStore(Settings(job_dir=str(tmp_path)))
    reported, release = threading.Event(), threading.Event()

    def run() -> dict:
        report_progress(0.25, "a quarter")
        report_progress(0.5, "half")  # within MIN_WRITE_INTERVAL_S: written by the heartbeat
        reported.set()
        assert release.wait(WAIT_S)
        return {"answer": 42}

    job_id = store.submit("/v1/design", run)["id"]
    assert reported.wait(WAIT_S)
    deadline = time.monotonic() + WAIT_S
    while (status := store.get(job_id))["message"] != "half":
        assert time.monotonic() < deadline
        time.sleep(POLL_S)
    assert status["status"] == "running" and status["progress"] == 0.5
    while store.get(job_id)["updated"] <= status["updated"]:  # the heartbeat rewrites it
        assert time.monotonic() < deadline
        time.sleep(POLL_S)
    release.set()
    while (status := store.get(job_id))["status"] != "done":
        assert time.monotonic() < deadline
        time.sleep(POLL_S)
    assert status["result"] == {"answer": 42} and status["progress"] == 1.0


def test_an_invalid_job_request_is_refused_at_once_with_the_endpoint_error_body(client, tmp_path):
    r = client.post(
        "/v1/jobs", json={"endpoint": "/v1/design", "request": {**OUTWARD_FOUR, "dim": 4}}
    )
    assert r.status_code == 422
    assert_error(r.json()["detail"], "invalid_request")
    assert r.json()["detail"]["message"].startswith("request.dim")
    assert list(tmp_path.iterdir()) == []  # nothing was stored
    r = client.post("/v1/jobs", json={"endpoint": "/v1/plot", "request": {}})
    assert r.status_code == 422
    assert_error(r.json()["detail"], "invalid_request")
    r = client.post("/v1/jobs", json={"endpoint": "/v1/analyze"})
    assert r.status_code == 422
    assert_error(r.json()["detail"], "invalid_request")


def test_a_job_is_validated_under_its_apps_settings_and_its_answer_is_not_held_to_them(tmp_path):
    client = app_client(tmp_path, max_nodes=4)
    frame = SINGULAR_MOTION["frame"]  # four nodes: within the limit; five are not
    five = {**frame, "positions": [*frame["positions"], [9.0, 9.0]]}
    r = client.post("/v1/jobs", json={"endpoint": "/v1/analyze", "request": {"frame": five}})
    assert r.status_code == 422
    detail = r.json()["detail"]
    assert_error(detail, "invalid_request")
    assert detail["message"].startswith("request.frame.positions") and "max_nodes" in detail["message"]
    status = wait(client, submit(client, "/v1/design", OUTWARD_FOUR))
    assert status["status"] == "done", status
    assert len(status["result"]["frame"]["positions"]) == 4 + 4  # four unspecified nodes added


@pytest.mark.parametrize("job_id", ["0" * 32, "nope", "A" * 32, "f" * 32 + ".result"])
def test_unknown_job_ids_are_a_404_with_a_code(client, tmp_path, job_id):
    # A stored job "fff…f" whose result file must not be reachable as the id "fff…f.result".
    (tmp_path / f"{'f' * 32}.result.json").write_text('{"status": "done"}')
    r = client.get(f"/v1/jobs/{job_id}")
    assert r.status_code == 404
    assert_error(r.json()["detail"], "unknown_job")


def test_a_job_over_its_budget_fails_with_too_expensive(tmp_path):
    client = app_client(tmp_path, job_time_budget_s=0.0)
    status = wait(client, submit(client, "/v1/design", OUTWARD_FOUR))
    assert status["status"] == "failed" and status["result"] is None
    assert_error(status["error"], "too_expensive")
    assert "900" not in status["error"]["message"] and "0 s" in status["error"]["message"]


def test_a_job_fails_with_the_code_its_endpoint_answers(client):
    direct = client.post("/v1/motion", json=SINGULAR_MOTION)
    assert direct.status_code == 422
    status = wait(client, submit(client, "/v1/motion", SINGULAR_MOTION))
    assert status["status"] == "failed"
    assert status["error"] == {k: direct.json()["detail"][k] for k in ("code", "message")}
    assert status["error"]["code"] == "singular_path"


def test_two_app_instances_on_one_job_dir_see_each_others_jobs(tmp_path):
    first, second = app_client(tmp_path), app_client(tmp_path)
    job_id = submit(first, "/v1/design/auxetic", AUXETIC)
    status = wait(second, job_id)
    assert status["status"] == "done"
    assert without_timings(status["result"]) == without_timings(wait(first, job_id)["result"])
    other = submit(second, "/v1/analyze", {"frame": SINGULAR_MOTION["frame"]})
    assert wait(first, other)["result"]["nontrivial_zero_modes"] == 1


def test_stored_jobs_are_bounded_the_oldest_finished_go_first(tmp_path):
    client = app_client(tmp_path, max_stored_jobs=2)
    request = {"frame": SINGULAR_MOTION["frame"]}
    ids = [submit(client, "/v1/analyze", request)]
    for _ in range(3):
        wait(client, ids[-1])
        time.sleep(0.02)  # distinct modification times
        ids.append(submit(client, "/v1/analyze", request))
    wait(client, ids[-1])
    assert [client.get(f"/v1/jobs/{i}").status_code for i in ids] == [404, 404, 200, 200]
    assert len(list(tmp_path.glob("*.json"))) == 2 + 2  # two status and two result files


def test_expired_jobs_are_forgotten(tmp_path):
    client = app_client(tmp_path, job_ttl_s=0.0)
    old = submit(client, "/v1/analyze", {"frame": SINGULAR_MOTION["frame"]})
    wait(client, old)
    time.sleep(0.02)
    wait(client, submit(client, "/v1/analyze", {"frame": SINGULAR_MOTION["frame"]}))
    assert client.get(f"/v1/jobs/{old}").status_code == 404


def test_a_worker_with_no_room_answers_429(tmp_path):
    client = app_client(tmp_path, max_pending_jobs=0)
    r = client.post("/v1/jobs", json={"endpoint": "/v1/design/auxetic", "request": AUXETIC})
    assert r.status_code == 429
    assert_error(r.json()["detail"], "too_many_jobs")


def test_an_unusable_job_directory_is_a_503_naming_it(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    client = app_client(blocker / "jobs")
    r = client.post("/v1/jobs", json={"endpoint": "/v1/design/auxetic", "request": AUXETIC})
    assert r.status_code == 503
    assert_error(r.json()["detail"], "jobs_unavailable")
    assert str(blocker / "jobs") in r.json()["detail"]["message"]


def test_a_job_whose_worker_stopped_is_reported_lost(client, tmp_path):
    job_id = "f" * 32
    stale = {
        "id": job_id,
        "endpoint": "/v1/design",
        "status": "running",
        "progress": 0.25,
        "message": "placed 1 unspecified nodes",
        "created": "2026-01-01T00:00:00.000+00:00",
        "started": "2026-01-01T00:00:00.000+00:00",
        "finished": None,
        "updated": time.time() - 3600,
    }
    (tmp_path / f"{job_id}.json").write_text(json.dumps(stale))
    status = client.get(f"/v1/jobs/{job_id}").json()
    assert status["status"] == "failed"
    assert_error(status["error"], "job_lost")


# --- a live two-worker service and the `zeromode job` command --------------------------------


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


@pytest.fixture(scope="module")
def live_url(tmp_path_factory: pytest.TempPathFactory):
    """uvicorn with two worker processes sharing one job directory."""
    job_dir = tmp_path_factory.mktemp("jobs")
    log_path = job_dir.parent / "uvicorn.log"
    port = free_port()
    command = [sys.executable, "-m", "uvicorn", "zeromode.service.app:app", "--workers", "2"]
    with open(log_path, "w") as log:
        proc = subprocess.Popen(
            [*command, "--host", "127.0.0.1", "--port", str(port), "--log-level", "warning"],
            env={**os.environ, "ZEROMODE_JOB_DIR": str(job_dir)},
            stdout=log,
            stderr=subprocess.STDOUT,
        )
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 60
        while True:
            if proc.poll() is not None or time.monotonic() > deadline:
                pytest.fail(f"uvicorn did not start:\n{log_path.read_text()}")
            try:
                if httpx.get(f"{url}/health", timeout=2).status_code == 200:
                    break
            except httpx.TransportError:
                time.sleep(0.1)
        yield url
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def zeromode_job(url: str, endpoint: str, request: Path) -> subprocess.CompletedProcess:
    command = [sys.executable, "-m", "zeromode.service.cli", "job", endpoint, str(request)]
    run = subprocess.run(
        [*command, "--url", url, "--poll", "0.05"], check=False, capture_output=True, timeout=60
    )
    # Decoded by hand: text mode would turn the progress bar's carriage returns into newlines.
    return subprocess.CompletedProcess(
        run.args, run.returncode, run.stdout.decode(), run.stderr.decode()
    )


def test_cli_job_prints_the_result_and_draws_a_progress_bar(live_url, tmp_path):
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
    """submit_job, job and wait: the same result as the direct call, failures as ZeromodeError."""
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
        failing = client.submit_job("/v1/motion", SINGULAR_MOTION)
        with pytest.raises(ZeromodeError) as failure:
            client.wait(failing, poll=0.05, timeout=60)
        assert failure.value.code == "singular_path"
        with pytest.raises(ZeromodeError) as unknown:
            client.job("0" * 32)
        assert unknown.value.status == 404 and unknown.value.code == "unknown_job"


def test_a_result_over_its_size_limit_fails_the_job_and_is_not_stored(tmp_path):
    client = app_client(tmp_path, max_job_result_bytes=200)
    request = {"frame": SINGULAR_MOTION["frame"]}
    direct = client.post("/v1/analyze", json=request)
    assert len(direct.content) > 200  # the same answer would not fit
    job_id = submit(client, "/v1/analyze", request)
    status = wait(client, job_id)
    assert status["status"] == "failed"
    assert_error(status["error"], "result_too_large")
    assert "200" in status["error"]["message"]
    assert not list(tmp_path.glob("*.result.json"))


def test_the_job_store_keeps_to_its_disk_quota(tmp_path):
    client = app_client(tmp_path, max_job_store_bytes=1)
    status = wait(client, submit(client, "/v1/analyze", {"frame": SINGULAR_MOTION["frame"]}))
    assert_error(status["error"], "job_store_full")
    assert not list(tmp_path.glob("*.result.json"))
    # Now its status file alone passes the quota: the next job is refused at once.
    r = client.post("/v1/jobs", json={"endpoint": "/v1/analyze", "request": {"frame": SINGULAR_MOTION["frame"]}})
    assert r.status_code == 429
    assert_error(r.json()["detail"], "job_store_full")


def test_one_client_cannot_hold_every_job_slot(tmp_path):
    client = app_client(tmp_path, max_jobs_per_client=1, max_pending_jobs=4)
    slow = {"dim": 2, "cells": [30, 30], "poisson_ratio": -0.5}
    first = submit(client, "/v1/design/auxetic", slow)
    r = client.post("/v1/jobs", json={"endpoint": "/v1/design/auxetic", "request": AUXETIC})
    assert r.status_code == 429
    assert_error(r.json()["detail"], "too_many_jobs_for_client")
    # Another client (another API key) still gets a slot while the first job runs.
    other = client.post(
        "/v1/jobs", json={"endpoint": "/v1/design/auxetic", "request": AUXETIC}, headers={"x-api-key": "other"}
    )
    assert other.status_code == 202
    assert wait(client, first)["status"] == "done"
    assert wait(client, other.json()["id"])["status"] == "done"
