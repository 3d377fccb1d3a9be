"""A running job stops at its time budget and on DELETE, even inside one long library call
(issue #18): its worker process is restarted, seen from the Dask cluster itself (the pids of its
workers), on the session's real LocalCluster (``dask_scheduler`` in conftest.py).

The long call is one LAPACK SVD: the dense analysis of a 1 500-node ladder (a 3 000 × 3 000
compatibility matrix, 15-40 s on one core), which checks no budget while it runs.
"""

from __future__ import annotations

import os
import time
from datetime import datetime

import pytest
from test_jobs import app_client

from benchmarks.bench_offload import big_frame

LONG = {"frame": big_frame(1_500), "options": {"method": "dense"}}
BUDGET_S = 4.0
POLL_S = 0.02


def worker_pids(scheduler: str) -> set[int]:
    """Process ids of the cluster's workers, asked of the workers themselves."""
    from distributed import Client

    with Client(scheduler, set_as_default=False, timeout=30) as client:
        return set(client.run(os.getpid).values())


def submitted(client, request: dict) -> str:
    r = client.post("/v1/jobs", json={"endpoint": "/v1/analyze", "request": request})
    assert r.status_code == 202, r.text
    return r.json()["id"]


def until(client, job_id: str, states: tuple[str, ...], wait_s: float = 60.0) -> tuple[dict, float, float]:
    """The job's status once it is in one of ``states``, when the poll that saw it answered, and
    when the last poll that still saw it in another state was sent (``-inf`` if none): the job
    left that state after the last of these, whatever the polls' own latency on a busy machine."""
    deadline = time.monotonic() + wait_s
    still_before = float("-inf")
    while time.monotonic() < deadline:
        sent = time.monotonic()
        status = client.get(f"/v1/jobs/{job_id}").json()
        if status["status"] in states:
            return status, time.monotonic(), still_before
        still_before = sent
        time.sleep(POLL_S)
    pytest.fail(f"job {job_id} never reached {states}: {status}")


def restarted(scheduler: str, before: set[int], wait_s: float = 240.0) -> set[int]:
    """The worker pids once one of ``before`` has been replaced (its worker restarted). The wait
    is generous because a restarted worker process starts Python, Dask and the kernels again:
    90 s was exceeded once at load 9 (a full suite beside six other sessions)."""
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline:
        try:
            now = worker_pids(scheduler)
        except OSError:  # a worker closing while it is asked (CommClosedError): ask again
            time.sleep(0.2)
            continue
        if now - before and len(now) == len(before):
            return now
        time.sleep(0.2)
    pytest.fail("no worker was restarted")


def test_a_running_job_is_stopped_at_its_budget(tmp_path, dask_scheduler):
    """Failed too_expensive within 10 % of the job budget from the moment it was seen running,
    by the engine's watchdog (the worker's own check never runs inside the SVD); the worker is
    restarted and the next job runs."""
    before = worker_pids(dask_scheduler)
    with app_client(tmp_path, dask_scheduler, job_time_budget_s=BUDGET_S) as client:
        job_id = submitted(client, LONG)
        _, seen_running, _ = until(client, job_id, ("running",))
        status, _, still_running = until(client, job_id, ("done", "failed", "cancelled"))
        assert status["status"] == "failed" and status["error"]["code"] == "too_expensive", status
        assert "was stopped" in status["error"]["message"] and f"{BUDGET_S:g} s" in status["error"]["message"]
        # It ran at least from the answer that first showed it running to the sending of the last
        # poll that still did: a lower bound on its run that no polling latency inflates (an
        # upper bound taken at the failed poll's answer read 4.5 s once at CI load).
        assert still_running - seen_running <= 1.1 * BUDGET_S, still_running - seen_running
        recorded = datetime.fromisoformat(status["finished"]) - datetime.fromisoformat(status["started"])
        assert recorded.total_seconds() <= 1.1 * BUDGET_S, recorded
        restarted(dask_scheduler, before)
        small = {"frame": big_frame(20), "options": {"method": "dense"}}
        after, _, _ = until(client, submitted(client, small), ("done", "failed"))
        assert after["status"] == "done" and after["result"]["nodes"] == 20
        assert client.get(f"/v1/jobs/{job_id}").json()["status"] == "failed"  # the stop is not recorded over it


def test_delete_stops_a_running_job(tmp_path, dask_scheduler):
    """DELETE of a running job answers it cancelled at once and restarts the worker computing it;
    the job stays cancelled (the stopped task's end is not recorded over it)."""
    before = worker_pids(dask_scheduler)
    with app_client(tmp_path, dask_scheduler, job_time_budget_s=600.0) as client:
        job_id = submitted(client, LONG)
        until(client, job_id, ("running",))
        t0 = time.monotonic()
        answer = client.delete(f"/v1/jobs/{job_id}")
        # "At once": long before the job would end (its budget is 600 s); 1.14 s of wall clock
        # was seen at load 12, so the bound leaves room for a loaded machine.
        assert time.monotonic() - t0 < 5.0
        assert answer.status_code == 200 and answer.json()["status"] == "cancelled", answer.text
        assert answer.json()["error"]["code"] == "cancelled"
        restarted(dask_scheduler, before)
        time.sleep(1.0)
        assert client.get(f"/v1/jobs/{job_id}").json()["status"] == "cancelled"
        assert client.get("/v1/engine").json()["processing"] == 0


def test_a_heavy_sweep_point_is_stopped_at_its_budget_and_its_neighbours_finish(tmp_path, dask_scheduler):
    """Heavy sweep points run one per Dask task, so the watchdog stops the one that overruns
    (failed too_expensive within 10 % of the budget) while the points around it are answered."""
    small = {"frame": big_frame(20), "options": {"method": "dense"}}
    with app_client(tmp_path, dask_scheduler, job_time_budget_s=BUDGET_S) as client:
        r = client.post("/v1/sweeps", json={"endpoint": "/v1/analyze", "template": {},
                                            "requests": [small, LONG, small]})
        assert r.status_code == 202, r.text
        sweep_id = r.json()["id"]
        deadline = time.monotonic() + 120
        while (status := client.get(f"/v1/sweeps/{sweep_id}").json())["status"] == "running":
            assert time.monotonic() < deadline, status
            time.sleep(0.1)
        by_point = {p["point"]: p for p in status["results"]}
        assert [by_point[i]["status"] for i in range(3)] == ["done", "failed", "done"], status
        assert by_point[0]["result"]["nodes"] == by_point[2]["result"]["nodes"] == 20
        assert by_point[1]["error"]["code"] == "too_expensive" and "was stopped" in by_point[1]["error"]["message"]
        record = client.app.state.jobs.store.sweep_points(sweep_id, limit=10)
        long_point = next(p for p in record if p["point"] == 1)
        assert long_point["finished"] - long_point["started"] <= 1.1 * BUDGET_S, long_point
