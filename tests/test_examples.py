"""The named examples (`zeromode example list`) reproduce the paper's counts.

Every /v1/design example is designed through POST /v1/design and its frame is re-analysed with the test
suite's own reference rank (tests/oracles/rigidity.py): exactly d(d+1)/2 + M zero modes, no
self-stress, every requested motion a zero mode, and the paper's node counts where it gives them.
The examples are JSON files of the zeromode.service.wire.examples package: GET /v1/examples serves
them, and a built wheel carries them. An example for another endpoint names it ("endpoint");
its own test checks its answer (tests/test_api_multistable.py).
"""

import json
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from oracles.rigidity import compatibility_matrix, normalised, reference_counts

from zeromode.service.wire.examples import (
    example_description,
    example_endpoint,
    example_names,
    example_request,
)

REPO = Path(__file__).resolve().parents[1]

# Unspecified nodes the paper reports (Fig. 3b–c, Fig. 4) or bounds (Fig. 3e: at most 5).
PAPER_NODES = {
    "outward_2d": (2, 2),
    "outward_2d_four_nodes": (4, 4),
    "cube_outward_3d": (1, 5),
    "two_mode_2d": (1, 1),
    "two_mode_3d": (4, 4),
}


@pytest.mark.parametrize("name", [n for n in example_names() if example_endpoint(n) == "/v1/design"])
def test_example_designs_as_in_the_paper(client, name):
    request = example_request(name)
    response = client.post("/v1/design", json=request)
    assert response.status_code == 200, response.text
    body = response.json()
    d, motions = request["dim"], request["motions"]
    x = np.asarray(body["frame"]["positions"], dtype=float)
    edges = np.asarray(body["frame"]["edges"], dtype=int)
    counts = reference_counts(x, edges)
    assert counts["zero_modes"] == d * (d + 1) // 2 + len(motions)
    assert counts["self_stresses"] == 0
    c = compatibility_matrix(normalised(x), edges)
    for mode in body["modes"]:
        u = np.asarray(mode, dtype=float).ravel()
        assert np.linalg.norm(c @ u) <= 1e-9 * np.linalg.norm(c) * np.linalg.norm(u)
    if name in PAPER_NODES:
        low, high = PAPER_NODES[name]
        assert low <= len(x) - len(request["positions"]) <= high


def test_the_service_lists_and_serves_every_example_file(client):
    files = sorted(p.stem for p in (REPO / "service" / "wire" / "examples").glob("*.json"))
    assert len(files) >= 8 and example_names() == files
    listed = client.get("/v1/examples").json()
    assert [e["name"] for e in listed] == files
    for name in files:
        on_disk = json.loads((REPO / "service" / "wire" / "examples" / f"{name}.json").read_text(encoding="utf-8"))
        endpoint = on_disk.get("endpoint", "/v1/design")
        assert {"name": name, "description": on_disk["description"], "endpoint": endpoint} in listed
        assert endpoint in client.app.openapi()["paths"]
        assert client.get(f"/v1/examples/{name}/request").json() == on_disk["request"]
        assert example_description(name) == on_disk["description"]
    # A copy: changing it changes nothing served.
    example_request(files[0])["dim"] = 7
    assert example_request(files[0]) == json.loads(
        (REPO / "service" / "wire" / "examples" / f"{files[0]}.json").read_text(encoding="utf-8")
    )["request"]
    missing = client.get("/v1/examples/no_such_example/request")
    assert missing.status_code == 404 and missing.json()["detail"]["code"] == "unknown_example"


@pytest.mark.slow
def test_a_built_wheel_carries_the_examples_and_the_pictures(tmp_path):
    """A non-editable install gets the package data: build the wheel (pip, build isolation:
    downloads setuptools) and list it."""
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path), str(REPO)],
        check=True, timeout=600,
    )
    (wheel,) = tmp_path.glob("zeromode-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    for path in (REPO / "service" / "wire" / "examples").glob("*.json"):
        assert f"zeromode/service/wire/examples/{path.name}" in names
    for path in (REPO / "viz").glob("*.py"):
        assert f"zeromode/viz/{path.name}" in names
