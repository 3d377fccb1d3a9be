"""The viewer page (GET /) in a real headless Chromium against a live uvicorn on loopback.

A user's path through the page: pick a named example, design it, see the frame, drag the slider
along its finite motion (keyboard on the range input, as a user would), switch nothing else,
download an export. Checked: the drawing is the designed frame (one circle per node, one line
per bar, each bar's ends on its nodes' circles), moving the slider moves the nodes while every
bar stays on its nodes, the downloaded VTK file reads back with meshio, and the browser's console
shows no error.

The browser is Debian's ``chromium`` driven by Playwright's Python package (no browser download:
``executable_path`` points at the system's binary). Without them the test is skipped with the
way to get them — except under CI (``CI=true``), where it fails: CI must run it.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import meshio
import numpy as np
import pytest
from required import missing

from tests.client.conftest import served
from zeromode.service.rest.app import create_app

CHROMIUM_ARGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]
HOW_TO_GET_ONE = (
    "the viewer test needs a Chromium and Playwright's Python package: on Debian or Ubuntu "
    "`apt-get install -y chromium` and `pip install playwright` (no `playwright install`: the "
    "system's /usr/bin/chromium is used)"
)
# Waits for the page: a design plus its finite motion on a busy 2-core machine.
DESIGN_TIMEOUT_MS = 120_000


def chromium_path() -> str | None:
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    return None


@pytest.fixture(scope="module")
def browser():
    path = chromium_path()
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        path = None
    if path is None:
        missing("the viewer test", HOW_TO_GET_ONE)
    with sync_playwright() as playwright:
        chromium = playwright.chromium.launch(executable_path=path, args=CHROMIUM_ARGS)
        yield chromium
        chromium.close()


@pytest.fixture(scope="module")
def live_url():
    """The real app served by uvicorn on a loopback port the kernel chose."""
    with served(create_app()) as url:
        yield url


def drawing(page) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node centres (N, 2) in node order, bar ends (N_B, 2, 2) and bar nodes (N_B, 2) read
    from the page's SVG."""
    nodes = page.eval_on_selector_all(
        "#frame circle.node", "cs => cs.map(c => [+c.dataset.node, +c.getAttribute('cx'), +c.getAttribute('cy')])"
    )
    bars = page.eval_on_selector_all(
        "#frame line.bar",
        "ls => ls.map(l => [+l.dataset.edge, +l.getAttribute('x1'), +l.getAttribute('y1'), +l.getAttribute('x2'), +l.getAttribute('y2')])",
    )
    centres = np.array([c[1:] for c in sorted(nodes)])
    ends = np.array([b[1:] for b in sorted(bars)]).reshape(-1, 2, 2)
    return centres, ends, np.array(sorted(b[0] for b in bars))


def test_design_play_and_download_in_a_real_browser(browser, live_url, tmp_path):
    page = browser.new_page(viewport={"width": 1280, "height": 900}, accept_downloads=True)
    problems: list[str] = []
    page.on("console", lambda msg: problems.append(msg.text) if msg.type == "error" else None)
    page.on("pageerror", lambda exc: problems.append(str(exc)))
    page.goto(live_url + "/")
    page.wait_for_selector("#example option[value='example:outward_2d']", state="attached")
    page.select_option("#example", "example:outward_2d")
    page.wait_for_function("document.getElementById('request').value.includes('positions')")
    page.click("#design")
    page.wait_for_selector("#slider:not([disabled])", timeout=DESIGN_TIMEOUT_MS)

    design = page.evaluate("state.response")
    x = np.array(design["frame"]["positions"])
    edges = np.array(design["frame"]["edges"])
    before, ends, bar_ids = drawing(page)
    assert len(before) == len(x) and list(bar_ids) == list(range(len(edges)))
    assert np.allclose(ends, before[edges], atol=1e-6)
    # The page is a similarity image of the positions, y flipped.
    fit = np.column_stack([np.ones(len(x)), x[:, 0], -x[:, 1]])
    coef, *_ = np.linalg.lstsq(fit, before, rcond=None)
    assert np.allclose(fit @ coef, before, atol=1e-6)
    assert "zero modes" in page.inner_text("#summary")
    assert len(page.query_selector_all("#frame line.arrow")) == len(x)  # the mode, at the reference

    page.focus("#slider")
    page.keyboard.press("Home")  # to the start of the finite motion
    start, ends_start, _ = drawing(page)
    page.keyboard.press("End")
    end, ends_end, _ = drawing(page)
    size = np.ptp(before, axis=0).max()
    assert np.abs(start - before).max() > 0.01 * size and np.abs(end - start).max() > 0.01 * size
    for centres, bar_ends in ((start, ends_start), (end, ends_end)):
        assert np.allclose(bar_ends, centres[edges], atol=1e-6)
    assert page.query_selector_all("#frame g.trajectories line")

    page.wait_for_selector("#downloads button[data-format='vtk']")
    with page.expect_download() as info:
        page.click("#downloads button[data-format='vtk']")
    saved = Path(tmp_path) / "frame.vtu"
    info.value.save_as(saved)
    mesh = meshio.read(saved)
    assert np.allclose(mesh.points[:, :2], x)
    assert problems == []
    page.close()


def test_the_page_and_its_files_are_served(client):
    page = client.get("/")
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    for src in ("/viewer/viewer.js", "/viewer/viewer.css"):
        assert src in page.text
        assert client.get(src).status_code == 200
    assert "http" not in client.get("/viewer/viewer.js").text.replace("http://www.w3.org/2000/svg", "")  # no CDN
    assert client.get("/viewer/app.py").status_code == 404
