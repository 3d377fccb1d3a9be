"""A /v1/map answer drawn and exported (issue #41's undone item 1), and a chain's XDMF read from
its verified ``chain.path`` (item 2): from the library, over REST on a real uvicorn server, and
through the ``zeromode`` command.

Independent routes: the exported map (CSV) is compared with the scipy oracle of
tests/test_jobs_sequential.py (the module's bar lengths kept and |x_a − x_b| = d_in, solved by
least squares from the reference, nothing of solver/sequential); its fixed points are found
again on that oracle by Brent's method and their stability by its central difference; the
frame formats are read back with meshio, networkx and csv against the request's frame; the
picture's elements are counted in its SVG and its PNG's colours looked for; the XDMF's time
steps are read back with meshio and compared with the design's own chain.path.
"""

from __future__ import annotations

import csv
import io
import json
import xml.etree.ElementTree as ET
from pathlib import Path

import httpx
import meshio
import networkx as nx
import numpy as np
import pytest
from client.conftest import served
from PIL import Image
from scipy.optimize import brentq
from test_jobs_sequential import EDGES, MODULES, map_request, oracle_map, oracle_slope, zeromode

import zeromode as zm
from zeromode.service.rest.app import create_app
from zeromode.viz.style import SOURCE, TARGET

SVG = "{http://www.w3.org/2000/svg}"
# The deployable module's features: an unstable fixed point (f′ = 1.8) and a stable one (0.4).
DEPLOYABLE = [{"kind": "fixed_point", "d": 1.2, "slope": 1.8}, {"kind": "fixed_point", "d": 1.8, "slope": 0.4}]


@pytest.fixture(scope="module")
def service():
    with served(create_app()) as url, httpx.Client(base_url=url, timeout=300) as http:
        yield http


@pytest.fixture(scope="module")
def deployable_module() -> list[list[float]]:
    """The positions of a module designed to have both an unstable and a stable fixed point."""
    return zm.sequential(DEPLOYABLE).to_dict()["module"]["frame"]["positions"]


def post(http: httpx.Client, path: str, body: dict) -> httpx.Response:
    r = http.post(path, json=body)
    assert r.status_code == 200, r.text
    return r


def read_csv(content: bytes) -> tuple[list[str], np.ndarray]:
    rows = list(csv.reader(io.StringIO(content.decode())))
    return rows[0], np.array(rows[1:], dtype=float)


def oracle_fixed_points(positions, lower: float, upper: float, n: int = 24) -> list[tuple[float, bool]]:
    """(d*, stable) of f(d) = d by the oracle: sign changes of f(d) − d on a grid strictly inside
    the usable range, refined by Brent's method; stable when |f′(d*)| < 1 (central difference)."""
    grid = np.linspace(lower, upper, n + 2)[1:-1]
    g = np.array([oracle_map(positions, d) - d for d in grid])
    found = []
    for k in np.flatnonzero(np.sign(g[:-1]) != np.sign(g[1:])):
        star = brentq(lambda d: oracle_map(positions, d) - d, grid[k], grid[k + 1], xtol=1e-12)
        found.append((star, abs(oracle_slope(positions, star)) < 1))
    return found


def read_vtu(content: bytes, path: Path) -> meshio.Mesh:
    path.write_bytes(content)
    return meshio.read(path)


def groups(svg: ET.Element, prefix: str) -> list[ET.Element]:
    return [g for g in svg.iter(f"{SVG}g") if (g.get("id") or "").startswith(prefix)]


def test_map_csv_over_rest_is_the_oracle_map(service: httpx.Client, tmp_path: Path) -> None:
    """POST /v1/export writes a /v1/map answer's samples as CSV (d_in, f, f′): f equals the
    oracle's at interior samples to 1e-9, f′ its central difference to 1e-5; the library's
    export of the same module writes the same file."""
    positions = MODULES[0]
    answer = post(service, "/v1/map", map_request(positions)).json()
    r = post(service, "/v1/export", {"format": "map_csv", "document": answer})
    assert r.headers["content-type"].startswith("text/csv")
    header, rows = read_csv(r.content)
    assert header == ["d_in", "d_out", "slope"]
    assert len(rows) == len(answer["d_in"]) and np.all(np.diff(rows[:, 0]) > 0)
    assert answer["lower"]["d_in"] <= rows[0, 0] and rows[-1, 0] <= answer["upper"]["d_in"]
    for i in np.linspace(len(rows) // 8, len(rows) - 1 - len(rows) // 8, 4).astype(int):  # clear of the folds
        d, f, slope = rows[i]
        assert f == pytest.approx(oracle_map(positions, d), rel=1e-9), d
        assert slope == pytest.approx(oracle_slope(positions, d), rel=1e-5, abs=1e-6), d
    library = zm.module_map(zm.Frame.build(positions, EDGES), (0, 1), (2, 3))
    assert library.export(tmp_path / "map.csv").read_bytes() == r.content


def test_map_answer_exports_its_module_in_the_frame_formats(service: httpx.Client, tmp_path: Path) -> None:
    """The frame formats write the module: meshio's VTU has the request's nodes and rods, the
    input pair as site 1 and the output pair as site 2; networkx's GraphML the same graph with
    site source/target and the map in its metadata; the kit list one row per rod. A map request
    is answered first and writes the same VTU."""
    positions = MODULES[1]
    request = map_request(positions)
    answer = post(service, "/v1/map", request).json()
    x, e = np.array(positions), np.array(EDGES)
    mesh = read_vtu(post(service, "/v1/export", {"format": "vtk", "document": answer}).content, tmp_path / "answer.vtu")
    assert np.allclose(mesh.points[:, :2], x) and np.array_equal(mesh.cells[0].data, e)
    assert sorted(np.flatnonzero(mesh.point_data["site"] == 1)) == [0, 1]
    assert sorted(np.flatnonzero(mesh.point_data["site"] == 2)) == [2, 3]
    again = post(service, "/v1/export", {"format": "vtk", "document": request}).content
    assert np.array_equal(read_vtu(again, tmp_path / "request.vtu").point_data["site"], mesh.point_data["site"])

    path = tmp_path / "module.graphml"
    path.write_bytes(post(service, "/v1/export", {"format": "graphml", "document": answer}).content)
    graph = nx.read_graphml(path)
    assert graph.number_of_nodes() == len(x) and graph.number_of_edges() == len(e)
    sites = {int(n): data.get("site") for n, data in graph.nodes(data=True)}
    assert {n for n, s in sites.items() if s == "source"} == {0, 1}
    assert {n for n, s in sites.items() if s == "target"} == {2, 3}
    metadata = json.loads(graph.graph["metadata"])
    assert metadata["kind"] == "map"
    assert metadata["map"]["fixed_points"] == answer["fixed_points"]

    kit = post(service, "/v1/export", {"format": "kit_csv", "document": answer}).text
    header, *rows = csv.reader(line for line in kit.splitlines() if not line.startswith("#"))
    rods = [row for row in rows if row[header.index("kind")] == "rod"]
    assert [[int(r[1]), int(r[2])] for r in rods] == EDGES
    lengths = [float(r[3]) for r in rods]
    assert lengths == pytest.approx(np.linalg.norm(x[e[:, 0]] - x[e[:, 1]], axis=1).tolist(), rel=1e-11)


def test_map_picture_shows_the_module_and_the_oracle_fixed_points(
    service: httpx.Client, tmp_path: Path, deployable_module
) -> None:
    """The picture of a module with an unstable and a stable fixed point (the oracle's): its SVG
    (POST /v1/export map_svg) holds the module's rods, nodes and four pair markers, f, the
    diagonal, the usable range, both folds and one fixed-point group per oracle fixed point with
    the oracle's stability; ``zeromode plot`` of the request writes a PNG with the pair markers'
    colours and the stable point's red fill."""
    request = {"frame": {"dim": 2, "positions": deployable_module, "edges": EDGES},
               "input_pair": [0, 1], "output_pair": [2, 3]}
    answer = post(service, "/v1/map", request).json()
    svg = ET.fromstring(post(service, "/v1/export", {"format": "map_svg", "document": answer}).content)
    (module,) = groups(svg, "module")
    count = lambda name: sum(len(g.findall(f"{SVG}path")) for g in module.iter(f"{SVG}g") if g.get("id") == name)
    assert count("bar") == len(EDGES) and count("node") == len(deployable_module) and count("marker") == 4
    for name in ("map-f", "map-diagonal", "usable-range"):
        assert len(groups(svg, name)) == 1, name
    ends = [answer["lower"], answer["upper"]]
    assert len(groups(svg, "fold-")) == sum(end["kind"] == "fold" for end in ends)
    oracle = oracle_fixed_points(deployable_module, answer["lower"]["d_in"], answer["upper"]["d_in"])
    assert [s for _, s in oracle] == [False, True]  # the design's promise, by the oracle
    drawn = groups(svg, "fixed-point-")
    assert [g.get("id").endswith("-stable") for g in drawn] == [s for _, s in oracle]
    assert [p["d"] for p in answer["fixed_points"]] == pytest.approx([d for d, _ in oracle], rel=1e-9)

    png = post(service, "/v1/export", {"format": "map_png", "document": answer})
    assert png.headers["content-type"] == "image/png" and Image.open(io.BytesIO(png.content)).format == "PNG"
    (tmp_path / "map.json").write_text(json.dumps(request))
    run = zeromode("plot", "map.json", "-o", "map.png", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    image = np.asarray(Image.open(tmp_path / "map.png").convert("RGB")).reshape(-1, 3).astype(int)
    for colour in (SOURCE, TARGET, "#d62728"):  # the markers, and matplotlib's C3 of the stable fill
        rgb = np.array([int(colour[i:i + 2], 16) for i in (1, 3, 5)])
        assert np.sum(np.all(np.abs(image - rgb) <= 8, axis=1)) > 20, colour


def test_a_malformed_map_answer_is_refused(service: httpx.Client) -> None:
    """A map document whose samples do not pair up (or are none) is a 422 naming the problem,
    never a 500; a map format asked of another document is 422 invalid_document."""
    answer = post(service, "/v1/map", map_request(MODULES[0])).json()
    for broken in ({**answer, "d_out": answer["d_out"][:-1]}, {**answer, "d_in": [], "d_out": [], "slope": []}):
        for fmt in ("map_csv", "map_svg", "vtk"):
            r = service.post("/v1/export", json={"format": fmt, "document": broken})
            assert r.status_code == 422 and r.json()["detail"]["code"] == "invalid_request", r.text
            assert "samples" in r.json()["detail"]["message"]
    r = service.post("/v1/export", json={"format": "map_csv", "document": {"frame": answer["frame"]}})
    assert r.status_code == 422 and r.json()["detail"]["code"] == "invalid_document", r.text


def test_the_library_and_cli_write_the_map_by_suffix(tmp_path: Path) -> None:
    """``zm.module_map(...).export`` and ``zeromode export`` read a map's .csv as map_csv and a
    .svg as the picture; .vtu stays the module's frame."""
    module = zm.Frame.build(MODULES[2], EDGES)
    result = zm.module_map(module, (0, 1), (2, 3))
    header, rows = read_csv(result.export(tmp_path / "lib.csv").read_bytes())
    assert header == ["d_in", "d_out", "slope"] and len(rows) == len(result.to_dict()["d_in"])
    assert ET.parse(result.export(tmp_path / "lib.svg")).getroot().find(f".//{SVG}g[@id='map-f']") is not None
    assert len(meshio.read(result.export(tmp_path / "lib.vtu")).points) == len(MODULES[2])
    (tmp_path / "answer.json").write_text(json.dumps(result.to_dict()))
    run = zeromode("export", "answer.json", "-o", "cli.csv", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "cli.csv").read_bytes() == (tmp_path / "lib.csv").read_bytes()


@pytest.mark.parametrize("soliton", [False, True])
def test_a_chain_xdmf_steps_through_its_verified_path(service: httpx.Client, tmp_path: Path, soliton: bool) -> None:
    """The XDMF of a sequential design (POST /v1/export) has one time step per configuration of
    chain.path, in order, each the frame's points plus its displacement equal to that
    configuration (to round-off: the export aligns each to the frame, which it already is), at
    time d_0 of that sample; a soliton's chain (with its anchors) likewise."""
    if soliton:
        body = zm.sequential(DEPLOYABLE, soliton={"n_modules": 4}).to_dict()
    else:
        body = zm.sequential([{"kind": "fixed_point", "d": 1.5, "slope": -0.5}], n_modules=4).to_dict()
    chain = body["chain"]
    content = post(service, "/v1/export", {"format": "xdmf", "document": body}).content
    path = tmp_path / "chain.xdmf"
    path.write_bytes(content)
    with meshio.xdmf.TimeSeriesReader(str(path)) as reader:
        points, _ = reader.read_points_cells()
        steps = [reader.read_data(k) for k in range(reader.num_steps)]
    assert len(steps) == len(chain["path"]) > 3
    for (t, point_data, _), configuration, distances in zip(steps, chain["path"], chain["distances"]):
        assert t == pytest.approx(distances[0], rel=1e-12)
        moved = points[:, :2] + point_data["displacement"][:, :2]
        assert np.max(np.abs(moved - np.array(configuration))) < 1e-12
