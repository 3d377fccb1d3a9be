"""The designer page's interactive speed in Debian's chromium (issue #40's floors), and the
helpers that drive the page (tests/test_designer.py and docs/designer_pictures.py use them).

Against a `zeromode serve` on loopback (requests answered in process), measured in the browser:

1. the live solution-space update while an arrow is dragged: from the pointer event's time stamp
   to the space recomputed (solution_space.js) and the drawing rebuilt, over MOVES moves of the
   fourth arrow of the outward square (a conic or two points, as the arrow moves) — p50/p95/max;
2. click to drawing of a 2D single-mode design (the outward square): from the click's time stamp
   to the first animation frame after the designed frame is drawn, DESIGNS times after one
   warm-up design — p50/p95/max, beside the service's own design time;
3. the page weight: the HTML and every file it loads (and, apart, the OpenAPI document the
   Chain tab reads once for its examples);
4. a frame of the Multistable and Chain tabs' animations (issue #41): the slider moved to the
   next sample → drawing, springs or chain, and charts rebuilt, FRAMES frames of the default
   example's design (and of the Chain tab's soliton: its springs, wall and energy chart) —
   p50/p95/max;
5. the 3D tab with four specified nodes (their space a quadric surface): EDITS edits of a motion
   in the table, each from the input event to the surface recomputed (its conic sections) and
   redrawn, and TURNS moves of a drag that turns the view (event → drawing rebuilt).

The load average is printed beside the figures (the machine is shared).

    python -m benchmarks.bench_designer [--out docs/benchmarks/designer.md]
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
from pathlib import Path

import httpx
import numpy as np

from benchmarks.bench_sweeps import start_service_with

MOVES, DESIGNS, FRAMES, EDITS, TURNS = 300, 30, 60, 100, 100
# The outward square of Fig. 3 on the page's snapping grid: corners and outward arrows.
CORNERS = [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)]
ARROW = 0.5
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking"]


def screen(page, world) -> tuple[float, float]:
    """Where on the screen the page draws a world point (its own map, read back)."""
    vx, vy = page.evaluate("p => designer.map.toPage(p)", [float(v) for v in world])
    box = page.locator("[data-testid=canvas]").bounding_box()
    return box["x"] + vx * box["width"] / 800, box["y"] + vy * box["height"] / 600


def space_d(page) -> str | None:
    """The `d` of the first motion's solution-space path (None when not drawn)."""
    el = page.query_selector("[data-testid=solution-space]")
    return None if el is None else el.get_attribute("d")


def drag_arrow(page, start, tip, steps=6) -> list[str | None]:
    """Press at ``start`` (placing a node there if none), drag to ``tip`` in ``steps`` moves;
    the solution space's path after every move."""
    page.mouse.move(*screen(page, start))
    page.mouse.down()
    seen = []
    for s in np.linspace(0, 1, steps + 1)[1:]:
        page.mouse.move(*screen(page, np.add(start, s * np.subtract(tip, start))))
        seen.append(space_d(page))
    page.mouse.up()
    return seen


def draw_outward_square(page) -> list[list[str | None]]:
    """The four corners placed and their outward arrows dragged; the space's paths per drag."""
    return [drag_arrow(page, c, np.multiply(c, 1 + ARROW)) for c in CORNERS]


def goto_designer(page, url: str):
    """Load the page and wait until it has listed the examples (its start-up requests done)."""
    page.goto(url + "/")
    page.wait_for_selector("#example option[value='example:outward_2d']", state="attached")
    return page


def stats(values) -> dict:
    v = np.asarray(values, dtype=float)
    return {"n": len(v), "p50": float(np.percentile(v, 50)), "p95": float(np.percentile(v, 95)), "max": float(v.max())}


def page_weight(url: str) -> dict[str, int]:
    """Bytes of the page and of every file it names (/viewer/…)."""
    html = httpx.get(url + "/").text
    sizes = {"/": len(html.encode())}
    for src in re.findall(r'(?:src|href)="(/viewer/[^"]+)"', html):
        sizes[src] = len(httpx.get(url + src).content)
    return sizes


def measure(url: str) -> dict:
    from playwright.sync_api import sync_playwright

    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=shutil.which("chromium"), args=CHROMIUM_ARGS)
        page = goto_designer(browser.new_page(viewport={"width": 1280, "height": 900}), url)
        for c in CORNERS[:3]:
            drag_arrow(page, c, np.multiply(c, 1 + ARROW))
        page.evaluate("designer.timings.live.length = 0")
        # The fourth arrow swept round its node: the space jumps between points and the conic.
        corner = np.array(CORNERS[3])
        page.mouse.move(*screen(page, corner))
        page.mouse.down()
        for t in np.linspace(0, 4 * np.pi, MOVES):
            page.mouse.move(*screen(page, corner + ARROW * np.array([np.cos(t), np.sin(t)]) * (1 + 0.3 * np.sin(3 * t))))
        page.mouse.move(*screen(page, corner * (1 + ARROW)))
        page.mouse.up()
        live = page.evaluate("designer.timings.live")
        kinds = page.evaluate("designer.spaces[0].kind")
        server = []
        page.click("[data-testid=design]")  # one warm-up design (the service's first-call costs), not counted
        page.wait_for_function("designer.timings.design.length === 1")
        page.evaluate("designer.timings.design.length = 0")
        for _ in range(DESIGNS):
            n = page.evaluate("designer.timings.design.length")
            page.click("[data-testid=design]")
            page.wait_for_function(f"designer.timings.design.length > {n}")
            server.append(page.evaluate("designer.response.report.timings_ms.total"))
        design = page.evaluate("designer.timings.design")
        frames = {tab: stats(animation_frames(page, tab)) for tab in ("multistable", "chain", "soliton")}
        surface = surface_updates(page)
        browser.close()
    return {"live": stats(live), "final_space": kinds, "design": stats(design), "server": stats(server), "frames": frames, **surface}


def surface_updates(page) -> dict:
    """The 3D tab's four-node surface: EDITS table edits of node 4's u_x (swept over [−0.8, 0.8]),
    then a drag of TURNS moves turning the view; the page's own timings of each (ms)."""
    page.click("[data-testid=tab-3d]")
    page.wait_for_function("designer.nodes.length === 5")
    page.locator("#table3d tbody tr").nth(4).locator("button").click()
    page.wait_for_function("designer.nodes.length === 4")
    page.evaluate("designer.timings.table.length = 0; designer.timings.turn.length = 0")
    cell = page.locator("#table3d tbody tr").nth(3).locator("input").nth(3)
    shapes = set()
    for value in 0.8 * np.sin(np.linspace(0, 2 * np.pi, EDITS)):
        cell.fill(f"{value:.4f}")
        shapes.add(page.evaluate("designer.spaces[0].shape || designer.spaces[0].kind"))
    box = page.locator("[data-testid=canvas]").bounding_box()
    page.mouse.move(box["x"] + 200, box["y"] + 200)
    page.mouse.down()
    for t in np.linspace(0, 2 * np.pi, TURNS):
        page.mouse.move(box["x"] + 200 + 120 * np.sin(t), box["y"] + 200 + 40 * np.sin(2 * t))
    page.mouse.up()
    points = sum(len(c) for c in page.evaluate("designer.spaces[0].curves"))
    return {"surface_edit": stats(page.evaluate("designer.timings.table")), "surface_turn": stats(page.evaluate("designer.timings.turn")),
            "surface_shapes": sorted(shapes), "surface_points": points}


def animation_frames(page, tab: str) -> list[float]:
    """The tab's default example designed ("soliton": the Chain tab's soliton example), then
    FRAMES slider steps timed in the page (the input event's handler: the drawing and the
    charts rebuilt; ms each)."""
    example, tab = (tab, "chain") if tab == "soliton" else (None, tab)
    page.click(f"[data-testid=tab-{tab}]")
    page.wait_for_function("designer.features.length" if tab == "chain" else "designer.conformations.length")
    if example:
        page.select_option("[data-testid=chain-example]", example)
    page.click("[data-testid=design]")
    page.wait_for_function("!document.getElementById('play').disabled", timeout=600_000)
    return page.evaluate("""n => {
        const s = document.getElementById('slider'), times = [];
        for (let i = 0; i < n; i++) {
            s.value = (+s.value + 1) % (+s.max + 1);
            const t0 = performance.now();
            s.dispatchEvent(new Event('input'));
            times.push(performance.now() - t0);
        }
        return times;
    }""", FRAMES)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="docs/benchmarks/designer.md")
    args = parser.parse_args()
    proc, url = start_service_with({"ZEROMODE_OFFLOAD": "false"})
    try:
        load_before = os.getloadavg()
        figures = measure(url)
        load_after = os.getloadavg()
        weight = page_weight(url)
        openapi = len(httpx.get(url + "/openapi.json").content)
    finally:
        proc.terminate()
        proc.wait(timeout=30)
    live, design, server = figures["live"], figures["design"], figures["server"]
    lines = [
        "# Designer page: interactive speed (issues #40, #41)",
        "",
        "`python -m benchmarks.bench_designer` — Debian's chromium (headless) against `zeromode serve` on loopback.",
        f"Load average before/after: {load_before[0]:.2f} / {load_after[0]:.2f} (1 min), {os.cpu_count()} cores, shared.",
        "",
        "| measure | n | p50 (ms) | p95 (ms) | max (ms) | floor |",
        "|---|---|---|---|---|---|",
        f"| live solution-space update while dragging (event → space recomputed and redrawn) | {live['n']} | {live['p50']:.1f} | {live['p95']:.1f} | {live['max']:.1f} | p95 ≤ 50 |",
        f"| 2D single-mode design, click → frame drawn (next animation frame; after one warm-up) | {design['n']} | {design['p50']:.1f} | {design['p95']:.1f} | {design['max']:.1f} | ≤ 150 |",
        f"| of which the service's design time (report.timings_ms.total) | {server['n']} | {server['p50']:.1f} | {server['p95']:.1f} | {server['max']:.1f} | |",
    ]
    for tab, f in figures["frames"].items():
        lines.append(f"| {tab} animation frame (slider step → drawing and charts rebuilt) | {f['n']} | {f['p50']:.1f} | {f['p95']:.1f} | {f['max']:.1f} | |")
    for key, what, floor in (("surface_edit", "3D, four nodes: table edit → quadric surface recomputed and redrawn", "p95 ≤ 50"),
                             ("surface_turn", "3D, four nodes: drag move → view turned, surface redrawn", "")):
        f = figures[key]
        lines.append(f"| {what} | {f['n']} | {f['p50']:.1f} | {f['p95']:.1f} | {f['max']:.1f} | {floor} |")
    lines += [
        "",
        (f"Page weight: {sum(weight.values())} bytes ({', '.join(f'{k} {v}' for k, v in weight.items())}); floor 400 KB. "
        f"The Chain tab reads /openapi.json ({openapi} bytes) once, when first opened, for its examples."),
        "",
        (f"The 3D edits swept the surface through {', '.join(figures['surface_shapes'])}; "
         f"{figures['surface_points']} drawn points at the last edit."),
        "",
    ]
    text = "\n".join(lines)
    print(text)
    Path(args.out).write_text(text, encoding="utf-8")


if __name__ == "__main__":
    main()
