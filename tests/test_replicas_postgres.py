"""Service replicas on one PostgreSQL database, as docs/howto/dask.md tells users to
run them: the tests' own server on loopback (tests/postgres_server.py), real ``zeromode serve``
processes with their own embedded Dask clusters, one of them killed with -9 mid-sweep.

Independent routes: each replica is asked over HTTP, the store is read directly, and sampled
results are compared with the endpoint answering the same request in this process.
"""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import ExitStack, closing, contextmanager
from pathlib import Path

import httpx
import pytest
import sqlalchemy as sa
from client.conftest import loopback_socket, wait_for_health
from fastapi.testclient import TestClient
from test_jobs import without_timings
from test_sweeps import SLOW_POINTS, finish, get_from, wait_until_some_done

from zeromode.service.jobs.store import Store, jobs, metadata
from zeromode.service.rest.app import ENGINE_RETRY_FIRST_S, create_app
from zeromode.service.wire.settings import Settings

# A replica silent this long is taken for dead (ZEROMODE_JOB_LEASE_S; 20 s by default): short,
# so that the test waits seconds, not minutes, for the survivor to adopt.
LEASE_S = 3.0
# Both replicas up with running engines (embedded clusters on a busy 2-core machine) within this.
STARTUP_S = 90.0
# The whole sweep, adoption included, within this (the floor: 2 minutes for the test).
SWEEP_S = 90.0
# 40 points of ~0.2 s (one worker a replica): still running when 4 are done and the owner dies.
GRID = {**SLOW_POINTS, "poisson_ratio": SLOW_POINTS["poisson_ratio"][:20]}


@contextmanager
def replica(tmp_path: Path, name: str, database_url: str) -> Iterator[tuple[str, subprocess.Popen, Path]]:
    """`zeromode serve` in a process group of its own (its Dask workers die with it when the
    group is killed, as a container's would); (url, process, log)."""
    sock = loopback_socket()
    port = sock.getsockname()[1]
    sock.close()
    env = {**os.environ, "ZEROMODE_DATABASE_URL": database_url, "ZEROMODE_JOB_LEASE_S": str(LEASE_S),
           # A user's defaults (conftest.py turns offloading off for in-process apps); one worker each.
           "ZEROMODE_OFFLOAD": "true", "ZEROMODE_DASK_WORKERS": "1"}
    env.pop("ZEROMODE_DASK_SCHEDULER", None)
    log_path = tmp_path / f"{name}.log"
    with open(log_path, "w") as log:
        proc = subprocess.Popen([sys.executable, "-m", "zeromode.service.cli", "serve", "--port", str(port)],
                                env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        yield f"http://127.0.0.1:{port}", proc, log_path
    finally:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()


def wait_for_engine(url: str, proc: subprocess.Popen, log_path: Path, deadline: float) -> None:
    """/health until its engine is running (no request other than /health is sent: the start
    must not wait for one)."""
    wait_for_health(url, lambda: proc.poll() is None, log_path.read_text)
    while time.monotonic() < deadline:
        if httpx.get(f"{url}/health", timeout=10).json()["engine"] == "running":
            return
        assert proc.poll() is None, log_path.read_text()
        time.sleep(0.1)
    pytest.fail(f"the replica at {url} has no running engine:\n{log_path.read_text()}")


def test_tables_created_by_replicas_opening_together_exist_once(postgres):
    """Eight stores opened at the same moment on an empty database (the race replicas started
    together run): every one opens, and each table exists once."""
    url = postgres.new_database()
    barrier, errors, stores = threading.Barrier(8), [], []

    def open_store() -> None:
        barrier.wait()
        try:
            stores.append(Store(url))
        except Exception as exc:  # noqa: BLE001 — collected, asserted below
            errors.append(exc)

    threads = [threading.Thread(target=open_store) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == [] and len(stores) == 8
    with stores[0].db.connect() as conn:
        tables = conn.execute(sa.text(
            "SELECT tablename FROM pg_tables WHERE schemaname = 'public' ORDER BY tablename")).scalars().all()
        indexes = conn.execute(sa.text(
            "SELECT indexname FROM pg_indexes WHERE tablename = 'jobs' AND indexname <> 'jobs_pkey'")).scalars().all()
    assert tables == sorted(metadata.tables) and sorted(indexes) == sorted(i.name for i in jobs.indexes)
    for store in stores:
        store.close()


def test_an_engine_that_cannot_start_is_started_again_in_the_background(postgres, dask_scheduler, caplog):
    """The app's database does not exist at startup: the start fails, is logged, and is tried
    again without any request; once the database exists the engine runs. (Offloading off and
    nothing to adopt: on a shared database the engine starts all the same, to adopt a stopped
    replica's work later.)"""
    url = postgres.url("zm_later")
    app = create_app(Settings(database_url=url, dask_scheduler=dask_scheduler, offload=False))
    with caplog.at_level(logging.ERROR, logger="zeromode"), TestClient(app) as client:
        deadline = time.monotonic() + 30
        while "could not start (attempt 1)" not in caplog.text:
            assert time.monotonic() < deadline, "the failed start was not logged"
            time.sleep(0.05)
        assert client.get("/health").json()["engine"] == "idle"
        assert postgres.new_database("zm_later") == url
        # Retries after 1, 2, 4 ... s: found within the next waits.
        deadline = time.monotonic() + 30 * ENGINE_RETRY_FIRST_S
        while client.get("/health").json()["engine"] != "running":
            assert time.monotonic() < deadline, caplog.text
            time.sleep(0.1)


def test_two_replicas_started_together_share_a_sweep_and_the_survivor_adopts_the_killed_ones_work(
        tmp_path, postgres):
    """Two replicas started at the same moment on an empty database both come up with running
    engines (no lost table creation); a sweep submitted to one is seen by both; that one killed
    with -9 mid-sweep, the other adopts its unfinished points once its lease runs out: every
    point done, each recorded once, the results recorded before the kill unchanged."""
    database_url = postgres.new_database()
    with ExitStack() as stack:
        (url_a, proc_a, log_a), (url_b, proc_b, log_b) = (
            stack.enter_context(replica(tmp_path, name, database_url)) for name in ("a", "b"))
        deadline = time.monotonic() + STARTUP_S
        wait_for_engine(url_a, proc_a, log_a, deadline)
        wait_for_engine(url_b, proc_b, log_b, deadline)
        for log_path in (log_a, log_b):
            assert "could not start" not in log_path.read_text(), log_path.read_text()

        total = len(GRID["poisson_ratio"]) * len(GRID["cells"])
        body = {"endpoint": "/v1/design/auxetic", "template": {"dim": 2}, "grid": GRID}
        accepted = httpx.post(f"{url_a}/v1/sweeps", json=body, timeout=30)
        assert accepted.status_code == 202, accepted.text
        sweep_id = accepted.json()["id"]
        wait_until_some_done(url_b, sweep_id, 4)  # the other replica sees its progress
        os.killpg(proc_a.pid, signal.SIGKILL)  # the replica, its Dask scheduler and worker
        proc_a.wait()
        store = stack.enter_context(closing(Store(database_url)))
        before = {p["point"]: p for p in store.iter_sweep_points(sweep_id)}
        assert 4 <= len(before) < total

        status = finish(get_from(url_b), sweep_id, wait_s=SWEEP_S)
        points = list(store.iter_sweep_points(sweep_id))
    assert status["status"] == "done" and status["done"] == total, status
    assert sorted(r["point"] for r in status["results"]) == list(range(total))
    # Each point recorded once: the finishing order numbers 1 … total, none twice, none past it.
    assert sorted(p["seq"] for p in points) == list(range(1, total + 1))
    by_point = {p["point"]: p for p in points}
    changed = {k: (p["attempts"], by_point[k]["attempts"], by_point[k]["result"] == p["result"])
               for k, p in before.items() if by_point[k]["result"] != p["result"] or by_point[k]["attempts"] != 1}
    assert not changed, (changed, log_a.read_text()[-3000:], log_b.read_text()[-3000:])
    # The survivor ran exactly the rest: every point unfinished at the kill, on its second attempt.
    adopted = [p for p in points if p["point"] not in before]
    assert adopted and all(p["attempts"] == 2 for p in adopted)
    # Results as the endpoint itself answers them: one from before the kill, some adopted.
    direct = TestClient(create_app())
    for p in [next(iter(before.values())), *adopted[:3]]:
        answer = direct.post("/v1/design/auxetic", json={"dim": 2, **p["params"]})
        assert answer.status_code == 200
        assert without_timings(p["result"]) == without_timings(answer.json())
