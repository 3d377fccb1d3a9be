"""The real app, in process, for the contract tests: one instance for the whole folder."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from zeromode.service.rest.app import create_app


@pytest.fixture(scope="session")
def client() -> TestClient:
    # Server exceptions become 500 responses, seen as a client would see them.
    return TestClient(create_app(), raise_server_exceptions=False)


@pytest.fixture(scope="session")
def openapi(client: TestClient) -> dict:
    response = client.get("/openapi.json")
    assert response.status_code == 200
    return response.json()
