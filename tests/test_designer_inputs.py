"""The designer page (GET /) given what a new user gives it: degenerate drawings, files that are
not networks, a network of thousands of bars, a design replaced while its answer is on the way
(issue #40's review). Debian's chromium against a live uvicorn on loopback, as
tests/test_designer.py; the solution space is checked against its definition by numpy, the
page's state against what was drawn or sent."""

from __future__ import annotations

import json

import httpx
import numpy as np
import pytest
from browser import browser, designer_url, open_page  # noqa: F401 (fixtures)

from benchmarks.bench_designer import ARROW, CORNERS, drag_arrow, draw_outward_square, screen

TIMEOUT_MS = 180_000


def bar_condition_residual(x: np.ndarray, u: np.ndarray, p: np.ndarray) -> float:
    """How far the best motion v of a node at p misses (x_i − p)·(u_i − v) = 0 for every i
    (least squares over v), relative to the terms' scale; 0 when p is in the solution space."""
    rows = x - p
    rhs = np.einsum("ij,ij->i", rows, u)
    v, *_ = np.linalg.lstsq(rows, rhs, rcond=None)
    scale = max(np.abs(rows).max() * max(np.abs(u).max(), np.abs(v).max()), 1e-300)
    return float(np.abs(rows @ v - rhs).max() / scale)


def test_degenerate_drawings_have_their_true_space(browser, designer_url):  # noqa: F811
    """Collinear nodes, arrows not yet drawn and a rigid rotation: the quadric c = p·v vanishes on
    every linear solution (Q = 0), so the space is the line of the nodes or every position — it
    was reported as "no real solution, imaginary parallel lines". Checked from the definition."""
    page, problems = open_page(browser, designer_url)
    compute = "([x, u]) => { const s = SolutionSpace.compute(x, u); return {kind: s.kind, curves: s.curves, reason: s.reason}; }"
    rng = np.random.default_rng(7)
    # Three nodes on the x axis, the middle one moving against the others: p on the axis, v = (0, any).
    x, u = np.array([[-1.0, 0], [0, 0], [1, 0]]), np.array([[0, 0.5], [0, -0.5], [0, 0.5]])
    space = page.evaluate(compute, [x.tolist(), u.tolist()])
    assert space["kind"] == "line"
    line = np.array(space["curves"][0])
    assert np.abs(line[:, 1]).max() < 1e-12 and np.ptp(line[:, 0]) > 10
    for t in rng.uniform(0.05, 0.95, 5):
        assert bar_condition_residual(x, u, line[0] + t * (line[1] - line[0])) < 1e-9
    # Off the axis the conditions cannot all hold (the numpy least squares misses them).
    assert bar_condition_residual(x, u, np.array([0.3, 0.7])) > 1e-3
    # No arrows, or arrows that rotate the nodes rigidly: every position has a motion.
    for u in (np.zeros((3, 2)), np.array([[0.0, 0], [0, 1], [-1, 0]])):
        x = np.array([[0.0, 0], [1, 0], [0, 1]])
        space = page.evaluate(compute, [x.tolist(), u.tolist()])
        assert space["kind"] == "plane" and "every position" in space["reason"]
        assert max(bar_condition_residual(x, u, p) for p in rng.normal(size=(6, 2)) * 3) < 1e-9

    # Drawn: three clicks and no drag say what to do next, not "no real solution".
    for p in x:
        page.mouse.click(*screen(page, p))
    assert page.evaluate("designer.nodes.length") == 3
    text = page.inner_text("[data-testid=space-text]")
    assert "drag from a node" in text and "no real" not in text
    page.click("[data-testid=clear]")
    for c, tip in (((-1, 0), (-1, 0.5)), ((0, 0), (0, -0.5)), ((1, 0), (1, 0.5))):
        drag_arrow(page, c, tip)
    assert page.get_attribute("[data-testid=solution-space]", "data-kind") == "line"
    assert "no real" not in page.inner_text("[data-testid=space-text]")
    assert problems == []
    page.close()


def test_files_that_are_not_networks_leave_the_page_as_it_was(browser, designer_url, tmp_path):  # noqa: F811
    """Uploads on the Allostery tab: text that is not JSON, an edge to a node that does not exist,
    a position that is not two numbers, 3D positions: each says what is wrong in one sentence and
    draws nothing (the bad edge used to throw inside the drawing and stay, every later drawing
    failing; a string coordinate logged NaN attributes). A good file then replaces the message."""
    page, problems = open_page(browser, designer_url)
    page.click("[data-testid=tab-allostery]")
    triangle = {"dim": 2, "positions": [[0, 0], [1, 0], [0, 1]], "edges": [[0, 1], [1, 2], [0, 2]]}
    files = {
        "notes.json": ("hello, not JSON {", "not valid JSON"),
        "edge.json": (json.dumps({**triangle, "edges": [[0, 1], [1, 2], [0, 7]]}), "edge 2 is not two different node indices"),
        "loop.json": (json.dumps({**triangle, "edges": [[0, 1], [1, 1]]}), "edge 1 is not two different node indices"),
        "text.json": (json.dumps({**triangle, "positions": [[0, 0], ["a", 0], [0, 1]]}), "position 1 is not two finite numbers"),
        "space.json": (json.dumps({**triangle, "positions": [[0, 0, 0], [1, 0, 0], [0, 1, 0]]}), "position 0 is not two finite numbers"),
    }
    for name, (text, says) in files.items():
        path = tmp_path / name
        path.write_text(text)
        page.set_input_files("[data-testid=network-file]", str(path))
        page.wait_for_selector("#status.error")
        status = page.inner_text("[data-testid=status]")
        assert status.startswith(name) and says in status, status
        assert page.evaluate("designer.network") is None
        assert page.query_selector_all("#canvas circle.network-node") == []
        page.evaluate("say('')")
    good = tmp_path / "triangle.json"
    good.write_text(json.dumps({"frame": triangle}))
    page.set_input_files("[data-testid=network-file]", str(good))
    page.wait_for_function("designer.network && designer.network.positions.length === 3")
    assert page.get_attribute("#status", "class") != "error" and "3 nodes, 3 bars" in page.inner_text("[data-testid=status]")
    assert problems == []
    page.close()


def test_a_large_network_is_drawn_once_per_view(browser, designer_url):  # noqa: F811
    """A network of 3 600 nodes and about 10 500 bars: its bars are one path holding every bar
    (checked against the edges: one move-line pair each) and dragging a site's motion rebuilds
    only the sites — the network's layer is the same DOM node before and after (it used to be
    rebuilt, 18 881 line elements, at every pointer move: 0.25–0.6 s a move at load 13)."""
    page, problems = open_page(browser, designer_url)
    page.click("[data-testid=tab-allostery]")
    n = 60
    xs, ys = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float))
    positions = np.column_stack([xs.ravel() + 0.5 * (ys.ravel() % 2), ys.ravel() * np.sqrt(3) / 2]) * 0.1
    at = lambda i, j: j * n + i
    edges = [[at(i, j), at(i + 1, j)] for j in range(n) for i in range(n - 1)]
    edges += [[at(i, j), at(i, j + 1)] for j in range(n - 1) for i in range(n)]
    edges += [[at(i, j), at(i + 1, j + 1)] for j in range(1, n - 1, 2) for i in range(n - 1)]
    edges += [[at(i, j), at(i - 1, j + 1)] for j in range(0, n - 1, 2) for i in range(1, n)]
    page.evaluate("frame => useNetwork(frame)", {"dim": 2, "positions": positions.tolist(), "edges": edges})
    assert page.evaluate("designer.network.positions.length") == n * n
    d = page.get_attribute("#canvas path.bar.network", "d")
    assert d.count("M") == d.count("L") == len(edges)
    assert len(page.query_selector_all("#canvas circle.network-node")) == n * n
    page.evaluate("document.querySelector('#canvas g.network').dataset.seen = 'before'")
    page.check("input[name=role][value=source]")
    drag_arrow(page, positions[0], positions[0] + [0.2, 0], steps=3)
    assert page.evaluate("designer.nodes.length") == 1
    assert page.get_attribute("#canvas g.network", "data-seen") == "before"
    assert len(page.query_selector_all("#canvas line.arrow.drawn")) == 1
    assert problems == []
    page.close()


def test_a_replaced_design_never_comes_back(browser, designer_url):  # noqa: F811
    """The answer of a design the user has replaced is dropped, whatever order the answers come
    in: (1) the drawing edited while its design is on the way — nothing is drawn when the answer
    comes, and the page says to press Design again; (2) edited and designed again — the page
    shows the second design, its report and downloads, the first answer arriving last. Each
    first answer is held back by the browser (the server answers it as usual) until then."""
    page, problems = open_page(browser, designer_url)
    held, hold = [], [True]

    def route(r):
        if hold[0]:
            hold[0] = False
            held.append(r)
        else:
            r.continue_()

    def release():
        with page.expect_response("**/v1/design"):
            held.pop().continue_()
        page.evaluate("new Promise((done) => setTimeout(done, 200))")  # the page's handler runs

    page.route("**/v1/design", route)
    draw_outward_square(page)
    page.click("[data-testid=design]")
    page.wait_for_function("document.getElementById('status').textContent.startsWith('designing')")
    half = np.multiply(CORNERS[3], 1 + ARROW / 2)
    drag_arrow(page, CORNERS[3], half)  # (1)
    assert "press Design again" in page.inner_text("[data-testid=status]")
    release()
    assert page.evaluate("designer.response") is None
    assert page.query_selector_all("#canvas line.bar") == [] and page.query_selector_all("#downloads button") == []
    assert "press Design again" in page.inner_text("[data-testid=status]")

    hold[0] = True  # (2): the half-arrow target held, the full one designed meanwhile
    page.click("[data-testid=design]")
    page.wait_for_function("document.getElementById('status').textContent.startsWith('designing')")
    drag_arrow(page, CORNERS[3], np.multiply(CORNERS[3], 1 + ARROW))
    page.click("[data-testid=design]")
    page.wait_for_selector("[data-testid=play]:not([disabled])", timeout=TIMEOUT_MS)
    second = page.evaluate("designer.response")
    release()
    assert page.evaluate("designer.response") == second
    mode = np.array(second["modes"][0])[:4]
    drawn = ARROW * np.array(CORNERS)  # the outward square: its arrows all as long
    assert abs(abs(np.sum(mode * drawn)) / (np.linalg.norm(mode) * np.linalg.norm(drawn)) - 1) < 1e-9
    assert page.get_attribute("#status", "class") != "error"
    assert page.query_selector("[data-testid=download-vtk]")
    # A click meant to place a node by hand on a designed frame says how, and changes nothing.
    page.check("[data-testid=place-unspecified]")
    page.mouse.click(*screen(page, (0, 1.2)))
    assert "edit the drawing" in page.inner_text("[data-testid=status]") and page.evaluate("designer.response") == second
    assert problems == []
    page.close()


def test_controls_are_not_cut_and_a_network_replaces_the_example(browser, designer_url):  # noqa: F811
    """The empty page's hint readable at 800 px. At 1400 px: the two-motion design's mode list is as wide as its text (it was squeezed to a
    sliver beside Play); the upload control's text is whole (the file input's "No file chosen"
    was cut to "No f…sen"); a network drawn over the allostery example takes its place — the
    example list, its description and the name no longer name the preset, and no canvas hint is
    written across the network's bars."""
    page, problems = open_page(browser, designer_url, width=800)
    # The empty page's hint, at the narrowest window: readable (its glyphs ≥ 12 px; were 10 px).
    assert "Click to place a node" in page.text_content("#canvas text")
    assert page.eval_on_selector("#canvas text", "t => t.getBoundingClientRect().height") >= 12
    page.set_viewport_size({"width": 1400, "height": 900})
    fits = "e => { const c = document.createElement('canvas').getContext('2d'); c.font = getComputedStyle(e).font; return c.measureText(e.options ? e.options[e.selectedIndex].text : e.textContent.trim()).width < e.clientWidth; }"
    page.select_option("[data-testid=example]", "example:two_mode_2d")
    page.wait_for_function("designer.spaces.length === 2")
    page.click("[data-testid=design]")
    page.wait_for_selector("[data-testid=play]:not([disabled])", timeout=TIMEOUT_MS)
    assert page.is_visible("[data-testid=mode-select]") and page.eval_on_selector("[data-testid=mode-select]", fits)
    # Refine is for one motion: disabled here, and its tooltip says why.
    assert page.is_disabled("[data-testid=refine]") and "this design has 2 motions" in page.get_attribute("[data-testid=refine]", "title")

    page.click("[data-testid=tab-allostery]")
    upload = page.locator("label.button")
    assert upload.is_visible() and page.eval_on_selector("label.button", "e => e.scrollWidth <= e.clientWidth")
    assert "Upload" in upload.inner_text()
    page.select_option("[data-testid=example]", "preset:allostery_2d")
    page.wait_for_function("designer.nodes.length === 6")
    assert page.input_value("[data-testid=name]") == "allostery_2d"
    page.click("[data-testid=network-sheet]")
    assert page.evaluate("designer.network.positions.length") == 63
    assert page.input_value("[data-testid=example]") == "" and page.inner_text("#example-text") == ""
    assert page.input_value("[data-testid=name]") == "allosteric_sheet"
    assert page.query_selector_all("#canvas text") == []
    assert problems == []
    page.close()


def test_a_slow_direct_request_shows_the_bar_busy(browser, designer_url, tmp_path):  # noqa: F811
    """Requests that are not jobs report no progress, yet some take seconds (a GIF export took
    9.3 s at load 10, allostery in a 6 400-node network 3.4 s): one unanswered after a second
    shows the progress bar as busy, naming what it waits for, until the answer comes. The
    export is held back by the browser (the server answers it as usual once released)."""
    page, problems = open_page(browser, designer_url)
    page.select_option("[data-testid=example]", "example:outward_2d")
    page.wait_for_function("designer.nodes.length === 4")
    page.click("[data-testid=design]")
    page.wait_for_selector("[data-testid=download-vtk]", timeout=TIMEOUT_MS)
    page.wait_for_function("document.getElementById('status').textContent.startsWith('finite motion')", timeout=TIMEOUT_MS)
    page.wait_for_selector("#progress-box", state="hidden")
    held = []
    page.route("**/v1/export", lambda route: held.append(route))
    page.click("[data-testid=download-vtk]")
    page.wait_for_selector("[data-testid=progress].busy", state="visible", timeout=TIMEOUT_MS)
    assert "POST /v1/export" in page.inner_text("#progress-text") and len(held) == 1
    assert "exporting ParaView (.vtu)" in page.inner_text("[data-testid=status]")
    # Every format offered has a human name (no internal name like kit_csv, no cut-off sentence).
    labels = page.eval_on_selector_all("#downloads button", "bs => bs.map(b => [b.dataset.format, b.textContent])")
    assert len(labels) >= 8 and all(text != name and "_" not in text and len(text) <= 24 for name, text in labels)
    with page.expect_download() as info:
        held[0].continue_()
    assert info.value.suggested_filename == "outward_2d.vtu"
    page.wait_for_selector("#progress-box", state="hidden")
    assert page.query_selector("[data-testid=progress].busy") is None
    assert problems == []
    page.close()


def test_designed_nodes_appear_round_by_round_across_redraws(browser, designer_url):  # noqa: F811
    """Judicious placement's rounds as an animation: each unspecified node appears 0.15 s after
    the one before, its bars with it (a bar at its newer node's delay), and the delays count from
    the design's arrival, so a redraw carries them on (the traced motion redrew the frame within
    milliseconds and every node popped in at once). Read from the drawing at a redraw with the
    design's arrival set just before it, and long after it (nothing left to appear)."""
    page, problems = open_page(browser, designer_url)
    page.select_option("[data-testid=example]", "example:outward_2d_four_nodes")
    page.wait_for_function("designer.nodes.length === 4")
    page.click("[data-testid=design]")
    page.wait_for_function("document.getElementById('status').textContent.startsWith('finite motion')", timeout=TIMEOUT_MS)
    # The example's options come with its drawing (n_unspecified = 4: Fig. 3c, not Fig. 3b's 2).
    options = httpx.get(f"{designer_url}/v1/examples/outward_2d_four_nodes/request").json()["options"]
    assert options["n_unspecified"] == 4 and page.evaluate("designer.response.report.unspecified_nodes") == 4
    edges = page.evaluate("designer.frame.edges")
    delay = "es => es.map(e => [+(e.dataset.node ?? e.dataset.edge), parseFloat(e.style.animationDelay)])"
    page.evaluate("designer.appearAt = performance.now(); draw()")
    nodes = dict(page.eval_on_selector_all("#canvas circle.node-new", delay))
    assert sorted(nodes) == [4, 5, 6, 7]
    steps = np.diff([nodes[i] for i in sorted(nodes)])
    assert np.allclose(steps, 0.15, atol=2e-3) and nodes[4] > -0.3
    bars = dict(page.eval_on_selector_all("#canvas line.bar-new", delay))
    assert sorted(bars) == list(range(len(edges)))  # every bar has a new node at one end
    for b, (i, j) in enumerate(edges):
        assert bars[b] == pytest.approx(max(nodes.get(i, -np.inf), nodes.get(j, -np.inf)), abs=2e-3)
    page.evaluate("designer.appearAt = performance.now() - 10_000; draw()")
    assert page.query_selector_all("#canvas .node-new, #canvas .bar-new") == []
    assert problems == []
    page.close()


def test_trajectories_drawn_once_per_motion(browser, designer_url):  # noqa: F811
    """The nodes' trajectories along the traced motion: one path per step k holding every node's
    segment from sample k to k + 1 (checked against the body's path through the page's own map),
    built once per traced motion — a slider step re-attaches the same layer (a 12 × 12 sheet drew
    8 683 line elements at every animation frame: 141 ms a frame at load 9)."""
    page, problems = open_page(browser, designer_url)
    page.click("[data-testid=tab-auxetic]")
    page.fill("#cells-x", "2")
    page.fill("#cells-y", "2")
    page.click("[data-testid=design]")
    page.wait_for_function("document.getElementById('status').textContent.startsWith('finite motion')", timeout=TIMEOUT_MS)
    path = np.array(page.evaluate("designer.motionPath.path"))
    to_page = np.array(page.evaluate("P => P.map(c => c.map(p => designer.map.toPage(p)))", path.tolist()))
    steps = page.eval_on_selector_all("#canvas g.trajectories path.step", "ps => ps.map(p => p.getAttribute('d'))")
    assert len(steps) == len(path) - 1
    for k, d in enumerate(steps):
        numbers = np.array([float(v) for v in d.replace("M", " ").replace("L", " ").split()]).reshape(-1, 2, 2)
        assert numbers.shape[0] == path.shape[1]
        assert np.abs(numbers[:, 0] - to_page[k]).max() <= 0.051 and np.abs(numbers[:, 1] - to_page[k + 1]).max() <= 0.051
    page.evaluate("document.querySelector('#canvas g.trajectories').dataset.seen = 'before'")
    before = page.eval_on_selector_all("#canvas circle.node", "cs => cs.map(c => +c.getAttribute('cx'))")
    page.focus("[data-testid=slider]")
    page.keyboard.press("End")
    assert page.get_attribute("#canvas g.trajectories", "data-seen") == "before"
    assert page.eval_on_selector_all("#canvas circle.node", "cs => cs.map(c => +c.getAttribute('cx'))") != before
    assert problems == []
    page.close()


def test_a_service_that_asks_for_a_key(browser, dask_scheduler):  # noqa: F811
    """A service with an API key refuses the page's first request (GET /v1/examples, 401): the
    page opens its Service box and says to enter the key there; the key entered, the examples
    are listed (they stayed empty until the page was reloaded, which loses the key) and a design
    goes through with it."""
    from tests.client.conftest import served
    from zeromode.service.rest.app import create_app
    from zeromode.service.wire.settings import Settings

    with served(create_app(Settings(api_key="k3y-for-the-test", dask_scheduler=dask_scheduler))) as url:
        page = browser.new_page(viewport={"width": 1280, "height": 900})
        page.goto(url + "/")
        page.wait_for_selector("#status.error")
        assert "Enter the API key under Service" in page.inner_text("[data-testid=status]")
        assert page.is_visible("#apikey")
        page.fill("#apikey", "k3y-for-the-test")
        page.dispatch_event("#apikey", "change")
        page.wait_for_selector("#example option[value='example:outward_2d']", state="attached")
        page.select_option("[data-testid=example]", "example:outward_2d")
        page.wait_for_function("designer.nodes.length === 4")
        page.click("[data-testid=design]")
        page.wait_for_selector("[data-testid=play]:not([disabled])", timeout=TIMEOUT_MS)
        assert page.evaluate("designer.response.report.analysis.nontrivial_zero_modes") == 1
        page.close()


def test_a_drawing_survives_a_look_at_another_tab(browser, designer_url):  # noqa: F811
    """Draw two motions of three nodes, look at the Auxetic tab, come back: the nodes, both
    motions (the motion list too), the name and the solution spaces are as they were (the drawing
    was wiped by any tab click)."""
    page, problems = open_page(browser, designer_url)
    page.fill("[data-testid=name]", "two_by_hand")
    for c, tip in (((-1, -1), (-1.5, -1)), ((1, -1), (1.5, -1)), ((0, 1), (0, 1.5))):
        drag_arrow(page, c, tip)
    page.click("[data-testid=add-motion]")
    for c, tip in (((-1, -1), (-1, -1.5)), ((1, -1), (1.25, -1)), ((0, 1), (0.5, 1))):
        drag_arrow(page, c, tip)
    drawn = page.evaluate("[designer.nodes.map((n) => n.x), designer.motions]")
    spaces = page.evaluate("designer.spaces.map((s) => s.kind)")
    page.click("[data-testid=tab-auxetic]")
    assert page.evaluate("designer.nodes.length") == 0
    page.click("[data-testid=tab-draw]")
    assert page.evaluate("[designer.nodes.map((n) => n.x), designer.motions]") == drawn
    assert page.evaluate("designer.spaces.map((s) => s.kind)") == spaces == ["conic", "conic"]
    assert page.eval_on_selector_all("[data-testid=motion-index] option", "os => os.map((o) => o.textContent)") == ["1", "2"]
    assert page.input_value("[data-testid=name]") == "two_by_hand"
    assert len(page.query_selector_all("#canvas line.arrow.drawn")) == 6
    assert problems == []
    page.close()
