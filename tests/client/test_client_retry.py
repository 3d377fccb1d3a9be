"""Retries, backoff and timeouts: only failed connections are retried, after the documented
backoff·2^(attempt−1) waits.

Attempts are counted where they happen — at a listening socket that accepts and never answers,
at a counting httpx transport, or by the waits between them (time.sleep / asyncio.sleep
recorded, not slept) — never through the client's own bookkeeping alone, and never by timing
the wall clock.
"""

from __future__ import annotations

import asyncio
import socket
import threading
import time
from collections.abc import Callable, Iterator

import httpx
import pytest
from oracles import frames

from zeromode_client import (
    AsyncClient,
    Client,
    Frame,
    ZeromodeConnectionError,
    ZeromodeError,
    ZeromodeTimeoutError,
)

BACKOFF = 0.05
SQUARE = Frame.from_json(frames.SQUARE)


@pytest.fixture
def refusing_url() -> Iterator[str]:
    """A loopback port that is bound but not listening: every connection is refused at once."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        yield f"http://127.0.0.1:{sock.getsockname()[1]}"


@pytest.fixture
def silent_url() -> Iterator[tuple[str, list[socket.socket]]]:
    """A port that accepts connections (listed as they arrive) and never answers: reads time out."""
    accepted: list[socket.socket] = []
    stop = threading.Event()
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        sock.listen(8)
        sock.settimeout(0.05)

        def accept() -> None:
            while not stop.is_set():
                try:
                    accepted.append(sock.accept()[0])
                except TimeoutError:
                    continue

        thread = threading.Thread(target=accept, daemon=True)
        thread.start()
        try:
            yield f"http://127.0.0.1:{sock.getsockname()[1]}", accepted
        finally:
            stop.set()
            thread.join()
            for conn in accepted:
                conn.close()


@pytest.fixture
def sleeps(monkeypatch: pytest.MonkeyPatch) -> list[float]:
    """The waits this test's thread asks for, recorded instead of slept (time.sleep and
    asyncio.sleep); other threads (the live service of this folder) sleep as usual."""
    asked: list[float] = []
    here = threading.current_thread()
    real_sleep, real_async_sleep = time.sleep, asyncio.sleep

    def sleep(delay: float) -> None:
        if threading.current_thread() is here:
            asked.append(delay)
        else:
            real_sleep(delay)

    async def async_sleep(delay: float, *args, **kwargs):
        if threading.current_thread() is not here:
            return await real_async_sleep(delay, *args, **kwargs)
        asked.append(delay)
        return await real_async_sleep(0, *args, **kwargs)

    monkeypatch.setattr(time, "sleep", sleep)
    monkeypatch.setattr(asyncio, "sleep", async_sleep)
    return asked


def backoffs(retries: int) -> list[float]:
    """backoff·2^(attempt−1) before each retry."""
    return [BACKOFF * 2**i for i in range(retries)]


@pytest.mark.parametrize("retries", [0, 2])
def test_refused_connection_is_retried_then_raised(
    refusing_url: str, sleeps: list[float], retries: int
) -> None:
    client = Client(refusing_url, retries=retries, backoff=BACKOFF)
    with client, pytest.raises(ZeromodeConnectionError) as info:
        client.analyze(SQUARE)
    assert info.value.attempts == retries + 1 and info.value.status is None
    assert isinstance(info.value.__cause__, httpx.ConnectError)
    assert sleeps == pytest.approx(backoffs(retries))


def test_async_refused_connection_is_retried_then_raised(
    refusing_url: str, sleeps: list[float]
) -> None:
    async def scenario() -> ZeromodeConnectionError:
        async with AsyncClient(refusing_url, retries=2, backoff=BACKOFF) as client:
            with pytest.raises(ZeromodeConnectionError) as info:
                await client.health()
            return info.value

    error = asyncio.run(scenario())
    assert error.attempts == 3
    # Zero-length sleeps are the event loop's own checkpoints, not waits.
    assert [delay for delay in sleeps if delay > 0] == pytest.approx(backoffs(2))


def test_a_silent_service_times_out_without_retry(silent_url, sleeps: list[float]) -> None:
    url, accepted = silent_url
    client = Client(url, timeout=0.3, retries=3, backoff=BACKOFF)
    with client, pytest.raises(ZeromodeTimeoutError) as info:
        client.health()
    assert info.value.code == "timeout"
    assert len(accepted) == 1 and sleeps == []  # one read timeout, no second attempt


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
