"""The designer page (GET /) in Debian's chromium against a live uvicorn on loopback (with a real
Dask cluster behind the jobs API): a design drawn by hand, as the issue's Done-when asks.

Checked through independent routes: the solution space the page computes in JavaScript
(service/rest/static/solution_space.js) against the definition — a point p of it has a motion v with
(x_i − p)·(u_i − v) = 0 for every specified node i, found here by numpy's least squares; the
outward square's space is the circle through its corners (closed form); the ε chart's polylines
and labels and the Play warning against the service's numbers in its response bodies (the
curves themselves are checked against an oracle in test_epsilon_curve.py); the downloaded file read back with meshio. Latency figures
are recorded by benchmarks/bench_designer.py, not asserted here (no test races the clock).
"""

from __future__ import annotations

import csv
import io
import itertools
import json
from pathlib import Path

import meshio
import numpy as np
import pytest
from browser import browser, designer_url, open_page  # noqa: F401 (fixtures)
from oracles.rigidity import compatibility_matrix, reference_counts, rigid_generators
from oracles.two_triangles import TwoTriangles
from scipy.optimize import brentq

from benchmarks.bench_designer import (
    ARROW,
    CORNERS,
    drag_arrow,
    draw_outward_square,
    screen,
    space_d,
)

# Waits for the page: a design, a job on the cluster, on a busy 2-core machine.
TIMEOUT_MS = 180_000


def motion_for(x: np.ndarray, u: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, float]:
    """The motion v of a node at p joined to every specified node, from the definition
    (x_i − p)·(u_i − v) = 0 ⇔ (x_i − p)·v = (x_i − p)·u_i, by least squares; its largest
    residual relative to the scale of the terms."""
    rows = x - p
    rhs = np.einsum("ij,ij->i", rows, u)
    v, *_ = np.linalg.lstsq(rows, rhs, rcond=None)
    scale = np.abs(rows).max() * max(np.abs(u).max(), np.abs(v).max(), 1e-300)
    return v, float(np.abs(rows @ v - rhs).max() / scale)


def legend(page) -> set[str]:
    """What the legend lists (its entries' keys)."""
    return set(page.eval_on_selector_all("[data-testid=legend] span[data-key]", "s => s.map(e => e.dataset.key)"))


def polyline_distance(line: np.ndarray, p: np.ndarray) -> float:
    """Distance from p to the polyline through the rows of ``line``."""
    a, b = line[:-1], line[1:]
    t = np.clip(np.einsum("ij,ij->i", p - a, b - a) / np.maximum(np.einsum("ij,ij->i", b - a, b - a), 1e-300), 0, 1)
    return float(np.linalg.norm(a + t[:, None] * (b - a) - p, axis=1).min())


def label_number(text: str) -> float:
    """The number after "= " in a chart label as the page formats it ("0.431", "1.87e-8")."""
    return float(text.rsplit("= ", 1)[1])


def check_epsilon_chart(page, amplitudes, curves: dict) -> None:
    """The ε chart (#epsilon) draws exactly ``curves`` (name → ε at ``amplitudes``): each
    polyline's points are one affine image of (amplitude, ε) shared by all curves (to the
    page's 0.1 px rounding), and each label states the last value to the page's 3 digits."""
    lines = {name: np.array([[float(v) for v in p.split(",")] for p in page.get_attribute(
        f"#epsilon polyline.epsilon.{name}", "points").split()]) for name in curves}
    assert len(page.query_selector_all("#epsilon polyline.epsilon")) == len(curves)
    values = np.concatenate([np.asarray(v, dtype=float) for v in curves.values()])
    pixels = np.concatenate([lines[name] for name in curves])
    scale_x, residual_x = affine_fit(np.tile(np.asarray(amplitudes, dtype=float), len(curves)), pixels[:, 0])
    scale_y, residual_y = affine_fit(values, pixels[:, 1])
    assert scale_x > 0 and scale_y < 0  # ε grows upwards
    assert residual_x <= 0.06 and residual_y <= 0.06
    for name, eps in curves.items():
        assert label_number(page.text_content(f"#epsilon text.epsilon-label.{name}")) == pytest.approx(eps[-1], rel=5e-3)


def test_draw_design_play_refine_certify_and_download(browser, designer_url, tmp_path):  # noqa: F811
    page, problems = open_page(browser, designer_url)
    page.fill("[data-testid=name]", "outward_2d")
    shapes = draw_outward_square(page)
    assert page.evaluate("designer.nodes.length") == 4
    # Three specified nodes: a conic, redrawn as the third arrow moves (Fig. 2).
    assert all(d for d in shapes[2]) and len(set(shapes[2])) >= 4
    # Four nodes moving outward (a dilation): Ã loses a rank and the space is a conic again, the
    # circle through the corners (Fig. 3a) — the closed form, not the page's own arithmetic.
    assert page.get_attribute("[data-testid=solution-space]", "data-kind") == "conic"
    assert page.is_visible("[data-testid=solution-space]")
    assert len(page.query_selector_all("#canvas line.arrow.drawn")) == 4
    x = np.array(CORNERS)
    u = ARROW * x
    assert np.allclose(page.evaluate("designer.motions[0]"), u)
    curve = np.concatenate([np.array(c) for c in page.evaluate("designer.spaces[0].curves")])
    assert len(curve) > 100
    assert np.allclose(np.linalg.norm(curve, axis=1), np.sqrt(2), atol=1e-9)
    assert max(motion_for(x, u, p)[1] for p in curve) < 1e-9

    page.click("[data-testid=design]")
    page.wait_for_selector("[data-testid=play]:not([disabled])", timeout=TIMEOUT_MS)
    design = page.evaluate("designer.response")
    frame = np.array(design["frame"]["positions"])
    assert np.allclose(frame[:4], x) and design["report"]["analysis"]["nontrivial_zero_modes"] == 1
    # The service's unspecified nodes sit on the space the page drew.
    assert np.allclose(np.linalg.norm(frame[4:], axis=1), np.sqrt(2), atol=1e-6)
    assert len(page.query_selector_all("#canvas circle.node")) == len(frame)
    assert len(page.query_selector_all("#canvas line.bar")) == len(design["frame"]["edges"])
    assert page.evaluate("designer.timings.design.length") == 1
    # The linear design's finite path leaves the arrows (ε ≈ 0.56 at a = 0.3): said, Refine offered.
    page.wait_for_function("document.getElementById('status').textContent.includes('finite motion')", timeout=TIMEOUT_MS)
    status = page.inner_text("[data-testid=status]")
    assert "leaves the arrows" in status and "Refine" in status and page.is_enabled("[data-testid=refine]")
    assert {"specified", "unspecified", "mode", "space-0"} <= legend(page) and "source" not in legend(page)
    # The Play warning quotes the service's ε at the amplitude (POST /v1/motion's epsilon_curve).
    linear = page.evaluate("designer.motionPath.epsilon_curve")
    a = float(page.input_value("[data-testid=amplitude]"))
    assert linear["amplitudes"][-1] == pytest.approx(a, rel=1e-12)
    bound = "≥" if linear["at_end"][-1] else "="
    quoted = str(float(f"{linear['epsilon'][-1]:.2f}"))  # as the page's fmt(ε, 2)
    assert f"(ε {bound} {quoted} at a = {a:.2f}" in page.inner_text("#status")
    check_epsilon_chart(page, linear["amplitudes"], {"linear": linear["epsilon"]})

    # Play: the slider moves and the nodes with it, every bar still on its nodes.
    reference = page.evaluate("designer.motionPath.reference_index")
    keys, legend_box = legend(page), page.locator("[data-testid=legend]").bounding_box()
    page.click("[data-testid=play]")
    page.wait_for_function(f"+document.getElementById('slider').value !== {reference}")
    page.click("[data-testid=play]")
    k = int(page.input_value("[data-testid=slider]"))
    moved = np.array(page.evaluate("designer.motionPath.path")[k])
    assert np.abs(moved - frame).max() > 1e-3
    # The legend stays as it was (the mode's arrows, drawn at t = 0, keep their entry): nothing
    # under the drawing jumps while it plays.
    assert legend(page) == keys and page.locator("[data-testid=legend]").bounding_box() == legend_box

    # The amplitude control sets how far the motion is followed.
    page.eval_on_selector("[data-testid=amplitude]", "e => { e.value = '0.2'; e.dispatchEvent(new Event('input')); }")
    page.wait_for_function("designer.motionPath && Math.abs(Math.max(...designer.motionPath.parameter) - 0.2) < 1e-9",
                           timeout=TIMEOUT_MS)

    page.evaluate("designer.progressLog.length = 0")
    # The bar as drawn: every width its fill takes while the job runs (read from the DOM).
    page.evaluate("""() => {
        const fill = document.querySelector('[data-testid=progress] > div');
        window.widths = [];
        new MutationObserver(() => window.widths.push(parseFloat(fill.style.width))).observe(fill, {attributes: true});
    }""")
    page.click("[data-testid=refine]")
    page.wait_for_function("designer.refined && designer.refinedPath", timeout=TIMEOUT_MS)
    progress = page.evaluate("designer.progressLog")
    assert progress[-1] == 1 and len(set(progress)) >= 2 and progress == sorted(progress)
    widths = page.evaluate("window.widths")
    assert widths[0] == 0 and widths[-1] == 100 and widths == sorted(widths)
    refined = page.evaluate("designer.refined")
    assert refined["epsilon_after"] < refined["epsilon_before"]
    # The chart draws the service's curves, whose last values are the report's ε before and after.
    curve = refined["epsilon_curve"]
    assert curve["before"][-1] == refined["epsilon_before"] and curve["after"][-1] == refined["epsilon_after"]
    check_epsilon_chart(page, curve["amplitudes"], {"linear": curve["before"], "refined": curve["after"]})
    report = page.inner_text("[data-testid=report]")
    assert "ε before" in report and "ε after" in report

    page.click("[data-testid=certify]")
    page.wait_for_function("designer.certificate", timeout=TIMEOUT_MS)
    assert "rigidity margin" in page.inner_text("[data-testid=report]")
    # No self-stress: "not prestress stable" is what a mechanism should be, and the page says so.
    assert page.evaluate("designer.certificate.prestress.decided_by") == "no_self_stress"
    assert "stays free" in page.inner_text("[data-testid=status]")
    assert "expected for a mechanism" in page.get_attribute("[data-testid=report] tr[data-row='prestress stable']", "title")
    # Every row of the report has its one-line meaning on hover; everything answered is behind
    # the raw JSON toggle, a vector to a line.
    titles = page.eval_on_selector_all("[data-testid=report] tr:not(.section)", "rs => rs.map(r => r.title)")
    assert len(titles) > 20 and all(titles)
    assert page.is_hidden("#raw")
    page.check("[data-testid=raw-toggle]")
    raw = page.inner_text("#raw")
    assert json.loads(raw)["design"] == design and json.loads(raw)["certificate"] == page.evaluate("designer.certificate")
    assert f"[{x[0][0]:g},{x[0][1]:g}]" in raw.replace(".0,", ",").replace(".0]", "]")
    assert page.get_attribute("[data-testid=progress]", "data-value") == "1"

    # A frame's downloads: no module-map format (only a given module's /v1/map answer has a map).
    offered = page.eval_on_selector_all("#downloads button", "bs => bs.map(b => b.dataset.format)")
    assert "vtk" in offered and not [f for f in offered if f.startswith("map_")]
    with page.expect_download() as info:
        page.click("[data-testid=download-vtk]")
    assert info.value.suggested_filename == "outward_2d.vtu"
    saved = Path(tmp_path) / info.value.suggested_filename
    info.value.save_as(saved)
    assert np.allclose(meshio.read(saved).points[:, :2], frame)
    assert problems == []
    page.close()


def test_the_page_solution_space_satisfies_the_definition(browser, designer_url):  # noqa: F811
    """Random specified sets through the page's SolutionSpace.compute: every point it returns
    (on a conic, k = 3, or isolated, k = 4) has a motion satisfying all k bar conditions, and the
    motion it returns is one; a numpy root of the conic's determinant equation lies on its curve;
    k = 6 is refused, and numpy agrees that Ã z = b has no solution."""
    page, problems = open_page(browser, designer_url)
    rng = np.random.default_rng(40)
    for trial in range(12):
        k = 3 if trial < 6 else 4
        x, u = rng.normal(size=(k, 2)), rng.normal(size=(k, 2))
        space = page.evaluate("([x, u]) => { const s = SolutionSpace.compute(x, u); return {kind: s.kind, curves: s.curves, points: s.points}; }",
                              [x.tolist(), u.tolist()])
        if k == 3:
            assert space["kind"] == "conic"
            curve = np.concatenate([np.array(c) for c in space["curves"]])
            assert max(motion_for(x, u, p)[1] for p in curve) < 1e-7
            # From the definition: det[(p − x_i)ᵀ, (p − x_i)·u_i] = 0 along a line through the
            # specified nodes' centroid; its real roots near the nodes are on the page's curve.
            centre, direction = x.mean(axis=0), rng.normal(size=2)
            direction /= np.linalg.norm(direction)

            def det(t, centre=centre, direction=direction, x=x, u=u):
                p = centre + t * direction
                return np.linalg.det(np.column_stack([p - x, np.einsum("ij,ij->i", p - x, u)]))

            ts = np.array([-1.0, 0.0, 1.0])
            coef = np.polyfit(ts, [det(t) for t in ts], 2)  # the determinant is quadratic in p
            for t in np.roots(coef):
                if abs(t.imag) < 1e-12 and abs(t.real) < 3 * np.ptp(x):
                    p = centre + t.real * direction
                    gap = min(polyline_distance(np.array(c), p) for c in space["curves"])
                    assert gap < 0.01 * np.ptp(x), (trial, p)
        else:
            assert space["kind"] in ("points", "none")
            for sol in space["points"]:
                p, v = np.array(sol["position"]), np.array(sol["motion"])
                assert abs(np.einsum("ij,ij->i", x - p, u - v)).max() < 1e-8 * (1 + np.abs(u).max()) * (1 + np.ptp(x))
                assert motion_for(x, u, p)[1] < 1e-7
    x, u = rng.normal(size=(6, 2)), rng.normal(size=(6, 2))
    space = page.evaluate("([x, u]) => { const s = SolutionSpace.compute(x, u); return [s.kind, s.reason]; }", [x.tolist(), u.tolist()])
    a_tilde = np.column_stack([u, x, -np.ones(6)])
    b = np.einsum("ij,ij->i", x, u)
    z, *_ = np.linalg.lstsq(a_tilde, b, rcond=None)
    assert np.linalg.norm(a_tilde @ z - b) > 1e-6 * np.linalg.norm(b)
    assert space[0] == "none" and "contradict" in space[1]
    assert problems == []
    page.close()


def test_sheet_and_allostery_forms_legends_errors_and_layout(browser, designer_url):  # noqa: F811
    page, problems = open_page(browser, designer_url, width=800)
    # Example names fit their list (descriptions go below it and in the tooltip).
    assert page.evaluate("""() => {
        const sel = document.getElementById('example'), ctx = document.createElement('canvas').getContext('2d');
        ctx.font = getComputedStyle(sel).font;
        return Math.max(...[...sel.options].map((o) => ctx.measureText(o.text).width)) < sel.clientWidth - 24;
    }""")
    # An auxetic sheet: no specified nodes, so no such legend entry; ν in the report.
    page.click("[data-testid=tab-auxetic]")
    page.fill("#cells-x", "2")
    page.fill("#cells-y", "2")
    page.check("[data-testid=tolerance]")
    page.click("[data-testid=design]")
    page.wait_for_selector("[data-testid=play]:not([disabled])", timeout=TIMEOUT_MS)
    assert "specified" not in legend(page) and "unspecified" in legend(page)
    report = page.inner_text("[data-testid=report]")
    assert "Poisson ratio" in report and "tolerance, bar lengths" in report
    assert page.query_selector("[data-testid=download-vtk]")
    # A refused request clears the design, its report and its downloads.
    page.fill("#nu", "7")
    page.click("[data-testid=design]")
    page.wait_for_selector("#status.error", timeout=TIMEOUT_MS)
    assert page.evaluate("designer.response") is None
    assert page.query_selector_all("#canvas line.bar") == []
    assert page.query_selector_all("#downloads button") == []
    assert page.query_selector_all("[data-testid=report] tr") == []

    # Allostery: source and target markers in the drawing and the legend.
    page.select_option("[data-testid=example]", "preset:allostery_2d")
    page.wait_for_function("designer.nodes.length === 6")
    page.click("[data-testid=design]")
    page.wait_for_selector("[data-testid=play]:not([disabled])", timeout=TIMEOUT_MS)
    assert {"source", "target"} <= legend(page)
    assert page.query_selector_all("#canvas polygon.marker.source") and page.query_selector_all("#canvas polygon.marker.target")

    # From 800 to 1920 px: the drawing fits the window, the slider keeps its width as t changes.
    for width in (800, 1024, 1400, 1920):
        page.set_viewport_size({"width": width, "height": 900})
        canvas = page.locator("[data-testid=canvas]").bounding_box()
        assert canvas["x"] >= 0 and canvas["x"] + canvas["width"] <= width and canvas["width"] > 300
        assert page.evaluate("document.documentElement.scrollWidth") <= width
        player = page.locator("#player").bounding_box()  # the drawing spans the player's row
        assert abs(player["x"] - canvas["x"]) < 1 and abs(player["width"] - canvas["width"]) < 1
        widths = []
        for key in ("Home", "End"):
            page.focus("[data-testid=slider]")
            page.keyboard.press(key)
            widths.append(page.locator("[data-testid=slider]").bounding_box()["width"])
        assert widths[0] == widths[1]
    # The refused request is the browser's one logged network error; nothing else.
    assert problems == ["Failed to load resource: the server responded with a status of 422 (Unprocessable Entity)"]
    page.close()


def test_two_motions_cross_where_the_service_places_its_node(browser, designer_url):  # noqa: F811
    """Fig. 4: the two-motion example's spaces, drawn by the page, cross where the service's
    exact resultant puts the unspecified node; a node placed by hand at that crossing leaves
    both motions (the service's analysis of the hand-built frame: two non-rigid zero modes)."""
    page, problems = open_page(browser, designer_url)
    page.select_option("[data-testid=example]", "example:two_mode_2d")
    page.wait_for_function("designer.spaces.length === 2")
    assert page.get_attribute("[data-testid=solution-space-2]", "data-kind") == "conic"
    crossings = np.array(page.evaluate("designer.crossings"))
    assert {"space-0", "space-1", "crossing"} <= legend(page)
    page.check("[data-testid=place-unspecified]")
    page.mouse.click(*screen(page, crossings[0]))
    page.wait_for_function("document.getElementById('status').textContent.includes('by hand')", timeout=TIMEOUT_MS)
    assert "2 non-rigid zero modes, 0 self-stresses" in page.inner_text("[data-testid=status]")
    page.check("[data-testid=place-specified]")
    page.click("[data-testid=design]")
    page.wait_for_selector("[data-testid=play]:not([disabled])", timeout=TIMEOUT_MS)
    design = page.evaluate("designer.response")
    placed = np.array(design["frame"]["positions"][3:])
    size = np.ptp(np.array(design["frame"]["positions"][:3]), axis=0).max()
    # Each service node is one of the page's crossings, to the polyline's accuracy.
    assert all(np.linalg.norm(crossings - p, axis=1).min() < 1e-3 * size for p in placed)
    assert problems == []
    page.close()


def test_a_3d_target_from_the_table(browser, designer_url):  # noqa: F811
    """The 3D tab: five specified nodes in a table; the space of a node joined to all five is a
    curve (m = 2), each of its points with a motion meeting the five conditions (numpy, from the
    definition) and all in one plane (the supplement's planar curve); an edit redraws it; the
    design is a 3D frame with one non-rigid zero mode; dragging turns the view."""
    page, problems = open_page(browser, designer_url)
    page.click("[data-testid=tab-3d]")
    page.wait_for_function("designer.nodes.length === 5")
    assert page.get_attribute("[data-testid=solution-space]", "data-kind") == "conic"
    x = np.array(page.evaluate("designer.nodes.map((n) => n.x)"))
    u = np.array(page.evaluate("designer.motions[0]"))
    curve = np.concatenate([np.array(c) for c in page.evaluate("designer.spaces[0].curves")])
    assert max(motion_for(x, u, p)[1] for p in curve) < 1e-7
    centred = curve - curve.mean(axis=0)
    assert np.linalg.svd(centred, compute_uv=False)[2] < 1e-8 * np.abs(centred).max()
    before = space_d(page)
    page.locator("#table3d tbody tr").nth(4).locator("input").nth(5).fill("0.5")  # u_z of node 5
    page.wait_for_function(f"document.querySelector('[data-testid=solution-space]').getAttribute('d') !== {before!r}")
    page.locator("#table3d tbody tr").nth(4).locator("input").nth(5).fill("0")
    page.click("[data-testid=design]")
    page.wait_for_selector("[data-testid=play]:not([disabled])", timeout=TIMEOUT_MS)
    design = page.evaluate("designer.response")
    assert design["frame"]["dim"] == 3 and design["report"]["analysis"]["nontrivial_zero_modes"] == 1
    assert np.allclose(design["frame"]["positions"][:5], x)
    turned = page.eval_on_selector_all("#canvas circle.node", "cs => cs.map(c => +c.getAttribute('cx'))")
    box = page.locator("[data-testid=canvas]").bounding_box()
    page.mouse.move(box["x"] + 100, box["y"] + 100)
    page.mouse.down()
    page.mouse.move(box["x"] + 160, box["y"] + 120, steps=4)
    page.mouse.up()
    assert page.eval_on_selector_all("#canvas circle.node", "cs => cs.map(c => +c.getAttribute('cx'))") != turned
    assert problems == []
    page.close()


def determinant(x: np.ndarray, u: np.ndarray, p: np.ndarray) -> float:
    """det[x_i − p, (x_i − p)·u_i] for four specified nodes in 3D, relative to the product of the
    rows' norms: zero iff (x_i − p)·v = (x_i − p)·u_i has a solution v (when the x_i − p span R³)."""
    rows = np.column_stack([x - p, np.einsum("ij,ij->i", x - p, u)])
    return float(abs(np.linalg.det(rows)) / np.prod(np.linalg.norm(rows, axis=1)))


def four_node_surface(page) -> tuple[np.ndarray, np.ndarray]:
    """The 3D tab with its fifth specified node removed: four nodes, their space a surface."""
    page.click("[data-testid=tab-3d]")
    page.wait_for_function("designer.nodes.length === 5")
    page.locator("#table3d tbody tr").nth(4).locator("button").click()
    page.wait_for_function("designer.nodes.length === 4 && designer.spaces[0].kind === 'quadric'")
    return np.array(page.evaluate("designer.nodes.map((n) => n.x)")), np.array(page.evaluate("designer.motions[0]"))


def drawn_points(page) -> np.ndarray:
    return np.concatenate([np.array(c) for c in page.evaluate("designer.spaces[0].curves")])


def test_four_nodes_in_3d_draw_their_quadric_surface(browser, designer_url):  # noqa: F811
    """Four specified nodes in 3D (m = 3): the page draws a surface of positions (Fig. 2g), every
    drawn point with a motion meeting the four conditions (numpy least squares and the determinant,
    from the definition), spread over the box around the nodes; where a line meets the surface
    (numpy's roots of the determinant, quadratic along a line) the page's ray hit lands; an edit of
    the table redraws it; the degenerate cases — the tetrahedron's dilation (its circumsphere, closed
    form), a plane pair, coplanar nodes (a plane), a rigid motion (every position, as numpy finds),
    eight nodes (no solution, numpy agrees) — are named with their reason."""
    page, problems = open_page(browser, designer_url)
    x, u = four_node_surface(page)
    assert page.get_attribute("[data-testid=solution-space]", "data-kind") == "quadric"
    assert page.get_attribute("[data-testid=solution-space]", "data-shape").startswith("a hyperboloid")
    assert "surface" in page.inner_text("[data-testid=space-text]")
    points = drawn_points(page)
    assert len(points) > 500
    assert max(motion_for(x, u, p)[1] for p in points) < 1e-9
    assert max(determinant(x, u, p) for p in points) < 1e-9
    # The oracle tells the surface from the space around it: points off it fail.
    rng = np.random.default_rng(3)
    off = x.mean(axis=0) + rng.normal(size=(20, 3))
    assert np.median([determinant(x, u, p) for p in off]) > 1e-3
    # Spread over the box: the drawn points reach past the nodes' extent on every axis.
    assert np.all(np.ptp(points, axis=0) >= np.ptp(x, axis=0))
    for _ in range(6):
        centre, e = x.mean(axis=0) + 0.3 * rng.normal(size=3), rng.normal(size=3)
        e /= np.linalg.norm(e)
        ts = np.array([-1.0, 0.0, 1.0])
        coef = np.polyfit(ts, [np.linalg.det(np.column_stack([x - centre - t * e, np.einsum("ij,ij->i", x - centre - t * e, u)])) for t in ts], 2)
        roots = sorted(t.real for t in np.roots(coef) if abs(t.imag) < 1e-9)
        lo, hi = np.array(page.evaluate("designer.spaces[0].box"))
        inside = [t for t in roots if np.all(centre + t * e >= lo - 1e-12) and np.all(centre + t * e <= hi + 1e-12)]
        hit = page.evaluate("([o, d]) => SolutionSpace.hit(designer.spaces[0], o, d)", [(centre + 10 * e).tolist(), (-e).tolist()])
        if inside:  # the first root met coming from +10 e
            assert np.linalg.norm(np.array(hit) - (centre + max(inside) * e)) < 1e-9 * np.ptp(x)
        else:
            assert hit is None
    before = space_d(page)
    page.locator("#table3d tbody tr").nth(3).locator("input").nth(3).fill("0.4")  # u_x of node 4
    page.wait_for_function(f"document.querySelector('[data-testid=solution-space]').getAttribute('d') !== {before!r}")
    u[3, 0] = 0.4
    assert np.allclose(page.evaluate("designer.motions[0]"), u)
    assert max(motion_for(x, u, p)[1] for p in drawn_points(page)) < 1e-9

    def space(x, u):
        return page.evaluate("""([x, u]) => { const s = SolutionSpace.compute(x, u);
            return {kind: s.kind, shape: s.shape, reason: s.reason, curves: s.curves}; }""", [x.tolist(), u.tolist()])

    tetra = np.array([[1.0, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]])
    sphere = space(tetra, 0.5 * tetra)
    assert (sphere["kind"], sphere["shape"]) == ("quadric", "a sphere")
    ball = np.concatenate([np.array(c) for c in sphere["curves"]])
    assert np.allclose(np.linalg.norm(ball, axis=1), np.sqrt(3), atol=1e-9)  # the circumsphere
    planes = space(tetra, tetra * [1, -1, 0])
    assert (planes["kind"], planes["shape"]) == ("quadric", "a pair of crossing planes")
    pair = np.concatenate([np.array(c) for c in planes["curves"]])
    assert max(motion_for(tetra, tetra * [1, -1, 0], p)[1] for p in pair) < 1e-9
    flat = rng.normal(size=(4, 3)) * [1, 1, 0]
    motion = rng.normal(size=(4, 3))
    plane = space(flat, motion)
    assert (plane["kind"], plane["shape"]) == ("quadric", "a plane") and "coplanar" in page.evaluate(
        "([x, u]) => { designer.spaces = [SolutionSpace.compute(x, u)]; describeSpaces(); return document.getElementById('space-text').textContent; }",
        [flat.tolist(), motion.tolist()])
    sheet = np.concatenate([np.array(c) for c in plane["curves"]])
    assert np.linalg.svd(sheet - sheet.mean(axis=0), compute_uv=False)[2] < 1e-9 * np.ptp(sheet)
    assert max(motion_for(flat, motion, p)[1] for p in sheet) < 1e-9
    rigid = space(tetra, np.cross([0.0, 0, 1], tetra))
    assert rigid["kind"] == "volume" and "every position" in rigid["reason"]
    assert max(motion_for(tetra, np.cross([0.0, 0, 1], tetra), p)[1] for p in rng.normal(size=(10, 3))) < 1e-9
    eight, motions = rng.normal(size=(8, 3)), rng.normal(size=(8, 3))
    none = space(eight, motions)
    a_tilde, b = np.column_stack([motions, eight, -np.ones(8)]), np.einsum("ij,ij->i", eight, motions)
    z, *_ = np.linalg.lstsq(a_tilde, b, rcond=None)
    assert np.linalg.norm(a_tilde @ z - b) > 1e-6 * np.linalg.norm(b)
    assert none["kind"] == "none" and "contradict" in none["reason"]
    assert problems == []
    page.close()


def residuals(x: np.ndarray, u: np.ndarray, points: np.ndarray) -> np.ndarray:
    """motion_for's relative residual at many points at once (batched pseudo-inverse)."""
    rows = x[None] - points[:, None]
    rhs = np.einsum("pij,ij->pi", rows, u)
    v = np.einsum("pji,pi->pj", np.linalg.pinv(rows), rhs)
    scale = np.abs(rows).max(axis=(1, 2)) * np.maximum(np.abs(u).max(), np.abs(v).max(axis=1))
    return np.abs(np.einsum("pij,pj->pi", rows, v) - rhs).max(axis=1) / scale


def determinant_quadric(x: np.ndarray, u: np.ndarray, rng) -> np.ndarray:
    """The 4×4 symmetric D with p̃ᵀDp̃ = det[x_i − p, (x_i − p)·u_i] (degree two in p), fitted to
    the determinant at 40 random points by least squares (the fit's residual checked)."""
    ps = x.mean(axis=0) + rng.normal(size=(40, 3))
    dets = np.array([np.linalg.det(np.column_stack([x - p, np.einsum("ij,ij->i", x - p, u)])) for p in ps])
    pairs = [(a, b) for a in range(4) for b in range(a, 4)]
    h = np.column_stack([ps, np.ones(len(ps))])
    basis = np.column_stack([h[:, a] * h[:, b] for a, b in pairs])
    coef, *_ = np.linalg.lstsq(basis, dets, rcond=None)
    assert np.abs(basis @ coef - dets).max() <= 1e-8 * np.abs(dets).max()
    d = np.zeros((4, 4))
    for (a, b), c in zip(pairs, coef):
        d[a, b] += c / 2
        d[b, a] += c / 2
    return d / np.linalg.norm(d)


# (rank of D, rank of its 3×3 block) for each named surface: quadrics classified by ranks.
SHAPE_RANKS = {
    "an ellipsoid": (4, 3), "a sphere": (4, 3), "a hyperboloid of one sheet": (4, 3), "a hyperboloid of two sheets": (4, 3),
    "a cone": (3, 3), "an elliptic paraboloid": (4, 2), "a hyperbolic paraboloid": (4, 2), "an elliptic cylinder": (3, 2),
    "a hyperbolic cylinder": (3, 2), "a pair of crossing planes": (2, 2), "a parabolic cylinder": (3, 1),
    "a pair of parallel planes": (2, 1), "a plane": (1, 1),
}


def test_every_kind_of_quadric_surface_from_the_definition(browser, designer_url):  # noqa: F811
    """Four specified nodes on a small integer grid (or a regular tetrahedron), moved by integer
    linear maps or at random: every surface the page draws has all its points on the space
    (numpy least squares), and the name it gives matches the quadric numpy fits to the
    determinant det[x_i − p, (x_i − p)·u_i] (its ranks; for rank 4 its signature), and the drawing
    reaches wherever random lines meet that quadric inside the box — all thirteen
    kinds met (coplanar nodes whose plane of solutions misses the box around them draw nothing:
    numpy's plane has the box's corners on one side); "none" only where numpy finds Ã z = b inconsistent, "volume" only where every
    random position has a motion."""
    page, problems = open_page(browser, designer_url)
    rng = np.random.default_rng(42)
    tetra = np.array([[1.0, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]])
    # The rarest kinds given (found by the same kind of draw), then random draws.
    cases = [(tetra, np.array([[3.0, -1, 1], [-1, -1, -3], [-1, 3, 1], [-1, -1, 1]])),  # a sphere
             (np.array([[2.0, 0, -1], [2, 1, 0], [0, -2, 0], [-2, 1, 1]]),
              np.array([[-1.0, 1, -3], [0, 0, -1], [0, 0, -2], [1, -1, 4]])),  # a parabolic cylinder
             (tetra, np.array([[-1.0, 1, 1], [1, 1, -1], [-1, -1, -1], [1, -1, 1]]))]  # parallel planes
    for trial in range(120):
        x = tetra if trial % 2 else rng.integers(-2, 3, size=(4, 3)).astype(float)
        cases.append((x, x @ rng.integers(-1, 2, size=(3, 3)).T if trial % 3 else rng.integers(-1, 2, size=(4, 3)).astype(float)))
    seen = set()
    for x, u in cases:
        s = page.evaluate("([x, u]) => { const s = SolutionSpace.compute(x, u); return {kind: s.kind, shape: s.shape, curves: s.curves, box: s.box}; }",
                          [x.tolist(), u.tolist()])
        a_tilde, b = np.column_stack([u, x, -np.ones(4)]), np.einsum("ij,ij->i", x, u)
        z, *_ = np.linalg.lstsq(a_tilde, b, rcond=None)
        consistent = np.linalg.norm(a_tilde @ z - b) <= 1e-9 * max(np.linalg.norm(b), 1)
        if s["kind"] == "none":
            assert not consistent, (x, u)
            continue
        assert consistent, (x, u)
        if s["kind"] == "volume":
            assert residuals(x, u, x.mean(axis=0) + rng.normal(size=(10, 3))).max() < 1e-9, (x, u)
            continue
        assert s["kind"] == "quadric", (x, u, s["kind"])
        coplanar = np.linalg.matrix_rank(np.column_stack([x, np.ones(4)])) < 4
        if not s["curves"]:
            # Nothing drawn: only coplanar nodes (else the space holds them), whose space lies in the
            # plane of the linear solutions' positions z*_p + span of the null vectors' position
            # rows (numpy's SVD of Ã) — a plane that misses the box: its corners all on one side.
            assert coplanar, (x, u)
            _, _, vt = np.linalg.svd(a_tilde)
            normal = np.linalg.svd(vt[4:, :3])[2][-1]
            corners = np.array(list(itertools.product(*zip(*s["box"]))))
            side = (corners - z[:3]) @ normal
            assert np.all(side > 0) or np.all(side < 0), (x, u)
            continue
        drawn = np.concatenate([np.array(c) for c in s["curves"]])
        assert residuals(x, u, drawn).max() < 1e-9, (x, u, s["shape"])
        seen.add(s["shape"])
        if coplanar:
            continue  # coplanar nodes: the determinant gains the nodes' plane as a spurious factor
        d = determinant_quadric(x, u, rng)
        # The wireframe covers the surface in the box: where random lines through the box meet
        # p̃ᵀDp̃ = 0 (numpy's roots) a drawn line is near (a fifth of the box's side).
        lo, hi = np.array(s["box"])
        for _ in range(4):
            c, e = lo + (hi - lo) * rng.random(3), rng.normal(size=3)
            line = np.array([[*(c + t * e), 1] for t in (-1.0, 0.0, 1.0)])
            coef = np.polyfit([-1.0, 0.0, 1.0], np.einsum("ti,ij,tj->t", line, d, line), 2)
            for t in np.roots(coef):
                p = c + t.real * e
                if abs(t.imag) < 1e-9 and np.all(p >= lo) and np.all(p <= hi):
                    gap = min(polyline_distance(np.array(curve), p) for curve in s["curves"])
                    assert gap < 0.1 * np.max(hi - lo), (x, u, s["shape"], p)
        ranks = (np.linalg.matrix_rank(d, tol=1e-7), np.linalg.matrix_rank(d[:3, :3], tol=1e-7))
        assert ranks == SHAPE_RANKS[s["shape"]], (x, u, s["shape"], ranks)
        if ranks == (4, 3):
            signs = np.sign(np.linalg.eigvalsh(d)), np.sign(np.linalg.eigvalsh(d[:3, :3]))
            one_sheet = abs(signs[0].sum()) == 0
            ellipsoid = abs(signs[1].sum()) == 3
            assert (s["shape"] == "a hyperboloid of one sheet") == one_sheet and (s["shape"] in ("an ellipsoid", "a sphere")) == ellipsoid
    assert seen == set(SHAPE_RANKS), set(SHAPE_RANKS) - seen
    assert problems == []
    page.close()


def test_nodes_placed_by_hand_on_the_3d_surface_make_the_design(browser, designer_url):  # noqa: F811
    """Five unspecified nodes placed by clicking the surface of four specified nodes: each on the
    space to 1e-9 (numpy least squares), with the motion the linear system gives it; a click off
    the drawing places nothing; with four placed, Design refuses (two non-rigid modes); Design uses the hand-built frame, and numpy's SVD of C (built here
    from the positions and bars the service analysed) has exactly one non-rigid zero mode, which
    moves the specified nodes along the requested motion; the finite motion is traced. On the five
    nodes' curve, a click places a node on it too."""
    page, problems = open_page(browser, designer_url)
    x, u = four_node_surface(page)
    page.check("[data-testid=place-3d]")
    box = page.locator("[data-testid=canvas]").bounding_box()
    page.mouse.click(box["x"] + 3, box["y"] + 3)  # empty corner: nothing
    page.wait_for_selector("#status.error")
    assert page.evaluate("designer.placed.length") == 0
    points = drawn_points(page)
    rng = np.random.default_rng(40)
    held = []  # the fourth placement's own check (POST /v1/analyze), held back in the browser
    for n, i in enumerate(rng.choice(len(points), 5, replace=False)):
        if n == 3:
            page.route("**/v1/analyze", lambda route: held.append(route) if not held else route.continue_())
        page.mouse.click(*screen(page, points[i]))
        page.wait_for_function(f"designer.placed.length === {n + 1}")
        if n == 3:  # four placed: the frame still has two non-rigid modes, and Design says so
            page.click("[data-testid=design]")
            page.wait_for_function("document.getElementById('status').textContent.includes('not the one target motion')",
                                   timeout=TIMEOUT_MS)
            # The placement's check answering after Design's refusal does not overwrite it.
            with page.expect_response("**/v1/analyze"):
                held[0].continue_()
            page.unroute("**/v1/analyze")
            page.evaluate("new Promise((done) => setTimeout(done, 100))")
            status = page.inner_text("[data-testid=status]")
            assert "not the one target motion" in status and "2 non-rigid zero modes" in status
            assert page.evaluate("designer.response") is None and page.evaluate("designer.placed.length") == 4
    placed = page.evaluate("designer.placed")
    for node in placed:
        p, v = np.array(node["x"]), np.array(node["u"])
        assert motion_for(x, u, p)[1] < 1e-9
        assert np.allclose(v, motion_for(x, u, p)[0], rtol=1e-9, atol=1e-9 * np.abs(u).max())
    page.wait_for_function("document.getElementById('status').textContent.includes('built by hand: 9 nodes')", timeout=TIMEOUT_MS)
    assert "20 bars, 1 non-rigid zero mode, 0 self-stresses" in page.inner_text("[data-testid=status]")
    page.click("[data-testid=design]")
    page.wait_for_selector("[data-testid=play]:not([disabled])", timeout=TIMEOUT_MS)
    design = page.evaluate("designer.response")
    frame = np.array(design["frame"]["positions"])
    assert np.allclose(frame[:4], x) and np.allclose(frame[4:], [n["x"] for n in placed])
    c = compatibility_matrix(frame, design["frame"]["edges"])
    counts = reference_counts(frame, design["frame"]["edges"])
    assert (counts["zero_modes"], counts["nontrivial_zero_modes"], counts["self_stresses"]) == (7, 1, 0)
    sigma = np.linalg.svd(c, compute_uv=False)
    assert len(sigma) == 20 and sigma[-1] > 1e-6 * sigma[0]  # full row rank, decided with a wide gap
    # That one carries the requested motion: u_S extends to a zero mode (C_U v_U = −C_S u_S) ...
    rhs = -c[:, :12] @ u.ravel()
    v_u, *_ = np.linalg.lstsq(c[:, 12:], rhs, rcond=None)
    assert np.linalg.norm(c[:, 12:] @ v_u - rhs) < 1e-9 * np.linalg.norm(rhs)
    # ... and u_S is not a rigid motion of the specified nodes (so it is the non-rigid one).
    rigid = rigid_generators(x)
    w, *_ = np.linalg.lstsq(rigid, u.ravel(), rcond=None)
    assert np.linalg.norm(rigid @ w - u.ravel()) > 0.1 * np.linalg.norm(u)
    mode = np.array(design["modes"][0])
    assert np.allclose(mode[:4], u) and np.linalg.norm(c @ mode.ravel()) < 1e-9 * np.linalg.norm(c) * np.linalg.norm(mode)
    assert page.evaluate("designer.motionPath.path.length") > 2
    page.click("[data-testid=clear-placed]")  # back to judicious placement
    assert page.evaluate("[designer.placed.length, designer.response]") == [0, None]

    # Five specified nodes: their curve (Fig. 2e); a click on it places a node exactly on it.
    page.click("[data-testid=tab-3d]")
    page.wait_for_function("designer.nodes.length === 5 && designer.spaces[0].kind === 'conic'")
    x5, u5 = np.array(page.evaluate("designer.nodes.map((n) => n.x)")), np.array(page.evaluate("designer.motions[0]"))
    curve = drawn_points(page)
    page.mouse.click(*screen(page, curve[np.argmin(np.linalg.norm(curve - x5.mean(axis=0), axis=1))]))
    page.wait_for_function("designer.placed.length === 1")
    assert motion_for(x5, u5, np.array(page.evaluate("designer.placed[0].x")))[1] < 1e-9
    # The refused click is the page's one error line (a status, not a console error).
    assert problems == []
    page.close()


def test_allosteric_sites_picked_on_a_network(browser, designer_url, tmp_path):  # noqa: F811
    """Allostery inside a given network: the drawn triangulated sheet, two source and two target
    nodes picked on it with their motions dragged; the modified frame's mode moves every bar
    rigidly to first order (C·u = 0, C built here from the definition) and carries the drawn
    motions at the sites, up to scale, within the reported target error."""
    page, problems = open_page(browser, designer_url)
    page.click("[data-testid=tab-allostery]")
    # An uploaded network (a design response holding its frame) is drawn for picking.
    upload = tmp_path / "triangle.json"
    triangle = {"dim": 2, "positions": [[0, 0], [1, 0], [0, 1]], "edges": [[0, 1], [1, 2], [0, 2]]}
    upload.write_text(json.dumps({"frame": triangle}))
    page.set_input_files("[data-testid=network-file]", str(upload))
    page.wait_for_function("designer.network && designer.network.positions.length === 3")
    assert len(page.query_selector_all("#canvas circle.network-node")) == 3
    assert page.get_attribute("#canvas path.bar.network", "d").count("L") == 3
    page.click("[data-testid=network-sheet]")
    positions = np.array(page.evaluate("designer.network.positions"))
    order = np.lexsort((positions[:, 0], positions[:, 1]))
    bottom, top = order[3:5], order[-5:-3]  # two neighbours on the bottom row, two on the top
    pulls = {"source": np.array([[-0.25, 0], [0.25, 0]]), "target": np.array([[-0.25, 0.0], [0.25, 0.0]])}
    for role, nodes in (("source", bottom), ("target", top)):
        page.check(f"input[name=role][value={role}]")
        for node, pull in zip(nodes, pulls[role], strict=True):
            drag_arrow(page, positions[node], positions[node] + pull, steps=3)
    assert page.evaluate("designer.nodes.map((n) => [n.role, n.index])") == [
        ["source", int(bottom[0])], ["source", int(bottom[1])], ["target", int(top[0])], ["target", int(top[1])]]
    page.click("[data-testid=design]")
    page.wait_for_selector("[data-testid=play]:not([disabled])", timeout=TIMEOUT_MS)
    design = page.evaluate("designer.response")
    x, edges = np.array(design["frame"]["positions"]), np.array(design["frame"]["edges"])
    u = np.array(design["modes"][0])
    d = x[edges[:, 0]] - x[edges[:, 1]]
    stretch = np.einsum("ij,ij->i", d, u[edges[:, 0]] - u[edges[:, 1]])
    assert np.abs(stretch).max() < 1e-9 * np.abs(d).max() * np.abs(u).max()
    source_rows = u[bottom]
    scale = np.sum(source_rows * pulls["source"]) / np.sum(pulls["source"] ** 2)
    assert np.allclose(source_rows, scale * pulls["source"], atol=1e-9 * np.abs(u).max())
    assert design["report"]["target_error"] <= 1e-9
    assert {"source", "target"} <= legend(page)
    assert problems == []
    page.close()


def designed(page) -> dict:
    """Design pressed, and the body once the page has its motion to play (the refusal said if not)."""
    page.click("[data-testid=design]")
    page.wait_for_function("(designer.response && !document.getElementById('play').disabled) || document.getElementById('status').className === 'error'",
                           timeout=TIMEOUT_MS)
    body = page.evaluate("designer.response")
    assert body, page.inner_text("[data-testid=status]")
    return body


def affine_fit(values: np.ndarray, pixels: np.ndarray) -> tuple[float, float]:
    """The chart's axis map pixel = a·value + b (least squares) and its worst residual in px."""
    a, b = np.polyfit(values, pixels, 1)
    return float(a), float(np.abs(a * values + b - pixels).max())


def drawn_nodes(page) -> np.ndarray:
    """Centres of the frame's node circles as drawn (SVG units)."""
    return np.array(page.eval_on_selector_all("#canvas circle.node", "cs => cs.map(c => [+c.getAttribute('cx'), +c.getAttribute('cy')])"))


def similarity_fit(world: np.ndarray, drawn: np.ndarray) -> tuple[np.ndarray, float]:
    """The page's drawing map fitted from one configuration (x ↦ s·(x, −y) + t, least squares);
    returns a function of world points and the fit's worst residual in px."""
    rows = np.concatenate([np.column_stack([world[:, 0], np.ones(len(world)), np.zeros(len(world))]),
                           np.column_stack([-world[:, 1], np.zeros(len(world)), np.ones(len(world))])])
    coef, *_ = np.linalg.lstsq(rows, np.concatenate([drawn[:, 0], drawn[:, 1]]), rcond=None)
    s, tx, ty = coef
    to_page = lambda p: np.column_stack([s * p[:, 0] + tx, -s * p[:, 1] + ty])
    return to_page, float(np.abs(to_page(world) - drawn).max())


def test_multistable_design_with_its_energy_landscape(browser, designer_url):  # noqa: F811
    """Issue #41 item 1 in the page: the tristable example's form, its rods and springs drawn
    (springs as zig-zags, in the legend), the motion played through the conformations, and the
    energy landscape under it checked against the body: the curve is the body's (arc length,
    energy) through one affine map per axis, one marker per body minimum at its (s, E), one
    barrier between each pair of neighbours at the highest sample between them, and the cursor
    at the slider's sample as the animation moves; the report has the minima's figures."""
    page, problems = open_page(browser, designer_url)
    page.click("[data-testid=tab-multistable]")
    page.wait_for_function("designer.conformations.length === 3")
    assert page.input_value("[data-testid=name]") == "tristable_triangle_2d"
    inputs = page.query_selector_all("[data-testid=conformations] input")
    assert len(inputs) == 3 * 3 * 2
    assert len(page.query_selector_all("#canvas circle.conformation-node")) == 9
    # An edit of the form is the request: the third conformation's apex, moved and moved back.
    apex = "[data-testid=conformations] input[data-conformation='2'][data-node='2'][data-axis='1']"
    preview = "cs => cs.map(c => [+c.getAttribute('cx'), +c.getAttribute('cy')])"
    before = np.array(page.eval_on_selector_all("#canvas circle.conformation-node", preview))
    page.fill(apex, "1.3")
    assert page.evaluate("designer.conformations[2][2][1]") == 1.3
    after = np.array(page.eval_on_selector_all("#canvas circle.conformation-node", preview))
    # The apex rose against the base: its height over the base in px grew by 0.15 of the base's width.
    height = lambda p: (p[6, 1] - p[8, 1]) / (p[7, 0] - p[6, 0])
    assert height(after) - height(before) == pytest.approx(0.15, abs=1e-3)
    page.fill(apex, "1.15")
    page.fill("[data-testid=barrier]", "0.0001")  # the default is 8.5e-5, the springs reach 1.7e-4
    body = designed(page)
    land, minima = body["landscape"], body["minima"]
    assert body["report"]["barrier"] == 0.0001
    assert np.array(body["conformations"])[2, 2, 1] == 1.15

    # The drawing: every rod, every spring as a zig-zag (a path of many corners), legend entries.
    assert len(page.query_selector_all("#canvas line.bar")) == len(body["frame"]["edges"])
    springs = page.eval_on_selector_all("#canvas path.spring", "ps => ps.map(p => p.getAttribute('d'))")
    assert len(springs) == len(body["springs"]["pairs"]) and all(d.count("L") >= 10 for d in springs)
    assert {"rod", "spring", "specified", "unspecified", "conformation-0", "conformation-2"} <= legend(page)

    # The landscape chart against the body.
    s, e = np.array(land["arclength"]), np.array(land["energy"])
    curve = np.array([[float(v) for v in p.split(",")] for p in page.get_attribute("#landscape polyline.energy", "points").split()])
    assert len(curve) == len(s)
    ax, x_residual = affine_fit(s, curve[:, 0])
    ay, y_residual = affine_fit(e, curve[:, 1])
    assert ax > 0 and ay < 0 and x_residual < 0.06 and y_residual < 0.06  # points written to 0.1 px
    bx, by = np.polyfit(s, curve[:, 0], 1)[1], np.polyfit(e, curve[:, 1], 1)[1]
    marks = page.eval_on_selector_all("#landscape circle.minimum", "cs => cs.map(c => [+c.getAttribute('cx'), +c.getAttribute('cy')])")
    assert len(marks) == len(minima) == 3
    for (cx, cy), m in zip(marks, minima, strict=True):
        assert abs(cx - (ax * m["arclength"] + bx)) < 0.1 and abs(cy - (ay * m["energy"] + by)) < 0.1
    tops = page.eval_on_selector_all("#landscape polygon.barrier", "ps => ps.map(p => +p.dataset.sample)")
    at = land["conformation_samples"]
    assert tops == [a + int(np.argmax(e[a:b + 1])) for a, b in itertools.pairwise(at)]

    # The cursor follows the animation: at the slider's sample, and it moves with Play.
    def cursor():
        k = int(page.input_value("[data-testid=slider]"))
        x = float(page.get_attribute("[data-testid=landscape-cursor]", "x1"))
        return k, x

    k0, x0 = cursor()
    assert abs(x0 - (ax * s[k0] + bx)) < 0.1
    first = drawn_nodes(page)
    page.click("[data-testid=play]")
    page.wait_for_function(f"+document.getElementById('slider').value !== {k0}")
    page.click("[data-testid=play]")
    k1, x1 = cursor()
    assert k1 != k0 and abs(x1 - (ax * s[k1] + bx)) < 0.1 and x1 != x0
    # The drawn nodes are the body's sample k1, through the drawing's map fitted at sample k0.
    to_page, residual = similarity_fit(np.array(land["positions"][k0]), first)
    assert residual < 0.01
    assert np.abs(to_page(np.array(land["positions"][k1])) - drawn_nodes(page)).max() < 0.01

    report = page.inner_text("[data-testid=report]")
    for words in ("Minimum 1", "Minimum 3", "curvature E″(s)", "Hessian λ_min", "barrier after", "springs"):
        assert words in report
    titled = page.eval_on_selector_all("[data-testid=report] tr[data-row='Hessian λ_min']", "rs => rs.map(r => [r.title, r.cells[2].textContent])")
    assert len(titled) == 3 and all(title and unit == "k" for title, unit in titled)

    # 800 px: the drawing and the chart fit the window.
    page.set_viewport_size({"width": 800, "height": 900})
    chart = page.locator("[data-testid=landscape]").bounding_box()
    assert chart["x"] >= 0 and chart["x"] + chart["width"] <= 800
    assert page.evaluate("document.documentElement.scrollWidth") <= 800
    assert problems == []
    page.close()


def test_chain_animated_with_its_map_as_a_cobweb(browser, designer_url, tmp_path):  # noqa: F811
    """Issue #41 item 2 in the page: the deployable example's form (from the OpenAPI examples),
    the chain drawn from the body and animated along its traced motion (nodes move between
    frames; the drawn ends are the body's chain.path ends through the drawing's map fitted on the
    chain as built), the map chart with one marker per fixed point and the cobweb of the body's
    distances at the slider's sample, and the designed module's map asked of POST /v1/map
    agreeing with the chain's iterates."""
    page, problems = open_page(browser, designer_url)
    page.click("[data-testid=tab-chain]")
    page.wait_for_function("designer.features.length === 2")
    assert page.input_value("[data-testid=chain-example]") == "deployable"
    assert page.input_value("[data-testid=d0]") == "1.21"
    assert len(page.query_selector_all("[data-testid=features] tr")) == 2
    page.fill("[data-testid=n-modules]", "10")
    body = designed(page)
    chain = body["chain"]
    path = np.array(chain["path"])
    assert len(chain["pairs"]) == 11 and len(page.query_selector_all("#canvas line.pair")) == 11
    assert len(page.query_selector_all("#canvas line.bar")) == len(chain["frame"]["edges"])
    assert {"pair", "bar", "track"} <= legend(page)

    # The chain as built at the reference sample; its drawing map fitted there.
    assert int(page.input_value("[data-testid=slider]")) == chain["reference_index"]
    to_page, residual = similarity_fit(np.array(chain["frame"]["positions"]), drawn_nodes(page))
    assert residual < 0.01
    ends = []
    for key, k in (("Home", 0), ("End", len(path) - 1)):
        page.focus("[data-testid=slider]")
        page.keyboard.press(key)
        assert int(page.input_value("[data-testid=slider]")) == k
        drawn = drawn_nodes(page)
        assert np.abs(to_page(path[k]) - drawn).max() < 0.01
        ends.append(drawn)
    assert np.abs(ends[0] - ends[1]).max() > 20  # the chain opens: far nodes move by many px

    # Playing moves the nodes between frames.
    page.click("[data-testid=play]")
    frames = []
    for _ in range(3):
        k = int(page.input_value("[data-testid=slider]"))
        page.wait_for_function(f"+document.getElementById('slider').value !== {k}")
        frames.append(drawn_nodes(page))
    page.click("[data-testid=play]")
    assert all(np.abs(a - b).max() > 0.1 for a, b in itertools.pairwise(frames))

    # The map chart: f's samples, one marker per fixed point, the cobweb of d at the slider's sample.
    k = int(page.input_value("[data-testid=slider]"))
    d = np.array(chain["distances"][k])
    assert len(page.query_selector_all("#map-chart circle.fixed-point")) == len(body["map"]["fixed_points"]) >= 2
    web = np.array([[float(v) for v in p.split(",")] for p in page.get_attribute("[data-testid=cobweb]", "points").split()])
    expected = [(d[0], d[0])] + [q for i in range(len(d) - 1) for q in ((d[i], d[i + 1]), (d[i + 1], d[i + 1]))]
    expected = np.array(expected)
    assert web.shape == expected.shape
    ax, x_residual = affine_fit(expected[:, 0], web[:, 0])
    ay, y_residual = affine_fit(expected[:, 1], web[:, 1])
    assert ax > 0 and ay < 0 and x_residual < 0.01 and y_residual < 0.01
    assert len(page.query_selector_all("#profile rect.distance")) == len(d)

    # POST /v1/map of the designed module at the iterates: f(d_k) = d_{k+1}.
    page.wait_for_function("designer.mapCheck", timeout=TIMEOUT_MS)
    assert page.evaluate("designer.mapCheck.deviation") <= 1e-8
    evaluated = page.evaluate("designer.mapCheck.evaluated")
    assert np.allclose([p["d_in"] for p in evaluated], chain["iterates"][:-1])
    report = page.inner_text("[data-testid=report]")
    for words in ("chain deviation", "fixed point 2", "POST /v1/map check", "usable range"):
        assert words in report

    # The chain exports as a design does, named after it.
    with page.expect_download() as info:
        page.click("[data-testid=download-vtk]")
    assert info.value.suggested_filename == "deployable_chain.vtu"
    saved = Path(tmp_path) / info.value.suggested_filename
    info.value.save_as(saved)
    assert np.allclose(meshio.read(saved).points[:, :2], chain["frame"]["positions"])

    # 1920 and 800 px: the drawing and both charts inside the window, no sideways scrolling.
    for width in (1920, 800):
        page.set_viewport_size({"width": width, "height": 900})
        for testid in ("canvas", "map-chart", "profile"):
            box = page.locator(f"[data-testid={testid}]").bounding_box()
            assert box["x"] >= 0 and box["x"] + box["width"] <= width and box["width"] > 150
        assert page.evaluate("document.documentElement.scrollWidth") <= width

    # A feature out of the module's reach: the service's refusal said, the old chain cleared.
    page.locator("[data-testid=features] tr").nth(1).locator("input").nth(0).fill("9")
    page.click("[data-testid=design]")
    page.wait_for_selector("#status.error", timeout=TIMEOUT_MS)
    assert "feature_out_of_reach" in page.inner_text("[data-testid=status]")
    assert page.evaluate("designer.response") is None and page.is_hidden("#map-box")
    assert page.query_selector_all("#canvas line.bar") == []
    assert problems == ["Failed to load resource: the server responded with a status of 422 (Unprocessable Entity)"]
    page.close()


def test_a_given_module_mapped(browser, designer_url):  # noqa: F811
    """The Chain tab's given module (POST /v1/map): the two-triangle module with its hinge moved
    in the table; the body's map is the closed form's (tests/oracles/two_triangles.py), its ends
    the closed form's folds, the chart draws the body's samples, and there is one marker per
    fixed point of the closed form (roots of f(d) − d on the usable range)."""
    page, problems = open_page(browser, designer_url)
    page.click("[data-testid=tab-chain]")
    page.wait_for_function("designer.features.length === 2")
    page.check("[data-testid=chain-given]")
    assert page.is_hidden("[data-testid=features]") and page.is_visible("[data-testid=module]")
    page.fill("[data-testid=module] input[data-node='4'][data-axis='1']", "0.5")
    page.click("[data-testid=design]")
    page.wait_for_function("designer.response || document.getElementById('status').className === 'error'", timeout=TIMEOUT_MS)
    body = page.evaluate("designer.response")
    assert body, page.inner_text("[data-testid=status]")
    positions = np.array(body["module"]["frame"]["positions"])
    assert positions[4].tolist() == [0.15, 0.5]
    exact, m = TwoTriangles(positions), body["map"]
    d_in, d_out = np.array(m["d_in"]), np.array(m["d_out"])
    assert max(abs(exact.f(a) - b) / b for a, b in zip(d_in, d_out, strict=True)) < 1e-8
    assert m["lower"]["kind"] == m["upper"]["kind"] == "fold"
    assert [m["lower"]["d_in"], m["upper"]["d_in"]] == pytest.approx(exact.range(), rel=1e-6)
    lo, hi = exact.range()
    grid = np.linspace(lo, hi, 2001)[1:-1]
    gap = np.array([exact.f(d) - d for d in grid])
    roots = [brentq(lambda d: exact.f(d) - d, a, b) for a, b, ga, gb in zip(grid, grid[1:], gap, gap[1:]) if ga * gb < 0]
    drawn = page.eval_on_selector_all("#map-chart circle.fixed-point", "cs => cs.map(c => +c.getAttribute('cx'))")
    assert len(drawn) == len(m["fixed_points"]) == len(roots) >= 1
    assert sorted(p["d"] for p in m["fixed_points"]) == pytest.approx(roots, rel=1e-8)
    curve = np.array([[float(v) for v in p.split(",")] for p in page.get_attribute("#map-chart polyline.map", "points").split()])
    ax, x_residual = affine_fit(d_in, curve[:, 0])
    ay, y_residual = affine_fit(d_out, curve[:, 1])
    assert ax > 0 and ay < 0 and x_residual < 0.06 and y_residual < 0.06
    assert len(page.query_selector_all("#canvas line.bar")) == 6 and len(page.query_selector_all("#canvas line.pair")) == 2
    assert page.is_hidden("[data-testid=profile]") and page.query_selector("[data-testid=cobweb]") is None
    # The given module's map downloads as its samples: f at every row is the closed form's.
    page.wait_for_selector("[data-testid=download-map_csv]", timeout=TIMEOUT_MS)
    with page.expect_download() as info:
        page.click("[data-testid=download-map_csv]")
    assert info.value.suggested_filename.endswith(".csv")
    rows = list(csv.DictReader(io.StringIO(Path(info.value.path()).read_text())))
    assert len(rows) == len(d_in) >= 10
    assert max(abs(exact.f(float(r["d_in"])) - float(r["d_out"])) / float(r["d_out"]) for r in rows) < 1e-8
    # The multistable example in the list of examples opens its own tab, its form filled.
    page.select_option("[data-testid=example]", "example:tristable_triangle_2d")
    page.wait_for_function("designer.kind === 'multistable' && designer.conformations.length === 3")
    assert page.get_attribute("[data-testid=tab-multistable]", "aria-selected") == "true"
    assert page.evaluate("designer.response") is None and page.is_hidden("#map-box")
    assert problems == []
    page.close()


def drawn_segment(d: str) -> np.ndarray:
    """The first and last points of an SVG path's ``d`` (M x y L … L x y)."""
    numbers = np.array([float(v) for v in d.replace("M", " ").replace("L", " ").split()]).reshape(-1, 2)
    return np.array([numbers[0], numbers[-1]])


def wall_from_definition(d: np.ndarray, d_u: float, d_s: float) -> float:
    """The domain wall of distances d (n + 1,): the fractional index where the switched fraction
    s_k = (d_k − d_u)/(d_s − d_u) first reaches ½, s interpolated linearly between pairs; NaN if
    it never does."""
    s = (d - d_u) / (d_s - d_u)
    up = np.flatnonzero((s[:-1] < 0.5) & (s[1:] >= 0.5))
    if not len(up):
        return float("nan")
    k = up[0]
    return float(k + (0.5 - s[k]) / (s[k + 1] - s[k]))


def test_soliton_springs_and_travelling_wall(browser, designer_url):  # noqa: F811
    """Issue #41's soliton in the Chain tab (its OpenAPI example): the chain's rods and one spring
    per copy drawn as zig-zags whose ends are the body's spring nodes (through the drawing's map
    fitted on the drawn nodes), the domain wall drawn on the chain where the wall recomputed here
    from the body's d_k (numpy, from its definition) puts it — the point of the chain at
    the fractional index, the pairs' midpoints interpolated — and moving monotonically out along the
    chain as Play drives the input from d_s towards d_u; under it, d_k along the chain with the
    wall at that index, and the springs' energy along the drive with the cursor."""
    page, problems = open_page(browser, designer_url)
    page.click("[data-testid=tab-chain]")
    page.wait_for_function("designer.features.length === 2")
    page.select_option("[data-testid=chain-example]", "soliton")
    assert page.is_checked("[data-testid=soliton]") and page.is_visible("[data-testid=stiffness]")
    assert page.is_hidden("[data-testid=d0]")
    page.fill("[data-testid=n-modules]", "10")
    page.fill("[data-testid=stiffness]", "2")
    body = designed(page)
    chain, sol = body["chain"], body["soliton"]
    assert sol["stiffness"] == 2 and len(sol["springs"]["pairs"]) == 10 and len(chain["pairs"]) == 11
    path, distances, pairs = np.array(chain["path"]), np.array(chain["distances"]), np.array(chain["pairs"])
    d_u, d_s = sol["unstable"]["d"], sol["stable"]["d"]
    rows = np.array(sol["rows"])
    samples = len(rows)
    # The wall from its definition at every drive sample, against the body's.
    walls = np.array([wall_from_definition(distances[r], d_u, d_s) for r in rows])
    body_walls = np.array([np.nan if w is None else w for w in sol["wall"]])
    assert np.array_equal(np.isnan(walls), np.isnan(body_walls))
    assert np.allclose(walls[~np.isnan(walls)], body_walls[~np.isnan(walls)], rtol=0, atol=1e-12)
    assert np.nanmax(walls) - np.nanmin(walls) >= 8

    assert page.evaluate("+document.getElementById('slider').max") == samples - 1
    # It opens where the wall has entered the chain (the first sample from the stable end with one).
    entered = max(k for k in range(samples) if not np.isnan(walls[k]) and np.all(np.isnan(walls[k + 1:])))
    assert int(page.input_value("[data-testid=slider]")) == samples - 1 - entered
    assert len(page.query_selector_all("#canvas line.bar")) == len(chain["frame"]["edges"])
    assert {"rod", "spring", "wall", "pair"} <= legend(page)

    def frame():
        """What one animation frame shows, read at once: the slider, the drawn nodes, springs and wall."""
        return page.evaluate("""() => {
            const wall = document.querySelector('#canvas circle.wall'), a = (e, n) => +e.getAttribute(n);
            return { k: +document.getElementById('slider').value,
                     nodes: [...document.querySelectorAll('#canvas circle.node')].map((c) => [a(c, 'cx'), a(c, 'cy')]),
                     springs: [...document.querySelectorAll('#canvas path.spring')].map((p) => p.getAttribute('d')),
                     wall: wall && { w: +wall.dataset.wall, at: [a(wall, 'cx'), a(wall, 'cy')] },
                     profileWall: (() => { const l = document.querySelector('#profile line.wall'); return l && a(l, 'x1'); })(),
                     bars: [...document.querySelectorAll('#profile rect.distance')].map((r) => a(r, 'x') + a(r, 'width') / 2),
                     cursor: +document.querySelector('[data-testid=landscape-cursor]').getAttribute('x1') };
        }""")

    def check(f, to_page=None):
        """Frame f against the body: slider sample k shows drive sample P − 1 − k (the drive played
        from the stable end); springs and wall through the drawing's map (fitted here unless given)."""
        row = rows[samples - 1 - f["k"]]
        x = path[row]
        if to_page is None:
            to_page, residual = similarity_fit(x, np.array(f["nodes"]))
            assert residual < 0.01
        assert np.abs(to_page(x) - np.array(f["nodes"])).max() < 0.01
        ends = np.array([drawn_segment(d) for d in f["springs"]])
        want = np.stack([to_page(x[[i for i, _ in sol["springs"]["pairs"]]]), to_page(x[[j for _, j in sol["springs"]["pairs"]]])], axis=1)
        assert ends.shape == want.shape and np.abs(ends - want).max() <= 0.1
        w = walls[samples - 1 - f["k"]]
        if np.isnan(w):
            assert f["wall"] is None and f["profileWall"] is None
            return to_page, w
        assert f["wall"]["w"] == pytest.approx(w, abs=1e-9)
        k = min(int(np.floor(w)), len(pairs) - 2)
        phi = w - k
        middle = x[pairs].mean(axis=1)  # each pair's midpoint
        place = (1 - phi) * middle[k] + phi * middle[k + 1]  # pair k's and pair k + 1's, interpolated as w is
        assert np.abs(to_page(place[None])[0] - np.array(f["wall"]["at"])).max() <= 0.1
        # d_k along the chain: the wall's line where index w is on the bars' axis.
        a, residual = affine_fit(np.arange(len(f["bars"]), dtype=float), np.array(f["bars"]))
        b = np.polyfit(np.arange(len(f["bars"])), f["bars"], 1)[1]
        assert residual < 0.01 and abs(f["profileWall"] - (a * w + b)) < 0.1
        return to_page, w

    # The first frame, and one with the wall in the bulk; the energy along the drive.
    to_page, _ = check(frame())
    energy = np.array(sol["energy"])[::-1]
    curve = np.array([[float(v) for v in p.split(",")] for p in page.get_attribute("#landscape polyline.energy", "points").split()])
    assert len(curve) == samples and page.is_visible("[data-testid=landscape]")
    ay, y_residual = affine_fit(energy, curve[:, 1])
    ax, x_residual = affine_fit(np.log10(np.abs(np.array(sol["drive"])[::-1] - d_u)), curve[:, 0])
    assert ay < 0 and ax < 0 and y_residual < 0.06 and x_residual < 0.06  # |d₀ − d_u| falls to the right
    middle = int(np.nanargmin(np.abs(walls - 5)))
    page.evaluate("k => { const s = document.getElementById('slider'); s.value = k; s.dispatchEvent(new Event('input')); }", samples - 1 - middle)
    f = frame()
    _, w = check(f, to_page)
    assert 4 < w < 6 and abs(f["cursor"] - curve[f["k"], 0]) < 0.1

    # Play from where the wall is near the input: it moves out along the chain, frame after frame
    # (back in when the sweep turns at the end: with the animation, always).
    near = int(np.nanargmin(np.abs(walls - 1.5)))
    page.evaluate("k => { const s = document.getElementById('slider'); s.value = k; s.dispatchEvent(new Event('input')); }", samples - 1 - near)
    page.click("[data-testid=play]")
    seen = []
    for _ in range(12):
        k = page.evaluate("+document.getElementById('slider').value")
        page.wait_for_function(f"+document.getElementById('slider').value !== {k}")
        seen.append(frame())
    page.click("[data-testid=play]")
    placed = []
    for f in seen:
        _, w = check(f, to_page)
        if not np.isnan(w):
            placed.append((f["k"], w))
    assert len(placed) >= 6 and placed[-1][1] > placed[0][1] + 1
    assert all((wb - wa) * (kb - ka) > 0 for (ka, wa), (kb, wb) in itertools.pairwise(placed))
    report = page.inner_text("[data-testid=report]")
    for words in ("Soliton", "wall travel", "uniform at d_u", "barrier"):
        assert words in report
    assert problems == []

    # More copies than the wall can reach from round-off of d_u (≈ 59 for f′(d_u) = 1.8): refused
    # before any work, the old soliton cleared.
    page.fill("[data-testid=n-modules]", "80")
    page.click("[data-testid=design]")
    page.wait_for_selector("#status.error", timeout=TIMEOUT_MS)
    assert "soliton_out_of_reach" in page.inner_text("[data-testid=status]")
    assert page.evaluate("designer.response") is None and page.query_selector("#canvas circle.wall") is None
    assert page.is_hidden("#landscape-box")
    assert problems == ["Failed to load resource: the server responded with a status of 422 (Unprocessable Entity)"]
    page.close()
