"""Shared test setup.

zeromode's numerics are many small dense problems; a multi-threaded BLAS only contends on the
2-core CI machine, so tests run single-threaded like the service (set before numpy loads).
"""

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")


import pytest  # noqa: E402
from fastapi.testclient import TestClient  # noqa: E402


@pytest.fixture(scope="session")
def client() -> TestClient:
    """The real app in process; server exceptions become 500 responses, as a client sees them."""
    from zeromode.service.app import create_app

    return TestClient(create_app(), raise_server_exceptions=False)
