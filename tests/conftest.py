"""Shared test setup.

zeromode's numerics are many small dense problems; a multi-threaded BLAS only contends on the
2-core CI machine, so tests run single-threaded like the service (set before numpy loads).
"""

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import shutil
import tempfile

# Apps built with default settings keep their job records in this session's own SQLite file,
# not in the user's state directory; nothing the tests start writes its state or caches under
# the user's home either (the suite writes only in the checkout and the system temp directory).
_STATE = tempfile.mkdtemp(prefix="zeromode-tests-")
os.environ.setdefault("ZEROMODE_DATABASE_URL", f"sqlite:///{_STATE}/jobs.sqlite3")
os.environ["XDG_STATE_HOME"] = f"{_STATE}/state"
os.environ["XDG_CACHE_HOME"] = f"{_STATE}/cache"
os.environ["XDG_CONFIG_HOME"] = f"{_STATE}/config"
# What reads HOME itself (chromium's crash reports and dconf, matplotlib's and ezdxf's caches)
# writes there too, never in the user's home.
os.environ["HOME"] = f"{_STATE}/home"
os.makedirs(os.environ["HOME"])
# Apps under test answer every request in process unless a test turns offloading on
# (tests/test_offload.py): no Dask cluster per test app.
os.environ.setdefault("ZEROMODE_OFFLOAD", "false")


import pytest
from fastapi.testclient import TestClient


def pytest_sessionstart(session: pytest.Session) -> None:
    """Load the analysis's compiled kernels once, before any test, or compile them in a fresh
    environment (half a minute of CPU, .ci/run's cold cache): no test's client timeout has to
    absorb that, and the services the tests start load them from the same cache."""
    from zeromode.solver.analysis.rigidity import warm_up

    warm_up()


def pytest_sessionfinish(session: pytest.Session) -> None:
    """The session's state directory goes with it (the services it started have stopped)."""
    shutil.rmtree(_STATE, ignore_errors=True)


@pytest.fixture(scope="session")
def client() -> TestClient:
    """The real app in process; server exceptions become 500 responses, as a client sees them."""
    from zeromode.service.rest.app import create_app

    return TestClient(create_app(), raise_server_exceptions=False)


@pytest.fixture(scope="session")
def dask_scheduler():
    """One real Dask cluster of two worker processes on loopback for the session; apps under
    test point ZEROMODE_DASK_SCHEDULER at it instead of each starting their own."""
    from zeromode.service.jobs.cluster import local_cluster
    from zeromode.service.wire.settings import Settings

    cluster = local_cluster(Settings(dask_workers=2))
    try:
        yield cluster.scheduler_address
    finally:
        cluster.close()


@pytest.fixture(scope="session")
def postgres():
    """The tests' own PostgreSQL server on loopback for the session (tests/postgres_server.py);
    skipped without its binaries, failed under CI."""
    from postgres_server import postgres_server

    with postgres_server() as server:
        yield server


@pytest.fixture(params=["sqlite", "postgresql"])
def database_url(request, tmp_path) -> str:
    """A new, empty job store: a SQLite file of the test's own, then a database of its own on
    the tests' PostgreSQL server: tests that take it run on both."""
    if request.param == "sqlite":
        return f"sqlite:///{tmp_path}/jobs.sqlite3"
    return request.getfixturevalue("postgres").new_database()
