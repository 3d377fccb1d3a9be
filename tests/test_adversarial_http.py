"""Hostile HTTP against a real uvicorn server on loopback (issue #18): bodies counted as they
arrive (chunked, a lying Content-Length, gzip bombs), content types, encodings, JSON depth,
CORS preflight with the API key, no Host-header redirects, bounded request ids, gzip responses. Raw sockets where httpx would correct the request."""

from __future__ import annotations

import gzip
import json
import os
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator

import httpx
import pytest
from fastapi.testclient import TestClient

from tests.client.conftest import loopback_socket, served, wait_for_health
from zeromode.service.rest.app import create_app
from zeromode.service.wire.settings import Settings

LIMIT = 50_000
KEY = "hostile-key-1"
ORIGIN = "https://lab.example"
TRIANGLE = {"dim": 2, "positions": [[0, 0], [1, 0], [0, 1]], "edges": [[0, 1], [1, 2], [0, 2]]}


@pytest.fixture(scope="module")
def url() -> Iterator[str]:
    settings = Settings(max_body_bytes=LIMIT, api_key=KEY, cors_origins=(ORIGIN,))
    with served(create_app(settings)) as address:
        yield address


def raw(url: str, request: bytes) -> tuple[int, dict]:
    """Send bytes as they are, in pieces, while reading the answer (a server that refuses early
    closes the connection before the rest is sent); its status and JSON body."""
    host, port = url.removeprefix("http://").split(":")
    with socket.create_connection((host, int(port)), timeout=30) as conn:

        def send() -> None:
            try:
                for k in range(0, len(request), 16384):
                    conn.sendall(request[k : k + 16384])
                    time.sleep(0.002)
            except OSError:
                pass  # refused and closed: the answer is already on its way

        sender = threading.Thread(target=send, daemon=True)
        sender.start()
        data = b""
        try:
            while not _complete(data) and (chunk := conn.recv(65536)):
                data += chunk
        except ConnectionResetError:
            pass
        sender.join()
    head, _, body = data.partition(b"\r\n\r\n")
    status = int(head.split()[1])
    if b"transfer-encoding: chunked" in head.lower():
        body = b"".join(body.split(b"\r\n")[1::2])
    answer = json.loads(body)
    return status, answer.get("detail", answer) if status >= 400 else answer


def _complete(data: bytes) -> bool:
    head, sep, body = data.partition(b"\r\n\r\n")
    if not sep:
        return False
    for line in head.lower().split(b"\r\n"):
        if line.startswith(b"content-length:"):
            return len(body) >= int(line.split(b":")[1])
    return body.endswith(b"0\r\n\r\n")


def chunked(body: bytes, size: int = 4096) -> bytes:
    parts = [body[k : k + size] for k in range(0, len(body), size)]
    return b"".join(b"%x\r\n%s\r\n" % (len(p), p) for p in parts) + b"0\r\n\r\n"


def detail(response: httpx.Response) -> tuple[int, str]:
    return response.status_code, response.json()["detail"]["code"]


def post(url: str, body: bytes, **headers) -> httpx.Response:
    headers = {"x-api-key": KEY, "content-type": "application/json", **headers}
    return httpx.post(f"{url}/v1/analyze", content=body, headers=headers, timeout=60)


def big_frame_body(nodes: int) -> bytes:
    positions = [[i, (i * i) % 7] for i in range(nodes)]
    return json.dumps({"frame": {"dim": 2, "positions": positions, "edges": []}}).encode()


def test_chunked_body_with_a_lying_content_length_is_counted(url):
    body = big_frame_body(30_000)  # ~ 350 kB, seven times the limit
    assert len(body) > 5 * LIMIT
    head = (
        b"POST /v1/analyze HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
        b"X-Api-Key: " + KEY.encode() + b"\r\nTransfer-Encoding: chunked\r\nConnection: close\r\n"
    )
    lying = head + b"Content-Length: 10\r\n\r\n"
    head += b"\r\n"
    status, refusal = raw(url, head + chunked(body))
    assert (status, refusal["code"]) == (413, "body_too_large")
    status, refusal = raw(url, lying + chunked(body))
    assert 400 <= status < 500 and "code" in refusal
    # The same body, chunked but within the limit, is served.
    small = json.dumps({"frame": TRIANGLE}).encode()
    status, answer = raw(url, head + chunked(small, 16))
    assert status == 200 and answer["rank"] == 3


def test_gzip_bodies_are_decoded_and_bombs_refused(url):
    small = json.dumps({"frame": TRIANGLE}).encode()
    response = post(url, gzip.compress(small), **{"content-encoding": "gzip"})
    assert response.status_code == 200 and response.json()["rank"] == 3
    bomb = gzip.compress(b" " * 200_000_000 + small)  # 200 MB of whitespace in ~200 kB
    assert len(bomb) < 5 * LIMIT
    response = post(url, bomb, **{"content-encoding": "gzip"})
    assert detail(response) == (413, "body_too_large")
    broken = post(url, gzip.compress(small)[:-12], **{"content-encoding": "gzip"})
    assert detail(broken) == (400, "invalid_encoding")
    other = post(url, small, **{"content-encoding": "br"})
    assert detail(other) == (415, "unsupported_encoding")


def test_large_responses_come_gzipped(url):
    body = json.dumps({"frame": {"dim": 2, "positions": [[i, i % 3] for i in range(100)], "edges": []}})
    response = post(url, body.encode(), **{"accept-encoding": "gzip"})
    assert response.status_code == 200
    assert response.headers.get("content-encoding") == "gzip"
    assert response.json()["nodes"] == 100  # httpx decodes it: the body is intact


@pytest.mark.parametrize(
    ("body", "headers", "status", "code"),
    [
        (b'{"frame": 1}', {"content-type": "text/plain"}, 415, "unsupported_media_type"),
        (json.dumps({"frame": TRIANGLE}).encode("utf-16"), {}, 400, "not_utf8"),
        (b'{"frame": "\xff\xfe"}', {}, 400, "not_utf8"),
        (b"[" * 10_000 + b"]" * 10_000, {}, 400, "too_deep"),
    ],
    ids=["text-plain", "utf-16", "latin-1", "deep"],
)
def test_bodies_that_are_not_utf8_json_are_refused_with_a_code(url, body, headers, status, code):
    response = post(url, body, **headers)
    assert detail(response) == (status, code)


def test_strings_that_look_like_brackets_are_not_nesting(url):
    body = json.dumps({"frame": TRIANGLE, "options": {"seeed": "[" * 200}}).encode()
    response = post(url, body)
    # Refused for the unknown field it is, not for depth.
    assert response.status_code == 422 and "seeed" in response.json()["detail"]["message"]


def test_cors_preflight_allows_the_api_key_header(url):
    response = httpx.options(
        f"{url}/v1/analyze",
        headers={
            "origin": ORIGIN,
            "access-control-request-method": "POST",
            "access-control-request-headers": "x-api-key, content-type",
        },
    )
    assert response.status_code == 200
    allowed = response.headers["access-control-allow-headers"].lower()
    assert "x-api-key" in allowed and response.headers["access-control-allow-origin"] == ORIGIN


def test_no_redirect_takes_its_url_from_the_host_header(url):
    response = httpx.get(
        f"{url}/v1/jobs/", headers={"host": "evil.example", "x-api-key": KEY}, follow_redirects=False
    )
    assert response.status_code < 300 or response.status_code >= 400
    assert "evil.example" not in response.headers.get("location", "")


@pytest.mark.parametrize("given", ["a" * 100_000, "id\r\nX-Evil: 1", "ok id with spaces"])
def test_request_ids_are_bounded_and_sanitised(url, given):
    head = f"GET /health HTTP/1.1\r\nHost: x\r\nX-Request-Id: {given[:60_000]}\r\nConnection: close\r\n\r\n"
    host, port = url.removeprefix("http://").split(":")
    with socket.create_connection((host, int(port)), timeout=30) as conn:
        conn.sendall(head.encode())
        data = conn.recv(65536)
    returned = [
        line.split(b":", 1)[1].strip() for line in data.split(b"\r\n") if line.lower().startswith(b"x-request-id:")
    ]
    assert not data.startswith(b"HTTP/1.1 5")
    assert all(len(value) <= 64 and b" " not in value for value in returned)
    assert b"x-evil" not in data.lower()
    ok = httpx.get(f"{url}/health", headers={"x-request-id": "trace-42"})
    assert ok.headers["x-request-id"] == "trace-42"


@pytest.fixture(scope="module")
def deployed() -> Iterator[str]:
    """`zeromode serve` as deployed: its uvicorn options come from the settings."""
    port = loopback_socket()
    number = port.getsockname()[1]
    port.close()
    env = {**os.environ, "ZEROMODE_MAX_HEADER_BYTES": "8192", "ZEROMODE_MAX_CONNECTIONS": "8"}
    command = [sys.executable, "-m", "zeromode.service.cli", "serve", "--port", str(number)]
    process = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    address = f"http://127.0.0.1:{number}"
    wait_for_health(address, lambda: process.poll() is None)
    yield address
    process.terminate()
    process.wait(10)


def test_oversized_headers_are_refused_by_the_server(deployed):
    # Past ZEROMODE_MAX_HEADER_BYTES (8192 here): the app's 431 with its code and sentence ...
    response = httpx.get(f"{deployed}/health", headers={"x-padding": "a" * 30_000})
    assert response.status_code == 431 and response.json()["detail"]["code"] == "headers_too_large"
    # ... and past h11's buffer (8 × the limit) the parser's own 4xx, the service unharmed.
    response = httpx.get(f"{deployed}/health", headers={"x-padding": "a" * 100_000})
    assert 400 <= response.status_code < 500
    assert httpx.get(f"{deployed}/health").status_code == 200


def test_connections_past_the_cap_are_answered_503_and_the_service_recovers(deployed):
    idle = [socket.create_connection(("127.0.0.1", int(deployed.rsplit(":", 1)[1]))) for _ in range(12)]
    for conn in idle:
        conn.sendall(b"GET /health HTTP/1.1\r\nHost: x\r\n")  # headers never finished
    time.sleep(0.3)
    assert httpx.get(f"{deployed}/health").status_code == 503  # refused at once, not queued
    for conn in idle:
        conn.close()
    time.sleep(0.3)
    assert httpx.get(f"{deployed}/health").status_code == 200


# --- inputs that once gave a 5xx or ran past the budget (issue #18, item 6) -------------------


@pytest.fixture(scope="module")
def app_client() -> Iterator[TestClient]:
    with TestClient(create_app(), raise_server_exceptions=False) as c:
        yield c


@pytest.mark.parametrize("scale", [9e307, 1e-300])
def test_motion_of_coordinates_whose_squares_overflow_or_underflow_is_refused(app_client, scale):
    square = [[0, 0], [scale, 0], [0, scale], [scale, scale]]
    frame = {"dim": 2, "positions": square, "edges": [[0, 1], [1, 3], [3, 2], [2, 0]]}
    response = app_client.post("/v1/motion", json={"frame": frame})
    assert (response.status_code, response.json()["detail"]["code"]) == (422, "out_of_range")
    # Within the range the same four-bar moves (it is a 200 at the scales users have).
    ok = app_client.post("/v1/motion", json={"frame": {**frame, "positions": [[x * 1e6 for x in p] for p in [[0, 0], [1, 0], [0, 1], [1, 1]]]}})
    assert ok.status_code in (200, 422) and ok.json().get("detail", {}).get("code") != "out_of_range"


def test_many_nodes_without_bars_are_counted_without_dense_work(app_client):
    n = 10_001
    frame = {"dim": 2, "positions": [[i, (i * i) % 97] for i in range(n)], "edges": []}
    t0 = time.process_time()  # CPU time (the app runs in this process): the load does not count
    body = app_client.post("/v1/analyze", json={"frame": frame}).json()
    elapsed = time.process_time() - t0
    # No bars: C is 0 × 2N, every one of the 2N velocities is a zero mode, 3 of them rigid.
    assert (body["rank"], body["zero_modes"], body["rigid_body_modes"]) == (0, 2 * n, 3)
    assert body["bases_included"] is False and elapsed < 10  # was 227 s and +3 GB


def test_the_service_returns_bases_only_up_to_its_setting():
    n = 200  # a chain: n − 1 bars, 2n − (n − 1) − 3 = n − 2 nontrivial modes of 2n numbers each
    frame = {"dim": 2, "positions": [[i, 0.3 * (i % 2)] for i in range(n)], "edges": [[i, i + 1] for i in range(n - 1)]}
    for limit, included in ((2 * n * (n - 2), True), (2 * n * (n - 2) - 1, False)):
        with TestClient(create_app(Settings(max_basis_numbers=limit))) as c:
            body = c.post("/v1/analyze", json={"frame": frame}).json()
        assert body["bases_included"] is included and body["nontrivial_zero_modes"] == n - 2
        assert len(body["modes"]) == (n - 2 if included else 0)
