"""Branched multistable designs and the ``no_path`` refusal against the real service (uvicorn on
loopback): the client's answer has its branch point where it was asked, with the rank drop and
both tangents checked here from the definition; a triangle whose orientation flips between two
conformations is refused with ``no_path`` and the figures of the closest motion found."""

from __future__ import annotations

import httpx
import numpy as np
from oracles.motion import bar_lengths
from oracles.rigidity import compatibility_matrix

from zeromode_client import Client

APEX = [[0.3, 0.8], [0.45, 1.0], [0.65, 1.15]]
CONFORMATIONS = [[[0.0, 0.0], [1.0, 0.0], p] for p in APEX]
# The specified triangle turns over (its apex crosses the line of its base): a motion between
# the two must make the three nodes collinear on the way, which no linkage the construction finds
# does; each attempt is refused quickly (the traced motion ends without meeting conformation 1).
FLIPPED = [[[0.0, 0.0], [1.0, 0.0], [0.4, 0.15]], [[0.0, 0.0], [1.0, 0.0], [0.6, -0.15]]]


def test_branched_design_over_the_client(service_url: str) -> None:
    with Client(service_url, timeout=300.0) as client:
        result = client.design_multistable(dim=2, conformations=CONFORMATIONS, options={"bifurcation": 0})
    b = result["bifurcation"]
    assert b["index"] == 0 and [m["index"] for m in result["minima"]] == [1, 2]
    edges = np.asarray(result["frame"]["edges"])
    confs = result.array("conformations")
    lengths = [bar_lengths(c, edges) for c in confs]
    assert max(np.max(np.abs(ell - lengths[0]) / lengths[0]) for ell in lengths) <= 1e-12
    x = confs[0] - confs[0].mean(axis=0)
    x = x / np.sqrt(np.mean(np.sum(x * x, axis=1)))
    c = compatibility_matrix(x, edges)  # C from the definition (tests/oracles)
    s = np.linalg.svd(c, compute_uv=False)
    assert s[-1] <= 1e-12 * s[0] < 1e-3 * s[-2]  # one rank lost: a self-stress
    omega = np.linalg.svd(c)[0][:, -1]
    for name in ("taken_tangent", "other_tangent"):
        t = np.asarray(b[name], dtype=float)
        assert np.linalg.norm(c @ t.ravel()) <= 1e-9 * s[0]
        du = t[edges[:, 0]] - t[edges[:, 1]]
        q = np.sum(omega * np.sum(du * du, axis=1))
        assert abs(q) <= 1e-9 * np.sum(np.abs(omega) * np.sum(du * du, axis=1))


def test_no_path_is_refused_with_its_figures(service_url: str) -> None:
    orientation = [np.linalg.det(np.array(c[1:]) - np.array(c[0])) for c in FLIPPED]
    assert orientation[0] * orientation[1] < 0  # the premise: the triangle turns over
    response = httpx.post(f"{service_url}/v1/design/multistable", json={"dim": 2, "conformations": FLIPPED}, timeout=300.0)
    assert response.status_code == 422, response.text
    detail = response.json()["detail"]
    assert detail["code"] == "no_path" and "conformation 1" in detail["message"]
    best = detail["best"]
    assert best["epsilons"][0] == 0.0 and best["epsilons"][1] > 1e-6
    assert f"{best['epsilons'][1]:.2e}" in detail["message"]
    assert len(best["parameters"]) == 2 and best["traced_to"] > 0
