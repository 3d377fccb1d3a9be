"""POST /v1/design/auxetic on sheets two modules wide, through a real uvicorn server on
loopback: the reported range is the one a continuation of the returned frame finds
(tests/oracles/sheet_range.py), a strain inside it is served with states at that strain, and
one past it is refused naming it (issue #42)."""

from __future__ import annotations

import httpx
import numpy as np
import pytest
from client.conftest import served
from oracles.motion import boundary_strains, relative_bar_error
from oracles.sheet_range import SheetEvents, first_event

from zeromode.service.rest.app import create_app


@pytest.fixture(scope="module")
def url():
    with served(create_app()) as address:
        yield address


def post(url: str, body: dict) -> httpx.Response:
    return httpx.post(f"{url}/v1/design/auxetic", json=body, timeout=120.0)


@pytest.mark.parametrize(
    ("cells", "poisson", "strain", "lower"),
    [([2, 2], -1.0, 0.16, -0.234236), ([2, 3], -0.3, 0.04, -0.323388)],
)
def test_two_column_sheet_is_served_with_the_sheets_own_range(url, cells, poisson, strain, lower):
    r = post(url, {"dim": 2, "cells": cells, "poisson_ratio": poisson, "strain": strain})
    assert r.status_code == 200, r.text
    body = r.json()
    usable = body["report"]["strain_range"]
    x0 = np.array(body["frame"]["positions"])
    edges = np.array(body["frame"]["edges"])
    boundary = {k: np.asarray(v) for k, v in body["report"]["boundary"].items()}
    # The lower end, against the figure and against a continuation of this very frame.
    assert abs(usable["lower"]["strain"] - lower) <= 5e-7
    for end, sign in ((usable["lower"], -1), (usable["upper"], 1)):
        found, reason = first_event(x0, edges, boundary, sign, usable["proximity_fraction"])
        assert end["reason"] == reason and abs(end["strain"] - found) <= 1e-9, (end, found, reason)
    # The states are at ±strain, keep every bar, and keep nodes apart as the report says.
    assert body["report"]["max_relative_bar_error"] <= 1e-9
    apart = SheetEvents(x0, edges, usable["proximity_fraction"])
    for state in body["states"]:
        x = np.array(state["positions"])
        sign = 1 if state["name"] == "expanded" else -1
        ex, _ = boundary_strains(x0, x, boundary, finite=True)
        assert abs(ex - sign * strain) <= 1e-12 and abs(state["strain"] - ex) <= 1e-12
        assert relative_bar_error([x], edges, x0) <= body["report"]["max_relative_bar_error"] + 1e-15
        assert apart.gap(x) >= 0  # no two nodes without a bar closer than the stated fraction
    assert body["report"]["min_node_distance"] >= usable["proximity_fraction"]
    # Past the sheet's own end: refused, naming the range.
    refused = post(url, {"dim": 2, "cells": cells, "poisson_ratio": poisson, "strain": abs(lower) + 1e-3})
    assert refused.status_code == 422
    detail = refused.json()["detail"]
    assert detail["code"] == "strain_out_of_range" and f"{lower:+.6g}" in detail["message"]
