"""A 10⁵-node frame through REST: /v1/analyze on a real uvicorn server on loopback.

The request body is gzip-compressed JSON (``Content-Encoding: gzip``), so a frame whose plain
JSON nears the body limit still fits; the response is asked for with ``Accept-Encoding: gzip``.
The counts are checked against the patch's geometry (a triangulated rhombus is rigid, every bar
beyond 2N − 3 is a self-stress), not against the solver.
"""

from __future__ import annotations

import gzip
import json
from collections.abc import Iterator

import httpx
import pytest

from benchmarks.lattices import triangulated_lattice
from tests.client.conftest import served
from zeromode.service.rest.app import create_app


@pytest.fixture(scope="module")
def url() -> Iterator[str]:
    """The real app (default settings) served by uvicorn on loopback."""
    with served(create_app()) as address:
        yield address


def test_a_100k_node_lattice_through_rest_with_gzip_bodies(url):
    frame = triangulated_lattice(100_000)
    n, nb = frame.n_nodes, frame.n_edges
    body = {
        "frame": {
            "dim": 2,
            "positions": frame.positions.tolist(),
            "edges": frame.edges.tolist(),
        },
        "options": {"bases": False},
    }
    plain = json.dumps(body).encode()
    packed = gzip.compress(plain, compresslevel=6)
    assert len(packed) < len(plain) / 2
    response = httpx.post(
        f"{url}/v1/analyze",
        content=packed,
        headers={
            "content-type": "application/json",
            "content-encoding": "gzip",
            "accept-encoding": "gzip",
        },
        timeout=120.0,
    )
    assert response.status_code == 200, response.text[:300]
    answer = response.json()  # httpx undoes the response's gzip
    assert (answer["nodes"], answer["edges"], answer["method"]) == (n, nb, "sparse")
    assert answer["rank"] == 2 * n - 3
    assert answer["nontrivial_zero_modes"] == 0
    assert answer["self_stresses"] == nb - (2 * n - 3)
    assert answer["rank_gap"]["first_zero"] < 1e-12 * answer["rank_gap"]["last_nonzero"]


def test_a_gzip_body_that_inflates_past_the_limit_is_refused(url):
    # 1 MB of zeros compresses to about 1 kB: the limit must count the decompressed bytes.
    from zeromode.service.wire.settings import Settings

    limit = Settings().max_body_bytes
    bomb = gzip.compress(b'{"frame": ' + b" " * (limit + 1) + b"}")
    response = httpx.post(
        f"{url}/v1/analyze",
        content=bomb,
        headers={"content-type": "application/json", "content-encoding": "gzip"},
        timeout=60.0,
    )
    assert response.status_code == 413
    assert response.json()["detail"]["code"] == "body_too_large"
