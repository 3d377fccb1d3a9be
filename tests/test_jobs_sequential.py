"""POST /v1/map and POST /v1/design/sequential as jobs and sweeps (issue #41 item 3), on the real
uvicorn server and the session's real Dask cluster, and through the ``zeromode`` command.

Independent routes: a job's result is the synchronous route's body (timings aside); the map
points a sweep answers are checked against a scipy oracle written here from the definition (the
module's bar lengths kept and |x_a − x_b| = d_in, solved by least squares along d_in from the
reference, nothing of solver/sequential), and a designed module's features against the same
oracle; a request the solver refuses up front is refused at POST /v1/jobs (and at POST
/v1/sweeps, naming the point) with the synchronous route's own body.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import httpx
import numpy as np
import pytest
from client.conftest import served
from scipy.optimize import least_squares
from test_jobs import without_timings

from zeromode.service.rest.app import create_app
from zeromode.service.wire.settings import Settings
from zeromode.solver.progress import progress_scope

ZEROMODE = str(Path(sys.executable).with_name("zeromode"))  # the console script pip installed
EDGES = [[0, 2], [0, 4], [2, 4], [1, 3], [1, 4], [3, 4]]
PAIRS = {"input_pair": [0, 1], "output_pair": [2, 3]}
# Two-triangle modules (two rigid triangles hinged at node 4) with different hinges and outputs.
MODULES = [
    [[-1.0, 0.0], [1.0, 0.0], [-0.8, 1.0], [0.8, 1.0], [0.15, 0.45]],
    [[-1.0, 0.0], [1.0, 0.0], [-0.7, 1.1], [0.9, 0.9], [0.0, 0.5]],
    [[-1.0, 0.0], [1.0, 0.0], [-0.6, 1.2], [0.6, 1.2], [-0.2, 0.4]],
]
AT = [0.8, 1.4, 2.0]  # inside each module's usable range (between its folds)
DEPLOYABLE = {"features": [{"kind": "fixed_point", "d": 1.2, "slope": 1.8},
                           {"kind": "fixed_point", "d": 1.8, "slope": 0.4}],
              "chain": {"n_modules": 6, "d0": 1.21}}
WAIT_S = 300.0
FINISHED = ("done", "failed", "cancelled", "interrupted")


def map_request(positions, at=AT) -> dict:
    return {"frame": {"dim": 2, "positions": positions, "edges": EDGES}, **PAIRS, "at": at}


def oracle_configuration(positions, edges, pair, d: float, steps: int = 40) -> np.ndarray:
    """The module's configuration with every bar length of ``positions`` kept and the distance
    across ``pair`` equal to d, by least squares (scipy) stepped along the input distance from
    the reference (so on the branch through it), rigid motions fixed by three linear rows."""
    x0 = np.asarray(positions, dtype=float)
    e = np.asarray(edges)
    lengths = np.linalg.norm(x0[e[:, 0]] - x0[e[:, 1]], axis=1)
    centred = x0 - x0.mean(axis=0)
    a, b = pair

    def residual(flat, target):
        x = flat.reshape(x0.shape)
        u = x - x0
        return np.concatenate([
            np.linalg.norm(x[e[:, 0]] - x[e[:, 1]], axis=1) - lengths,
            [np.linalg.norm(x[a] - x[b]) - target],
            [u[:, 0].sum(), u[:, 1].sum(), np.sum(centred[:, 0] * u[:, 1] - centred[:, 1] * u[:, 0])],
        ])

    x = x0.ravel()
    for target in np.linspace(np.linalg.norm(x0[a] - x0[b]), d, steps + 1)[1:]:
        x = least_squares(residual, x, args=(target,), xtol=1e-15, ftol=1e-15, gtol=1e-15).x
    assert np.max(np.abs(residual(x, d))) < 1e-12
    return x.reshape(x0.shape)


def oracle_map(positions, d: float, edges=EDGES, input_pair=(0, 1), output_pair=(2, 3)) -> float:
    """d_out at d_in = d by the oracle."""
    y = oracle_configuration(positions, edges, input_pair, d)
    c, e = output_pair
    return float(np.linalg.norm(y[c] - y[e]))


def oracle_slope(positions, d: float, h: float = 1e-5) -> float:
    """f′(d) by a central difference of the oracle (truncation ~h² f‴)."""
    return (oracle_map(positions, d + h) - oracle_map(positions, d - h)) / (2 * h)


@pytest.fixture(scope="module")
def service_url(tmp_path_factory: pytest.TempPathFactory, dask_scheduler: str):
    """The app on the session's Dask cluster, served by a real uvicorn on loopback."""
    tmp = tmp_path_factory.mktemp("jobs_sequential")
    app = create_app(Settings(dask_scheduler=dask_scheduler, database_url=f"sqlite:///{tmp}/jobs.sqlite3"))
    with served(app) as url:
        yield url


@pytest.fixture
def service(service_url: str):
    with httpx.Client(base_url=service_url, timeout=WAIT_S) as http:
        yield http


def wait_job(http: httpx.Client, job_id: str) -> dict:
    deadline = time.monotonic() + WAIT_S
    progress = []
    while time.monotonic() < deadline:
        status = http.get(f"/v1/jobs/{job_id}").json()
        progress.append(status["progress"])
        if status["status"] in FINISHED:
            assert progress == sorted(progress)
            return status
        time.sleep(0.05)
    pytest.fail(f"job {job_id} did not finish within {WAIT_S} s")


def test_map_and_sequential_jobs_answer_as_their_routes(service: httpx.Client) -> None:
    jobs = {}
    for endpoint, request in (("/v1/map", map_request(MODULES[0])), ("/v1/design/sequential", DEPLOYABLE)):
        r = service.post("/v1/jobs", json={"endpoint": endpoint, "request": request})
        assert r.status_code == 202, r.text
        jobs[endpoint] = (r.json()["id"], request)
    for endpoint, (job_id, request) in jobs.items():
        status = wait_job(service, job_id)
        assert status["status"] == "done" and status["progress"] == 1.0, status
        direct = service.post(endpoint, json=request)
        assert direct.status_code == 200, direct.text
        assert without_timings(status["result"]) == without_timings(direct.json())
    # The sequential job's chain: six copies, its conformation the orbit within map_rtol.
    chain = status["result"]["chain"]
    assert len(chain["pairs"]) == 7 and chain["deviation"] <= status["result"]["map_rtol"]


def test_a_map_sweep_over_modules_agrees_with_the_scipy_oracle(service: httpx.Client) -> None:
    r = service.post("/v1/sweeps", json={
        "endpoint": "/v1/map", "template": map_request(MODULES[0]),
        "requests": [{"frame": {"dim": 2, "positions": p, "edges": EDGES}} for p in MODULES],
    })
    assert r.status_code == 202, r.text
    sweep_id, deadline = r.json()["id"], time.monotonic() + WAIT_S
    while (status := service.get(f"/v1/sweeps/{sweep_id}?limit=100").json())["status"] == "running":
        assert time.monotonic() < deadline
        time.sleep(0.1)
    assert status["status"] == "done" and status["done"] == len(MODULES), status
    points = sorted(status["results"], key=lambda p: p["point"])
    assert [p["status"] for p in points] == ["done"] * len(MODULES)
    for positions, point in zip(MODULES, points, strict=True):
        evaluated = point["result"]["evaluated"]
        assert [e["d_in"] for e in evaluated] == AT
        for e in evaluated:
            assert e["d_out"] == pytest.approx(oracle_map(positions, e["d_in"]), rel=1e-9)
            assert e["slope"] == pytest.approx(oracle_slope(positions, e["d_in"]), rel=1e-6)
        # The samples too: a few of them, spread over the usable range (away from its folds).
        body = point["result"]
        for k in np.linspace(0.1 * len(body["d_in"]), 0.9 * len(body["d_in"]), 5).astype(int):
            assert body["d_out"][k] == pytest.approx(oracle_map(positions, body["d_in"][k]), rel=1e-8)


def start_module(n: int) -> dict:
    """A start module of n nodes: a zig-zag strip (only its size matters to the refusal)."""
    positions = [[float(i), float(i % 2)] for i in range(n)]
    edges = [[i, i + 1] for i in range(n - 1)] + [[i, i + 2] for i in range(n - 3)]
    return {"frame": {"dim": 2, "positions": positions, "edges": edges}, "input_pair": [0, n - 1],
            "output_pair": [1, n - 2]}


# Requests the solver refuses before any work (its check_* functions), with their codes.
REFUSED = [
    ("/v1/map", {"frame": {"dim": 2, "positions": [[float(i), float(i * i % 7)] for i in range(201)], "edges": []},
                 **PAIRS}, "too_expensive"),  # d·N = 402 > MAP_MAX_DOF
    ("/v1/map", {**map_request(MODULES[0]), "input_pair": [0, 2]}, "invalid_pair"),  # a bar
    ("/v1/design/sequential", {"features": [{"kind": "fixed_point", "d": 1.2, "slope": 0.5}],
                               "start": start_module(17)}, "too_expensive"),  # > DESIGN_MAX_NODES
    ("/v1/design/sequential", {"features": [{"kind": "fixed_point", "d": 9.0, "slope": 0.5}]},
     "feature_out_of_reach"),  # beyond 2·reach·r of the two-triangle module
    ("/v1/design/sequential", {"features": [{"kind": "range", "source": [0.1, 150.0], "target": [0.1, 150.0]}],
                               "reach": 100.0}, "too_expensive"),  # the NLP's ladder > MAX_LADDER
    ("/v1/design/sequential", {"features": [{"kind": "period_two", "d1": 1.5, "d2": 1.5}]}, "invalid_feature"),
    ("/v1/design/sequential", {**DEPLOYABLE, "start": {"frame": map_request(MODULES[0])["frame"], "input_pair": [0, 1],
                                                         "output_pair": [1, 2]}}, "invalid_pair"),  # not chainable
]


@pytest.mark.parametrize(("endpoint", "request_", "code"), REFUSED, ids=[f"{e}:{c}" for e, _, c in REFUSED])
def test_a_refused_request_is_refused_at_submission_as_its_route_refuses_it(service, endpoint, request_, code):
    direct = service.post(endpoint, json=request_)
    assert direct.status_code == 422 and direct.json()["detail"]["code"] == code, direct.text
    job = service.post("/v1/jobs", json={"endpoint": endpoint, "request": request_})
    assert job.status_code == 422 and job.json()["detail"] == direct.json()["detail"], job.text
    sweep = service.post("/v1/sweeps", json={"endpoint": endpoint, "requests": [request_]})
    assert sweep.status_code == 422 and sweep.json()["detail"]["code"] == "invalid_point", sweep.text
    assert code in sweep.json()["detail"]["message"]


def test_the_python_client_runs_both_as_jobs_and_sweeps(service_url: str) -> None:
    """zeromode_client (no service/ or solver/ import): a sequential job equals the client's
    direct call, a sweep over `at` answers each point as the oracle, a refusal at submission is
    a ZeromodeError with the route's code."""
    from zeromode_client import Client, ZeromodeError

    request = {"features": [{"kind": "period_two", "d1": 1.3, "d2": 1.7}], "chain": {"n_modules": 4}}
    with Client(service_url, timeout=WAIT_S) as client:
        job = client.submit_job("/v1/design/sequential", request)
        result = client.wait(job, poll=0.05, timeout=WAIT_S)
        assert without_timings(result.raw) == without_timings(client.design_sequential(**request).raw)
        points = list(client.sweep("/v1/map", map_request(MODULES[2]), grid={"at": [[d] for d in AT]},
                                   poll=0.05, timeout=WAIT_S))
        assert sorted(p.point for p in points) == [0, 1, 2] and {p.status for p in points} == {"done"}
        for p in points:
            (evaluated,) = p.result.raw["evaluated"]
            assert [evaluated["d_in"]] == p.params["at"]
            assert evaluated["d_out"] == pytest.approx(oracle_map(MODULES[2], evaluated["d_in"]), rel=1e-9)
        with pytest.raises(ZeromodeError) as refused:
            client.submit_job("/v1/design/sequential", {**request, "start": start_module(17)})
        assert refused.value.status == 422 and refused.value.code == "too_expensive"


@pytest.mark.parametrize("endpoint", ["/v1/map", "/v1/design/sequential"])
def test_a_job_past_its_time_budget_fails_too_expensive(endpoint: str) -> None:
    """The job's own run (service.jobs.tasks.execute, as a worker runs it) under a job time
    budget of 1 ms, far less than a map's continuation: failed, too_expensive naming it."""
    from zeromode.service.jobs.tasks import execute

    request = map_request(MODULES[0]) if endpoint == "/v1/map" else DEPLOYABLE
    status, detail = execute("budget", endpoint, request, Settings(job_time_budget_s=0.001).model_dump_json())
    assert status == "failed" and detail["code"] == "too_expensive", detail
    assert "0.001 s" in detail["message"]


def test_a_sequential_design_reports_its_stages_in_order() -> None:
    """The operation's progress (what a job reports): monotone, through the start's map, IPOPT,
    the verification and the chain, ending at 1."""
    from zeromode.operations.endpoints import sequential
    from zeromode.service.wire.schemas.sequential import SequentialRequest

    reports: list[tuple[float, str]] = []
    with progress_scope(lambda f, m: reports.append((f, m))):
        sequential(SequentialRequest.model_validate(DEPLOYABLE))
    fractions = [f for f, _ in reports]
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    stages = [m for _, m in reports]
    order = [next(i for i, m in enumerate(stages) if word in m)
             for word in ("the start's map", "IPOPT", "verification", "chain")]
    assert order == sorted(order), stages


def zeromode(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """The installed command, run in ``cwd`` with a HOME of its own there."""
    (cwd / "home").mkdir(exist_ok=True)
    return subprocess.run([ZEROMODE, *args], capture_output=True, text=True, timeout=600, cwd=cwd,
                          env={**os.environ, "HOME": str(cwd / "home")}, check=False)


def test_the_cli_designs_plots_and_exports_a_sequential_document(tmp_path: Path) -> None:
    request = {"features": [{"kind": "fixed_point", "d": 1.5, "slope": -0.5}], "chain": {"n_modules": 4}}
    (tmp_path / "seq.json").write_text(json.dumps(request))
    run = zeromode("design", "seq.json", "-o", "answer.json", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    answer = json.loads((tmp_path / "answer.json").read_text())
    positions = answer["module"]["frame"]["positions"]
    assert answer["module"]["frame"]["edges"] == [list(e) for e in EDGES]
    # The designed module meets its feature, by the oracle: f(1.5) = 1.5, f′(1.5) = −0.5.
    assert oracle_map(positions, 1.5) == pytest.approx(1.5, rel=1e-8)
    assert oracle_slope(positions, 1.5) == pytest.approx(-0.5, rel=1e-5)
    # Plot and export of the request (designed again) and of its answer show the chain: 5 + 3·3 nodes.
    for doc in ("seq.json", "answer.json"):
        run = zeromode("export", doc, "-o", "chain.graphml", cwd=tmp_path)
        assert run.returncode == 0, run.stderr
        nodes = ET.parse(tmp_path / "chain.graphml").getroot().iter("{http://graphml.graphdrawing.org/xmlns}node")
        assert len(list(nodes)) == 5 + 3 * 3
    run = zeromode("plot", "answer.json", "-o", "chain.svg", cwd=tmp_path)
    assert run.returncode == 0 and (tmp_path / "chain.svg").read_text().lstrip().startswith("<"), run.stderr
    # A map document: its answer by `design`, drawn as the module beside its map
    # (tests/test_map_documents.py checks the chart); an answer without its frame (from before
    # answers carried one) has no module to draw in the picture of `export` (exit 2, one line).
    (tmp_path / "map.json").write_text(json.dumps(map_request(MODULES[1])))
    run = zeromode("design", "map.json", "-o", "map_answer.json", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    answer = json.loads((tmp_path / "map_answer.json").read_text())
    assert answer["evaluated"][0]["d_out"] == pytest.approx(oracle_map(MODULES[1], AT[0]), rel=1e-9)
    run = zeromode("plot", "map_answer.json", "-o", "map.svg", cwd=tmp_path)
    assert run.returncode == 0 and ET.parse(tmp_path / "map.svg").getroot().tag.endswith("svg"), run.stderr
    (tmp_path / "old_answer.json").write_text(json.dumps({k: v for k, v in answer.items() if k != "frame"}))
    run = zeromode("export", "old_answer.json", "-o", "module.vtu", cwd=tmp_path)
    assert run.returncode == 2 and run.stderr.startswith("error [invalid_request]") and "Traceback" not in run.stderr
    assert not (tmp_path / "module.vtu").exists()
    # A refusal of the solver's up-front checks: its code, no traceback.
    (tmp_path / "far.json").write_text(json.dumps({"features": [{"kind": "fixed_point", "d": 9.0, "slope": 0.5}]}))
    run = zeromode("design", "far.json", cwd=tmp_path)
    assert run.returncode == 2 and run.stderr.startswith("error [feature_out_of_reach]"), run.stderr
