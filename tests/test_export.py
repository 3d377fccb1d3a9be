"""Exports (zeromode.export, POST /v1/export, `zeromode export`), each read back with the library
its field uses — meshio, networkx, ezdxf, Pillow — or, for STL, by a 30-line binary reader
written here, and compared with the frame of the document it came from: positions, bars, their
lengths (recomputed from the positions), roles, modes; a finite motion's configurations keep
every bar length and are in the pose nearest the reference (centroid matched, and the Kabsch
optimality condition: the cross-covariance with the reference is symmetric).
"""

from __future__ import annotations

import csv
import io
import json
import math
import xml.etree.ElementTree as ET

import ezdxf
import meshio
import networkx as nx
import numpy as np
import pytest
from PIL import Image

from zeromode.operations.endpoints import respond
from zeromode.service.cli import main
from zeromode.service.wire.examples import example_request

LATTICE = {"cells": [2, 2], "poisson_ratio": -0.5}
ALLOSTERIC = {
    "dim": 2,
    "source": {"positions": [[0, 0], [1, 0], [0, 1]], "motion": [[-1, 0], [1, 0], [0, 1]]},
    "target": {"positions": [[5, 0], [6, 0], [5, 1]], "motion": [[0, -1], [1, 1], [-1, 0]]},
}
DOCUMENTS = {
    "outward_2d": example_request("outward_2d"),
    "five_node_3d": example_request("five_node_3d"),
    "lattice": LATTICE,
    "allosteric": ALLOSTERIC,
}


@pytest.fixture(scope="module")
def designed() -> dict[str, dict]:
    return {name: respond(doc)[0] for name, doc in DOCUMENTS.items()}


def export(client, fmt: str, document: dict, **fields) -> bytes:
    r = client.post("/v1/export", json={"format": fmt, "document": document, **fields})
    assert r.status_code == 200, r.text
    return r.content


def arrays(doc: dict):
    f = doc["frame"]
    return np.array(f["positions"], float), np.array(f["edges"], int), np.array(doc["modes"], float)


def lengths_of(x: np.ndarray, e: np.ndarray) -> np.ndarray:
    return np.sqrt(((x[e[:, 0]] - x[e[:, 1]]) ** 2).sum(axis=1))


def pad3(v: np.ndarray) -> np.ndarray:
    return np.concatenate([v, np.zeros((*v.shape[:-1], 3 - v.shape[-1]))], axis=-1)


@pytest.mark.parametrize("name", list(DOCUMENTS))
def test_vtk_reads_back_with_meshio(client, designed, tmp_path, name):
    doc = designed[name]
    x, e, modes = arrays(doc)
    path = tmp_path / "frame.vtu"
    path.write_bytes(export(client, "vtk", doc))
    mesh = meshio.read(path)
    assert np.allclose(mesh.points, pad3(x), atol=1e-12)
    assert [block.type for block in mesh.cells] == ["line"]
    assert np.array_equal(mesh.cells[0].data, e)
    assert np.allclose(mesh.cell_data["length"][0], lengths_of(x, e), rtol=1e-12)
    spec = np.zeros(len(x), int)
    spec[doc["frame"]["specified"]] = 1
    assert np.array_equal(mesh.point_data["specified"], spec)
    for m, mode in enumerate(modes):
        assert np.allclose(mesh.point_data[f"mode_{m}"], pad3(mode), atol=1e-12)
    site = mesh.point_data["site"]
    if name == "allosteric":
        assert set(np.flatnonzero(site == 1)) == set(doc["report"]["source"])
        assert set(np.flatnonzero(site == 2)) == set(doc["report"]["target"])
        assert set(np.flatnonzero(site == 3)) == set(doc["report"]["relays"])
    else:
        assert not site.any()
    if name == "lattice":  # each finite state as a displacement field from the reference
        for state in doc["states"]:
            assert np.allclose(mesh.point_data[state["name"]], pad3(np.array(state["positions"]) - x), atol=1e-12)
        assert mesh.field_data["poisson_ratio"][0] == pytest.approx(doc["poisson_ratio"])
    assert mesh.field_data["report.analysis.nontrivial_zero_modes"][0] == len(modes)


def kabsch_pose_holds(y: np.ndarray, x: np.ndarray) -> bool:
    """y is in the pose nearest x: same centroid, and Yᵀ X symmetric (the first-order condition
    of min over rotations R of ‖Y R − X‖, which a Kabsch alignment satisfies)."""
    p, q = y - y.mean(axis=0), x - x.mean(axis=0)
    m = p.T @ q
    scale = np.linalg.norm(m)
    return np.allclose(y.mean(axis=0), x.mean(axis=0), atol=1e-9 * np.abs(x).max()) and np.allclose(
        m, m.T, atol=1e-8 * scale
    )


@pytest.mark.parametrize("name", ["outward_2d", "five_node_3d", "allosteric"])
def test_xdmf_holds_the_finite_motion_as_a_time_series(client, designed, tmp_path, name):
    doc = designed[name]
    x, e, _ = arrays(doc)
    path = tmp_path / "motion.xdmf"
    path.write_bytes(export(client, "xdmf", doc, motion={"amplitude": 0.3}))
    with meshio.xdmf.TimeSeriesReader(str(path)) as reader:
        points, cells = reader.read_points_cells()
        steps = [reader.read_data(k) for k in range(reader.num_steps)]
    assert np.allclose(points, pad3(x)) and np.array_equal(cells[0].data, e)
    assert len(steps) >= 10
    times = [t for t, _, _ in steps]
    assert times == sorted(times) and min(times) < 0 < max(times)
    lengths = lengths_of(x, e)
    moved = 0.0
    for _, point_data, _ in steps:
        y = (points + point_data["displacement"])[:, : x.shape[1]]
        assert np.allclose(lengths_of(y, e), lengths, rtol=1e-8)  # a finite motion: bars keep length
        assert kabsch_pose_holds(y, x)  # rigid motion removed
        moved = max(moved, float(np.abs(y - x).max()))
    assert moved > 1e-2 * np.abs(x).max()  # and it does move


@pytest.mark.parametrize("name", list(DOCUMENTS))
def test_graphs_read_back_with_networkx(client, designed, name):
    doc = designed[name]
    x, e, modes = arrays(doc)
    d = x.shape[1]
    data = json.loads(export(client, "node_link_json", doc))
    from_json = nx.node_link_graph(data, edges="edges")
    from_graphml = nx.read_graphml(io.BytesIO(export(client, "graphml", doc)), node_type=int)
    spec = set(doc["frame"]["specified"])
    for g in (from_json, from_graphml):
        assert sorted(g.nodes) == list(range(len(x)))
        assert {frozenset(edge) for edge in g.edges} == {frozenset(edge) for edge in e.tolist()}
        for i, attrs in g.nodes(data=True):
            assert np.allclose([attrs[a] for a in "xyz"[:d]], x[i], atol=1e-12)
            assert attrs["role"] == ("specified" if i in spec else "unspecified")
            for m, mode in enumerate(modes):
                assert np.allclose([attrs[f"mode{m}_{a}"] for a in "xyz"[:d]], mode[i], atol=1e-12)
        for i, j, attrs in g.edges(data=True):
            assert attrs["length"] == pytest.approx(float(np.linalg.norm(x[i] - x[j])), rel=1e-12)
    assert from_json.graph["metadata"]["kind"] == json.loads(from_graphml.graph["metadata"])["kind"]
    if name == "allosteric":
        sites = nx.get_node_attributes(from_graphml, "site")
        assert {i for i, s in sites.items() if s == "source"} == set(doc["report"]["source"])


PIN, WIDTH = 4.0, 10.0


@pytest.mark.parametrize("name", list(DOCUMENTS))
def test_dxf_cut_file_reads_back_with_ezdxf(client, designed, tmp_path, name):
    doc = designed[name]
    x, e, _ = arrays(doc)
    path = tmp_path / "cut.dxf"
    path.write_bytes(export(client, "dxf", doc, fabrication={"pin_diameter_mm": PIN, "link_width_mm": WIDTH}))
    dxf = ezdxf.readfile(path)
    assert dxf.header["$INSUNITS"] == 4  # millimetres
    scale = float(dxf.header.custom_vars.get("zeromode.mm_per_unit"))
    msp = dxf.modelspace()
    outlines = msp.query("LWPOLYLINE")
    holes = msp.query("CIRCLE")
    labels = msp.query("TEXT")
    assert len(outlines) == len(labels) == len(e) and len(holes) == 2 * len(e)
    assert all(h.dxf.radius == pytest.approx(PIN / 2) and h.dxf.layer == "CUT" for h in holes)
    centres = np.array([[h.dxf.center.x, h.dxf.center.y] for h in holes])
    lengths = lengths_of(x, e)
    assert min(lengths) * scale == pytest.approx(5 * WIDTH)  # the default scale's rule
    for label in labels:
        (i, j), mm = label.dxf.text.split()[0].split("-"), float(label.dxf.text.split()[1])
        b = next(k for k, (a, c) in enumerate(e.tolist()) if {a, c} == {int(i), int(j)})
        assert mm == pytest.approx(lengths[b] * scale, abs=0.05)
        # The outline around the label holds two holes, the bar's length apart.
        at = np.array([label.dxf.align_point.x, label.dxf.align_point.y])
        box = next(p for p in (np.array([(q[0], q[1]) for q in o.get_points("xy")]) for o in outlines)
                   if np.all(at >= p.min(axis=0)) and np.all(at <= p.max(axis=0)))
        inside = np.all((centres >= box.min(axis=0)) & (centres <= box.max(axis=0)), axis=1)
        assert inside.sum() == 2
        pins = centres[inside]
        assert np.linalg.norm(pins[0] - pins[1]) == pytest.approx(lengths[b] * scale, rel=1e-9)
    # Each outline is the link's stadium: 2 × width wide, its straight sides pin-to-pin long.
    for outline in outlines:
        pts = np.array([(p[0], p[1]) for p in outline.get_points("xy")])
        bulges = [p[4] for p in outline.get_points("xyseb")]
        assert outline.closed and sorted(bulges) == [0, 0, 1, 1]
        assert np.ptp(pts[:, 1]) == pytest.approx(WIDTH)
    # Parts do not overlap: the outlines' boxes (with their rounded ends) are disjoint.
    boxes = [(p[:, 0].min() - WIDTH / 2, p[:, 0].max() + WIDTH / 2, p[:, 1].min(), p[:, 1].max())
             for p in (np.array([(q[0], q[1]) for q in o.get_points("xy")]) for o in outlines)]
    for a in range(len(boxes)):
        for b in range(a):
            A, B = boxes[a], boxes[b]
            assert A[1] <= B[0] or B[1] <= A[0] or A[3] <= B[2] or B[3] <= A[2]


def test_cut_svg_is_in_millimetres_without_legend(client, designed):
    doc = designed["outward_2d"]
    svg = ET.fromstring(export(client, "cut_svg", doc))
    assert svg.get("width").endswith("mm") and svg.get("height").endswith("mm")
    text = ET.tostring(svg, encoding="unicode")
    assert "legend" not in text and "<text" not in text  # labels are engraved outlines
    dxf = ezdxf.read(io.StringIO(export(client, "dxf", doc).decode()))
    lo, hi = (np.array([min(v), max(v)]) for v in zip(*(
        (h.dxf.center.x, h.dxf.center.y) for h in dxf.modelspace().query("CIRCLE")
    )))
    width_mm = float(svg.get("width").removesuffix("mm"))
    assert width_mm >= hi[0] - lo[0]  # the page holds the parts at 1:1


def read_binary_stl(data: bytes) -> np.ndarray:
    """Triangles (F, 3, 3) of a binary STL: 80-byte header, uint32 count, 50-byte records."""
    count = int(np.frombuffer(data[80:84], "<u4")[0])
    assert len(data) == 84 + 50 * count
    records = np.frombuffer(data[84:], np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")]))
    return records["v"].astype(float)


@pytest.mark.parametrize("name", ["outward_2d", "five_node_3d"])
def test_stl_links_are_closed_plates_of_the_right_volume(client, designed, name):
    doc = designed[name]
    x, e, _ = arrays(doc)
    thickness = 2.5
    tri = read_binary_stl(export(client, "stl", doc, fabrication={
        "pin_diameter_mm": PIN, "link_width_mm": WIDTH, "thickness_mm": thickness, "mm_per_unit": 60.0,
    }))
    # Closed and consistently oriented: every directed edge appears once and its reverse once.
    keys = np.round(tri, 4)
    directed = {}
    for t in keys:
        for a, b in ((0, 1), (1, 2), (2, 0)):
            edge = (tuple(t[a]), tuple(t[b]))
            directed[edge] = directed.get(edge, 0) + 1
    assert set(directed.values()) == {1}
    assert all((b, a) in directed for a, b in directed)
    # Volume by the divergence theorem: the plates' area × thickness, the stadium minus two
    # holes (polygons of 48 sides lose under 0.3 % of a circle's area).
    volume = float(np.sum(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])))) / 6
    r_end, r_pin = WIDTH / 2, PIN / 2
    expected = sum((length * 60.0 * WIDTH + math.pi * r_end**2 - 2 * math.pi * r_pin**2) * thickness
                   for length in lengths_of(x, e))
    assert volume == pytest.approx(expected, rel=5e-3)
    assert tri[:, :, 2].min() == pytest.approx(0) and tri[:, :, 2].max() == pytest.approx(thickness)


def test_kit_csv_lists_every_bar_with_its_length(client, designed):
    doc = designed["five_node_3d"]
    x, e, _ = arrays(doc)
    text = export(client, "kit_csv", doc, fabrication={"mm_per_unit": 100.0}).decode()
    rows = list(csv.DictReader(line for line in text.splitlines() if not line.startswith("#")))
    assert len(rows) == len(e)
    for row in rows:
        i, j = int(row["node_i"]), int(row["node_j"])
        assert float(row["length"]) == pytest.approx(float(np.linalg.norm(x[i] - x[j])), rel=1e-10)
        assert float(row["length_mm"]) == pytest.approx(100.0 * float(row["length"]), rel=1e-6)


@pytest.mark.parametrize("frames", [2, 7, 25])
def test_gif_has_the_expected_number_of_frames(client, designed, frames):
    gif = Image.open(io.BytesIO(export(client, "gif", designed["outward_2d"], animation={"frames": frames})))
    assert gif.format == "GIF" and gif.n_frames == 2 * frames - 2
    first, middle = np.asarray(gif.convert("RGB")), None
    gif.seek(frames - 1)
    middle = np.asarray(gif.convert("RGB"))
    assert np.abs(first.astype(int) - middle.astype(int)).sum() > 0  # the frame moves


def test_animated_svg_plays_every_frame(client, designed):
    frames = 12
    doc = designed["allosteric"]
    x, e, _ = arrays(doc)
    svg = ET.fromstring(export(client, "svg_animation", doc, animation={"frames": frames}))
    ns = "{http://www.w3.org/2000/svg}"
    motion = next(g for g in svg.iter(ns + "g") if g.get("class") == "motion")
    bars = [el for el in motion if el.get("class") == "bar"]
    nodes = [el for el in motion if "node" in (el.get("class") or "").split()]
    assert len(bars) == len(e) and len(nodes) == len(x)
    for el in bars + nodes:
        for animate in el.iter(ns + "animate"):
            assert len(animate.get("values").split(";")) == 2 * frames - 2 + 1  # the loop closes
    # Bars join their nodes in every frame (pixels: 0.1 px rounding).
    node_at = {int(n.get("data-node")): n for n in nodes}
    for bar in bars:
        i, j = e[int(bar.get("data-edge"))]
        values = {a.get("attributeName"): [float(v) for v in a.get("values").split(";")] for a in bar.iter(ns + "animate")}
        cx = {k: [float(v) for v in a.get("values").split(";")] for k in (i, j)
              for a in node_at[k].iter(ns + "animate") if a.get("attributeName") == "cx"}
        assert np.allclose(values["x1"], cx[i], atol=0.11) and np.allclose(values["x2"], cx[j], atol=0.11)
    markers = [el for el in motion if "marker" in (el.get("class") or "")]
    assert len(markers) == len(doc["report"]["source"]) + len(doc["report"]["target"])


def test_a_motion_response_exports_with_its_frame(client, designed):
    doc = designed["outward_2d"]
    motion = client.post("/v1/motion", json={"frame": doc["frame"], "amplitude": 0.2}).json()
    data = json.loads(export(client, "node_link_json", motion, frame=doc["frame"]))
    assert data["graph"]["metadata"]["kind"] == "motion"
    gif = Image.open(io.BytesIO(export(client, "gif", motion, frame=doc["frame"], animation={"frames": 5})))
    assert gif.n_frames == 8


def test_formats_are_listed_and_errors_name_the_problem(client, designed):
    formats = {f["name"]: f for f in client.get("/v1/export/formats").json()}
    assert {"vtk", "xdmf", "graphml", "node_link_json", "dxf", "cut_svg", "stl", "kit_csv", "gif", "svg_animation"} <= set(formats)
    assert all(f["available"] for name, f in formats.items() if name != "mp4")
    # `map` says which formats write a module's map: exactly those a designed frame cannot take.
    for name, f in formats.items():
        if not f["motion"]:
            r = client.post("/v1/export", json={"format": name, "document": designed["outward_2d"]})
            assert (r.status_code == 422) == f["map"], (name, r.status_code)
    assert {name for name, f in formats.items() if f["map"]} == {"map_csv", "map_svg", "map_png"}
    cases = [
        ({"format": "ply", "document": designed["outward_2d"]}, "invalid_request"),
        ({"format": "vtk"}, "invalid_request"),
        ({"format": "dxf", "document": designed["outward_2d"], "fabrication": {"pin_diameter_mm": 9}}, "invalid_options"),
        ({"format": "dxf", "document": designed["outward_2d"], "fabrication": {"mm_per_unit": 1}}, "invalid_options"),
        ({"format": "vtk", "document": {"nothing": 1}}, "invalid_document"),
        ({"format": "gif", "document": designed["outward_2d"], "motion": {"mode": 3}}, "invalid_options"),
    ]
    for body, code in cases:
        r = client.post("/v1/export", json=body)
        assert r.status_code == 422 and r.json()["detail"]["code"] == code, (body.get("format"), r.text)
    if not formats["mp4"]["available"]:
        r = client.post("/v1/export", json={"format": "mp4", "document": designed["outward_2d"]})
        assert r.status_code == 422 and r.json()["detail"]["code"] == "unavailable_format"


def test_cli_designs_and_exports_a_request(tmp_path, capsys):
    request = tmp_path / "request.json"
    request.write_text(json.dumps(DOCUMENTS["lattice"]))
    response = tmp_path / "response.json"
    assert main(["design", str(request), "-o", str(response)]) == 0
    doc = json.loads(response.read_text())
    assert doc["poisson_ratio"] == pytest.approx(-0.5)
    out = tmp_path / "sheet.vtu"
    assert main(["export", str(response), "--format", "vtk", "-o", str(out)]) == 0
    mesh = meshio.read(out)
    assert np.allclose(mesh.points[:, :2], doc["frame"]["positions"])
    assert main(["export", str(request), "-o", str(tmp_path / "sheet.graphml")]) == 0  # designed first
    assert nx.read_graphml(tmp_path / "sheet.graphml").number_of_edges() == len(doc["frame"]["edges"])
    assert main(["export", str(response), "-o", str(tmp_path / "x.svg")]) == 2
    assert "--format" in capsys.readouterr().err
