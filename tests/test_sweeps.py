"""Sweeps: POST /v1/sweeps and its reads, the library's ``sweep``, the CLI and the client, on
real Dask clusters; nothing lost when a worker or the service is killed.

Results are checked against the endpoints called directly, one request each (the independent
route); tables against the answers they were read from.
"""

from __future__ import annotations

import asyncio
import csv
import io
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import pyarrow.parquet as pq
import pytest
from client.conftest import loopback_socket, wait_for_health
from fastapi.testclient import TestClient
from test_jobs import app_client, without_timings

from zeromode.service.jobs.sweeps import sweep
from zeromode.service.rest.app import create_app
from zeromode.service.wire.settings import Settings
from zeromode_client import SweepProgress

AUXETIC = {"dim": 2, "cells": [3, 3]}
GRID = {"poisson_ratio": [-0.2, -0.5, -0.8], "cells": [[2, 2], [3, 3]]}
# Enough work (~0.2 s a point) that a sweep is still running when something is killed.
SLOW_POINTS = {"poisson_ratio": [-0.3 - 0.01 * i for i in range(30)], "cells": [[24, 24], [20, 20]]}
WAIT_S = 120.0


@pytest.fixture
def client(tmp_path: Path, dask_scheduler: str, database_url: str) -> Iterator[TestClient]:
    """An app on a SQLite file, then on a PostgreSQL database (conftest.py)."""
    with app_client(tmp_path, dask_scheduler, database_url=database_url) as c:
        yield c


def finish(get, sweep_id: str, wait_s: float = WAIT_S) -> dict:
    """Poll GET /v1/sweeps/{id} (``get(path)``) until the sweep ends, reading every page of
    results; its last status with all results in ``results``. The counts never fall."""
    deadline = time.monotonic() + wait_s
    after, results, ended = 0, [], 0
    while time.monotonic() < deadline:
        status = get(f"/v1/sweeps/{sweep_id}?after={after}&limit=7").json()
        now_ended = status["done"] + status["failed"] + status["cancelled"] + status["interrupted"]
        assert now_ended >= ended and status["total"] == sum(
            status[k] for k in ("done", "failed", "running", "queued", "cancelled", "interrupted"))
        ended = now_ended
        results += status["results"]
        after = status["next"]
        if status["status"] != "running" and len(status["results"]) < 7:
            return {**status, "results": results}
        if len(status["results"]) < 7:
            time.sleep(0.05)
    pytest.fail(f"sweep {sweep_id} did not finish within {wait_s} s")


def submit(client, body: dict) -> dict:
    r = client.post("/v1/sweeps", json=body)
    assert r.status_code == 202, r.text
    assert r.headers["location"] == f"/v1/sweeps/{r.json()['id']}"
    return r.json()


def test_a_grid_sweep_runs_every_point_as_the_endpoint_answers_it(client):
    accepted = submit(client, {"endpoint": "/v1/design/auxetic", "template": AUXETIC, "grid": GRID})
    assert accepted["total"] == 6 and accepted["status"] == "running"
    status = finish(client.get, accepted["id"])
    assert status["status"] == "done" and status["done"] == 6 and status["progress"] == 1.0
    results = status["results"]
    assert sorted(r["seq"] for r in results) == list(range(1, 7))  # each point once, paged in order
    by_point = {r["point"]: r for r in results}
    # The grid's order: the last key varies fastest.
    assert [by_point[i]["params"] for i in range(6)] == [
        {"poisson_ratio": nu, "cells": cells} for nu in GRID["poisson_ratio"] for cells in GRID["cells"]
    ]
    for point in (0, 5):
        direct = client.post("/v1/design/auxetic", json={**AUXETIC, **by_point[point]["params"]})
        assert direct.status_code == 200
        assert without_timings(by_point[point]["result"]) == without_timings(direct.json())


def test_sweep_results_download_as_ndjson_csv_and_parquet(client):
    sweep_id = submit(client, {"endpoint": "/v1/design/auxetic", "template": AUXETIC, "grid": GRID})["id"]
    results = {r["point"]: r for r in finish(client.get, sweep_id)["results"]}
    lines = client.get(f"/v1/sweeps/{sweep_id}/results.ndjson")
    assert lines.headers["content-type"].startswith("application/x-ndjson")
    docs = [json.loads(line) for line in lines.text.splitlines()]
    assert sorted(d["point"] for d in docs) == list(range(6))
    for d in docs:
        assert d["result"] == results[d["point"]]["result"] and d["status"] == "done"
    table = list(csv.DictReader(io.StringIO(client.get(f"/v1/sweeps/{sweep_id}/results.csv").text)))
    assert [int(r["point"]) for r in table] == list(range(6))
    for r in table:
        answer = results[int(r["point"])]
        assert float(r["param.poisson_ratio"]) == answer["params"]["poisson_ratio"]
        assert json.loads(r["param.cells"]) == answer["params"]["cells"]
        assert float(r["poisson_ratio"]) == answer["result"]["poisson_ratio"]
        assert int(r["report.analysis.nontrivial_zero_modes"]) == answer["result"]["report"]["analysis"]["nontrivial_zero_modes"] == 1
    parquet = pq.read_table(io.BytesIO(client.get(f"/v1/sweeps/{sweep_id}/results.parquet").content)).to_pylist()
    assert [p["point"] for p in parquet] == list(range(6))
    assert [p["report.analysis.rank"] for p in parquet] == [int(r["report.analysis.rank"]) for r in table]


def test_a_list_of_requests_is_a_sweep_merged_over_the_template(client):
    requests = [{"poisson_ratio": -0.4}, {"poisson_ratio": -0.6, "cells": [2, 2]}]
    sweep_id = submit(client, {"endpoint": "/v1/design/auxetic", "template": AUXETIC, "requests": requests})["id"]
    results = sorted(finish(client.get, sweep_id)["results"], key=lambda r: r["point"])
    assert [r["params"] for r in results] == requests
    assert [len(r["result"]["frame"]["positions"]) for r in results] == [
        len(client.post("/v1/design/auxetic", json={**AUXETIC, **q}).json()["frame"]["positions"]) for q in requests
    ]


@pytest.mark.parametrize(
    ("body", "code", "words"),
    [
        ({"grid": {"poisson_ratio": [-0.5, "x"]}}, "invalid_point", "point 1 (poisson_ratio=\"x\")"),
        ({"grid": {"poisson_ratio": [-0.5, 0.0]}}, "invalid_point", "point 1 (poisson_ratio=0.0)"),
        ({"grid": {"cells": [[4, 4], [0, 40]]}}, "invalid_point", "point 1 (cells=[0, 40])"),
        ({"grid": {"options.seeed": [1]}}, "invalid_point", "point 0"),
        ({"grid": {"poisson_ratio": list(range(101)), "cells": [[2, 2]] * 100}}, "too_many_points", "10100 points"),
        ({"grid": {"poisson_ratio": []}}, "invalid_sweep", "grid.poisson_ratio"),
        ({"grid": {"poisson_ratio": [-0.5]}, "requests": [{}]}, "invalid_sweep", "not both"),
    ],
)
def test_a_bad_point_is_refused_at_submit_naming_it(tmp_path, dask_scheduler, body, code, words):
    with app_client(tmp_path, dask_scheduler, max_sweep_points=10_000) as client:
        template = {"dim": 2, "cells": [4, 4], "poisson_ratio": -0.5}
        r = client.post("/v1/sweeps", json={"endpoint": "/v1/design/auxetic", "template": template, **body})
        assert r.status_code == 422, r.text
        detail = r.json()["detail"]
        assert detail["code"] == code and words in detail["message"], detail
        if code == "invalid_point":
            assert detail["error"]["code"] and detail["point"] in (0, 1)
        assert app_jobs(client).store.unfinished() == 0  # nothing recorded, nothing runs


def app_jobs(client: TestClient):
    return client.app.state.jobs or _open(client)


def _open(client: TestClient):
    from zeromode.service.jobs.manager import jobs_of_app

    return jobs_of_app(client.app.state)


def test_unknown_sweeps_are_a_404_and_cancel_stops_what_has_not_run(client):
    assert client.get(f"/v1/sweeps/{'0' * 32}").json()["detail"]["code"] == "unknown_sweep"
    assert client.get(f"/v1/sweeps/{'0' * 32}/results.csv").status_code == 404
    sweep_id = submit(client, {"endpoint": "/v1/design/auxetic", "template": {"dim": 2}, "grid": SLOW_POINTS})["id"]
    time.sleep(0.5)
    cancelled = client.delete(f"/v1/sweeps/{sweep_id}")
    assert cancelled.status_code == 200
    status = finish(client.get, sweep_id)
    assert status["status"] == "cancelled"
    assert status["cancelled"] > 0 and status["done"] + status["cancelled"] + status["failed"] == status["total"]
    assert all(r["status"] in ("done", "cancelled") for r in status["results"])
    assert all(r["error"]["code"] == "cancelled" for r in status["results"] if r["status"] == "cancelled")


def test_the_library_sweep_returns_a_dataframe_without_any_server(dask_scheduler):
    """``sweep`` on the session's cluster: one row per point in point order, the scalar fields
    of each answer equal to the endpoint's own answer."""
    seen = []
    table = sweep("/v1/design/auxetic", AUXETIC, GRID, scheduler=dask_scheduler, on_progress=seen.append)
    assert list(table["point"]) == list(range(6)) and set(table["status"]) == {"done"}
    assert [(s.done, s.failed, s.total) for s in seen] == [(k, 0, 6) for k in range(1, 7)]
    assert [s.elapsed for s in seen] == sorted(s.elapsed for s in seen) and seen[0].elapsed > 0
    assert repr(seen[-1]) == f"SweepProgress(done=6, failed=0, total=6, elapsed={seen[-1].elapsed:.1f})"
    direct = TestClient(create_app()).post("/v1/design/auxetic", json={**AUXETIC, "poisson_ratio": -0.8, "cells": [3, 3]})
    last = table.iloc[5]
    assert last["param.poisson_ratio"] == -0.8
    assert last["report.mode_residual"] == direct.json()["report"]["mode_residual"]


def test_the_library_sweep_starts_its_own_cluster_when_given_none():
    table = sweep("/v1/analyze", {"frame": {"dim": 2, "positions": [[0, 0], [1, 0], [0, 1]], "edges": [[0, 1], [1, 2]]}},
                  {"frame.edges": [[[0, 1], [1, 2]], [[0, 1], [1, 2], [0, 2]]]},
                  settings=Settings(dask_workers=1))
    assert list(table["nontrivial_zero_modes"]) == [1, 0]  # a hinge, then a triangle


# --- real processes: a dask scheduler, dask workers, the service, killed ---------------------


@contextmanager
def dask_processes(tmp_path: Path, workers: int = 2) -> Iterator[tuple[str, list[subprocess.Popen]]]:
    """`dask scheduler` and `dask worker` processes on loopback; (address, worker processes)."""
    scheduler_file = tmp_path / "scheduler.json"
    dask = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    log = open(tmp_path / "dask.log", "w")  # noqa: SIM115 — closed below
    procs = [subprocess.Popen([*dask, "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                               "--scheduler-file", str(scheduler_file)], stdout=log, stderr=subprocess.STDOUT, env=env)]
    try:
        deadline = time.monotonic() + 60
        while not scheduler_file.exists() or not scheduler_file.read_text().strip():
            assert time.monotonic() < deadline, (tmp_path / "dask.log").read_text()
            time.sleep(0.1)
        address = json.loads(scheduler_file.read_text())["address"]
        worker = [sys.executable, "-m", "distributed.cli.dask_worker", "--scheduler-file", str(scheduler_file),
                  "--nthreads", "1", "--no-nanny", "--no-dashboard", "--host", "127.0.0.1"]
        procs += [subprocess.Popen([*worker, "--name", f"w{i}"], stdout=log, stderr=subprocess.STDOUT, env=env)
                  for i in range(workers)]
        from distributed import Client

        with Client(address, timeout=30) as c:
            c.wait_for_workers(workers, timeout=60)
        yield address, procs[1:]
    finally:
        for p in procs:
            p.kill()
            p.wait()
        log.close()


@contextmanager
def zeromode_service(tmp_path: Path, env: dict[str, str], name: str) -> Iterator[tuple[str, subprocess.Popen]]:
    """`zeromode serve` as its own process (killable with -9)."""
    sock = loopback_socket()
    port = sock.getsockname()[1]
    sock.close()
    log_path = tmp_path / f"{name}.log"
    with open(log_path, "w") as log:
        proc = subprocess.Popen([sys.executable, "-m", "zeromode.service.cli", "serve", "--port", str(port)],
                                env={**os.environ, **env}, stdout=log, stderr=subprocess.STDOUT)
    url = f"http://127.0.0.1:{port}"
    try:
        wait_for_health(url, lambda: proc.poll() is None, log_path.read_text)
        yield url, proc
    finally:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                # A graceful stop closes the embedded Dask cluster's worker processes, which took
                # over 30 s at load 12; the fixture's job is to leave nothing running, not to time it.
                proc.kill()
                proc.wait(timeout=30)


def get_from(url: str):
    return lambda path: httpx.get(url + path, timeout=30)


def wait_until_some_done(url: str, sweep_id: str, at_least: int) -> dict:
    deadline = time.monotonic() + WAIT_S
    while time.monotonic() < deadline:
        status = httpx.get(f"{url}/v1/sweeps/{sweep_id}?limit=0", timeout=30).json()
        if status["done"] >= at_least:
            assert status["status"] == "running", "the sweep ended before anything could be killed"
            return status
        time.sleep(0.05)
    pytest.fail("the sweep made no progress")


def test_a_killed_worker_loses_no_point_and_runs_none_twice(tmp_path):
    """The service on a `dask scheduler` with two `dask worker` processes; one worker is killed
    (-9) mid-sweep: every point still completes, each recorded exactly once."""
    with dask_processes(tmp_path) as (address, workers):
        env = {"ZEROMODE_DATABASE_URL": f"sqlite:///{tmp_path}/jobs.sqlite3", "ZEROMODE_DASK_SCHEDULER": address}
        with zeromode_service(tmp_path, env, "service") as (url, _):
            total = len(SLOW_POINTS["poisson_ratio"]) * len(SLOW_POINTS["cells"])
            body = {"endpoint": "/v1/design/auxetic", "template": {"dim": 2}, "grid": SLOW_POINTS}
            sweep_id = httpx.post(f"{url}/v1/sweeps", json=body, timeout=30).json()["id"]
            wait_until_some_done(url, sweep_id, 4)
            workers[0].kill()
            status = finish(get_from(url), sweep_id)
    assert status["status"] == "done" and status["done"] == total, status
    assert sorted(r["point"] for r in status["results"]) == list(range(total))
    assert sorted(r["seq"] for r in status["results"]) == list(range(1, total + 1))


def test_a_service_killed_mid_sweep_keeps_its_results_and_its_successor_finishes_the_rest(tmp_path):
    """kill -9 of the service mid-sweep: every result recorded before is there, unchanged,
    after the restart; the unfinished points are resubmitted by the new instance once the dead
    one's lease runs out (attempt 2) and complete."""
    with dask_processes(tmp_path) as (address, _):
        env = {"ZEROMODE_DATABASE_URL": f"sqlite:///{tmp_path}/jobs.sqlite3", "ZEROMODE_DASK_SCHEDULER": address,
               "ZEROMODE_JOB_LEASE_S": "2"}
        grid = {**SLOW_POINTS, "cells": [[24, 24], [20, 20], [22, 22]]}  # 90 points: time to kill it
        total = len(grid["poisson_ratio"]) * len(grid["cells"])
        with zeromode_service(tmp_path, env, "first") as (url, proc):
            body = {"endpoint": "/v1/design/auxetic", "template": {"dim": 2}, "grid": grid}
            sweep_id = httpx.post(f"{url}/v1/sweeps", json=body, timeout=30).json()["id"]
            wait_until_some_done(url, sweep_id, 4)
            os.kill(proc.pid, signal.SIGKILL)
            proc.wait()
        from zeromode.service.jobs.store import Store

        # What the killed service had recorded, read from its database.
        before = {p["point"]: p for p in Store(env["ZEROMODE_DATABASE_URL"]).iter_sweep_points(sweep_id)}
        assert 4 <= len(before) < total
        with zeromode_service(tmp_path, env, "second") as (url, _):
            status = finish(get_from(url), sweep_id)
            after = {json.loads(line)["point"]: json.loads(line)
                     for line in httpx.get(f"{url}/v1/sweeps/{sweep_id}/results.ndjson", timeout=30).text.splitlines()}
    assert status["status"] == "done" and status["done"] == total, status
    # Nothing recorded was lost or rewritten.
    assert all(after[p]["result"] == record["result"] and after[p]["params"] == record["params"]
               for p, record in before.items())
    attempts = {p["point"]: p["attempts"] for p in Store(env["ZEROMODE_DATABASE_URL"]).iter_sweep_points(sweep_id)}
    assert all(attempts[p] == 1 for p in before)
    assert any(a == 2 for a in attempts.values())  # the rest ran again under the new instance


async def async_sweep(url: str) -> tuple[list, list]:
    """The AsyncClient's sweep of a hinge and a triangle: (points, progress values)."""
    from zeromode_client import AsyncClient

    progress = []
    async with AsyncClient(url) as zm:
        template = {"frame": {"dim": 2, "positions": [[0, 0], [1, 0], [0, 1]], "edges": [[0, 1], [1, 2]]}}
        grid = {"frame.edges": [[[0, 1], [1, 2]], [[0, 1], [1, 2], [0, 2]]]}
        points = [p async for p in zm.sweep("/v1/analyze", template, grid, on_progress=progress.append, poll=0.05)]
    return points, progress


def test_the_cli_and_the_client_run_sweeps_against_a_live_service(tmp_path, dask_scheduler):
    from client.conftest import served

    from zeromode_client import Client

    settings = Settings(database_url=f"sqlite:///{tmp_path}/jobs.sqlite3", dask_scheduler=dask_scheduler)
    with served(create_app(settings)) as url:
        with Client(url) as zm:
            progress = []
            points = list(zm.sweep("/v1/design/auxetic", AUXETIC, GRID, on_progress=progress.append, poll=0.05))
            assert sorted(p.point for p in points) == list(range(6))
            assert all(p.status == "done" and p.result.path == "/v1/design/auxetic" for p in points)
            assert [s.done for s in progress] == sorted(s.done for s in progress)
            assert (progress[-1].done, progress[-1].failed, progress[-1].total) == (6, 0, 6)
            # The counts and the time only, never the results: print() of one is a short line.
            assert all(len(repr(s)) < 80 for s in progress) and [s.elapsed for s in progress] == sorted(s.elapsed for s in progress)
            sweep_id = zm.submit_sweep("/v1/design/auxetic", AUXETIC, GRID)
            while not zm.sweep_status(sweep_id, limit=0).finished_running:
                time.sleep(0.05)
            table = list(csv.DictReader(io.StringIO(zm.sweep_results(sweep_id, "csv").decode())))
            assert len(table) == 6
        async_points, async_progress = asyncio.run(async_sweep(url))
        assert sorted(p.point for p in async_points) == [0, 1]
        assert all(isinstance(s, SweepProgress) for s in async_progress)
        assert (async_progress[-1].done, async_progress[-1].total) == (2, 2)
        grid = tmp_path / "grid.json"
        grid.write_text(json.dumps({"endpoint": "/v1/design/auxetic", "template": AUXETIC, "grid": GRID}))
        for where in (["--url", url, "--poll", "0.05"], ["--scheduler", dask_scheduler]):
            out, table_path = tmp_path / "points.ndjson", tmp_path / "table.csv"
            run = subprocess.run([sys.executable, "-m", "zeromode.service.cli", "sweep", str(grid), "-o", str(out),
                                  "--table", str(table_path), *where], capture_output=True, timeout=120, check=False)
            assert run.returncode == 0, run.stderr.decode()
            docs = [json.loads(line) for line in out.read_text().splitlines()]
            assert [d["point"] for d in docs] == list(range(6)) and all(d["status"] == "done" for d in docs)
            assert "6 points: 6 done" in run.stderr.decode() and "100%" in run.stderr.decode()
            assert len(list(csv.DictReader(table_path.open()))) == 6


def test_a_large_sweep_is_validated_on_the_workers_with_the_same_refusal(tmp_path, dask_scheduler):
    """From 64 points a running engine's workers validate the sweep: the refusal is the one the
    service itself gives (the lowest bad point, the endpoint's own error), and it uses the app's
    settings, not the workers' environment."""
    from zeromode.service.jobs.sweeps import SweepRefused, points, validate_points

    template = {"dim": 2, "cells": [4, 4]}
    grid = {"poisson_ratio": [-0.3 - 0.001 * i for i in range(100)]}
    grid["poisson_ratio"][70], grid["poisson_ratio"][90] = 0.0, 0.0
    with app_client(tmp_path, dask_scheduler, max_sweep_points=500) as client:
        finish(client.get, submit(client, {"endpoint": "/v1/design/auxetic", "template": AUXETIC, "grid": GRID})["id"])
        assert client.app.state.jobs.engine.started
        r = client.post("/v1/sweeps", json={"endpoint": "/v1/design/auxetic", "template": template, "grid": grid})
        assert r.status_code == 422, r.text
        with pytest.raises(SweepRefused) as local:
            validate_points("/v1/design/auxetic", points(template, grid, None, 500))
        assert r.json()["detail"] == local.value.detail and local.value.detail["point"] == 70
    two = {"frame": {"dim": 2, "positions": [[0, 0], [1, 0]], "edges": [[0, 1]]}}
    with app_client(tmp_path, dask_scheduler, max_nodes=2) as client:
        finish(client.get, submit(client, {"endpoint": "/v1/analyze", "template": two})["id"])
        three = {"frame": {**two["frame"], "positions": [[0, 0], [1, 0], [0, 1]]}}
        r = client.post("/v1/sweeps", json={"endpoint": "/v1/analyze", "template": three,
                                            "grid": {"options.bases": [True, False] * 40}})
        assert r.status_code == 422 and r.json()["detail"]["point"] == 0, r.text
        assert "max_nodes" in r.json()["detail"]["message"]
