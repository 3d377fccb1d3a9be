"""Live zeromode services for the client tests: one in a thread, one keyed in a subprocess.

Both listen on loopback ports the kernel chose (bind to port 0), so parallel runs never
collide; both are shut down at the end of the session.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import httpx
import pytest
import uvicorn

from zeromode.service.rest.app import create_app

STARTUP_TIMEOUT_S = 60.0
# The key the keyed service is started with (ZEROMODE_API_KEY).
API_KEY = "test-key-3f9c"


def loopback_socket() -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind(("127.0.0.1", 0))
    return sock


def wait_for_health(url: str, alive: Callable[[], bool], log: Callable[[], str] = str,
                    timeout_s: float = STARTUP_TIMEOUT_S) -> None:
    """Poll GET /health until it answers 200; fail early if the server died."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if not alive():
            pytest.fail(f"the service at {url} stopped while starting:\n{log()}")
        try:
            if httpx.get(f"{url}/health", timeout=2.0).status_code == 200:
                return
        except httpx.TransportError:
            pass
        time.sleep(0.05)
    pytest.fail(
        f"the service at {url} did not answer /health within {timeout_s} s:\n{log()}"
    )


@contextmanager
def served(app) -> Iterator[str]:
    """``app`` served by a real uvicorn in a background thread on a loopback port the kernel
    chose; its URL once /health answers, the server stopped on exit."""
    sock = loopback_socket()
    url = f"http://127.0.0.1:{sock.getsockname()[1]}"
    server = uvicorn.Server(uvicorn.Config(app, log_level="warning"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    try:
        wait_for_health(url, thread.is_alive)
        yield url
    finally:
        server.should_exit = True
        thread.join(timeout=10)
        sock.close()


@pytest.fixture(scope="session")
def service_url() -> Iterator[str]:
    """The real app (default settings) served by uvicorn in a background thread."""
    with served(create_app()) as url:
        yield url


@dataclass(frozen=True)
class KeyedService:
    url: str
    proc: subprocess.Popen[bytes]
    log_path: Path


@pytest.fixture(scope="session", autouse=True)
def keyed_service(tmp_path_factory: pytest.TempPathFactory) -> Iterator[KeyedService]:
    """The app started with ZEROMODE_API_KEY set: settings are read at import, hence a subprocess.

    Started as soon as the session starts, without waiting: its import (numpy, scipy, cvxpy,
    casadi) then overlaps the other tests instead of adding to the folder's run time.
    """
    with loopback_socket() as sock:
        port = sock.getsockname()[1]
    log_path = tmp_path_factory.mktemp("keyed") / "uvicorn.log"
    command = [sys.executable, "-m", "uvicorn", "zeromode.service.rest.app:app"]
    options = ["--host", "127.0.0.1", "--port", str(port), "--log-level", "warning"]
    with open(log_path, "w") as log:
        proc = subprocess.Popen(
            command + options,
            env={**os.environ, "ZEROMODE_API_KEY": API_KEY},
            stdout=log,
            stderr=subprocess.STDOUT,
        )
    try:
        yield KeyedService(f"http://127.0.0.1:{port}", proc, log_path)
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


@pytest.fixture(scope="session")
def keyed_service_url(keyed_service: KeyedService) -> str:
    wait_for_health(
        keyed_service.url,
        lambda: keyed_service.proc.poll() is None,
        keyed_service.log_path.read_text,
    )
    return keyed_service.url


@pytest.fixture(scope="session")
def api_key() -> str:
    return API_KEY
