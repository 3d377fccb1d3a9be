"""Screenshots of the designer page at work for docs/designer.md (docs/img/designer*.png).

Starts `zeromode serve` on loopback, drives Debian's chromium with Playwright as a user would:

- designer_draw.png: the outward square being drawn — the third arrow dragged, the conic live;
- designer.png: the square designed by judicious placement, refined and certified, with the
  linear and refined paths and ε(a) side by side and the report;
- designer_two_motions.png: the two-motion example (Fig. 4): both conics and where they cross;
- designer_3d.png: the 3D tab's five nodes designed, with the planar curve of their space;
- designer_3d_surface.png: four of them: their quadric surface of solutions as conic sections in
  a box, and five unspecified nodes placed on it by clicking, each with its motion and its bars;
- designer_3d_sphere.png: a regular tetrahedron dilating: its space is the circumsphere (Fig. 3d);
- designer_multistable.png: the tristable triangle (Multistable tab) designed, rods and springs
  a third of the way along its motion, the energy landscape under it and the minima's report;
- designer_chain.png: the deployable chain (Chain tab) designed and played part-way open, the
  module's map with the chain's cobweb and d_k along the chain;
- designer_soliton.png: the Chain tab's soliton example, played until its wall is half-way along
  the chain: rods, springs and the wall, the energy along the drive and d_k with the wall.

    python -m docs.designer_pictures [--only multistable chain soliton]
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

import numpy as np

from benchmarks.bench_designer import (
    ARROW,
    CHROMIUM_ARGS,
    CORNERS,
    drag_arrow,
    goto_designer,
    screen,
)
from benchmarks.bench_sweeps import start_service_with

OUT = Path(__file__).parent / "img"
TIMEOUT_MS = 300_000


SHOTS = ("pipeline", "surface", "multistable", "chain", "soliton")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=SHOTS, default=SHOTS, help="render only these pictures")
    only = parser.parse_args().only
    proc, url = start_service_with({"ZEROMODE_OFFLOAD": "false"})
    try:
        shoot(url, only)
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def shoot(url: str, only=SHOTS) -> None:
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=shutil.which("chromium"), args=CHROMIUM_ARGS)
        page = goto_designer(browser.new_page(viewport={"width": 1440, "height": 960}), url)
        if "pipeline" in only:
            shoot_pipeline(page)
        if "surface" in only:
            shoot_surface(page)
        if "multistable" in only:
            shoot_played(page, "multistable", 1 / 3, OUT / "designer_multistable.png")
        if "chain" in only:
            shoot_played(page, "chain", 0.8, OUT / "designer_chain.png")
        if "soliton" in only:
            shoot_played(page, "chain", None, OUT / "designer_soliton.png", example="soliton")
        browser.close()


def shoot_played(page, tab: str, where: float | None, path: Path, example: str | None = None) -> None:
    """The tab's default example (or the chain ``example``) designed, the slider set ``where``
    along the motion (None: a soliton's wall half-way along the chain), the whole page."""
    page.click(f"[data-testid=tab-{tab}]")
    page.wait_for_function("designer.features.length" if tab == "chain" else "designer.conformations.length")
    if example:
        page.select_option("[data-testid=chain-example]", example)
    page.click("[data-testid=design]")
    page.wait_for_function("!document.getElementById('play').disabled || document.getElementById('status').className === 'error'",
                           timeout=TIMEOUT_MS)
    if page.evaluate("!designer.response"):
        raise RuntimeError(f"{tab}: {page.inner_text('[data-testid=status]')}")
    if tab == "chain":
        page.wait_for_function("designer.mapCheck", timeout=TIMEOUT_MS)
    if where is None:
        walls = page.evaluate("designer.motionPath.wall.map((w) => w === null ? -1e9 : w)")
        n = len(page.evaluate("designer.response.chain.pairs")) - 1
        where = int(np.argmin(np.abs(np.array(walls) - n / 2))) / (len(walls) - 1)
    page.evaluate("f => { const s = document.getElementById('slider'); s.value = Math.round(f * s.max); s.dispatchEvent(new Event('input')); }", where)
    page.wait_for_timeout(2500)  # the progress bar's last transition; the new nodes' appearance (at most 2.3 s)
    page.screenshot(path=path, full_page=True)


def shoot_pipeline(page) -> None:
    """designer_draw.png, designer.png, designer_two_motions.png, designer_3d.png."""
    page.fill("[data-testid=name]", "outward_2d")
    for c in CORNERS[:2]:
        drag_arrow(page, c, np.multiply(c, 1 + ARROW))
    # The third arrow held mid-drag: the conic of a node joined to three specified nodes.
    start = np.array(CORNERS[2])
    page.mouse.move(*screen(page, start))
    page.mouse.down()
    page.mouse.move(*screen(page, start + [-0.3, -0.6]))
    page.screenshot(path=OUT / "designer_draw.png")
    page.mouse.move(*screen(page, start * (1 + ARROW)))
    page.mouse.up()
    drag_arrow(page, CORNERS[3], np.multiply(CORNERS[3], 1 + ARROW))
    page.click("[data-testid=design]")
    page.wait_for_selector("[data-testid=play]:not([disabled])", timeout=TIMEOUT_MS)
    page.click("[data-testid=refine]")
    page.wait_for_function("designer.refined && designer.refinedPath", timeout=TIMEOUT_MS)
    page.click("[data-testid=certify]")
    page.wait_for_function("designer.certificate", timeout=TIMEOUT_MS)
    page.wait_for_timeout(800)  # the progress bar's last transition
    page.screenshot(path=OUT / "designer.png", full_page=True)

    page.select_option("[data-testid=example]", "example:two_mode_2d")
    page.wait_for_function("designer.spaces.length === 2")
    page.click("[data-testid=design]")
    page.wait_for_selector("[data-testid=play]:not([disabled])", timeout=TIMEOUT_MS)
    page.locator("[data-testid=canvas]").screenshot(path=OUT / "designer_two_motions.png")

    page.click("[data-testid=tab-3d]")
    page.wait_for_function("designer.spaces.length === 1")
    page.click("[data-testid=design]")
    page.wait_for_selector("[data-testid=play]:not([disabled])", timeout=TIMEOUT_MS)
    page.locator("#view").screenshot(path=OUT / "designer_3d.png")


def shoot_surface(page) -> None:
    """designer_3d_surface.png: the 3D tab's first four nodes, five nodes placed by clicking their
    surface — drawn points spread apart (farthest-point order, from the specified nodes) whose
    motions are no longer than the longest specified one, so that every arrow stays in the picture."""
    page.click("[data-testid=tab-3d]")
    page.wait_for_function("designer.nodes.length === 5")
    page.locator("#table3d tbody tr").nth(4).locator("button").click()
    page.wait_for_function("designer.nodes.length === 4 && designer.spaces[0].kind === 'quadric'")
    page.check("[data-testid=place-3d]")
    points = np.concatenate([np.array(c) for c in page.evaluate("designer.spaces[0].curves")])
    speeds = np.array(page.evaluate("ps => ps.map((p) => Math.hypot(...SolutionSpace.motionAt(designer.spaces[0], p)))", points.tolist()))
    longest = max(np.linalg.norm(u) for u in page.evaluate("designer.motions[0]"))
    candidates = points[speeds <= longest]
    chosen = list(page.evaluate("designer.nodes.map((n) => n.x)"))
    while len(chosen) < 4 + 5:
        chosen.append(candidates[np.argmax(np.min([np.linalg.norm(candidates - c, axis=1) for c in chosen], axis=0))])
    for n, p in enumerate(chosen[4:]):
        page.mouse.click(*screen(page, p))
        page.wait_for_function(f"designer.placed.length === {n + 1}")
    page.wait_for_function("document.getElementById('status').textContent.includes('built by hand: 9 nodes')", timeout=TIMEOUT_MS)
    page.locator("#view").screenshot(path=OUT / "designer_3d_surface.png")
    page.evaluate("t => fillTable(t, t.map((p) => p.map((v) => v / 2)))", [[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]])
    page.wait_for_function("designer.spaces[0].shape === 'a sphere'")
    page.locator("#view").screenshot(path=OUT / "designer_3d_sphere.png")


if __name__ == "__main__":
    main()
