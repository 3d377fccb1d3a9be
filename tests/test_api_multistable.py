"""POST /v1/design/multistable, zm.multistable and the named example, checked from the body
alone by the tests' own oracles: rods keep their lengths in every conformation, an independent
continuation meets them, the energy and the rods-as-constraints curvature from the definition,
and the barriers on the body's own landscape."""

import itertools

import numpy as np
import pytest
from oracles.elastic import constrained_curvature, energy
from oracles.motion import bar_lengths, fidelity

import zeromode as zm
from zeromode.service.wire.examples import example_endpoint, example_request
from zeromode.solver.errors import DomainError

REQUEST = example_request("tristable_triangle_2d")


@pytest.fixture(scope="module")
def body(client):
    response = client.post("/v1/design/multistable", json=REQUEST)
    assert response.status_code == 200, response.text
    return response.json()


def test_the_example_names_its_endpoint():
    assert example_endpoint("tristable_triangle_2d") == "/v1/design/multistable"
    assert example_endpoint("outward_2d") == "/v1/design"


def test_served_design_is_tristable_by_the_definition(body):
    edges = np.asarray(body["frame"]["edges"])
    confs = np.asarray(body["conformations"], dtype=float)
    k = len(REQUEST["conformations"][0])
    assert np.array_equal(confs[:, :k], np.asarray(REQUEST["conformations"], dtype=float))
    lengths = [bar_lengths(c, edges) for c in confs]
    assert max(np.max(np.abs(ell - lengths[0]) / lengths[0]) for ell in lengths) <= 1e-12
    for c in confs[1:]:
        assert fidelity(confs[0], edges, range(len(confs[0])), c - confs[0]) <= 1e-6
    springs = body["springs"]
    pairs, stiffness, rest = (np.asarray(springs[f], dtype=float) for f in ("pairs", "stiffness", "rest_length"))
    pairs = pairs.astype(int)
    assert not {tuple(sorted(p)) for p in pairs.tolist()} & {tuple(sorted(e)) for e in edges.tolist()}
    assert len(body["minima"]) == 3
    for m, c in zip(body["minima"], confs):
        assert energy(c, pairs, stiffness, rest) == pytest.approx(m["energy"], rel=1e-12)
        kkt, curvature = constrained_curvature(c, edges, pairs, stiffness, rest)
        assert kkt <= 1e-7 and curvature > 0 and curvature == pytest.approx(m["curvature"], rel=1e-4)
        assert m["hessian_min_eigenvalue"] > 0
    e = np.asarray(body["landscape"]["energy"])
    at = body["landscape"]["conformation_samples"]
    barrier = body["report"]["barrier"]
    for left, right in itertools.pairwise(at):
        top = e[left : right + 1].max()
        assert top - max(e[left], e[right]) >= barrier * (1 - 1e-9)
        assert e[left] < e[left + 1] and e[right] < e[right - 1]  # strict minima on the samples
    # The motion itself (what the viewer animates): every rod at its length at every sample, the
    # springs' energy there the landscape's, each conformation at its sample up to a rigid motion.
    path = np.asarray(body["landscape"]["positions"], dtype=float)
    assert path.shape == (len(e), *confs[0].shape)
    assert max(np.max(np.abs(bar_lengths(p, edges) / lengths[0] - 1)) for p in path) <= 1e-9
    assert [energy(p, pairs, stiffness, rest) for p in path] == pytest.approx(e, rel=1e-9, abs=1e-12)
    gram = lambda p: np.linalg.norm(p[:, None] - p[None], axis=-1)
    for c, sample in zip(confs, at):
        assert np.allclose(gram(path[sample]), gram(c), atol=1e-9)
    report = body["report"]
    assert report["analysis"]["nontrivial_zero_modes"] == 1 and report["analysis"]["self_stresses"] == 0
    assert report["springs"] == len(pairs) and report["rods"] == len(edges)


def test_refusals_name_their_code(client):
    high = client.post("/v1/design/multistable", json={**REQUEST, "options": {"barrier": 10.0}})
    assert high.status_code == 422 and high.json()["detail"]["code"] == "no_springs"
    assert "largest barrier" in high.json()["detail"]["message"]
    a = np.asarray(REQUEST["conformations"][0])
    dilated = {"dim": 2, "conformations": [a.tolist(), (1.2 * a).tolist(), (1.4 * a).tolist()]}
    none = client.post("/v1/design/multistable", json=dilated)
    assert none.status_code == 422 and none.json()["detail"]["code"] == "no_linkage"
    one = client.post("/v1/design/multistable", json={**REQUEST, "conformations": REQUEST["conformations"][:1]})
    assert one.status_code == 422 and one.json()["detail"]["code"] == "invalid_request"
    typo = client.post("/v1/design/multistable", json={**REQUEST, "options": {"barier": 1.0}})
    assert typo.status_code == 422 and typo.json()["detail"]["code"] == "invalid_request"


def test_library_door_gives_the_rest_body_and_plots_the_landscape(body):
    r = zm.multistable(REQUEST["conformations"], seed=0)
    mine = r.to_dict()
    for key in ("frame", "conformations", "springs", "landscape", "minima"):
        assert mine[key] == body[key]
    figure = r.plot()
    (axes,) = figure.axes
    (curve, *_) = axes.lines
    assert np.allclose(curve.get_ydata(), np.asarray(body["landscape"]["energy"]) - min(body["landscape"]["energy"]))
    with pytest.raises(DomainError) as err:
        zm.multistable(REQUEST["conformations"], barrier=10.0)
    assert err.value.code == "no_springs"


def test_cli_designs_the_example(tmp_path):
    import json
    import subprocess
    import sys

    request = tmp_path / "tristable.json"
    request.write_text(json.dumps(REQUEST), encoding="utf-8")
    out = tmp_path / "answer.json"
    subprocess.run([sys.executable, "-m", "zeromode.service.cli", "design", str(request), "-o", str(out)],
                   check=True, timeout=300)
    answer = json.loads(out.read_text(encoding="utf-8"))
    assert len(answer["minima"]) == 3 and all(m["curvature"] > 0 for m in answer["minima"])


def test_a_multistable_job_answers_as_the_endpoint(tmp_path, dask_scheduler):
    from test_jobs import app_client, submit, wait, without_timings

    with app_client(tmp_path, dask_scheduler) as client:
        status = wait(client, submit(client, "/v1/design/multistable", REQUEST))
        assert status["status"] == "done", status
        direct = client.post("/v1/design/multistable", json=REQUEST)
        assert without_timings(status["result"]) == without_timings(direct.json())
        # Refused at submit with the endpoint's own code (the precheck), nothing queued.
        a = REQUEST["conformations"][0]
        rigid = {**REQUEST, "conformations": [a, REQUEST["conformations"][1], [[x + 1.0, y] for x, y in a]]}
        r = client.post("/v1/jobs", json={"endpoint": "/v1/design/multistable", "request": rigid})
        assert r.status_code == 422 and r.json()["detail"]["code"] == "rigid_target"
