"""Retries, backoff and timeouts: only failed connections are retried, and quickly given up.

Attempts are counted where they happen — at a refusing port (by the elapsed backoff) or at a
counting httpx transport — never through the client's own bookkeeping alone.
"""

from __future__ import annotations

import asyncio
import socket
import time
from collections.abc import Callable, Iterator

import httpx
import pytest
from client_reference import SQUARE

from zeromode_client import (
    AsyncClient,
    Client,
    ZeromodeConnectionError,
    ZeromodeError,
    ZeromodeTimeoutError,
)

BACKOFF = 0.05


@pytest.fixture
def refusing_url() -> Iterator[str]:
    """A loopback port that is bound but not listening: every connection is refused at once."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        yield f"http://127.0.0.1:{sock.getsockname()[1]}"


@pytest.fixture
def silent_url() -> Iterator[str]:
    """A listening port that never answers: connections succeed, reads time out."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        sock.listen(8)
        yield f"http://127.0.0.1:{sock.getsockname()[1]}"


@pytest.mark.parametrize("retries", [0, 2])
def test_refused_connection_is_retried_then_raised(refusing_url: str, retries: int) -> None:
    t0 = time.perf_counter()
    client = Client(refusing_url, retries=retries, backoff=BACKOFF)
    with client, pytest.raises(ZeromodeConnectionError) as info:
        client.analyze(SQUARE)
    elapsed = time.perf_counter() - t0
    assert info.value.attempts == retries + 1 and info.value.status is None
    assert isinstance(info.value.__cause__, httpx.ConnectError)
    waited = sum(BACKOFF * 2**i for i in range(retries))  # 0.05 + 0.1 for two retries
    assert waited <= elapsed < waited + 2.0


def test_async_refused_connection_is_retried_then_raised(refusing_url: str) -> None:
    async def scenario() -> ZeromodeConnectionError:
        async with AsyncClient(refusing_url, retries=2, backoff=BACKOFF) as client:
            with pytest.raises(ZeromodeConnectionError) as info:
                await client.health()
            return info.value

    t0 = time.perf_counter()
    error = asyncio.run(scenario())
    assert error.attempts == 3 and 3 * BACKOFF <= time.perf_counter() - t0 < 2.0


def test_a_silent_service_times_out_without_retry(silent_url: str) -> None:
    t0 = time.perf_counter()
    client = Client(silent_url, timeout=0.3, retries=3, backoff=BACKOFF)
    with client, pytest.raises(ZeromodeTimeoutError) as info:
        client.health()
    assert info.value.code == "timeout"
    assert 0.3 <= time.perf_counter() - t0 < 0.9  # one read timeout, no second attempt


def counting_transport(answer: Callable[[httpx.Request], httpx.Response]):
    calls: list[httpx.Request] = []

    def handler(request: httpx.Request) -> httpx.Response:
        calls.append(request)
        return answer(request)

    return httpx.MockTransport(handler), calls


def refuse(request: httpx.Request) -> httpx.Response:
    raise httpx.ConnectError("connection refused", request=request)


def test_connection_errors_are_retried_up_to_the_limit() -> None:
    transport, calls = counting_transport(refuse)
    client = Client("http://zeromode.test", retries=3, backoff=0.0, transport=transport)
    with client, pytest.raises(ZeromodeConnectionError):
        client.health()
    assert len(calls) == 4


def test_a_connection_that_recovers_succeeds() -> None:
    answers = iter([None, None, {"status": "ok", "version": "9"}])

    def flaky(request: httpx.Request) -> httpx.Response:
        body = next(answers)
        return refuse(request) if body is None else httpx.Response(200, json=body)

    transport, calls = counting_transport(flaky)
    with Client("http://zeromode.test", retries=2, backoff=0.0, transport=transport) as client:
        assert client.health().version == "9"
    assert len(calls) == 3


@pytest.mark.parametrize(
    ("status", "body", "code", "message"),
    [
        (
            422,
            {"detail": {"code": "no_solution", "message": "b is not in R(Ã)."}},
            "no_solution",
            "b is not in R(Ã).",
        ),
        (401, {"detail": {"code": "unauthorized", "message": "key."}}, "unauthorized", "key."),
        (
            500,
            {"detail": {"code": "internal_error", "message": "oops."}},
            "internal_error",
            "oops.",
        ),
        (503, None, "http_error", "Service Unavailable"),
        (404, {"detail": "Not Found"}, "http_error", "Not Found"),
    ],
)
def test_error_answers_raise_at_once(status: int, body, code: str, message: str) -> None:
    def answer(request: httpx.Request) -> httpx.Response:
        return httpx.Response(status, json=body) if body is not None else httpx.Response(status)

    transport, calls = counting_transport(answer)
    client = Client("http://zeromode.test", retries=3, backoff=0.0, transport=transport)
    with client, pytest.raises(ZeromodeError) as info:
        client.analyze(SQUARE)
    assert (info.value.status, info.value.code, info.value.message) == (status, code, message)
    assert len(calls) == 1  # never retried


def test_the_api_key_and_user_agent_headers_are_sent() -> None:
    transport, calls = counting_transport(
        lambda r: httpx.Response(200, json={"status": "ok", "version": "1"})
    )
    with Client("http://zeromode.test/", api_key="k", transport=transport) as client:
        client.health()
    assert calls[0].url == "http://zeromode.test/health"
    assert calls[0].headers["x-api-key"] == "k"
    assert calls[0].headers["user-agent"].startswith("zeromode-client/")


@pytest.mark.parametrize(
    "body", [b"<html>busy</html>", b'{"status": "ok"}'], ids=["html", "field missing"]
)
def test_an_unreadable_success_answer_raises(body: bytes) -> None:
    transport, _ = counting_transport(lambda r: httpx.Response(200, content=body))
    client = Client("http://zeromode.test", transport=transport)
    with client, pytest.raises(ZeromodeError) as info:
        client.health()
    assert (info.value.status, info.value.code) == (200, "invalid_response")
