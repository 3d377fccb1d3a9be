

@pytest.fixture(scope="module")
def served() -> Iterator[str]:
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


def test_oversized_headers_are_refused_by_the_server(served):
    response = httpx.get(f"{served}/health", headers={"x-padding": "a" * 100_000})
    assert 400 <= response.status_code < 500
    assert httpx.get(f"{served}/health").status_code == 200


def test_connections_past_the_cap_are_answered_503_and_the_service_recovers(served):
    idle = [socket.create_connection(("127.0.0.1", int(served.rsplit(":", 1)[1]))) for _ in range(12)]
    for conn in idle:
        conn.sendall(b"GET /health HTTP/1.1\r\nHost: x\r\n")  # headers never finished
    time.sleep(0.3)
    assert httpx.get(f"{served}/health").status_code == 503  # refused at once, not queued
    for conn in idle:
        conn.close()
    time.sleep(0.3)
    assert httpx.get(f"{served}/health").status_code == 200
