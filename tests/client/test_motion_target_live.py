"""/v1/motion's `target` against the live server (REST with httpx, the Python client) and the
CLI as a subprocess, checked against the four-bar's closed-form position analysis, numpy
recomputations and a lattice's boundary strains (oracles)."""

from __future__ import annotations

import json
import subprocess
import sys

import httpx
import numpy as np
import pytest
from oracles.mechanisms import (
    crank_angle,
    crank_angle_limit,
    four_bar,
    four_bar_at_crank_angle,
    in_ground_frame,
)
from oracles.motion import boundary_strains, relative_bar_error
from oracles.wire import frame_body

from zeromode_client import Client, ZeromodeError

FOUR_BAR = four_bar()
X = FOUR_BAR.positions
A, B = np.linalg.norm(X[1] - X[0]), np.linalg.norm(X[2] - X[1])  # crank, coupler
C, G = np.linalg.norm(X[3] - X[2]), np.linalg.norm(X[3] - X[0])  # rocker, ground
PHI_MAX = crank_angle_limit(X)  # the crank angle's turning point
CRANK = [3, 0, 1]


def check_crank(body: dict, phi: float) -> None:
    end = np.asarray(body["path"][body["target"]["index"]])
    assert abs(crank_angle(end) - phi) <= 1e-10
    assert np.max(np.abs(in_ground_frame(end) - four_bar_at_crank_angle(X, phi))) <= 1e-9
    assert relative_bar_error(body["path"], FOUR_BAR.edges, X) <= 1e-10
    assert body["target"]["error"] <= 1e-10 and body["target"]["kind"] == "angle"
    assert body["parameter"][body["target"]["index"]] == body["target"]["parameter"]


def post(url: str, body: dict) -> httpx.Response:
    return httpx.post(f"{url}/v1/motion", json=body, timeout=120)


@pytest.mark.parametrize("phi", [0.9, -0.6])
def test_crank_to_an_angle_over_rest(service_url, phi):
    r = post(service_url, {"frame": frame_body(FOUR_BAR), "target": {"kind": "angle", "nodes": CRANK, "value": phi}})
    assert r.status_code == 200, r.text
    check_crank(r.json(), phi)
    assert r.json()["singular_start"] is None


def test_crank_to_an_angle_through_the_client(service_url):
    with Client(service_url) as client:
        result = client.motion(frame_body(FOUR_BAR), target={"kind": "angle", "nodes": CRANK, "value": 1.1}, max_step=0.05)
    check_crank(result.raw, 1.1)


def test_distance_target_over_rest(service_url):
    r = post(service_url, {"frame": frame_body(FOUR_BAR), "target": {"kind": "distance", "nodes": [0, 2], "value": 2.0}})
    assert r.status_code == 200, r.text
    end = np.asarray(r.json()["path"][r.json()["target"]["index"]])
    assert abs(np.linalg.norm(end[2] - end[0]) - 2.0) <= 2e-10
    assert relative_bar_error([end], FOUR_BAR.edges, X) <= 1e-10


def test_lattice_strain_target_over_rest(service_url):
    sheet = httpx.post(f"{service_url}/v1/design/auxetic", json={"dim": 2, "cells": [3, 3], "poisson_ratio": -0.5}, timeout=120)
    assert sheet.status_code == 200, sheet.text
    frame, boundary = sheet.json()["frame"], sheet.json()["report"]["boundary"]
    r = post(service_url, {"frame": frame, "boundary": boundary, "target": {"kind": "strain", "axis": "x", "value": -0.03}})
    assert r.status_code == 200, r.text
    body = r.json()
    end = body["path"][body["target"]["index"]]
    eps_x, _ = boundary_strains(frame["positions"], end, boundary, finite=True)
    assert abs(eps_x - (-0.03)) <= 1e-10
    assert abs(body["strains"][body["target"]["index"]][0] - eps_x) <= 1e-12
    edges = np.asarray(frame["edges"])
    assert relative_bar_error(body["path"], edges, np.asarray(frame["positions"])) <= 1e-10


def test_beyond_a_turning_point_is_a_422_with_the_extreme(service_url):
    r = post(service_url, {"frame": frame_body(FOUR_BAR), "target": {"kind": "distance", "nodes": [0, 2], "value": A + B + 0.2}})
    assert r.status_code == 422
    detail = r.json()["detail"]
    assert detail["code"] == "target_past_turning_point"
    assert abs(detail["best"]["target"]["reached"] - (A + B)) <= 1e-7
    with Client(service_url) as client, pytest.raises(ZeromodeError) as info:
        client.motion(frame_body(FOUR_BAR), target={"kind": "angle", "nodes": CRANK, "value": PHI_MAX + 0.1})
    assert info.value.code == "target_past_turning_point"
    assert abs(info.value.detail["best"]["target"]["reached"] - PHI_MAX) <= 1e-7


@pytest.mark.parametrize(
    "change, code",
    [
        ({"target": {"kind": "angle", "nodes": [0, 1, 7], "value": 0.3}}, "invalid_target"),
        ({"target": {"kind": "angle", "nodes": [0, 1, 1], "value": 0.3}}, "invalid_target"),
        ({"target": {"kind": "strain", "axis": "x", "value": 0.1}}, "invalid_target"),
        ({"target": {"kind": "distance", "nodes": [0, 2], "value": 2.0}, "amplitude": 0.3}, "invalid_request"),
        ({"target": {"kind": "volume", "value": 2.0}}, "invalid_request"),
    ],
)
def test_bad_targets_are_a_422_with_a_code_and_a_sentence(service_url, change, code):
    r = post(service_url, {"frame": frame_body(FOUR_BAR), **change})
    assert r.status_code == 422
    assert r.json()["detail"]["code"] == code
    assert r.json()["detail"]["message"].endswith(".")


def test_a_path_from_a_branch_point_says_so(service_url):
    flat = {"dim": 2, "positions": [[0, 0], [2, 0], [3, 0], [1, 0]], "edges": [[0, 1], [1, 2], [2, 3], [3, 0]]}
    r = post(service_url, {"frame": flat, "mode": [[0, 0], [0, 0], [0, 1], [0, 1]], "amplitude": 0.2})
    assert r.status_code == 200, r.text
    start = r.json()["singular_start"]
    assert start is not None and start["step"] == r.json()["reference_index"] and start["parameter"] == 0.0
    assert start["extra_zero_modes"] == 1


def test_cli_motion_command_drives_the_crank(tmp_path):
    frame_file = tmp_path / "four_bar.json"
    frame_file.write_text(json.dumps(frame_body(FOUR_BAR)))
    target = json.dumps({"kind": "angle", "nodes": CRANK, "value": 0.8})
    run = subprocess.run(
        [sys.executable, "-m", "zeromode.service.cli", "motion", str(frame_file), "--target", target],
        check=False, capture_output=True, text=True, timeout=300,
    )
    assert run.returncode == 0, run.stderr
    check_crank(json.loads(run.stdout), 0.8)
    refused = json.dumps({"kind": "angle", "nodes": CRANK, "value": PHI_MAX + 0.1})
    run = subprocess.run(
        [sys.executable, "-m", "zeromode.service.cli", "motion", str(frame_file), "--target", refused],
        check=False, capture_output=True, text=True, timeout=300,
    )
    assert run.returncode == 2 and "target_past_turning_point" in run.stderr
