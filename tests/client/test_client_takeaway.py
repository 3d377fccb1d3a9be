"""The client's picture, example and export methods against the real service (uvicorn on
loopback): the SVG carries one circle per node and one line per bar of the frame sent; examples
are the service's named requests; exports read back with meshio, networkx and Pillow and match
the frame the client designed."""

from __future__ import annotations

import asyncio
import io
import xml.etree.ElementTree as ET

import meshio
import networkx as nx
import numpy as np
import pytest
from oracles import frames
from PIL import Image

from zeromode_client import AsyncClient, Client, ExportFile, Frame, ZeromodeError

SVG = "{http://www.w3.org/2000/svg}"
SQUARE = Frame.from_json(frames.SQUARE)


@pytest.fixture
def client(service_url: str):
    with Client(service_url, timeout=120.0) as c:
        yield c


def test_plot_returns_the_frame_as_svg(client: Client) -> None:
    svg = ET.fromstring(client.plot(SQUARE, modes=[[[0, 0], [0, 0], [1, 0], [1, 0]]]))
    assert svg.tag == SVG + "svg"
    nodes = [c for c in svg.iter(SVG + "circle") if "node" in c.get("class", "")]
    bars = [line for line in svg.iter(SVG + "line") if line.get("class") == "bar"]
    assert len(nodes) == len(SQUARE.positions) and len(bars) == len(SQUARE.edges)


def test_examples_are_ready_requests(client: Client) -> None:
    names = {e["name"] for e in client.examples()}
    assert "outward_2d" in names
    request = client.example("outward_2d")
    assert request["dim"] == 2 and len(request["positions"]) == 4
    with pytest.raises(ZeromodeError) as info:
        client.example("no_such_example")
    assert info.value.status == 404


def test_a_design_exports_for_paraview_and_networkx(client: Client, tmp_path) -> None:
    request = client.example("outward_2d")
    design = client.design(request["positions"], request["motions"])
    vtk = client.export(design, "vtk")
    assert isinstance(vtk, ExportFile) and vtk.filename.endswith(".vtu") and vtk.media_type == "application/xml"
    mesh = meshio.read(vtk.save(tmp_path / "design.vtu"))
    assert np.allclose(mesh.points[:, :2], design.frame.positions)
    assert np.array_equal(mesh.cells[0].data, design.frame.edges)
    graph = nx.read_graphml(io.BytesIO(client.export(design, "graphml").content), node_type=int)
    assert graph.number_of_nodes() == len(design.frame.positions)
    formats = {f["name"] for f in client.export_formats()}
    assert {"vtk", "graphml", "dxf", "stl", "gif"} <= formats


def test_async_exports_an_animation(service_url: str) -> None:
    async def scenario() -> bytes:
        async with AsyncClient(service_url, timeout=120.0) as client:
            request = await client.example("outward_2d")
            design = await client.design(request["positions"], request["motions"])
            svg, gif = await asyncio.gather(
                client.plot(design.frame), client.export(design, "gif", animation={"frames": 6})
            )
            assert svg.startswith("<svg")
            return gif.content

    gif = Image.open(io.BytesIO(asyncio.run(scenario())))
    assert gif.n_frames == 10  # 6 configurations there and back


def test_a_multistable_design_exports_its_springs_as_springs(client: Client, tmp_path) -> None:
    """Rods and springs through the real service: the VTU's line cells of kind 1 are the
    answer's springs with their stiffness and rest length, those of kind 0 its rods; the kit
    list's spring rows carry the same numbers; a chain exports rods only."""
    request = client.example("tristable_triangle_2d")
    design = client.design_multistable(**request)
    springs = design["springs"]
    mesh = meshio.read(client.export(design, "vtk").save(tmp_path / "tristable.vtu"))
    kind = np.concatenate(mesh.cell_data["kind"])
    cells = np.vstack([block.data for block in mesh.cells])
    assert np.array_equal(cells[kind == 0], design["frame"]["edges"])
    assert np.array_equal(cells[kind == 1], springs["pairs"])
    assert np.array_equal(np.concatenate(mesh.cell_data["stiffness"])[kind == 1], springs["stiffness"])
    assert np.array_equal(np.concatenate(mesh.cell_data["rest_length"])[kind == 1], springs["rest_length"])
    rows = [line.split(",") for line in client.export(design, "kit_csv").content.decode().splitlines()
            if not line.startswith("#")]
    header, rows = rows[0], rows[1:]
    spring_rows = [dict(zip(header, r)) for r in rows if r[header.index("kind")] == "spring"]
    assert [[int(r["node_i"]), int(r["node_j"])] for r in spring_rows] == springs["pairs"]
    assert [float(r["stiffness"]) for r in spring_rows] == pytest.approx(springs["stiffness"], rel=1e-11)
    chain = client.design_sequential(features=[{"kind": "fixed_point", "d": 1.5, "slope": -0.5}],
                                     chain={"n_modules": 3})
    graph = nx.read_graphml(io.BytesIO(client.export(chain, "graphml").content), node_type=int)
    assert set(nx.get_edge_attributes(graph, "kind").values()) == {"rod"}
    assert graph.number_of_edges() == len(chain["chain"]["frame"]["edges"])
