"""API key: a service started with ZEROMODE_API_KEY answers /v1/* only with the right X-API-Key."""

from __future__ import annotations

import pytest
from oracles import frames

from zeromode_client import Client, Frame, ZeromodeError

SQUARE = Frame.from_json(frames.SQUARE)


def test_health_stays_open(keyed_service_url: str) -> None:
    with Client(keyed_service_url) as client:
        assert client.health().status == "ok"


@pytest.mark.parametrize("key", [None, "wrong-key"], ids=["no key", "wrong key"])
def test_v1_needs_the_key(keyed_service_url: str, key: str | None) -> None:
    with Client(keyed_service_url, api_key=key) as client, pytest.raises(ZeromodeError) as info:
        client.analyze(SQUARE)
    assert (info.value.status, info.value.code) == (401, "unauthorized")
    assert "X-API-Key" in info.value.message


def test_the_key_opens_v1(keyed_service_url: str, api_key: str) -> None:
    with Client(keyed_service_url, api_key=api_key) as client:
        assert client.analyze(SQUARE).nontrivial_zero_modes == 1
