"""Load and soak test of the real service on loopback (issue 8).

Starts ``zeromode serve --workers W`` on a free 127.0.0.1 port, drives it with C concurrent
clients for a bounded number of requests and a bounded time, and reports p50/p99 latency,
throughput and errors per endpoint; ``--soak S`` then runs a mixed load for S seconds while
sampling the workers' resident memory, to check that it stays flat.

    python benchmarks/load.py [--workers 2] [--clients 8] [--requests 2000] [--soak 180]

Traffic goes to 127.0.0.1 only; every loop is bounded in count and time.
"""

from __future__ import annotations

import argparse
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

TRIANGLE = {
    "frame": {"dim": 2, "positions": [[0, 0], [1, 0], [0, 1]], "edges": [[0, 1], [1, 2], [0, 2]]}
}
DESIGN_2D = {
    "dim": 2,
    "positions": [[0.0, 0.0], [1.0, 0.1], [0.3, 1.2]],
    "motions": [[[0.1, -0.2], [0.3, 0.4], [-0.2, 0.1]]],
}
ENDPOINTS = {"/v1/analyze": TRIANGLE, "/v1/design": DESIGN_2D}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_server(workers: int, env: dict[str, str] | None = None) -> tuple[subprocess.Popen, str]:
    """`zeromode serve` on a free loopback port, with these extra environment variables."""
    port = free_port()
    exe = Path(sys.executable).with_name("zeromode")
    proc = subprocess.Popen(
        [str(exe), "serve", "--host", "127.0.0.1", "--port", str(port), "--workers", str(workers)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env={**os.environ, **(env or {})},
    )
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            if httpx.get(url + "/health", timeout=1).status_code == 200:
                return proc, url
        except httpx.HTTPError:
            time.sleep(0.2)
    proc.kill()
    raise RuntimeError("the service did not start within 60 s")


def worker_pids(parent: int) -> list[int]:
    out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(parent)], capture_output=True, text=True, check=False)
    return [parent] + [int(p) for p in out.stdout.split()]


def rss_mib(pids: list[int]) -> float:
    total = 0
    for pid in pids:
        try:
            for line in Path(f"/proc/{pid}/status").read_text().splitlines():
                if line.startswith("VmRSS:"):
                    total += int(line.split()[1])
        except FileNotFoundError:
            pass
    return total / 1024


def threads_wall(target, clients: int) -> float:
    """Seconds until ``clients`` threads each running ``target`` have all finished."""
    t0 = time.perf_counter()
    threads = [threading.Thread(target=target) for _ in range(clients)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return time.perf_counter() - t0


def drive(url: str, path: str, body: dict, clients: int, requests: int, max_seconds: float) -> dict:
    """C threads share a bounded request count; returns latencies and errors."""
    latencies: list[float] = []
    errors: list[str] = []
    lock = threading.Lock()
    remaining = [requests]
    stop_at = time.monotonic() + max_seconds
    payload = json.dumps(body)

    def run() -> None:
        with httpx.Client(base_url=url, timeout=30, headers={"content-type": "application/json"}) as client:
            while time.monotonic() < stop_at:
                with lock:
                    if remaining[0] <= 0:
                        return
                    remaining[0] -= 1
                t0 = time.perf_counter()
                try:
                    r = client.post(path, content=payload)
                    ok = r.status_code == 200
                except httpx.HTTPError as exc:
                    ok, r = False, exc
                dt = time.perf_counter() - t0
                with lock:
                    latencies.append(dt)
                    if not ok:
                        errors.append(str(getattr(r, "status_code", r)))

    wall = threads_wall(run, clients)
    lat = np.array(latencies) * 1e3
    return {
        "requests": len(latencies),
        "errors": len(errors),
        "p50_ms": float(np.percentile(lat, 50)),
        "p99_ms": float(np.percentile(lat, 99)),
        "throughput_rps": len(latencies) / wall,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--clients", type=int, default=8)
    parser.add_argument("--requests", type=int, default=2000)
    parser.add_argument("--max-seconds", type=float, default=120)
    parser.add_argument("--soak", type=float, default=0, help="seconds of mixed load while sampling memory")
    parser.add_argument("--out", default=None, help="write the markdown table here")
    args = parser.parse_args()
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    proc, url = start_server(args.workers)
    try:
        lines = [
            f"Service: {args.workers} workers; {args.clients} concurrent clients; loopback.",
            "",
            "| endpoint | requests | errors | p50 ms | p99 ms | throughput req/s |",
            "|---|---|---|---|---|---|",
        ]
        for path, body in ENDPOINTS.items():
            drive(url, path, body, args.clients, 50, 30)  # warm-up
            r = drive(url, path, body, args.clients, args.requests, args.max_seconds)
            lines.append(
                f"| {path} | {r['requests']} | {r['errors']} | {r['p50_ms']:.1f} | {r['p99_ms']:.1f} | {r['throughput_rps']:.0f} |"
            )
            print(lines[-1], flush=True)
        if args.soak > 0:
            pids = worker_pids(proc.pid)
            samples = [rss_mib(pids)]
            t_end = time.monotonic() + args.soak
            served = errors = 0
            while time.monotonic() < t_end:
                for path, body in ENDPOINTS.items():
                    r = drive(url, path, body, args.clients, 400, 15)
                    served += r["requests"]
                    errors += r["errors"]
                samples.append(rss_mib(pids))
            growth = samples[-1] - samples[1] if len(samples) > 2 else 0.0
            soak = (
                f"Soak: {args.soak:.0f} s, {served} requests, {errors} errors; resident memory of the "
                f"server processes {samples[0]:.0f} MiB at start, {samples[1]:.0f} MiB after the first "
                f"round, {samples[-1]:.0f} MiB at the end (growth after warm-up {growth:+.1f} MiB; "
                f"samples: {', '.join(f'{s:.0f}' for s in samples)})."
            )
            lines += ["", soak]
            print(lines[-1])
        if args.out:
            Path(args.out).write_text("\n".join(lines) + "\n")
    finally:
        proc.terminate()
        proc.wait(timeout=30)


if __name__ == "__main__":
    main()
