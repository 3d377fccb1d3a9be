"""POST /v1/map and POST /v1/design/sequential through the client against the real service on
loopback, checked against the two-triangle module's closed-form map (tests/oracles)."""

from __future__ import annotations

import itertools

import httpx
import numpy as np
import pytest
from oracles.two_triangles import TwoTriangles

from zeromode.service.wire.schemas.sequential import SEQUENTIAL_EXAMPLES
from zeromode_client import Client, ZeromodeError

MODULE = {"dim": 2, "positions": [[-1, 0], [1, 0], [-0.8, 1], [0.8, 1], [0.15, 0.45]],
          "edges": [[0, 2], [0, 4], [2, 4], [1, 3], [1, 4], [3, 4]]}


@pytest.fixture(scope="module")
def client(service_url: str):
    with Client(service_url) as c:
        yield c


def test_map_of_a_module_is_its_closed_form(client: Client) -> None:
    exact = TwoTriangles(MODULE["positions"])
    at = [0.8, 1.2, 1.9]
    result = client.module_map(MODULE, (0, 1), (2, 3), at=at)
    assert [result["lower"]["d_in"], result["upper"]["d_in"]] == pytest.approx(exact.range(), rel=1e-9)
    assert result["lower"]["kind"] == result["upper"]["kind"] == "fold"
    for point in result["evaluated"]:
        assert point["d_out"] == pytest.approx(exact.f(point["d_in"]), rel=1e-11)
        assert point["slope"] == pytest.approx(exact.slope(point["d_in"]), rel=1e-8)
    for fixed in result["fixed_points"]:
        assert exact.f(fixed["d"]) == pytest.approx(fixed["d"], rel=1e-12)
        assert fixed["stable"] == (abs(exact.slope(fixed["d"])) < 1)


def test_map_refusals(client: Client) -> None:
    with pytest.raises(ZeromodeError) as bar:
        client.module_map(MODULE, (0, 2), (1, 3))
    assert bar.value.status == 422 and bar.value.code == "invalid_pair"
    with pytest.raises(ZeromodeError) as outside:
        client.module_map(MODULE, (0, 1), (2, 3), at=[5.0])
    assert outside.value.code == "out_of_range"


def test_sequential_design_and_chain_follow_the_closed_form(client: Client) -> None:
    result = client.design_sequential(
        features=[{"kind": "fixed_point", "d": 1.2, "slope": 1.8}, {"kind": "fixed_point", "d": 1.8, "slope": 0.4}],
        chain={"n_modules": 8, "d0": 1.25},
    )
    exact = TwoTriangles(result["module"]["frame"]["positions"])
    for d, slope in ((1.2, 1.8), (1.8, 0.4)):
        assert exact.f(d) == pytest.approx(d, rel=1e-8)
        assert exact.slope(d) == pytest.approx(slope, rel=1e-8)
    chain = result["chain"]
    d = np.asarray(chain["distances"])
    lo, hi = exact.range()
    worst = max(abs(exact.f(d[p, k]) - d[p, k + 1]) / d[p, k + 1]
                for p in range(len(d)) for k in range(d.shape[1] - 1) if lo < d[p, k] < hi)
    assert worst <= result["map_rtol"] and chain["deviation"] <= result["map_rtol"]
    # the chained frame: each pair's distance in its positions is the iterate it was built with
    x = np.asarray(chain["frame"]["positions"])
    pairs = np.asarray(chain["pairs"])
    assert np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1) == pytest.approx(chain["iterates"], rel=1e-12)


def test_feature_out_of_reach_is_a_422_with_the_best_figures(client: Client, service_url: str) -> None:
    r = httpx.post(f"{service_url}/v1/design/sequential",
                   json={"features": [{"kind": "fixed_point", "d": 1.2, "slope": 40.0}]}, timeout=120)
    assert r.status_code == 422
    detail = r.json()["detail"]
    assert detail["code"] == "feature_out_of_reach"
    best = detail["best"]
    assert best["features"][0]["d_in"] == 1.2 and len(best["positions"]) == 5 and best["deviation"] > 1e-8
    with pytest.raises(ZeromodeError) as far:  # no node pair within reach is this far apart
        client.design_sequential(features=[{"kind": "fixed_point", "d": 1e300, "slope": 0.5}])
    assert far.value.code == "feature_out_of_reach"
    with pytest.raises(ZeromodeError) as same:
        client.design_sequential(features=[{"kind": "period_two", "d1": 1.3, "d2": 1.3}])
    assert same.value.code == "invalid_feature"
    with pytest.raises(ZeromodeError) as unknown:
        client.design_sequential(features=[{"kind": "chaos"}])
    assert unknown.value.code == "invalid_request"


@pytest.mark.parametrize("name", sorted(SEQUENTIAL_EXAMPLES))
def test_named_examples_are_served(client: Client, name: str) -> None:
    body = SEQUENTIAL_EXAMPLES[name]["value"]
    result = client.design_sequential(**body)
    assert result["deviation"] <= result["map_rtol"]
    exact = TwoTriangles(result["module"]["frame"]["positions"])
    for f in result["features"]:
        assert exact.f(f["d_in"]) == pytest.approx(f["d_out"], rel=1e-8)
    if result["chain"] is not None:
        assert result["chain"]["deviation"] <= result["map_rtol"]


def test_soliton_through_the_client_by_the_definition(client: Client) -> None:
    result = client.design_sequential(
        features=[{"kind": "fixed_point", "d": 1.2, "slope": 1.8}, {"kind": "fixed_point", "d": 1.8, "slope": 0.4}],
        soliton={"n_modules": 8, "stiffness": 2.0},
    )
    sol, chain = result["soliton"], result["chain"]
    exact = TwoTriangles(result["module"]["frame"]["positions"])
    d_u, d_s = sol["unstable"]["d"], sol["stable"]["d"]
    assert exact.f(d_u) == pytest.approx(d_u, rel=1e-12) and exact.f(d_s) == pytest.approx(d_s, rel=1e-12)
    pairs = np.asarray(sol["springs"]["pairs"])
    k, rest = np.asarray(sol["springs"]["stiffness"]), np.asarray(sol["springs"]["rest_length"])
    assert len(pairs) == 8 and np.all(k == 2.0)

    def energy(x):  # E = Σ k (|x_i − x_j| − L)²/2
        x = np.asarray(x)
        return 0.5 * np.sum(k * (np.linalg.norm(x[pairs[:, 0]] - x[pairs[:, 1]], axis=1) - rest) ** 2)

    distances = np.asarray(chain["distances"])[sol["rows"]]
    for row, wall in zip(distances, sol["wall"]):
        # the chain's conformation is the orbit of the module's closed-form map …
        assert [exact.f(d) for d in row[:-1]] == pytest.approx(row[1:], rel=result["map_rtol"])
        # … and the wall is where (d_k − d_u)/(d_s − d_u) crosses ½
        s = (row - d_u) / (d_s - d_u)
        up = [i for i in range(8) if s[i] < 0.5 <= s[i + 1]]
        assert (wall is None) == (not up)
        if up:
            assert wall == pytest.approx(up[0] + (0.5 - s[up[0]]) / (s[up[0] + 1] - s[up[0]]), abs=1e-12)
    walls = [w for w in sol["wall"] if w is not None]
    assert all(b < a for a, b in itertools.pairwise(walls)) and max(walls) - min(walls) >= sol["required_travel"] == 6
    for i, row in enumerate(sol["rows"]):
        assert energy(chain["path"][row]) == pytest.approx(sol["energy"][i], rel=1e-10)
    for state in (sol["unstable"], sol["stable"]):
        assert energy(state["positions"]) < 1e-20 and state["hessian_min_eigenvalue"] > 0
    with pytest.raises(ZeromodeError) as both:
        client.design_sequential(features=[{"kind": "fixed_point", "d": 1.2, "slope": 1.8},
                                           {"kind": "fixed_point", "d": 1.8, "slope": 0.4}],
                                 chain={"n_modules": 8}, soliton={"n_modules": 8})
    assert both.value.code == "invalid_soliton"
    with pytest.raises(ZeromodeError) as one:
        client.design_sequential(features=[{"kind": "fixed_point", "d": 1.2, "slope": 1.8}], soliton={})
    assert one.value.code == "invalid_soliton"
