"""Sweeps on the embedded Dask cluster against the workers' own rate (issue 16).

In one run, on one machine:

1. **Single process.** The sweep's points run one after the other in this process through the
   same task function the workers run (``execute``: validate, design, encode): t₁ per point.
   W worker processes can at best do W/t₁ points per second.
2. **Peer.** The same points through ``concurrent.futures.ProcessPoolExecutor`` with W
   processes (chunks of 16): what plain multiprocessing gets on this machine.
3. **zeromode.** ``zeromode serve`` (embedded LocalCluster of W workers, a SQLite store) takes
   the sweep as one POST /v1/sweeps; the wall time runs to the last point recorded (polled every
   0.1 s). Then the same sweep again while a client asks GET /health every 20 ms: its latencies
   while the workers are saturated.
4. **Status lookups.** A store holding 10⁴ finished jobs (each with a ~6 kB result): GET
   /v1/jobs/{id} of random ids through the same server, and the store's own lookup.

Throughput efficiency = (points / wall) / (W / t₁); overhead per point = W · wall / points − t₁.

    python benchmarks/bench_sweeps.py [--points 1000] [--out docs/benchmarks/sweeps.md]
"""

from __future__ import annotations

import argparse
import json
import os
import random
import subprocess
import tempfile
import threading
import time
import uuid
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import httpx
import numpy as np

from benchmarks.load import start_server

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

# A small 2D design: Fig. 3c of the paper (four specified nodes moving outward, four
# unspecified nodes placed), one point per placement seed.
TEMPLATE = {
    "dim": 2,
    "positions": [[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]],
    "motions": [[[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]]],
    "options": {"seed": 0, "n_unspecified": 4},
}
ENDPOINT = "/v1/design"
HEALTH_PERIOD_S = 0.02
# How often the benchmark asks for the sweep's status: its finishing time is known to ±POLL_S.
POLL_S = 0.1
LOOKUPS = 500
STORED_JOBS = 10_000


def requests_for(points: int) -> list[dict]:
    return [{**TEMPLATE, "options": {**TEMPLATE["options"], "seed": i}} for i in range(points)]


def run_one(request: dict) -> str:
    from zeromode.service.settings import Settings
    from zeromode.service.tasks import execute

    return execute("bench", ENDPOINT, request, Settings().model_dump_json())[0]


def single_process(requests: list[dict], blocks: int = 3, size: int = 200) -> float:
    """t₁: seconds per point in this process, the fastest of ``blocks`` blocks of ``size``
    points (the machine is shared: the fastest block is the least disturbed one, so W/t₁ is
    the highest rate the workers could reach, the strictest yardstick)."""
    run_one(requests[0])  # imports and first-call costs out of the measurement
    times = []
    for b in range(blocks):
        block = requests[b * size : (b + 1) * size]
        t0 = time.perf_counter()
        statuses = [run_one(r) for r in block]
        times.append((time.perf_counter() - t0) / len(block))
        assert set(statuses) == {"done"}, set(statuses)
    return min(times)


def process_pool(requests: list[dict], workers: int) -> float:
    with ProcessPoolExecutor(workers) as pool:
        list(pool.map(run_one, requests[:workers]))  # start and warm every process
        t0 = time.perf_counter()
        statuses = list(pool.map(run_one, requests, chunksize=16))
        wall = time.perf_counter() - t0
    assert set(statuses) == {"done"}
    return wall


def start_service_with(env: dict[str, str]) -> tuple[subprocess.Popen, str]:
    """`zeromode serve` (one process) with these ZEROMODE_* variables and, unless they name
    one, a fresh SQLite store; (process, URL)."""
    store = f"sqlite:///{tempfile.mkdtemp(prefix='zeromode-bench-')}/jobs.sqlite3"
    return start_server(1, {"ZEROMODE_DATABASE_URL": store, **env})


def run_sweep(http: httpx.Client, requests: list[dict]) -> tuple[float, dict]:
    t0 = time.perf_counter()
    r = http.post("/v1/sweeps", json={"endpoint": ENDPOINT, "template": TEMPLATE,
                                      "grid": {"options.seed": [q["options"]["seed"] for q in requests]}})
    assert r.status_code == 202, r.text
    sweep_id = r.json()["id"]
    while True:
        status = http.get(f"/v1/sweeps/{sweep_id}?limit=0").json()
        if status["status"] != "running":
            return time.perf_counter() - t0, status
        time.sleep(POLL_S)


def health_probe(url: str, stop: threading.Event, latencies: list[float]) -> None:
    with httpx.Client(base_url=url, timeout=30) as http:
        while not stop.is_set():
            t0 = time.perf_counter()
            http.get("/health").raise_for_status()
            latencies.append(time.perf_counter() - t0)
            time.sleep(HEALTH_PERIOD_S)


def fill_store(db_url: str, result_bytes: bytes) -> list[str]:
    from zeromode.service.store import Store

    store = Store(db_url)
    now = time.time()
    ids = [uuid.uuid4().hex for _ in range(STORED_JOBS)]
    rows = [{"id": i, "endpoint": ENDPOINT, "request": json.dumps(TEMPLATE), "client": "bench",
             "status": "done", "progress": 1.0, "message": "done", "result": result_bytes.decode(),
             "bytes": len(result_bytes), "created": now, "started": now, "finished": now,
             "attempts": 1, "owner": "bench"} for i in ids]
    with store.db.begin() as conn:
        from zeromode.service.store import jobs

        for k in range(0, len(rows), 500):
            conn.execute(jobs.insert(), rows[k : k + 500])
    store.close()
    return ids


def percentiles(values: list[float]) -> dict:
    ms = 1e3 * np.asarray(values)
    return {"n": len(values), "p50_ms": float(np.percentile(ms, 50)), "p99_ms": float(np.percentile(ms, 99)),
            "max_ms": float(ms.max())}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--points", type=int, default=1000)
    parser.add_argument("--out", default="docs/benchmarks/sweeps.md")
    args = parser.parse_args()
    workers = os.cpu_count() or 1
    requests = requests_for(args.points)
    t1 = single_process(requests)
    pool_wall = process_pool(requests, workers)
    state = tempfile.mkdtemp(prefix="zeromode-bench-")
    db_url = f"sqlite:///{state}/jobs.sqlite3"
    example = json.dumps(httpx_free_answer(requests[0]), separators=(",", ":")).encode()
    ids = fill_store(db_url, example)
    proc, url = start_service_with({"ZEROMODE_DATABASE_URL": db_url, "ZEROMODE_MAX_STORED_JOBS": str(10 * STORED_JOBS)})
    try:
        with httpx.Client(base_url=url, timeout=60) as http:
            run_sweep(http, requests[: 4 * workers])  # starts the embedded cluster and warms its workers
            idle: list[float] = []
            stop = threading.Event()
            probe = threading.Thread(target=health_probe, args=(url, stop, idle))
            probe.start()
            time.sleep(2.0)
            stop.set()
            probe.join()
            # Throughput alone (nothing else asks the service), then the same sweep again while
            # a client asks /health every 20 ms.
            wall, status = run_sweep(http, requests)
            assert status["done"] == args.points, status
            loaded: list[float] = []
            stop = threading.Event()
            probe = threading.Thread(target=health_probe, args=(url, stop, loaded))
            probe.start()
            _, status = run_sweep(http, requests)
            stop.set()
            probe.join()
            assert status["done"] == args.points, status
            lookups = []
            for job_id in random.Random(0).sample(ids, LOOKUPS):
                t0 = time.perf_counter()
                r = http.get(f"/v1/jobs/{job_id}")
                lookups.append(time.perf_counter() - t0)
                assert r.status_code == 200 and r.json()["status"] == "done"
    finally:
        proc.terminate()
        proc.wait(timeout=30)
    from zeromode.service.store import Store

    store = Store(db_url)
    direct = []
    for job_id in random.Random(1).sample(ids, LOOKUPS):
        t0 = time.perf_counter()
        store.job(job_id)
        direct.append(time.perf_counter() - t0)
    ideal = workers / t1
    report = {
        "machine": {"cores": workers, "load_average": os.getloadavg()},
        "points": args.points,
        "single_process_ms_per_point": 1e3 * t1,
        "ideal_points_per_s": ideal,
        "process_pool": {"wall_s": pool_wall, "points_per_s": args.points / pool_wall,
                         "efficiency": args.points / pool_wall / ideal},
        "zeromode": {"wall_s": wall, "points_per_s": args.points / wall, "efficiency": args.points / wall / ideal,
                     "overhead_ms_per_point": 1e3 * (workers * wall / args.points - t1)},
        "health_idle": percentiles(idle),
        "health_during_sweep": percentiles(loaded),
        "status_lookup_rest": percentiles(lookups),
        "status_lookup_store": percentiles(direct),
        "stored_jobs": STORED_JOBS + 4 * workers + 2 * args.points,
    }
    print(json.dumps(report, indent=2))
    write_markdown(report, Path(args.out))


def httpx_free_answer(request: dict) -> dict:
    """One point's answer, as a stored result of realistic size."""
    from zeromode.service.settings import Settings
    from zeromode.service.tasks import execute

    return json.loads(execute("bench", ENDPOINT, request, Settings().model_dump_json())[1])


def write_markdown(r: dict, out: Path) -> None:
    z, p = r["zeromode"], r["process_pool"]
    h, hi = r["health_during_sweep"], r["health_idle"]
    lines = [
        "# Sweeps on the embedded Dask cluster (benchmarks/bench_sweeps.py)",
        "",
        (f"{r['points']} small 2D designs (Fig. 3c, one point per placement seed) on {r['machine']['cores']} cores "
        f"(load average at the end {r['machine']['load_average'][0]:.1f}); one run, all rows from the same run."),
        "",
        "| route | wall (s) | points/s | of W/t₁ | overhead per point |",
        "|---|---|---|---|---|",
        (f"| one process, sequential (t₁ = {r['single_process_ms_per_point']:.2f} ms, fastest of 3 blocks of 200) | "
        f"{r['points'] * r['single_process_ms_per_point'] / 1e3:.2f} | {1e3 / r['single_process_ms_per_point']:.0f} | — | — |"),
        (f"| ProcessPoolExecutor, W processes, chunks of 16 (peer) | {p['wall_s']:.2f} | {p['points_per_s']:.0f} | "
        f"{100 * p['efficiency']:.0f} % | — |"),
        (f"| zeromode: POST /v1/sweeps → last point recorded | {z['wall_s']:.2f} | {z['points_per_s']:.0f} | "
        f"{100 * z['efficiency']:.0f} % | {z['overhead_ms_per_point']:.2f} ms |"),
        "",
        ("The floor: overhead ≤ 5 ms per point over the design itself, throughput ≥ 80 % of W/t₁ (W workers each at "
        "the single-process rate). The zeromode row includes validating all points, recording them in SQLite, "
        "the Dask scheduler (in the service process, on the same cores) and recording every result."),
        "",
        "| GET /health | n | p50 (ms) | p99 (ms) | max (ms) |",
        "|---|---|---|---|---|",
        f"| idle | {hi['n']} | {hi['p50_ms']:.1f} | {hi['p99_ms']:.1f} | {hi['max_ms']:.1f} |",
        f"| while the sweep saturates the workers | {h['n']} | {h['p50_ms']:.1f} | {h['p99_ms']:.1f} | {h['max_ms']:.1f} |",
        "",
        f"| status lookup, {r['stored_jobs']} jobs stored | n | p50 (ms) | p99 (ms) | max (ms) |",
        "|---|---|---|---|---|",
    ]
    for name, key in (("GET /v1/jobs/{id} (REST, result included)", "status_lookup_rest"),
                      ("Store.job (SQLite, WAL)", "status_lookup_store")):
        s = r[key]
        lines.append(f"| {name} | {s['n']} | {s['p50_ms']:.2f} | {s['p99_ms']:.2f} | {s['max_ms']:.2f} |")
    out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
