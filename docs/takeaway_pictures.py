"""Regenerate the pictures of the guide's how-to pages (docs/howto/pictures.md, paraview.md, cut.md):

    .venv/bin/python docs/takeaway_pictures.py

docs/img/viewer.png      the designer page (GET /) in headless Chromium, mid-way through the
                         finite motion of the 3 × 3 auxetic sheet
docs/img/motion_frame.png  one frame of the GIF export of the allosteric example's motion
docs/img/cut_file.png    the DXF cut file of the outward_2d design, drawn by ezdxf's matplotlib
                         backend

Needs Debian's chromium and Playwright's Python package (as tests/test_viewer.py).
"""

from __future__ import annotations

import io
import socket
import threading
import time
from pathlib import Path

import httpx
import uvicorn
from PIL import Image

from zeromode.service.rest.app import create_app

IMG = Path(__file__).resolve().parent / "img"
CHROMIUM_ARGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]
ALLOSTERIC = {
    "dim": 2,
    "source": {"positions": [[0, 0], [1, 0], [0, 1]], "motion": [[-1, 0], [1, 0], [0, 1]]},
    "target": {"positions": [[5, 0], [6, 0], [5, 1]], "motion": [[0, -1], [1, 1], [-1, 0]]},
}


def serve() -> tuple[str, uvicorn.Server]:
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    server = uvicorn.Server(uvicorn.Config(create_app(), log_level="warning", lifespan="off"))
    threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True).start()
    url = f"http://127.0.0.1:{sock.getsockname()[1]}"
    for _ in range(600):
        try:
            httpx.get(url + "/health", timeout=1)
            break
        except httpx.TransportError:
            time.sleep(0.05)
    return url, server


def viewer_screenshot(url: str) -> None:
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": 1280, "height": 860})
        page.goto(url + "/")
        page.wait_for_selector("#example option[value^='preset:auxetic']", state="attached")
        value = page.eval_on_selector("#example option[value^='preset:auxetic']", "o => o.value")
        page.select_option("#example", value)
        page.wait_for_function("designer.kind === 'auxetic'")
        page.click("[data-testid=design]")
        page.wait_for_selector("#slider:not([disabled])", timeout=120_000)
        page.wait_for_selector("#downloads button")
        page.eval_on_selector("#slider", "s => { s.value = Math.round(0.8 * s.max); s.dispatchEvent(new Event('input')); }")
        page.screenshot(path=str(IMG / "viewer.png"))
        browser.close()


def motion_frame(url: str) -> None:
    gif = httpx.post(url + "/v1/export", json={
        "format": "gif", "document": ALLOSTERIC, "motion": {"amplitude": 0.8},
        "animation": {"frames": 30, "title": "allosteric frame: its finite motion"},
    }, timeout=300).content
    image = Image.open(io.BytesIO(gif))
    image.seek(22)
    image.convert("RGB").save(IMG / "motion_frame.png")


def cut_file(url: str) -> None:
    import ezdxf
    from ezdxf.addons.drawing import Frontend, RenderContext, config
    from ezdxf.addons.drawing.matplotlib import MatplotlibBackend
    from matplotlib.figure import Figure

    from zeromode.export.fabrication import ensure_fonts

    request = httpx.get(url + "/v1/examples/outward_2d/request").json()
    dxf = httpx.post(url + "/v1/export", json={"format": "dxf", "document": request}, timeout=300).text
    doc = ezdxf.read(io.StringIO(dxf))
    ensure_fonts()
    fig = Figure(figsize=(9, 1.6))
    ax = fig.add_axes((0, 0, 1, 1))
    settings = config.Configuration(
        background_policy=config.BackgroundPolicy.WHITE, color_policy=config.ColorPolicy.COLOR
    )
    Frontend(RenderContext(doc), MatplotlibBackend(ax), config=settings).draw_layout(doc.modelspace())
    fig.savefig(IMG / "cut_file.png", dpi=130, facecolor="white")


if __name__ == "__main__":
    url, server = serve()
    try:
        viewer_screenshot(url)
        motion_frame(url)
        cut_file(url)
    finally:
        server.should_exit = True
