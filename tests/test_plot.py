"""Pictures (zeromode.viz, POST /v1/plot, `zeromode plot`).

The SVG is read back with xml.etree and checked against the frame from scratch: one circle per
node and one line per bar, the paper's colours per node class, a similarity (2D) or orthographic
(3D) map from positions to the page, arrows parallel to the modes at 15–25 % of the frame's size,
and solution-space points that satisfy every bar constraint by an independent least-squares
solve for u_U. PNG and PDF are checked against the SVG they must show: the PNG's pixels at the
SVG's node centres and arrow shafts carry the SVG's colours, the PDF's page is the SVG's size,
and (where the system has libcairo) an independent SVG renderer, cairosvg, draws the same ink.
"""

from __future__ import annotations

import io
import json
import math
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from oracles.motion import boundary_strains
from PIL import Image
from scipy.ndimage import binary_dilation

from zeromode.service.cli import main
from zeromode.service.wire.examples import example_request
from zeromode.service.wire.responses import frame_body
from zeromode.solver.construction.design import design
from zeromode.solver.frame import Frame
from zeromode.viz.curves import solution_drawing
from zeromode.viz.geometry import Window
from zeromode.viz.picture import Picture
from zeromode.viz.svg import picture_svg

SVG = "{http://www.w3.org/2000/svg}"
RED, BLUE, GREY = "#d7301f", "#2c7fb8", "#a3a3a3"


def figure(frame, **options) -> str:
    return picture_svg(Picture.build(frame, **options))


def designed(name: str):
    r = example_request(name)
    opts = r.get("options", {})
    return r, design(r["positions"], r["motions"], dim=r["dim"], seed=0, n_unspecified=opts.get("n_unspecified"))


def parse(svg: str) -> ET.Element:
    root = ET.fromstring(svg)
    assert root.tag == SVG + "svg"
    return root


def with_class(root: ET.Element, tag: str, *classes: str) -> list[ET.Element]:
    return [e for e in root.iter(SVG + tag) if set(classes) <= set(e.get("class", "").split())]


def centres(nodes: list[ET.Element]) -> np.ndarray:
    return np.array([[float(n.get("cx")), float(n.get("cy"))] for n in nodes])


def polygon(e: ET.Element) -> np.ndarray:
    return np.array([[float(v) for v in p.split(",")] for p in e.get("points").split()])


def rgb(colour: str) -> np.ndarray:
    return np.array([int(colour[i : i + 2], 16) for i in (1, 3, 5)], dtype=float)


def least_squares_motion_residual(x_s: np.ndarray, u_s: np.ndarray, x_u: np.ndarray) -> float:
    """min over u_U of max_i |(x_Si − x_U)·(u_Si − u_U)|, relative to the problem's scale."""
    a = x_s - x_u
    u_u, *_ = np.linalg.lstsq(a, np.einsum("ij,ij->i", a, u_s), rcond=None)
    scale = np.max(np.linalg.norm(a, axis=1)) * max(np.max(np.linalg.norm(u_s, axis=1)), np.linalg.norm(u_u))
    return float(np.max(np.abs(np.einsum("ij,ij->i", a, u_s - u_u))) / scale)


def by_node(elements: list[ET.Element]) -> dict[int, ET.Element]:
    return {int(e.get("data-node")): e for e in elements}


def node_page(root: ET.Element, n: int) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Page centres (n, 2), radii (n,) and fills of the node circles, in node order."""
    nodes = by_node(with_class(root, "circle", "node"))
    assert sorted(nodes) == list(range(n))
    ordered = [nodes[i] for i in range(n)]
    return centres(ordered), np.array([float(e.get("r")) for e in ordered]), [e.get("fill") for e in ordered]


def arrow_vectors(arrows: list[ET.Element]) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """node → (base, tip − base) of each arrow polygon (corners 0 and 6 flank the base, 3 is the tip)."""
    out = {}
    for a in arrows:
        p = polygon(a)
        base = 0.5 * (p[0] + p[6])
        out[int(a.get("data-node"))] = (base, p[3] - base)
    return out


@pytest.mark.parametrize("name", ["outward_2d", "outward_2d_four_nodes"])
def test_2d_design_picture(name):
    r, d = designed(name)
    frame, k = d.frame, len(r["positions"])
    root = parse(figure(frame, modes=d.modes, targets=r["motions"], solution_space=True))
    assert len(with_class(root, "circle", "node")) == frame.n_nodes
    bars = with_class(root, "line", "bar")
    assert len(bars) == frame.n_edges and {b.get("stroke") for b in bars} == {GREY}
    page, _, fills = node_page(root, frame.n_nodes)
    assert fills == [RED] * k + [BLUE] * (frame.n_nodes - k)
    spec = with_class(root, "circle", "node", "specified")
    assert sorted(int(e.get("data-node")) for e in spec) == list(frame.specified)

    # The page is a similarity image of the positions with y flipped (aspect ratio preserved).
    x = frame.positions
    fit = np.column_stack([np.ones(len(x)), x[:, 0], -x[:, 1]])
    (cx0, sx, _), *_ = np.linalg.lstsq(fit, page[:, 0], rcond=None)
    (cy0, _, sy), *_ = np.linalg.lstsq(fit, page[:, 1], rcond=None)
    assert sx > 0 and abs(sx - sy) < 1e-3 * sx
    assert np.allclose(page, np.column_stack([cx0 + sx * x[:, 0], cy0 - sy * x[:, 1]]), atol=0.08)
    # Bars join the right circles.
    for b in bars:
        i, j = frame.edges[int(b.get("data-edge"))]
        ends = np.array([[float(b.get("x1")), float(b.get("y1"))], [float(b.get("x2")), float(b.get("y2"))]])
        assert np.allclose(ends, page[[i, j]], atol=0.06)

    # One hollow arrow per specified node, one solid arrow per node, each starting at its node
    # and parallel to the mode (y flipped); the longest is 15–25 % of the frame's size, and a
    # requested motion and the designed mode have the same direction on a specified node.
    hollow = arrow_vectors(with_class(root, "polygon", "arrow", "target"))
    solid = arrow_vectors(with_class(root, "polygon", "arrow", "mode"))
    assert sorted(hollow) == list(frame.specified) and sorted(solid) == list(range(frame.n_nodes))
    assert {h.get("fill") for h in with_class(root, "polygon", "arrow", "target")} == {"#ffffff"}
    size = np.max(np.ptp(page, axis=0))
    for i, (base, vec) in solid.items():
        mode = d.modes[0][i] * [1, -1]
        assert np.allclose(base, page[i], atol=0.1)
        assert vec @ mode / (np.linalg.norm(vec) * np.linalg.norm(mode)) > 0.9999
    for i, (base, vec) in hollow.items():
        assert vec @ solid[i][1] / (np.linalg.norm(vec) * np.linalg.norm(solid[i][1])) > 0.9999
    longest = max(np.linalg.norm(v) for _, v in solid.values())
    assert 0.15 <= longest / size <= 0.25

    # The solution space: smooth polylines (the conic) under the frame.
    curves = with_class(root, "polyline", "solution")
    assert curves and sum(len(polygon(c)) for c in curves) > 100


def test_outward_square_solution_space_is_the_circle_through_the_corners():
    r = example_request("outward_2d")
    x_s, u_s = np.array(r["positions"]), np.array(r["motions"][0])
    drawing = solution_drawing(x_s, u_s)
    assert drawing.kind == "conic" and len(drawing.curves) == 1
    curve = drawing.curves[0]
    assert np.allclose(np.linalg.norm(curve, axis=1), np.sqrt(2), atol=1e-9)
    assert max(least_squares_motion_residual(x_s, u_s, p) for p in curve[::7]) < 1e-9
    # Closed and dense: consecutive points near, the angles leave no gap.
    steps = np.linalg.norm(np.diff(curve, axis=0), axis=1)
    assert np.linalg.norm(curve[0] - curve[-1]) < 0.05 and steps.max() < 0.05
    angles = np.sort(np.arctan2(curve[:, 1], curve[:, 0]))
    assert np.max(np.diff(np.r_[angles, angles[0] + 2 * np.pi])) < 0.05


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_conic_tracing_is_correct_and_complete(seed):
    """Build 3 specified nodes around a known solution (x_U, u_U) in 2D (m = 2, a conic): the
    traced curve passes through x_U and every traced point admits a u_U."""
    rng = np.random.default_rng(seed)
    x_u, u_u = rng.uniform(-1, 1, 2), rng.normal(size=2)
    x_s = rng.uniform(-2, 2, (3, 2))
    a = x_s - x_u
    u_s = rng.normal(size=(3, 2))
    u_s -= (np.einsum("ij,ij->i", a, u_s - u_u) / np.einsum("ij,ij->i", a, a))[:, None] * a
    window = Window.around(np.vstack([x_s, x_u]))
    drawing = solution_drawing(x_s, u_s, window)
    assert drawing.kind == "conic"
    points = np.vstack(drawing.curves)
    size = np.max(np.ptp(np.vstack([x_s, x_u]), axis=0))
    assert np.min(np.linalg.norm(points - x_u, axis=1)) < 0.01 * size
    assert max(least_squares_motion_residual(x_s, u_s, p) for p in points[::11]) < 1e-7
    for curve in drawing.curves:
        assert np.max(np.linalg.norm(np.diff(curve, axis=0), axis=1)) < 0.05 * window.screen_size


def test_cube_solution_space_is_a_sphere_drawn_as_a_wireframe():
    r = example_request("cube_outward_3d")
    x_s, u_s = np.array(r["positions"]), np.array(r["motions"][0])
    drawing = solution_drawing(x_s, u_s)
    assert drawing.kind == "quadric_surface" and len(drawing.curves) >= 10
    points = np.vstack(drawing.curves)
    # The paper's Fig. 3d: a sphere.  |x|² = 2c·x + (ρ² − |c|²) fitted by least squares.
    sol, *_ = np.linalg.lstsq(np.column_stack([2 * points, np.ones(len(points))]), (points**2).sum(axis=1), rcond=None)
    radii = np.linalg.norm(points - sol[:3], axis=1)
    assert np.ptp(radii) < 1e-9 * radii.mean() and np.allclose(sol[:3], 0, atol=1e-9)
    # Parallels and meridians reach all round it: points in every octant.
    assert len({tuple(v) for v in (points - sol[:3] > 0)}) == 8
    assert max(least_squares_motion_residual(x_s, u_s, p) for p in points[::37]) < 1e-9


def test_3d_picture_is_orthographic_with_depth_cues():
    r, d = designed("cube_outward_3d")
    frame, k = d.frame, len(r["positions"])
    root = parse(figure(frame, modes=d.modes, targets=r["motions"], solution_space=True))
    assert len(with_class(root, "line", "bar")) == frame.n_edges
    page, radius, fills = node_page(root, frame.n_nodes)
    x = frame.positions
    fit = np.column_stack([np.ones(len(x)), x])
    coef = np.linalg.lstsq(fit, np.column_stack([page * [1, -1], radius]), rcond=None)[0]
    assert np.allclose(fit @ coef[:, :2], page * [1, -1], atol=0.1)
    # Orthographic: the page is an affine image of x whose two rows are orthogonal, equally long.
    screen = coef[1:, :2].T
    g = screen @ screen.T
    assert abs(g[0, 1]) < 1e-3 * g[0, 0] and abs(g[0, 0] - g[1, 1]) < 1e-3 * g[0, 0]
    # Depth cue: the radius is affine in x along the one direction the page cannot see.
    assert np.allclose(fit @ coef[:, 2], radius, atol=0.06)
    depth = coef[1:, 2] / np.linalg.norm(coef[1:, 2])
    assert np.all(np.abs(screen @ depth) < 3e-2 * np.sqrt(g[0, 0]))  # radii are rounded to 0.1 px
    assert np.ptp(radius) > 0.2 * radius.max()
    # Farther (smaller) nodes are lighter; colours keep their class. Nodes are ordered by the
    # fitted radius: the written radii are rounded to 0.1 px, which ties nodes of nearly one depth.
    light = np.array([rgb(f).sum() for f in fills])
    nearness = fit @ coef[:, 2]
    for nodes in (np.arange(k), np.arange(k, frame.n_nodes)):
        order = nodes[np.argsort(nearness[nodes])]
        assert np.all(np.diff(light[order]) <= 3)
    assert all(rgb(f)[0] > rgb(f)[2] for f in fills[:k]) and all(rgb(f)[2] > rgb(f)[0] for f in fills[k:])
    # Wireframe of the sphere drawn under the frame.
    assert len(with_class(root, "polyline", "solution")) > 50


def test_empty_solution_space_is_said_not_invented():
    # Six generic specified nodes in 2D: b ∉ R(Ã), no unspecified node can join them all.
    rng = np.random.default_rng(3)
    x_s, u_s = rng.normal(size=(6, 2)), rng.normal(size=(6, 2))
    frame = Frame.build(x_s, [], list(range(6)))
    root = parse(figure(frame, targets=[u_s], solution_space=True))
    assert not with_class(root, "polyline", "solution") and not with_class(root, "circle", "solution")
    assert any("solution space (empty)" == (t.text or "") for t in root.iter(SVG + "text"))


def test_api_returns_svg_for_a_design(client):
    r, d = designed("outward_2d")
    body = {"frame": frame_body(d.frame), "modes": d.modes.tolist(), "targets": r["motions"],
            "solution_space": True, "title": "x < y & z"}
    resp = client.post("/v1/plot", json=body)
    assert resp.status_code == 200
    assert resp.headers["content-type"].startswith("image/svg+xml")
    root = parse(resp.text)
    assert len(with_class(root, "circle", "node")) == d.frame.n_nodes
    assert len(with_class(root, "line", "bar")) == d.frame.n_edges
    assert any(t.text == "x < y & z" for t in root.iter(SVG + "text"))
    paths = client.get("/openapi.json").json()["paths"]
    assert "image/svg+xml" in paths["/v1/plot"]["post"]["responses"]["200"]["content"]


def test_api_configurations_side_by_side_with_allosteric_markers(client):
    x = np.array([[0, 0], [1, 0], [0.5, 0.8], [1.5, 0.8], [2, 0]], float)
    edges = [[0, 1], [0, 2], [1, 2], [1, 3], [2, 3], [3, 4], [1, 4]]
    expanded, contracted = 1.2 * x, 0.7 * x
    body = {"frame": {"dim": 2, "positions": x.tolist(), "edges": edges, "specified": [0, 4]},
            "configurations": [expanded.tolist(), contracted.tolist()],
            "labels": ["frame", "expanded", "contracted"], "source": [0], "target_nodes": [4]}
    resp = client.post("/v1/plot", json=body)
    assert resp.status_code == 200, resp.text
    root = parse(resp.text)
    panels = [g for g in root.iter(SVG + "g") if g.get("class") == "panel"]
    assert len(panels) == 3
    scales = []
    for panel, pos in zip(panels, (x, expanded, contracted)):
        page, _, _ = node_page(panel, len(x))
        assert len(with_class(panel, "line", "bar")) == len(edges)
        # Each panel is the same similarity image (one scale for all: contraction stays visible).
        d_page = np.linalg.norm(page[1:] - page[0], axis=1)
        d_pos = np.linalg.norm(pos[1:] - pos[0], axis=1)
        assert np.allclose(d_page / d_pos, (d_page / d_pos).mean(), rtol=2e-3)
        scales.append((d_page / d_pos).mean())
        assert [int(m.get("data-node")) for m in with_class(panel, "polygon", "marker", "source")] == [0]
        assert [int(m.get("data-node")) for m in with_class(panel, "polygon", "marker", "target")] == [4]
    assert np.ptp(scales) < 2e-3 * scales[0]
    texts = {t.text for t in root.iter(SVG + "text")}
    assert {"frame", "expanded", "contracted", "source", "target"} <= texts


FRAME = {"dim": 2, "positions": [[0, 0], [1, 0], [0, 1]], "edges": [[0, 1], [1, 2], [0, 2]], "specified": [0, 1]}


@pytest.mark.parametrize(
    "body, code",
    [
        ({"frame": FRAME, "modes": [[[0, 0], [1, 0]]]}, "invalid_shape"),
        ({"frame": {**FRAME, "specified": []}, "targets": [[[0, 1]]]}, "invalid_targets"),
        ({"frame": FRAME, "targets": [[[0, 1], [1, 0], [0, 0]]]}, "invalid_shape"),
        ({"frame": FRAME, "source": [3]}, "invalid_nodes"),
        ({"frame": FRAME, "target_nodes": [1, 1]}, "invalid_nodes"),
        ({"frame": FRAME, "solution_space": True}, "no_motion"),
        ({"frame": FRAME, "labels": ["a", "b"]}, "invalid_labels"),
        ({"frame": FRAME, "configurations": [[[0, 0], [1, 0]]]}, "invalid_shape"),
        ({"frame": {**FRAME, "edges": [[0, 5]]}}, "edge_out_of_range"),
        ({"frame": FRAME, "configurations": [FRAME["positions"]] * 9}, "invalid_request"),
        ({"frame": FRAME, "modes": [[[0, 0], [1, "x"], [0, 0]]]}, "invalid_request"),
    ],
)
def test_api_bad_input_is_422_with_a_code(client, body, code):
    resp = client.post("/v1/plot", json=body)
    assert resp.status_code == 422
    detail = resp.json()["detail"]
    assert detail["code"] == code and detail["message"]


def test_api_rejects_non_finite_numbers(client):
    body = json.dumps({"frame": FRAME, "modes": [[[0, 0], [float("nan"), 0], [0, 0]]]})
    resp = client.post("/v1/plot", content=body, headers={"content-type": "application/json"})
    assert resp.status_code == 422


def test_cli_plots_a_request_and_a_response(tmp_path, client):
    request = example_request("cube_outward_3d")
    req = tmp_path / "request.json"
    req.write_text(json.dumps(request))
    assert main(["plot", str(req), "-o", str(tmp_path / "a.svg")]) == 0
    root = parse((tmp_path / "a.svg").read_text())
    _, d = designed("cube_outward_3d")
    assert len(with_class(root, "circle", "node")) == d.frame.n_nodes
    assert len(with_class(root, "polygon", "arrow", "target")) == len(request["positions"])
    assert with_class(root, "polyline", "solution")

    response = client.post("/v1/design", json=example_request("outward_2d")).json()
    resp_file = tmp_path / "response.json"
    resp_file.write_text(json.dumps(response))
    assert main(["plot", str(resp_file), "-o", str(tmp_path / "b.svg"), "--no-solution-space"]) == 0
    root = parse((tmp_path / "b.svg").read_text())
    assert len(with_class(root, "line", "bar")) == len(response["frame"]["edges"])
    assert len(with_class(root, "polygon", "arrow", "target")) == 4  # derived from the modes
    assert not with_class(root, "polyline", "solution")


def test_cli_refuses_other_formats_in_one_line(tmp_path, capsys):
    req = tmp_path / "request.json"
    req.write_text(json.dumps(example_request("outward_2d")))
    assert main(["plot", str(req), "-o", str(tmp_path / "a.gif")]) == 2
    err = capsys.readouterr().err.strip()
    assert ".svg" in err and ".png" in err and ".pdf" in err and err.count("\n") == 0
    assert not (tmp_path / "a.gif").exists()


# --------------------------------------------------------------------------------------------
# PNG and PDF show what the SVG shows.


def svg_and_raster(tmp_path, doc: dict, suffix: str, *extra: str) -> tuple[ET.Element, bytes]:
    """`zeromode plot` of one document as SVG and as ``suffix`` (png or pdf)."""
    path = tmp_path / "doc.json"
    path.write_text(json.dumps(doc))
    assert main(["plot", str(path), "-o", str(tmp_path / "a.svg"), *extra]) == 0
    assert main(["plot", str(path), "-o", str(tmp_path / f"a.{suffix}"), *extra]) == 0
    return parse((tmp_path / "a.svg").read_text()), (tmp_path / f"a.{suffix}").read_bytes()


def uncovered(circles: list[ET.Element]) -> list[ET.Element]:
    """The circles whose centre no circle painted after them covers (SVG paints in order)."""
    xy = centres(circles)
    r = np.array([float(c.get("r")) for c in circles])
    return [c for i, c in enumerate(circles) if np.all(np.linalg.norm(xy[i + 1 :] - xy[i], axis=1) > r[i + 1 :] + 1)]


RASTER_DOCUMENTS = {
    "design_2d": lambda: example_request("outward_2d"),
    "design_3d": lambda: example_request("cube_outward_3d"),
    "lattice": lambda: {"dim": 2, "cells": [3, 2], "poisson_ratio": -0.8},
    "allosteric": lambda: {
        "dim": 2,
        "source": {"positions": [[0, -0.5], [0, 0.5]], "motion": [[0, -1], [0, 1]]},
        "target": {"positions": [[6, -1], [6, 1]], "motion": [[0, 1], [0, -1]]},
    },
}


@pytest.mark.parametrize("name", sorted(RASTER_DOCUMENTS))
def test_png_pixels_carry_the_svg_colours(tmp_path, name):
    """At 2 pixels per SVG pixel: the PNG is the SVG's size, and at the centre of every node no
    later node covers, and halfway along every solid arrow clear of the nodes, the pixel has that
    shape's fill (antialiasing and 8-bit colour: within 12 levels per channel)."""
    scale = 2.0
    root, png = svg_and_raster(tmp_path, RASTER_DOCUMENTS[name](), "png", "--scale", str(scale))
    image = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=float)
    width, height = (float(root.get(a)) for a in ("width", "height"))
    assert image.shape[:2] == (math.ceil(height * scale), math.ceil(width * scale))

    def pixel(x: float, y: float) -> np.ndarray:
        return image[int(y * scale), int(x * scale)]

    nodes = with_class(root, "circle", "node")
    checked = uncovered(nodes)
    assert len(checked) >= 0.8 * len(nodes)
    for node in checked:
        # Markers are outlines around their node: its centre stays the node's fill.
        assert np.abs(pixel(float(node.get("cx")), float(node.get("cy"))) - rgb(node.get("fill"))).max() <= 12
    node_xy = centres(nodes)
    node_r = np.array([float(n.get("r")) for n in nodes])
    shafts = 0
    for arrow in with_class(root, "polygon", "arrow", "mode"):
        p = polygon(arrow)
        middle = 0.5 * (0.5 * (p[0] + p[6]) + p[3])
        if np.all(np.linalg.norm(node_xy - middle, axis=1) > node_r + 2) and np.linalg.norm(p[0] - p[6]) * scale >= 3:
            assert np.abs(pixel(*middle) - rgb(arrow.get("fill"))).max() <= 12
            shafts += 1
    assert shafts >= 2


def test_pdf_page_is_the_svg_size(tmp_path):
    root, pdf = svg_and_raster(tmp_path, example_request("outward_2d"), "pdf")
    assert pdf[:5] == b"%PDF-"
    box = [float(v) for v in re.search(rb"/MediaBox\s*\[\s*([\d.\s]+)\]", pdf).group(1).split()]
    assert box[:2] == [0, 0]
    # Whole output pixels at the default scale 1.5: at most 1/1.5 pt more than the SVG.
    for got, want in zip(box[2:], (float(root.get("width")), float(root.get("height")))):
        assert want <= got < want + 1 / 1.5 + 1e-6


def test_png_draws_the_ink_an_independent_svg_renderer_draws(tmp_path):
    """cairosvg renders the SVG; matplotlib's PNG puts ink (any channel below 200) on nearly the
    same pixels outside the text. Text is left out (where cairosvg draws glyphs, dilated by 3 px):
    the two renderers pick their fonts from the system, so glyphs differ with the fonts installed
    (installing Debian's chromium, which brings fonts, moved the allosteric picture's IoU with text
    from 0.92 to 0.85). Measured without text: 0.945–0.975 on the pictures here; 0.71–0.93 against
    a render that lost its nodes or its arrows."""
    try:
        import cairosvg
    except (ImportError, OSError) as exc:  # OSError: cairocffi found no libcairo on the system
        pytest.skip(f"cairosvg cannot load ({exc}); install the system's libcairo2 to run this check")
    for name, build in sorted(RASTER_DOCUMENTS.items()):
        _, png = svg_and_raster(tmp_path, build(), "png")
        ours = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))
        rendered = cairosvg.svg2png(bytestring=(tmp_path / "a.svg").read_bytes(), scale=1.5)
        theirs = np.asarray(Image.open(io.BytesIO(rendered)).convert("RGB"))
        h, w = min(ours.shape[0], theirs.shape[0]), min(ours.shape[1], theirs.shape[1])
        a, b = ours[:h, :w].min(axis=2) < 200, theirs[:h, :w].min(axis=2) < 200
        no_text = re.sub(r"<text[^>]*>.*?</text>", "", (tmp_path / "a.svg").read_text(), flags=re.DOTALL)
        shapes = np.asarray(
            Image.open(io.BytesIO(cairosvg.svg2png(bytestring=no_text.encode(), scale=1.5))).convert("RGB")
        )[:h, :w].min(axis=2) < 200
        keep = ~binary_dilation(b & ~shapes, iterations=3)
        assert (a & b & keep).sum() / ((a | b) & keep).sum() >= 0.935, name


# --------------------------------------------------------------------------------------------
# Lattices and allosteric frames: `zeromode plot` on saved /v1/design/auxetic and
# /v1/design/allosteric responses, and POST /v1/plot drawing the same.


def panels(root: ET.Element) -> list[ET.Element]:
    found = {g.get("id"): g for g in root.iter(SVG + "g") if g.get("class") == "panel"}
    return [found[f"panel-{k}"] for k in range(len(found))]


def text_of(panel: ET.Element, cls: str) -> str:
    (t,) = with_class(panel, "text", cls)
    return t.text


def numbers(text: str) -> list[float]:
    import re

    return [float(v) for v in re.findall(r"[+-]?\d+\.\d+", text.replace("\u2212", "-"))]


def similarity_scale(page: np.ndarray, x: np.ndarray) -> float:
    """The scale s of page = c + s·(x, −y) (2D, y flipped); asserts the map is such a similarity."""
    fit = np.column_stack([np.ones(len(x)), x[:, 0], -x[:, 1]])
    coef = np.linalg.lstsq(fit, page, rcond=None)[0]  # rows: offset, x, −y; columns: page x, y
    s = coef[1, 0]
    assert s > 0 and np.allclose(coef[1:], s * np.eye(2), atol=1e-3 * s)
    assert np.allclose(fit @ coef, page, atol=0.08)
    return float(s)


def plot_cli(tmp_path, name: str, doc: dict, *extra: str) -> ET.Element:
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(doc))
    out = tmp_path / f"{name}.svg"
    assert main(["plot", str(path), "-o", str(out), *extra]) == 0
    return parse(out.read_text())


@pytest.fixture(scope="module")
def auxetic(client):
    resp = client.post("/v1/design/auxetic", json={"dim": 2, "cells": [2, 2], "poisson_ratio": -1.0, "strain": 0.1})
    assert resp.status_code == 200, resp.text
    return resp.json()


def test_cli_draws_an_auxetic_response_contracted_reference_expanded(tmp_path, auxetic):
    doc = json.loads(json.dumps(auxetic))
    x = np.array(doc["frame"]["positions"])
    edges = np.array(doc["frame"]["edges"])
    n = len(x)
    # Give the mode a rigid part (a translation and a rotation, as the 3D chain's mode has): it
    # is still a zero mode of the same frame, and the picture must show the deformation only.
    mode = np.array(doc["modes"][0]) + [0.7, -0.4] + 0.5 * (x - x.mean(axis=0)) @ [[0, 1], [-1, 0]]
    doc["modes"] = [mode.tolist()]
    root = plot_cli(tmp_path, "auxetic", doc)

    states = {s["name"]: s for s in doc["states"]}
    expected = [("contracted", np.array(states["contracted"]["positions"])), ("reference", x),
                ("expanded", np.array(states["expanded"]["positions"]))]
    groups = panels(root)
    assert [text_of(g, "label") for g in groups] == [name for name, _ in expected]
    boundary = doc["report"]["boundary"]

    scales, centres_x = [], []
    for g, (name, pos) in zip(groups, expected):
        page, _, fills = node_page(g, n)
        assert len(with_class(g, "line", "bar")) == len(edges) and set(fills) == {BLUE}
        scales.append(similarity_scale(page, pos))
        centres_x.append(page[:, 0].mean())
        caption = numbers(text_of(g, "caption"))
        if name == "reference":
            assert caption == pytest.approx([doc["poisson_ratio"]], abs=0.006)
        else:
            eps_x, _ = boundary_strains(x, pos, boundary, finite=True)
            assert caption == pytest.approx([eps_x, states[name]["poisson_ratio"]], abs=0.006)
            assert not with_class(g, "polygon", "arrow")
    assert np.ptp(scales) < 1e-3 * scales[0] and np.all(np.diff(centres_x) > 0)  # one scale, in a row

    # The reference's arrows: a zero mode of the bars, (x_i − x_j)·(u_i − u_j) = 0, with no
    # rigid part left (no net translation, no net rotation about the centroid).
    page, _, _ = node_page(groups[1], n)
    arrows = arrow_vectors(with_class(groups[1], "polygon", "arrow", "mode"))
    assert len(arrows) >= n - 1  # only a node that does not move may lack an arrow
    u = np.zeros((n, 2))
    for i, (base, vec) in arrows.items():
        assert np.allclose(base, page[i], atol=0.1)
        u[i] = vec
    longest = np.max(np.linalg.norm(u, axis=1))
    for i, j in edges:
        if i in arrows and j in arrows:
            d = page[i] - page[j]
            assert abs(d @ (u[i] - u[j])) < 1e-2 * np.linalg.norm(d) * longest
    c = page - page.mean(axis=0)
    assert np.linalg.norm(u.sum(axis=0)) < 0.02 * n * longest
    assert abs(np.sum(c[:, 0] * u[:, 1] - c[:, 1] * u[:, 0])) < 0.02 * n * longest * np.max(np.linalg.norm(c, axis=1))
    # The untouched mode has no rigid part: the raw mode is drawn then, along the same lines.
    raw = arrow_vectors(with_class(panels(plot_cli(tmp_path, "raw", auxetic))[1], "polygon", "arrow", "mode"))
    assert all(np.allclose(raw[i][1], arrows[i][1], atol=0.3) for i in raw)


def test_api_draws_a_big_sheet_readably_with_arrows_on_its_boundary(tmp_path, client):
    resp = client.post("/v1/design/auxetic", json={"dim": 2, "cells": [12, 12], "poisson_ratio": -0.5})
    assert resp.status_code == 200, resp.text
    doc = resp.json()
    n = len(doc["frame"]["positions"])
    assert n > 200
    root = plot_cli(tmp_path, "big", doc)
    assert [len(with_class(g, "circle", "node")) for g in panels(root)] == [n] * 3

    reference = panels(root)[1]
    page, radius, _ = node_page(reference, n)
    boundary = set().union(*map(set, doc["report"]["boundary"].values()))
    arrows = arrow_vectors(with_class(reference, "polygon", "arrow", "mode"))
    assert set(arrows) <= boundary and 8 <= len(arrows) <= 36
    for side in doc["report"]["boundary"].values():
        assert len(set(side) & set(arrows)) >= 3
    # Readable: a node is smaller than a third of the gap to its nearest neighbour (median),
    # bars are thinner than nodes, and arrows are many node sizes long.
    gaps = np.linalg.norm(page[:, None] - page[None], axis=2)
    np.fill_diagonal(gaps, np.inf)
    assert radius.max() <= 0.34 * np.median(gaps.min(axis=1))
    assert max(float(b.get("stroke-width")) for b in with_class(reference, "line", "bar")) < radius.min()
    assert min(np.linalg.norm(v) for _, v in arrows.values()) > 5 * radius.max()

    # Without arrow_nodes, /v1/plot spreads arrows over the whole frame (a frame > 200 nodes).
    states = {s["name"]: s["positions"] for s in doc["states"]}
    body = {"frame": doc["frame"], "modes": doc["modes"], "frame_panel": 1,
            "configurations": [states["contracted"], states["expanded"]]}
    spread = panels(parse(client.post("/v1/plot", json=body).text))[1]
    nodes = sorted(arrow_vectors(with_class(spread, "polygon", "arrow", "mode")))
    assert 20 <= len(nodes) <= 100
    to_nearest = np.min(np.linalg.norm(page[:, None] - page[nodes][None], axis=2), axis=1)
    assert to_nearest.max() < 0.15 * np.max(np.ptp(page, axis=0))


@pytest.fixture(scope="module")
def allosteric_request():
    return {
        "dim": 2,
        "source": {"positions": [[0, -0.5], [0, 0.5]], "motion": [[0, -1], [0, 1]]},
        "target": {"positions": [[6, -1], [6, 1]], "motion": [[0, 1], [0, -1]]},
        # Economy: a chain with relays to draw (the default search may join these sites directly).
        "options": {"robustness": "economy"},
    }


@pytest.mark.parametrize("as_request", [False, True], ids=["response", "request"])
def test_cli_draws_an_allosteric_frame_with_source_and_target_marked(tmp_path, client, allosteric_request, as_request):
    resp = client.post("/v1/design/allosteric", json=allosteric_request)
    assert resp.status_code == 200, resp.text
    doc = resp.json()
    report, n = doc["report"], len(doc["frame"]["positions"])
    root = plot_cli(tmp_path, "allosteric", allosteric_request if as_request else doc)
    (panel,) = panels(root)
    _, _, fills = node_page(panel, n)
    source, target, relays = report["source"], report["target"], report["relays"]
    assert relays and all(fills[i] == BLUE for i in relays)
    assert all(fills[i] == RED for i in source + target)
    assert sorted(int(m.get("data-node")) for m in with_class(panel, "polygon", "marker", "source")) == source
    assert sorted(int(m.get("data-node")) for m in with_class(panel, "polygon", "marker", "target")) == target
    # Hollow arrows on the target nodes only, along the prescribed motion (y flipped); solid
    # arrows along the source motion on the source nodes.
    hollow = arrow_vectors(with_class(panel, "polygon", "arrow", "target"))
    solid = arrow_vectors(with_class(panel, "polygon", "arrow", "mode"))
    assert sorted(hollow) == target
    for nodes, site in ((target, hollow), (source, solid)):
        motion = allosteric_request["target" if site is hollow else "source"]["motion"]
        for i, u in zip(nodes, np.array(motion, float)):
            vec = site[i][1]
            assert vec @ (u * [1, -1]) / (np.linalg.norm(vec) * np.linalg.norm(u)) > 0.999
    assert not with_class(panel, "polyline", "solution") and not with_class(panel, "circle", "solution")
    assert {"source", "target", "requested motion", "zero mode"} <= {t.text for t in root.iter(SVG + "text")}


def test_cli_says_which_documents_it_draws(tmp_path, capsys):
    path = tmp_path / "other.json"
    path.write_text(json.dumps({"hello": 1}))
    assert main(["plot", str(path), "-o", str(tmp_path / "x.svg")]) == 2
    err = capsys.readouterr().err
    assert "invalid_document" in err and "/v1/design/allosteric" in err


def strip_body(length: float, **extra) -> dict:
    x = np.array([[0, 0], [length, 0], [length, 1], [0, 1]], float)
    return {"frame": {"dim": 2, "positions": x.tolist(), "edges": [[0, 1], [1, 2], [2, 3], [3, 0], [0, 2]]},
            "configurations": [(0.9 * x).tolist(), (1.1 * x).tolist()], "frame_panel": 1,
            "labels": ["small", "frame", "large"], "captions": ["a", "b", "c"], **extra}


@pytest.mark.parametrize("length, stacked", [(1.0, False), (5.0, True)])
def test_api_panels_in_a_row_or_a_column_with_labels_above_and_captions_below(client, length, stacked):
    resp = client.post("/v1/plot", json=strip_body(length, modes=[[[0, 0], [1, 0], [1, 0], [0, 0]]]))
    assert resp.status_code == 200, resp.text
    groups = panels(parse(resp.text))
    assert [text_of(g, "label") for g in groups] == ["small", "frame", "large"]
    assert [text_of(g, "caption") for g in groups] == ["a", "b", "c"]
    # The frame (with its arrows) is the middle panel.
    assert [len(with_class(g, "polygon", "arrow")) for g in groups] == [0, 2, 0]
    centres = []
    for g in groups:
        page, _, _ = node_page(g, 4)
        label_y, caption_y = (float(with_class(g, "text", c)[0].get("y")) for c in ("label", "caption"))
        assert label_y < page[:, 1].min() and caption_y > page[:, 1].max()
        centres.append(page.mean(axis=0))
    # Panels are centred across the layout (the frame's panel is widened by its arrows).
    centres = np.array(centres)
    along, across = (1, 0) if stacked else (0, 1)
    assert np.all(np.diff(centres[:, along]) > 50) and abs(centres[2, across] - centres[0, across]) < 1.0


def test_api_view_turns_a_3d_frame(client):
    x = np.array([[0, 0, 0], [2, 0, 0], [0, 1, 0], [0, 0, 1.5], [1, 1, 1]], float)
    frame = {"dim": 3, "positions": x.tolist(), "edges": [[0, 1], [0, 2], [0, 3], [1, 4], [2, 4], [3, 4]]}
    for view, fits in (([-90, 0], True), (None, False)):
        body = {"frame": frame} | ({"view": view} if view else {})
        page, _, _ = node_page(parse(client.post("/v1/plot", json=body).text), len(x))
        # Seen from −y at zero elevation: page x ∝ data x, page y ∝ −z.
        fit = np.column_stack([np.ones(len(x)), x[:, 0], -x[:, 2]])
        coef = np.linalg.lstsq(fit, page, rcond=None)[0]
        assert np.allclose(fit @ coef, page, atol=0.1) == fits


@pytest.mark.parametrize(
    "body, code",
    [
        ({"frame": FRAME, "frame_panel": 1}, "invalid_frame_panel"),
        ({"frame": FRAME, "configurations": [FRAME["positions"]], "captions": ["a", "b", "c"]}, "invalid_captions"),
        ({"frame": FRAME, "arrow_nodes": [0, 7]}, "invalid_nodes"),
        ({"frame": FRAME, "view": [0, float("inf")]}, "invalid_request"),
    ],
)
def test_api_bad_panel_options_are_422_with_a_code(client, body, code):
    resp = client.post("/v1/plot", content=json.dumps(body), headers={"content-type": "application/json"})
    assert resp.status_code == 422
    assert resp.json()["detail"]["code"] == code
