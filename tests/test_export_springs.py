"""Exports of multistable designs (rods and springs) and of sequential chains (rods), each file
read back with the independent library of its field — meshio, networkx, ezdxf, csv — and
compared with the REST body it came from: the body's own rods (``frame.edges``), springs
(``springs.pairs``, ``stiffness``, ``rest_length``) and every node in each conformation. A spring
is never written as a rod nor a rod as a spring: the two sets of pairs are read back apart and
must equal the body's, with no pair in both. The energy of each conformation is recomputed here
from the definition E = Σ k_s (|x_i − x_j| − L_s)²/2 on what the files hold, and compared with
the body's minima.
"""

from __future__ import annotations

import csv
import io
import json

import ezdxf
import meshio
import networkx as nx
import numpy as np
import pytest
from test_export import export, lengths_of, pad3, read_binary_stl

import zeromode as zm
from zeromode.service.cli import main
from zeromode.service.wire.examples import example_request

_rng = np.random.default_rng(0)
_x, _u, _w = (_rng.standard_normal((4, 3)) for _ in range(3))
REQUESTS = {
    "triangle_2d": example_request("tristable_triangle_2d"),
    "tetrahedron_3d": {
        "dim": 3, "conformations": [(_x + t * _u + t * t * _w).tolist() for t in (0.0, 0.05, 0.1)],
    },
}
CHAIN = {"features": [{"kind": "fixed_point", "d": 1.5, "slope": -0.5}], "chain": {"n_modules": 4}}


@pytest.fixture(scope="module")
def bodies(client) -> dict[str, dict]:
    out = {}
    for name, request in REQUESTS.items():
        r = client.post("/v1/design/multistable", json=request)
        assert r.status_code == 200, r.text
        out[name] = r.json()
    return out


@pytest.fixture(scope="module")
def chain_body(client) -> dict:
    r = client.post("/v1/design/sequential", json=CHAIN)
    assert r.status_code == 200, r.text
    return r.json()


def pair_set(pairs) -> set[frozenset]:
    return {frozenset(map(int, p)) for p in pairs}


def body_arrays(body: dict):
    """Positions (N, d), rods (B, 2), spring pairs (S, 2), stiffness, rest lengths and
    conformations (C, N, d) of a multistable body."""
    s = body["springs"]
    return (np.array(body["frame"]["positions"], float), np.array(body["frame"]["edges"], int),
            np.array(s["pairs"], int).reshape(-1, 2), np.array(s["stiffness"], float),
            np.array(s["rest_length"], float), np.array(body["conformations"], float))


def _written(path, content: bytes):
    """``path``, holding ``content``."""
    path.write_bytes(content)
    return path


def energy(x: np.ndarray, pairs: np.ndarray, stiffness: np.ndarray, rest: np.ndarray) -> float:
    """E = Σ k_s (ℓ_s − L_s)²/2, written from the definition."""
    ell = np.sqrt(((x[pairs[:, 0]] - x[pairs[:, 1]]) ** 2).sum(axis=1))
    return float(0.5 * np.sum(stiffness * (ell - rest) ** 2))


def test_the_designs_have_both_element_types(bodies):
    for body in bodies.values():
        _, rods, pairs, _, _, conformations = body_arrays(body)
        assert len(rods) > 0 and len(pairs) > 0 and len(conformations) == 3
        assert not pair_set(rods) & pair_set(pairs)


@pytest.mark.parametrize("name", list(REQUESTS))
def test_vtu_keeps_springs_a_cell_kind_of_their_own(client, bodies, tmp_path, name):
    body = bodies[name]
    x, rods, pairs, stiffness, rest, conformations = body_arrays(body)
    mesh = meshio.read(_written(tmp_path / "design.vtu", export(client, "vtk", body)))
    assert np.allclose(mesh.points, pad3(x), atol=1e-12)
    cells = np.vstack([block.data for block in mesh.cells if block.type == "line"])
    kind = np.concatenate(mesh.cell_data["kind"])
    assert len(cells) == len(kind) == len(rods) + len(pairs)
    assert np.array_equal(cells[kind == 0], rods)  # the rods, in the body's order, and nothing else
    assert np.array_equal(cells[kind == 1], pairs)  # the springs, likewise
    data = {name: np.concatenate(arrays) for name, arrays in mesh.cell_data.items()}
    springs = kind == 1
    assert np.array_equal(data["stiffness"][springs], stiffness)
    assert np.array_equal(data["rest_length"][springs], rest)
    assert np.isnan(data["stiffness"][~springs]).all() and np.isnan(data["rest_length"][~springs]).all()
    assert np.array_equal(data["bar"][~springs], np.arange(len(rods))) and (data["bar"][springs] == -1).all()
    assert np.array_equal(data["spring"][springs], np.arange(len(pairs))) and (data["spring"][~springs] == -1).all()
    assert np.allclose(data["length"], lengths_of(mesh.points, cells), rtol=1e-12)
    for c, conformation in enumerate(conformations):  # every node of each, as displacements
        assert np.allclose(mesh.points + mesh.point_data[f"conformation_{c}"], pad3(conformation), atol=1e-12)
    assert mesh.field_data["report.springs"][0] == len(pairs)


@pytest.mark.parametrize("name", list(REQUESTS))
def test_xdmf_steps_through_the_minima(client, bodies, tmp_path, name):
    body = bodies[name]
    x, rods, pairs, _, _, conformations = body_arrays(body)
    with meshio.xdmf.TimeSeriesReader(str(_written(tmp_path / "minima.xdmf", export(client, "xdmf", body)))) as reader:
        points, cells = reader.read_points_cells()
        steps = [reader.read_data(k) for k in range(reader.num_steps)]
    lines = np.vstack([block.data for block in cells])
    assert [t for t, _, _ in steps] == pytest.approx([m["arclength"] for m in body["minima"]], abs=1e-12)
    for (_, point_data, cell_data), conformation, minimum in zip(steps, conformations, body["minima"], strict=True):
        y = points + point_data["displacement"]
        assert np.allclose(y, pad3(conformation), atol=1e-12)  # placed as the body places it
        kind = np.concatenate(cell_data["kind"])
        rod_lines, spring_lines = lines[kind == 0], lines[kind == 1]
        assert np.array_equal(rod_lines, rods) and np.array_equal(spring_lines, pairs)
        assert np.allclose(lengths_of(y, rod_lines), lengths_of(pad3(x), rods), rtol=1e-9)  # rods keep length
        k = np.concatenate(cell_data["stiffness"])[kind == 1]
        rest = np.concatenate(cell_data["rest_length"])[kind == 1]
        assert energy(y, spring_lines, k, rest) == pytest.approx(minimum["energy"], rel=1e-9)


@pytest.mark.parametrize("name", list(REQUESTS))
def test_graphs_give_every_edge_its_kind(client, bodies, name):
    body = bodies[name]
    x, rods, pairs, stiffness, rest, conformations = body_arrays(body)
    d = x.shape[1]
    from_json = nx.node_link_graph(json.loads(export(client, "node_link_json", body)), edges="edges")
    from_graphml = nx.read_graphml(io.BytesIO(export(client, "graphml", body)), node_type=int)
    for g in (from_json, from_graphml):
        assert g.number_of_edges() == len(rods) + len(pairs)
        kinds = nx.get_edge_attributes(g, "kind")
        assert set(kinds.values()) == {"rod", "spring"}
        assert {frozenset(e) for e, k in kinds.items() if k == "rod"} == pair_set(rods)
        assert {frozenset(e) for e, k in kinds.items() if k == "spring"} == pair_set(pairs)
        for i, j, attrs in g.edges(data=True):
            if attrs["kind"] == "spring":
                s = attrs["spring"]
                assert {i, j} == set(pairs[s].tolist()) and "bar" not in attrs
                assert attrs["stiffness"] == stiffness[s] and attrs["rest_length"] == rest[s]
            else:
                assert {i, j} == set(rods[attrs["bar"]].tolist()) and "stiffness" not in attrs
            assert attrs["length"] == pytest.approx(float(np.linalg.norm(x[i] - x[j])), rel=1e-12)
        for i, attrs in g.nodes(data=True):
            for c, conformation in enumerate(conformations):
                assert [attrs[f"conformation_{c}_{a}"] for a in "xyz"[:d]] == pytest.approx(conformation[i], abs=1e-12)
    assert from_json.graph["metadata"]["kind"] == "multistable"
    assert len(from_json.graph["metadata"]["minima"]) == len(conformations)


PIN, WIDTH = 3.0, 8.0


def test_dxf_lays_the_springs_out_on_their_own_layer(client, bodies, tmp_path):
    body = bodies["triangle_2d"]
    _, rods, pairs, stiffness, rest, _ = body_arrays(body)
    fabrication = {"pin_diameter_mm": PIN, "link_width_mm": WIDTH}
    dxf = ezdxf.readfile(_written(tmp_path / "kit.dxf", export(client, "dxf", body, fabrication=fabrication)))
    scale = float(dxf.header.custom_vars.get("zeromode.mm_per_unit"))
    assert int(dxf.header.custom_vars.get("zeromode.springs")) == len(pairs)
    msp = dxf.modelspace()
    on = {layer: msp.query(f'*[layer=="{layer}"]') for layer in ("CUT", "ENGRAVE", "SPRING", "SPRING_ENGRAVE")}
    assert sum(len(q) for q in on.values()) == len(msp)
    # Links: rods only (an outline and two holes each; labels "i-j mm" name the rods' pairs).
    assert len(on["CUT"].query("LWPOLYLINE")) == len(rods) and len(on["CUT"].query("CIRCLE")) == 2 * len(rods)
    rod_labels = [t.dxf.text.split() for t in on["ENGRAVE"].query("TEXT")]
    assert {frozenset(map(int, words[0].split("-"))) for words in rod_labels} == pair_set(rods)
    # Springs: two holes and the line between them, its length the rest length in mm.
    lines = on["SPRING"].query("LINE")
    assert len(lines) == len(pairs) and len(on["SPRING"].query("CIRCLE")) == 2 * len(pairs)
    assert not on["SPRING"].query("LWPOLYLINE")
    drawn = sorted(float((line.dxf.end - line.dxf.start).magnitude) for line in lines)
    assert drawn == pytest.approx(sorted(rest * scale), rel=1e-9)  # the scale is written to 12 digits
    by_pair = {frozenset(p): s for s, p in enumerate(pairs.tolist())}
    labels = on["SPRING_ENGRAVE"].query("TEXT")
    assert len(labels) == len(pairs)
    seen = set()
    for text in labels:
        nodes, mm, k = text.dxf.text.split()
        s = by_pair[frozenset(map(int, nodes.split("-")))]
        seen.add(s)
        assert float(mm) == pytest.approx(rest[s] * scale, abs=0.05)
        assert float(k.removeprefix("k=")) == pytest.approx(stiffness[s], rel=1e-3)
    assert seen == set(range(len(pairs)))
    # Spring rows lie above the links' rows: no spring hole inside a link's box.
    link_top = max(p[1] for o in on["CUT"].query("LWPOLYLINE") for p in o.get_points("xy"))
    assert min(c.dxf.center.y for c in on["SPRING"].query("CIRCLE")) > link_top


def test_the_sheet_is_as_large_as_its_parts(bodies):
    """Sheet.size is the box of every part (holes' centres ± half a link width), with and
    without springs: no empty row is left for springs a design does not have."""
    from zeromode.export.fabrication import Fabrication, sheet
    from zeromode.export.takeaway import SpringSet, Takeaway
    from zeromode.solver.frame import Frame

    body = bodies["triangle_2d"]
    x, rods, pairs, stiffness, rest, _ = body_arrays(body)
    frame = Frame.build(x, rods, body["frame"]["specified"])
    fab = Fabrication()
    for springs in (None, SpringSet(pairs, stiffness, rest)):
        layout = sheet(Takeaway.build(frame, springs=springs), fab)
        centres = np.concatenate([layout.pins, layout.spring_pins]).reshape(-1, 2)
        assert len(centres) == 2 * (len(rods) + (0 if springs is None else len(pairs)))
        assert layout.size[1] == pytest.approx(centres[:, 1].max() + fab.link_width / 2)
        assert layout.size[0] == pytest.approx(centres[:, 0].max() + fab.link_width / 2)


def test_kit_csv_lists_the_springs_apart_with_rest_length_and_stiffness(client, bodies):
    body = bodies["triangle_2d"]
    x, rods, pairs, stiffness, rest, _ = body_arrays(body)
    text = export(client, "kit_csv", body, fabrication={"mm_per_unit": 100.0}).decode()
    rows = list(csv.DictReader(line for line in text.splitlines() if not line.startswith("#")))
    rod_rows = [r for r in rows if r["kind"] == "rod"]
    spring_rows = [r for r in rows if r["kind"] == "spring"]
    assert len(rod_rows) + len(spring_rows) == len(rows)
    assert [(int(r["node_i"]), int(r["node_j"])) for r in rod_rows] == [tuple(e) for e in rods.tolist()]
    assert [int(r["bar"]) for r in rod_rows] == list(range(len(rods)))
    for r in rod_rows:
        i, j = int(r["node_i"]), int(r["node_j"])
        assert float(r["length"]) == pytest.approx(float(np.linalg.norm(x[i] - x[j])), rel=1e-10)
        assert r["rest_length"] == r["stiffness"] == r["spring"] == ""
    assert [(int(r["node_i"]), int(r["node_j"])) for r in spring_rows] == [tuple(p) for p in pairs.tolist()]
    for s, r in enumerate(spring_rows):
        assert int(r["spring"]) == s and r["bar"] == r["length"] == r["length_mm"] == ""
        assert float(r["rest_length"]) == pytest.approx(rest[s], rel=1e-11)
        assert float(r["rest_length_mm"]) == pytest.approx(100.0 * rest[s], abs=1e-6)
        assert float(r["stiffness"]) == pytest.approx(stiffness[s], rel=1e-11)
    assert f"{len(rods)} struts, {len(pairs)} springs" in text.splitlines()[0]


def test_a_request_is_designed_first_and_exports_the_same_springs(client, bodies):
    """Same request, same answer: the request as the document gives the body's springs."""
    body = bodies["triangle_2d"]
    _, rods, pairs, stiffness, rest, _ = body_arrays(body)
    graph = nx.node_link_graph(json.loads(export(client, "node_link_json", REQUESTS["triangle_2d"])), edges="edges")
    springs = {frozenset((i, j)): a for i, j, a in graph.edges(data=True) if a["kind"] == "spring"}
    assert set(springs) == pair_set(pairs) and graph.number_of_edges() == len(rods) + len(pairs)
    assert [springs[frozenset(p)]["stiffness"] for p in pairs.tolist()] == pytest.approx(stiffness, rel=1e-9)
    assert [springs[frozenset(p)]["rest_length"] for p in pairs.tolist()] == pytest.approx(rest, rel=1e-9)


def test_stl_prints_the_links_only(client, bodies):
    body = bodies["triangle_2d"]
    x, rods, _, _, _, _ = body_arrays(body)
    tri = read_binary_stl(export(client, "stl", body, fabrication={"mm_per_unit": 60.0}))
    volume = float(np.sum(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])))) / 6
    r_end, r_pin, t = 4.0, 1.5, 3.0  # the default link width, pin and thickness
    expected = sum((length * 60.0 * 2 * r_end + np.pi * r_end**2 - 2 * np.pi * r_pin**2) * t for length in lengths_of(x, rods))
    assert volume == pytest.approx(expected, rel=5e-3)


def test_a_chain_exports_its_rods_and_no_spring(client, chain_body, tmp_path):
    chain = chain_body["chain"]
    x, rods = np.array(chain["frame"]["positions"], float), np.array(chain["frame"]["edges"], int)
    mesh = meshio.read(_written(tmp_path / "chain.vtu", export(client, "vtk", chain_body)))
    assert np.allclose(mesh.points, pad3(x), atol=1e-12)
    assert np.array_equal(mesh.cells[0].data, rods) and not np.concatenate(mesh.cell_data["kind"]).any()
    site = mesh.point_data["site"]
    assert set(np.flatnonzero(site == 1)) == set(chain["pairs"][0])
    assert set(np.flatnonzero(site == 2)) == set(chain["pairs"][-1])
    graph = nx.read_graphml(io.BytesIO(export(client, "graphml", chain_body)), node_type=int)
    assert set(nx.get_edge_attributes(graph, "kind").values()) == {"rod"}
    assert {frozenset(e) for e in graph.edges} == pair_set(rods)
    assert json.loads(graph.graph["metadata"])["chain"]["pairs"] == chain["pairs"]
    text = export(client, "kit_csv", chain_body).decode()
    rows = list(csv.DictReader(line for line in text.splitlines() if not line.startswith("#")))
    assert [r["kind"] for r in rows] == ["rod"] * len(rods)
    dxf = ezdxf.read(io.StringIO(export(client, "dxf", chain_body).decode()))
    assert not dxf.modelspace().query('*[layer=="SPRING"]')
    with meshio.xdmf.TimeSeriesReader(str(_written(tmp_path / "chain.xdmf", export(client, "xdmf", chain_body)))) as r:
        points, _ = r.read_points_cells()
        moved = [r.read_data(k)[1]["displacement"] for k in range(r.num_steps)]
    for u in moved:  # the chain's finite motion keeps every rod's length
        assert np.allclose(lengths_of(points + u, rods), lengths_of(points, rods), rtol=1e-8)


def test_springs_given_with_a_chain_export_as_springs(client, chain_body, tmp_path):
    """A chain has springs only when it is given some: here one across each copy's input pair."""
    chain = chain_body["chain"]
    pairs = chain["pairs"][:-1]
    given = {"pairs": pairs, "stiffness": [0.5 + k for k in range(len(pairs))], "rest_length": chain["iterates"][:-1]}
    mesh = meshio.read(_written(tmp_path / "sprung.vtu", export(client, "vtk", chain_body, springs=given)))
    kind = np.concatenate(mesh.cell_data["kind"])
    assert np.array_equal(mesh.cells[0].data[kind == 1], pairs)
    assert np.array_equal(mesh.cells[0].data[kind == 0], chain["frame"]["edges"])
    assert np.array_equal(np.concatenate(mesh.cell_data["stiffness"])[kind == 1], given["stiffness"])


def test_a_soliton_shaped_answer_exports_its_springs_and_uniform_states(client, chain_body, tmp_path):
    """A soliton (issue #41 item 2, answered beside ``chain`` as ``soliton``: springs on the
    chain's nodes and the chain in its two uniform states) exports its springs as springs and
    both states as configurations. The answer is built here in that shape from a real chain:
    springs across the copies' input pairs, the states the chain itself and a uniform stretch."""
    chain = chain_body["chain"]
    x = np.array(chain["frame"]["positions"], float)
    pairs = chain["pairs"][:-1]
    soliton = {
        "springs": {"pairs": pairs, "stiffness": [2.0] * len(pairs), "rest_length": chain["iterates"][:-1]},
        "unstable": {"positions": x.tolist()}, "stable": {"positions": (1.5 * x).tolist()},
    }
    document = {**chain_body, "soliton": soliton}
    mesh = meshio.read(_written(tmp_path / "soliton.vtu", export(client, "vtk", document)))
    kind = np.concatenate(mesh.cell_data["kind"])
    assert np.array_equal(mesh.cells[0].data[kind == 1], pairs)
    assert np.array_equal(mesh.cells[0].data[kind == 0], chain["frame"]["edges"])
    assert np.array_equal(np.concatenate(mesh.cell_data["rest_length"])[kind == 1], chain["iterates"][:-1])
    assert np.allclose(mesh.points + mesh.point_data["stable"], pad3(1.5 * x), atol=1e-12)
    assert np.allclose(mesh.point_data["unstable"], 0.0)
    graph = nx.node_link_graph(json.loads(export(client, "node_link_json", document)), edges="edges")
    assert {frozenset(e) for e, k in nx.get_edge_attributes(graph, "kind").items() if k == "spring"} == pair_set(pairs)


def test_bad_springs_are_refused_with_a_code(client, chain_body):
    rod = chain_body["chain"]["frame"]["edges"][0]
    cases = [
        ({"pairs": [rod], "stiffness": [1.0], "rest_length": [1.0]}, "invalid_springs"),
        ({"pairs": [[0, 0]], "stiffness": [1.0], "rest_length": [1.0]}, "invalid_springs"),
        ({"pairs": [[0, 10_000]], "stiffness": [1.0], "rest_length": [1.0]}, "invalid_springs"),
        ({"pairs": [[0, 2**70]], "stiffness": [1.0], "rest_length": [1.0]}, "invalid_springs"),
        ({"pairs": chain_body["chain"]["pairs"][:1] * 2, "stiffness": [1.0, 1.0], "rest_length": [1.0, 1.0]}, "invalid_springs"),
        ({"pairs": chain_body["chain"]["pairs"][:1], "stiffness": [1.0, 2.0], "rest_length": [1.0]}, "invalid_springs"),
        ({"pairs": chain_body["chain"]["pairs"][:1], "stiffness": [-1.0], "rest_length": [1.0]}, "invalid_springs"),
        ({"pairs": chain_body["chain"]["pairs"][:1], "stiffness": [1.0], "rest_length": [1.0], "k": 1}, "invalid_request"),
    ]
    for springs, code in cases:
        r = client.post("/v1/export", json={"format": "vtk", "document": chain_body, "springs": springs})
        assert r.status_code == 422 and r.json()["detail"]["code"] == code, (springs, r.text)
    infinite = json.dumps({"format": "vtk", "document": chain_body, "springs": "SPRINGS"}).replace(
        '"SPRINGS"', f'{{"pairs": [{chain_body["chain"]["pairs"][0]}], "stiffness": [1e309], "rest_length": [1.0]}}'
    )  # 1e309 overflows to inf when read
    r = client.post("/v1/export", content=infinite, headers={"content-type": "application/json"})
    assert r.status_code == 422 and r.json()["detail"]["code"] == "invalid_springs", r.text
    assert "stiffness" in r.json()["detail"]["message"]


def test_library_and_cli_export_by_suffix(tmp_path):
    r = zm.multistable(REQUESTS["triangle_2d"]["conformations"])
    body = r.to_dict()
    _, rods, pairs, stiffness, rest, _ = body_arrays(body)
    mesh = meshio.read(r.export(tmp_path / "lib.vtu"))
    kind = np.concatenate(mesh.cell_data["kind"])
    assert np.array_equal(mesh.cells[0].data[kind == 0], rods) and np.array_equal(mesh.cells[0].data[kind == 1], pairs)
    rows = list(csv.DictReader(line for line in r.export(tmp_path / "lib.csv").read_text().splitlines()
                               if not line.startswith("#")))
    assert [float(row["stiffness"]) for row in rows if row["kind"] == "spring"] == pytest.approx(stiffness, rel=1e-11)
    document = tmp_path / "multistable.json"
    document.write_text(json.dumps(body))
    assert main(["export", str(document), "-o", str(tmp_path / "cli.graphml")]) == 0
    graph = nx.read_graphml(tmp_path / "cli.graphml", node_type=int)
    springs = {frozenset((i, j)): a for i, j, a in graph.edges(data=True) if a["kind"] == "spring"}
    assert set(springs) == pair_set(pairs)
    assert [springs[frozenset(p)]["rest_length"] for p in pairs.tolist()] == pytest.approx(rest, rel=1e-12)
    s = zm.sequential(CHAIN["features"], n_modules=CHAIN["chain"]["n_modules"])
    chain = s.to_dict()["chain"]
    mesh = meshio.read(s.export(tmp_path / "chain.vtu"))
    assert np.array_equal(mesh.cells[0].data, chain["frame"]["edges"]) and not mesh.cell_data["kind"][0].any()
    document = tmp_path / "sequential.json"
    document.write_text(json.dumps(s.to_dict()))
    assert main(["export", str(document), "-o", str(tmp_path / "chain.csv")]) == 0
    rows = list(csv.DictReader(line for line in (tmp_path / "chain.csv").read_text().splitlines() if not line.startswith("#")))
    assert [(int(row["node_i"]), int(row["node_j"])) for row in rows] == [tuple(e) for e in chain["frame"]["edges"]]


def test_a_multistable_response_plots_as_its_rods(bodies):
    """documents.kind names the multistable response; ``zeromode plot`` (picture_for_document)
    still draws it as a design: one bar per rod, the springs not drawn as bars."""
    import xml.etree.ElementTree as ET

    from zeromode.operations.plotting import picture_for_document
    from zeromode.viz.svg import picture_svg

    body = bodies["triangle_2d"]
    svg = ET.fromstring(picture_svg(picture_for_document(body)))
    bars = [el for el in svg.iter("{http://www.w3.org/2000/svg}line") if el.get("class") == "bar"]
    assert len(bars) == len(body["frame"]["edges"])
