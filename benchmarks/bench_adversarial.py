"""The adversarial probe set of issue #18 against a live `zeromode serve`: figures for the guide.

Probes, each one HTTP request (raw bytes where a client library would correct them):

- **size**: for every endpoint, requests whose size must be refused before any work (nodes,
  bars, bars × degrees of freedom of a dense SVD, NLP unknowns, LMI size, relays, lattice cells,
  samples, sweep points, jobs of each), answered 422 in ≤ 50 ms (``SIZE``, also
  tests/test_refusal_speed.py);
- **malformed**: unknown fields in every endpoint and inside ``options``, wrong types, NaN and
  Infinity, ragged and oversized arrays, coordinates of 1e308, frames without bars or of a single
  node, over-deep JSON, UTF-16 and other encodings, wrong content types, bodies past the limit
  (chunked, a lying Content-Length, a gzip bomb), oversized headers, hostile request ids and
  Host headers, CORS preflights;
- **heavy**: requests that take longer than a short time budget (a dense SVD, a 10⁵-node analysis,
  a long continuation, tiny relays), under ``--budget`` seconds: how long past the budget each
  answer comes (an overrun is more than 10 %).

Counted: probes, 4xx by code, 5xx (must be 0), overruns (must be 0), the size refusals' time.

    python -m benchmarks.bench_adversarial [--out docs/benchmarks/adversarial.md] [--budget 2]
"""

from __future__ import annotations

import argparse
import gzip
import json
import os
import socket
import statistics
import threading
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx

from benchmarks.bench_offload import big_frame
from benchmarks.bench_sweeps import start_service_with

# The refusal-speed service: limits low enough that a frame past them is a small body (the
# limits' values do not change the checks' code paths, only how many bytes a probe sends).
SMALL_LIMITS = {"ZEROMODE_MAX_NODES": "1100", "ZEROMODE_MAX_EDGES": "3100"}
REFUSAL_MS = 50.0
TRIANGLE = {"dim": 2, "positions": [[0, 0], [1, 0], [0, 1]], "edges": [[0, 1], [1, 2], [0, 2]]}
SITES = {"source": {"positions": [[0, 0], [1, 0], [0, 1]], "motion": [[0, 0], [0, 0], [1, 0]]},
         "target": {"positions": [[12, 0], [13, 0], [12, 1]], "motion": [[0, 0], [0, 0], [-1, 0]]}}


def chain(n: int, dim: int = 2) -> dict:
    """A zig-zag chain of n nodes (each joined to the two before it): rigid, 2n − 3 bars."""
    positions = [[float(i), float(i % 2)] + [0.0] * (dim - 2) for i in range(n)]
    edges = [[i, i + 1] for i in range(n - 1)] + [[i, i + 2] for i in range(n - 2)]
    return {"dim": dim, "positions": positions, "edges": edges}


def scattered(n: int, dim: int = 2, bars_per_node: int = 0) -> dict:
    """n distinct nodes, each joined to its next ``bars_per_node`` (cyclically)."""
    positions = [[float(i % 97), float(i // 97)] + [float((i * 7) % 13)] * (dim - 2) for i in range(n)]
    edges = [[i, (i + k) % n] for i in range(n) for k in range(1, bars_per_node + 1)]
    return {"dim": dim, "positions": positions, "edges": edges}


@dataclass(frozen=True)
class Probe:
    """One request and the answers that are right for it (status, and codes when a 4xx)."""

    name: str
    path: str
    body: Any = None
    method: str = "POST"
    status: int = 422
    codes: tuple[str, ...] = ()
    headers: dict[str, str] = field(default_factory=dict)
    raw: bytes | None = None  # sent as is on a socket (the request line and headers included)


def _job(name: str, endpoint: str, request: dict, codes: tuple[str, ...]) -> Probe:
    return Probe(f"job: {name}", "/v1/jobs", {"endpoint": endpoint, "request": request}, codes=codes)


def size_probes() -> list[Probe]:
    """Every expensive quantity past its limit, per endpoint, on a service with SMALL_LIMITS."""
    too_many_nodes = scattered(1101)
    too_many_bars = scattered(300, bars_per_node=11)
    dense_3d = scattered(1001, dim=3, bars_per_node=3)  # C 3003 × 3003, past DENSE_MAX_SIDE
    big_nlp = chain(200)  # K = 64: 63 · 200 · 2 = 25 200 unknowns
    big_nlp["specified"] = [0, 1]
    lmi = chain(900, dim=3)  # p = 2700 − 6 − 0 > 2 500
    refine = {"frame": big_nlp, "motion": [[1, 0], [0, 1]], "options": {"K": 64}}
    tiny_relays = {"dim": 2, **SITES, "options": {"relay_spacing": 1e-3, "relay_growth": 1.0}}
    sheet = {"dim": 2, "cells": [51, 50], "poisson_ratio": -0.5}
    chain_3d = {"dim": 3, "cells": [65], "poisson_ratio": -0.5}
    toleranced_sheet = {"dim": 2, "cells": [10, 10], "poisson_ratio": -0.5, "tolerance": {}}
    refined_sheet = {"dim": 2, "cells": [20, 20], "poisson_ratio": -0.5, "refine": {"K": 64}}
    specified = [[float(i), float(i * i % 11)] for i in range(65)]
    big_module = {"frame": scattered(201), "input_pair": [0, 1], "output_pair": [2, 3]}  # d·N 402 > MAP_MAX_DOF
    big_start = {"features": [{"kind": "fixed_point", "d": 1.2, "slope": 0.5}],
                 "start": {"frame": chain(17), "input_pair": [0, 16], "output_pair": [1, 15]}}  # > DESIGN_MAX_NODES
    long_ladder = {"features": [{"kind": "range", "source": [0.1, 150.0], "target": [0.1, 150.0]}],
                   "reach": 100.0}  # the NLP's ladder > MAX_LADDER
    codes_nodes = ("invalid_request",)
    return [
        Probe("analyze: nodes", "/v1/analyze", {"frame": too_many_nodes}, codes=codes_nodes),
        Probe("analyze: bars", "/v1/analyze", {"frame": too_many_bars}, codes=codes_nodes),
        Probe("analyze: dense SVD size", "/v1/analyze", {"frame": dense_3d, "options": {"method": "dense"}},
              codes=("too_expensive",)),
        Probe("motion: nodes", "/v1/motion", {"frame": too_many_nodes}, codes=codes_nodes),
        Probe("refine: NLP unknowns", "/v1/refine", refine, codes=("too_expensive",)),
        Probe("certify: LMI size", "/v1/certify", {"frame": lmi}, codes=("too_expensive",)),
        Probe("allosteric: relays", "/v1/design/allosteric", tiny_relays, codes=("too_expensive",)),
        Probe("auxetic: sheet cells", "/v1/design/auxetic", sheet, codes=("invalid_size",)),
        Probe("auxetic: chain blocks", "/v1/design/auxetic", chain_3d, codes=("invalid_size",)),
        Probe("auxetic: tolerance size", "/v1/design/auxetic", toleranced_sheet, codes=("too_expensive",)),
        Probe("auxetic: NLP unknowns", "/v1/design/auxetic", refined_sheet, codes=("too_expensive",)),
        Probe("design: specified nodes", "/v1/design",
              {"dim": 2, "positions": specified, "motions": [specified]}, codes=codes_nodes),
        Probe("solution-space: samples", "/v1/solution-space",
              {"dim": 2, "positions": [[0, 0], [1, 0]], "motions": [[0, 0], [0, 1]], "samples": 1001},
              codes=codes_nodes),
        Probe("two-configuration: specified", "/v1/design/two-configuration",
              {"dim": 2, "initial": specified, "final": specified}, codes=codes_nodes),
        Probe("allosteric network: nodes", "/v1/design/allosteric/network",
              {"frame": too_many_nodes, "source": [0, 1], "target": [5, 6], "strain_ratio": 2.0}, codes=codes_nodes),
        Probe("map: degrees of freedom", "/v1/map", big_module, codes=("too_expensive",)),
        Probe("sequential: start nodes", "/v1/design/sequential", big_start, codes=("too_expensive",)),
        Probe("sequential: NLP ladder", "/v1/design/sequential", long_ladder, codes=("too_expensive",)),
        Probe("plot: nodes", "/v1/plot", {"frame": too_many_nodes}, codes=codes_nodes),
        Probe("export: nodes", "/v1/export", {"format": "graphml", "frame": too_many_nodes}, codes=codes_nodes),
        Probe("sweeps: points", "/v1/sweeps",
              {"endpoint": "/v1/design/auxetic", "template": {"cells": [3, 3]},
               "grid": {"poisson_ratio": [-0.1 - i / 1000 for i in range(101)], "seed": list(range(100))}},
              codes=("too_many_points",)),
        _job("relays", "/v1/design/allosteric", tiny_relays, ("too_expensive",)),
        _job("NLP unknowns", "/v1/refine", refine, ("too_expensive",)),
        _job("LMI size", "/v1/certify", {"frame": lmi}, ("too_expensive",)),
        _job("sheet cells", "/v1/design/auxetic", sheet, ("invalid_size",)),
        _job("dense SVD size", "/v1/analyze", {"frame": dense_3d, "options": {"method": "dense"}}, ("too_expensive",)),
        _job("map degrees of freedom", "/v1/map", big_module, ("too_expensive",)),
        _job("sequential start nodes", "/v1/design/sequential", big_start, ("too_expensive",)),
        _job("sequential NLP ladder", "/v1/design/sequential", long_ladder, ("too_expensive",)),
    ]


def process_cpu_s(pid: int) -> float:
    """CPU seconds (user + system) the process ``pid`` has used, from /proc (Linux)."""
    with open(f"/proc/{pid}/stat") as fh:
        fields = fh.read().rpartition(")")[2].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def refusal_times(url: str, probes: list[Probe], repeats: int = 5, server_pid: int | None = None) -> list[dict]:
    """Each probe sent ``repeats`` times on one kept-alive connection (bodies encoded before the
    clock starts): its statuses, codes, the median round trip in ms and, given the server's
    process, the median CPU time the server spent on it (``median_cpu_ms``: what a refusal
    costs, unlike the round trip not stretched by other work on a busy machine)."""
    rows = []
    with httpx.Client(base_url=url, timeout=120) as http:
        for probe in probes:
            content = json.dumps(probe.body).encode()
            times, cpu, answers = [], [], []
            for _ in range(repeats):
                c0 = process_cpu_s(server_pid) if server_pid else 0.0
                t0 = time.perf_counter()
                r = http.request(probe.method, probe.path, content=content, headers={"content-type": "application/json"})
                times.append(1e3 * (time.perf_counter() - t0))
                cpu.append(1e3 * ((process_cpu_s(server_pid) if server_pid else 0.0) - c0))
                answers.append((r.status_code, _code(r)))
            rows.append({"probe": probe.name, "bytes": len(content), "answers": sorted(set(answers)),
                         "median_ms": statistics.median(times), "max_ms": max(times),
                         "median_cpu_ms": statistics.median(cpu) if server_pid else None,
                         "ok": all(s == probe.status and c in probe.codes for s, c in answers)})
    return rows


def _code(r: httpx.Response) -> str | None:
    """The error code of a 4xx/5xx JSON body ({"detail": {"code": …}}), else None."""
    try:
        detail = r.json().get("detail")
    except ValueError:
        return None
    return detail.get("code") if isinstance(detail, dict) else None


# --- malformed input ------------------------------------------------------------------------

VALID = {
    "/v1/analyze": {"frame": TRIANGLE},
    "/v1/design": {"dim": 2, "positions": [[1, 1], [-1, 1], [-1, -1], [1, -1]],
                   "motions": [[[1, 1], [-1, 1], [-1, -1], [1, -1]]]},
    "/v1/solution-space": {"dim": 2, "positions": [[0, 0], [1, 0]], "motions": [[0, 1], [0, -1]]},
    "/v1/design/two-configuration": {"dim": 2, "initial": [[0, 0], [1, 0], [0, 1]], "final": [[0, 0], [1, 0.1], [0.1, 1]]},
    "/v1/design/auxetic": {"dim": 2, "cells": [3, 3], "poisson_ratio": -0.5},
    "/v1/design/allosteric": {"dim": 2, **SITES},
    "/v1/design/allosteric/network": {"frame": chain(12), "source": [0, 1], "target": [10, 11], "strain_ratio": 2.0},
    "/v1/motion": {"frame": {"dim": 2, "positions": [[0, 0], [1, 0], [1, 1], [0, 1]], "edges": [[0, 1], [1, 2], [2, 3], [3, 0]]},
                   "amplitude": 0.1},
    "/v1/refine": {"frame": {**TRIANGLE, "specified": [0, 1]}, "motion": [[0, 0], [1, 0]]},
    "/v1/certify": {"frame": TRIANGLE},
    "/v1/plot": {"frame": TRIANGLE},
    "/v1/export": {"format": "graphml", "frame": TRIANGLE},
    "/v1/jobs": {"endpoint": "/v1/analyze", "request": {"frame": TRIANGLE}},
    "/v1/sweeps": {"endpoint": "/v1/design/auxetic", "template": {"cells": [3, 3]}, "grid": {"poisson_ratio": [-0.3, -0.5]}},
}
FRAME_ENDPOINTS = ("/v1/analyze", "/v1/motion", "/v1/certify", "/v1/plot", "/v1/export", "/v1/design/allosteric/network")
HUGE = 1e308


def _frames() -> dict[str, Any]:
    """Hostile frames (each replaces a frame endpoint's valid frame)."""
    return {
        "ragged positions": {"dim": 2, "positions": [[0, 0], [1]], "edges": []},
        "3 numbers per node in 2D": {"dim": 2, "positions": [[0, 0, 0], [1, 0, 0]], "edges": [[0, 1]]},
        "edge out of range": {"dim": 2, "positions": [[0, 0], [1, 0]], "edges": [[0, 2]]},
        "negative index": {"dim": 2, "positions": [[0, 0], [1, 0]], "edges": [[-1, 0]]},
        "self-loop": {"dim": 2, "positions": [[0, 0], [1, 0]], "edges": [[0, 0]]},
        "duplicate bar": {"dim": 2, "positions": [[0, 0], [1, 0]], "edges": [[0, 1], [1, 0]]},
        "coincident nodes": {"dim": 2, "positions": [[0, 0], [0, 0], [1, 0]], "edges": [[0, 1], [1, 2]]},
        "coordinates 1e308": {"dim": 2, "positions": [[0, 0], [HUGE, HUGE], [0, HUGE]], "edges": [[0, 1], [1, 2], [0, 2]]},
        "coordinates 1e-308": {"dim": 2, "positions": [[0, 0], [1e-308, 0], [0, 1e-308]], "edges": [[0, 1], [1, 2], [0, 2]]},
        "no bars": {"dim": 2, "positions": [[0, 0], [1, 0], [0, 1]], "edges": []},
        "one node": {"dim": 2, "positions": [[0, 0]], "edges": []},
        "no nodes": {"dim": 2, "positions": [], "edges": []},
        "dim 4": {"dim": 4, "positions": [[0, 0, 0, 0]], "edges": []},
        "strings": {"dim": 2, "positions": [["a", "b"]], "edges": []},
        "specified out of range": {**TRIANGLE, "specified": [7]},
        "1e4 nodes, no bars": scattered(10_000),
    }


def _json_probes() -> list[Probe]:
    probes = []
    for path, body in VALID.items():
        probes += [
            Probe(f"{path}: unknown field", path, {**body, "seeed": 3}, status=None),
            Probe(f"{path}: body is a list", path, [body], status=None),
            Probe(f"{path}: body is a number", path, 3, status=None),
            Probe(f"{path}: empty object", path, {}, status=None),
            Probe(f"{path}: options of the wrong type", path, {**body, "options": [1]}, status=None),
            Probe(f"{path}: unknown option", path, {**body, "options": {"seeed": 3}}, status=None),
        ]
        for name, frame in _frames().items() if path in FRAME_ENDPOINTS else ():
            probes.append(Probe(f"{path}: {name}", path, {**body, "frame": frame}, status=None))
    for path in ("/v1/design", "/v1/solution-space", "/v1/design/auxetic", "/v1/design/allosteric"):
        body = VALID[path]
        probes.append(Probe(f"{path}: huge values", path, _scaled(body, HUGE), status=None))
    probes += [
        Probe("auxetic: poisson_ratio 1e308", "/v1/design/auxetic", {**VALID["/v1/design/auxetic"], "poisson_ratio": -HUGE}, status=None),
        Probe("auxetic: cell 1e308", "/v1/design/auxetic", {**VALID["/v1/design/auxetic"], "cell": [HUGE, HUGE]}, status=None),
        Probe("auxetic: 0 cells", "/v1/design/auxetic", {**VALID["/v1/design/auxetic"], "cells": [0, 5]}, status=None),
        Probe("auxetic: 10^9 cells", "/v1/design/auxetic", {**VALID["/v1/design/auxetic"], "cells": [10**9, 10**9]}, status=None),
        Probe("allosteric: relay_spacing 1e-300", "/v1/design/allosteric",
              {**VALID["/v1/design/allosteric"], "options": {"relay_spacing": 1e-300}}, status=None),
        Probe("allosteric: relay_spacing 1.5e-3", "/v1/design/allosteric",
              {**VALID["/v1/design/allosteric"], "options": {"relay_spacing": 1.5e-3}}, status=None),
        Probe("motion: amplitude 1e308", "/v1/motion", {**VALID["/v1/motion"], "amplitude": HUGE}, status=None),
        Probe("motion: max_step 1e-300", "/v1/motion", {**VALID["/v1/motion"], "max_step": 1e-300}, status=None),
        Probe("refine: K 10^6", "/v1/refine", {**VALID["/v1/refine"], "options": {"K": 10**6}}, status=None),
        Probe("jobs: unknown endpoint", "/v1/jobs", {"endpoint": "/v1/plot", "request": {}}, status=None),
        Probe("sweeps: grid into a list", "/v1/sweeps", {**VALID["/v1/sweeps"], "grid": {"cells.0": [3, 4]}}, status=None),
        Probe("sweeps: 10^12 points", "/v1/sweeps",
              {**VALID["/v1/sweeps"], "grid": {f"k{i}": list(range(10)) for i in range(12)}}, status=None),
        Probe("jobs: unknown id", "/v1/jobs/" + "0" * 32, method="GET", status=None),
        Probe("jobs: id of 10 kB", "/v1/jobs/" + "a" * 10_000, method="GET", status=None),
        Probe("sweeps: after past int64", "/v1/sweeps/" + "0" * 32 + "?after=99999999999999999999", method="GET", status=None),
    ]
    return probes


def _scaled(body: Any, factor: float) -> Any:
    """Every number of ``body`` times ``factor`` (integers and booleans kept)."""
    if isinstance(body, dict):
        return {k: v if k in ("dim", "cells", "edges", "source", "target") else _scaled(v, factor) for k, v in body.items()}
    if isinstance(body, list):
        return [_scaled(v, factor) for v in body]
    return body * factor if isinstance(body, float | int) and not isinstance(body, bool) and body != 0 else body


def _raw_probes() -> list[Probe]:
    """Transport-level probes, sent as bytes."""
    triangle = json.dumps({"frame": TRIANGLE}).encode()

    def post(body: bytes, *headers: str) -> bytes:
        lines = ["POST /v1/analyze HTTP/1.1", "host: x", "connection: close", *headers]
        return ("\r\n".join(lines) + "\r\n\r\n").encode() + body

    def chunked(body: bytes) -> bytes:
        return b"".join(b"%x\r\n%s\r\n" % (len(body[k:k + 4096]), body[k:k + 4096]) for k in range(0, len(body), 4096)) + b"0\r\n\r\n"

    big = json.dumps({"frame": scattered(30_000)}).encode() * 40  # ~ 25 MB, past the 20 MB limit
    bomb = gzip.compress(b" " * 200_000_000)
    deep = b"[" * 10_000 + b"]" * 10_000
    return [
        Probe("chunked past the limit", "/v1/analyze", raw=post(chunked(big), "content-type: application/json", "transfer-encoding: chunked"), status=None),
        Probe("chunked with a lying Content-Length", "/v1/analyze",
              raw=post(chunked(big), "content-type: application/json", "transfer-encoding: chunked", "content-length: 10"), status=None),
        Probe("Content-Length past the limit", "/v1/analyze", raw=post(b"", "content-type: application/json", "content-length: 999999999"), status=None),
        Probe("gzip bomb (200 MB of spaces)", "/v1/analyze",
              raw=post(bomb, "content-type: application/json", "content-encoding: gzip", f"content-length: {len(bomb)}"), status=None),
        Probe("brotli body", "/v1/analyze", raw=post(triangle, "content-type: application/json", "content-encoding: br", f"content-length: {len(triangle)}"), status=None),
        Probe("text/plain", "/v1/analyze", raw=post(triangle, "content-type: text/plain", f"content-length: {len(triangle)}"), status=None),
        Probe("no content type", "/v1/analyze", raw=post(triangle, f"content-length: {len(triangle)}"), status=None),
        Probe("UTF-16 body", "/v1/analyze", raw=post(triangle.decode().encode("utf-16"), "content-type: application/json",
                                                     f"content-length: {len(triangle.decode().encode('utf-16'))}"), status=None),
        Probe("byte-order mark", "/v1/analyze", raw=post(b"\xef\xbb\xbf" + triangle, "content-type: application/json",
                                                         f"content-length: {len(triangle) + 3}"), status=None),
        Probe("invalid UTF-8", "/v1/analyze", raw=post(b'{"frame": "\xff\xfe"}', "content-type: application/json", "content-length: 15"), status=None),
        Probe("10 000-deep JSON", "/v1/analyze", raw=post(deep, "content-type: application/json", f"content-length: {len(deep)}"), status=None),
        Probe("NaN literal", "/v1/analyze", raw=post(b'{"frame": {"dim": 2, "positions": [[NaN, 0]], "edges": []}}',
                                                     "content-type: application/json", "content-length: 59"), status=None),
        Probe("Infinity literal", "/v1/analyze", raw=post(b'{"frame": {"dim": 2, "positions": [[Infinity, 0]], "edges": []}}',
                                                          "content-type: application/json", "content-length: 64"), status=None),
        Probe("truncated JSON", "/v1/analyze", raw=post(triangle[:-5], "content-type: application/json", f"content-length: {len(triangle) - 5}"), status=None),
        Probe("100 kB header", "/v1/analyze", raw=post(triangle, "content-type: application/json", f"content-length: {len(triangle)}", "x-pad: " + "a" * 100_000), status=None),
        Probe("request id of 10 kB", "/health", raw=b"GET /health HTTP/1.1\r\nhost: x\r\nconnection: close\r\nx-request-id: " + b"r" * 10_000 + b"\r\n\r\n", status=None),
        Probe("Host evil.example on a slash URL", "/v1/jobs/", raw=b"GET /v1/jobs/ HTTP/1.1\r\nhost: evil.example\r\nconnection: close\r\n\r\n", status=None),
        Probe("CORS preflight with x-api-key", "/v1/analyze",
              raw=b"OPTIONS /v1/analyze HTTP/1.1\r\nhost: x\r\nconnection: close\r\norigin: https://lab.example\r\n"
                  b"access-control-request-method: POST\r\naccess-control-request-headers: x-api-key, content-type\r\n\r\n", status=None),
        Probe("GET on a POST route", "/v1/analyze", raw=b"GET /v1/analyze HTTP/1.1\r\nhost: x\r\nconnection: close\r\n\r\n", status=None),
        Probe("unknown path", "/v1/nothing", raw=b"GET /v1/nothing HTTP/1.1\r\nhost: x\r\nconnection: close\r\n\r\n", status=None),
    ]


def malformed_probes() -> list[Probe]:
    return _json_probes() + _raw_probes()


def send(url: str, probe: Probe, timeout: float = 120.0) -> tuple[int, str | None, float, bool]:
    """(status, code, seconds, whether the body is well formed: an error's {"detail": {"code",
    "message"}}, JSON, SVG or a file) of one probe."""
    content = json.dumps(probe.body).encode() if probe.body is not None else None
    t0 = time.perf_counter()
    if probe.raw is None:
        r = httpx.request(probe.method, url + probe.path, content=content, timeout=timeout,
                          headers={"content-type": "application/json", **probe.headers})
        elapsed = time.perf_counter() - t0
        code = _code(r)
        shaped = r.status_code < 400 or (code is not None and isinstance(r.json()["detail"].get("message"), str))
        return r.status_code, code, elapsed, shaped
    status, body = _raw(url, probe.raw, timeout)
    elapsed = time.perf_counter() - t0
    try:
        detail = json.loads(body).get("detail") if body else None
    except (ValueError, AttributeError):
        detail = None
    code = detail.get("code") if isinstance(detail, dict) else None
    return status, code, elapsed, status < 400 or code is not None


def _raw(url: str, request: bytes, timeout: float) -> tuple[int, bytes]:
    """Send bytes while reading the answer (a server that refuses early closes before the rest is
    sent); its status and body (dechunked)."""
    host, port = url.removeprefix("http://").split(":")
    with socket.create_connection((host, int(port)), timeout=timeout) as conn:
        def pump() -> None:
            try:
                for k in range(0, len(request), 65536):
                    conn.sendall(request[k:k + 65536])
            except OSError:
                pass

        sender = threading.Thread(target=pump, daemon=True)
        sender.start()
        data = b""
        try:
            while chunk := conn.recv(65536):
                data += chunk
        except (ConnectionResetError, TimeoutError):
            pass
        sender.join(timeout=5)
    head, _, body = data.partition(b"\r\n\r\n")
    if not head:
        return 0, b""
    if b"transfer-encoding: chunked" in head.lower():
        body = b"".join(body.split(b"\r\n")[1::2])
    return int(head.split()[1]), body


# --- heavy requests under a short budget ------------------------------------------------------

def heavy_probes() -> list[Probe]:
    """Requests that take longer than a 2 s budget: one long LAPACK call, one long sparse
    factorisation, a long continuation, a long chain of relays."""
    sheet = {"dim": 2, "cells": [12, 12], "poisson_ratio": -0.5}
    return [
        Probe("analysis, dense SVD 3000 × 3000", "/v1/analyze", {"frame": big_frame(1_500), "options": {"method": "dense"}}, status=None),
        Probe("analysis of 10⁵ nodes", "/v1/analyze", {"frame": big_frame(100_000), "options": {"bases": False}}, status=None),
        Probe("allosteric, 300 relays", "/v1/design/allosteric",
              {**VALID["/v1/design/allosteric"], "options": {"relay_spacing": 0.04, "relay_growth": 1.0}}, status=None),
        Probe("auxetic 40 × 40 with finite strain", "/v1/design/auxetic",
              {"dim": 2, "cells": [40, 40], "poisson_ratio": -0.5, "finite_strain": {"strain_range": [-0.05, 0.05]}}, status=None),
        Probe("motion of a 12 × 12 sheet (designed first)", "/v1/export",
              {"format": "svg_animation", "document": sheet}, status=None),
    ]


def heavy_times(url: str, budget_s: float) -> list[dict]:
    """Each heavy probe once: its answer, wall time, the time to send its body and have it read
    (the same bytes and one invalid byte, refused 400 ``not_utf8`` once all are read, before any
    parsing: the request's budget starts there) and whether it overran: answered later than 10 %
    past the budget, net of that upload."""
    rows = []
    for probe in heavy_probes():
        status, code, elapsed, _ = send(url, probe)
        body = json.dumps(probe.body).encode() + b"\xff"
        head = f"POST {probe.path} HTTP/1.1\r\nhost: x\r\nconnection: close\r\ncontent-type: application/json\r\n"
        upload = Probe("upload", probe.path, raw=(head + f"content-length: {len(body)}\r\n\r\n").encode() + body)
        up_status, up_code, up_s, _ = send(url, upload)
        assert (up_status, up_code) == (400, "not_utf8"), (up_status, up_code)
        rows.append({"probe": probe.name, "status": status, "code": code, "seconds": elapsed, "upload_s": up_s,
                     "overrun": elapsed - up_s > 1.1 * budget_s})
    return rows


def run_probes(url: str, probes: list[Probe]) -> dict:
    """Every probe once: counts by status class and by 4xx code, and the probes that answered 5xx,
    an ill-formed error body, or nothing."""
    by_code: Counter = Counter()
    statuses: Counter = Counter()
    bad = []
    for probe in probes:
        try:
            status, code, _, shaped = send(url, probe)
        except httpx.HTTPError as exc:
            bad.append({"probe": probe.name, "error": type(exc).__name__})
            continue
        statuses[f"{status // 100}xx"] += 1
        if 400 <= status < 500:
            by_code[f"{status} {code}"] += 1
        if status >= 500 or status == 0 or not shaped:
            bad.append({"probe": probe.name, "status": status, "code": code})
    return {"probes": len(probes), "statuses": dict(statuses), "codes": dict(by_code.most_common()), "bad": bad}


def _service(env: dict[str, str]):
    """`zeromode serve` with these settings once its engine runs: (process, URL)."""
    proc, url = start_service_with({"ZEROMODE_OFFLOAD": "true", **env})
    deadline = time.monotonic() + 120
    while httpx.get(url + "/health", timeout=10).json().get("engine") != "running":
        if time.monotonic() > deadline:
            proc.terminate()
            raise RuntimeError("the job engine did not start within 120 s")
        time.sleep(0.2)
    return proc, url


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="docs/benchmarks/adversarial.md")
    parser.add_argument("--budget", type=float, default=2.0)
    args = parser.parse_args()
    report: dict[str, Any] = {"cores": os.cpu_count(), "load_start": os.getloadavg(), "budget_s": args.budget}
    for part, env in (("malformed", {}), ("size", SMALL_LIMITS), ("heavy", {"ZEROMODE_TIME_BUDGET_S": str(args.budget)})):
        proc, url = _service(env)
        try:
            if part == "malformed":
                report[part] = run_probes(url, malformed_probes())
            elif part == "size":
                report[part] = run_probes(url, size_probes())
                report["refusals"] = refusal_times(url, size_probes())
            else:
                report[part] = heavy_times(url, args.budget)
        finally:
            proc.terminate()
            proc.wait(timeout=60)
    report["load_end"] = os.getloadavg()
    print(json.dumps(report, indent=2))
    write_markdown(report, Path(args.out))


def write_markdown(r: dict, out: Path) -> None:
    m, s, h, refusals = r["malformed"], r["size"], r["heavy"], r["refusals"]
    total = m["probes"] + s["probes"] + len(h)
    fivexx = sum(v for part in (m, s) for k, v in part["statuses"].items() if k == "5xx") + sum(x["status"] >= 500 for x in h)
    codes: Counter = Counter(m["codes"]) + Counter(s["codes"])
    overruns = sum(x["overrun"] for x in h)
    slow = [x for x in refusals if x["median_ms"] > REFUSAL_MS]
    lines = [
        "# Adversarial probes against a live service (benchmarks/bench_adversarial.py)",
        "",
        (f"`zeromode serve` (one process, offloading on, its embedded Dask cluster), {r['cores']} cores, load average "
        f"{r['load_start'][0]:.1f} at the start and {r['load_end'][0]:.1f} at the end; one run. "
        "`python -m benchmarks.bench_adversarial` regenerates this page."),
        "",
        "## Summary",
        "",
        ("| probes | 2xx | 4xx | 5xx | ill-formed error bodies or no answer | size refusals over 50 ms (median of 5) | "
        f"answers > 10 % past a {r['budget_s']:g} s budget |"),
        "|---|---|---|---|---|---|---|",
        (f"| {total} | {m['statuses'].get('2xx', 0) + s['statuses'].get('2xx', 0) + sum(x['status'] < 300 for x in h)} "
        f"| {sum(codes.values()) + sum(400 <= x['status'] < 500 for x in h)} | {fivexx} | {len(m['bad']) + len(s['bad'])} "
        f"| {len(slow)} of {len(refusals)} | {overruns} of {len(h)} |"),
        "",
        f"## Malformed input ({m['probes']} probes, default settings)",
        "",
        ("Unknown fields at the top and inside `options` of every POST endpoint, bodies of the wrong JSON type, "
        "hostile frames (ragged, out-of-range or negative indices, self-loops, coincident nodes, coordinates of "
        "1e308 and 1e-308, no bars, one node, none, dim 4, strings, 10⁴ nodes without bars) on every frame endpoint, "
        "huge values, tiny relays, 10⁹ cells, 10¹² sweep points, bodies past the limit (chunked, a lying "
        "Content-Length, a gzip bomb), encodings, content types, 10 000-deep JSON, NaN and Infinity literals, "
        "a 100 kB header, a 10 kB request id, a hostile Host header, a CORS preflight."),
        "",
        "| answer | probes |",
        "|---|---|",
        *[f"| {k} | {v} |" for k, v in sorted(m["statuses"].items())],
        "",
        f"Probes answered 5xx, with an ill-formed body or not at all: {m['bad'] + s['bad'] or 'none'}.",
        "",
        "| 4xx code (malformed and size probes) | probes |",
        "|---|---|",
        *[f"| {k} | {v} |" for k, v in sorted(codes.items())],
        "",
        f"## Size refusals (node and bar limits {SMALL_LIMITS['ZEROMODE_MAX_NODES']} / {SMALL_LIMITS['ZEROMODE_MAX_EDGES']} so that a frame past them is a small body)",
        "",
        "| probe | body (bytes) | answer | median (ms) | max (ms) |",
        "|---|---|---|---|---|",
        *[f"| {x['probe']} | {x['bytes']} | {', '.join(f'{a} {b}' for a, b in x['answers'])} | {x['median_ms']:.1f} | {x['max_ms']:.1f} |"
          for x in refusals],
        "",
        f"## Heavy requests under a {r['budget_s']:g} s budget",
        "",
        ("An overrun is an answer more than 10 % past the budget net of sending the body and having it read (the "
        "same bytes and one invalid byte, refused `not_utf8` once read, before any parsing: a request's budget "
        "starts when its body has been read)."),
        "",
        "| probe | answer | wall (s) | of which upload (s) | overrun |",
        "|---|---|---|---|---|",
        *[f"| {x['probe']} | {x['status']} {x['code'] or ''} | {x['seconds']:.2f} | {x['upload_s']:.2f} | {'yes' if x['overrun'] else 'no'} |"
          for x in h],
        "",
        "`/health` while 48 heavy requests run: docs/benchmarks/offload.md.",
        "",
        "## Notes",
        "",
        ("- A header block past 16 KiB (`ZEROMODE_MAX_HEADER_BYTES`) is answered 431 `headers_too_large` by the "
         "app; past 8 times that (uvicorn's `h11_max_incomplete_event_size`) h11 refuses it with its own "
         "plain-text 400 before the app sees it."),
        ("- A request's budget runs from the moment its body has been read; a heavy body past 1 MB is parsed by "
         "the service only to decide where it runs, and validated by the worker, inside the budget."),
    ]
    out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
