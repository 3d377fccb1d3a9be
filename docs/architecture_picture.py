"""Draw docs/img/architecture.png, the layers of zeromode and the path of one request through them
(docs/architecture.md):

    .venv/bin/python docs/architecture_picture.py

Boxes are the packages (clients, service, viz/export, solver and its stages in the paper's order),
grey arrows the direction of imports (a box imports only what its arrows reach, directly or
through the boxes they point to), the numbered
orange arrows the path of one design request: request → route → operation → pipeline → stages →
body.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch

OUT = Path(__file__).resolve().parent / "img" / "architecture.png"

INK, GREY, PATH = "#222222", "#8a8a8a", "#d9480f"
FILL = {"client": "#e7f0fb", "service": "#eef6ea", "side": "#f6f0fa", "solver": "#fff6e0", "stage": "#ffffff", "base": "#f1f1f1"}

# The solver's stages, left to right in import order (each imports only those to its left),
# with the paper's equations and figures each holds.
STAGES = [
    ("analysis", "the frame and C u = 0:\ncompatibility matrix,\nzero modes, rank,\neigenpairs  Eqs. 1–3"),
    ("motion", "finite motion, refinement,\ntargets, boundary strain\nbeyond the linear mode"),
    ("construction", "solution space, quadric,\njudicious placement,\nseveral motions\nEqs. 4–8, Figs. 2–4"),
    ("applications", "auxetic sheets and chains,\nfinite strain, allostery\nFig. 5; beside it:\nmultistable/, sequential/"),
    ("certificates", "prestress SDPs,\nstiffness margin,\nfabrication tolerance"),
]


def box(ax, x, y, w, h, title, body="", fill="#ffffff", size=11, weight="bold", lw=1.3, title_y=None):
    ax.add_patch(FancyBboxPatch((x, y), w, h, boxstyle="round,pad=0.0,rounding_size=0.12", fc=fill, ec=INK, lw=lw))
    ty = y + h - 0.28 if title_y is None else title_y
    ax.text(x + w / 2, ty, title, ha="center", va="top", fontsize=size, fontweight=weight, color=INK)
    if body:
        ax.text(x + w / 2, ty - 0.38, body, ha="center", va="top", fontsize=8.6, color=INK, linespacing=1.25)


def arrow(ax, a, b, color=GREY, lw=1.4, style="-|>", rad=0.0, ls="-", z=3):
    ax.add_patch(
        FancyArrowPatch(a, b, arrowstyle=style, mutation_scale=14, color=color, lw=lw, ls=ls,
                        connectionstyle=f"arc3,rad={rad}", zorder=z, shrinkA=2, shrinkB=2)
    )


def step(ax, xy, n):
    ax.text(*xy, str(n), ha="center", va="center", fontsize=9, fontweight="bold", color="white", zorder=6,
            bbox={"boxstyle": "circle,pad=0.22", "fc": PATH, "ec": "none"})


def draw() -> plt.Figure:
    fig, ax = plt.subplots(figsize=(15, 10.2))
    ax.set_xlim(0, 15)
    ax.set_ylim(0, 10.2)
    ax.axis("off")

    # Callers, and the doors they come in by.
    box(ax, 0.4, 9.0, 4.0, 0.95, "HTTP clients", "curl, zeromode_client (clients/python), the viewer", FILL["client"], size=10.5)
    box(ax, 4.7, 9.0, 3.0, 0.95, "service/cli.py", "zeromode serve | design | job …", FILL["client"], size=10.5)
    box(ax, 0.4, 7.55, 4.0, 1.1, "service/rest/  REST door", "FastAPI app, routes: parse → call\none operation → serialise; no numpy", FILL["service"], size=10.5)
    box(ax, 4.7, 7.55, 3.0, 1.1, "zeromode  library door", "import zeromode as zm:\ndesign, motion, certify …", FILL["service"], size=10.5)
    box(ax, 8.0, 7.55, 3.0, 1.1, "service/jobs/  job engine", "Dask tasks, sweeps,\nrecords; no HTTP", FILL["service"], size=10.5)
    box(ax, 0.4, 6.05, 6.6, 1.1, "zeromode/operations/", "one operation per endpoint: request → solver → (result, body);\nthe routes, the jobs, the CLI and the library call these", FILL["service"], size=10.5)
    box(ax, 7.3, 6.05, 3.7, 1.1, "service/wire/  wire format", "settings, schemas, responses.py:\nthe one place results become bodies", FILL["service"], size=10.5)

    # Drawing and files, beside them.
    box(ax, 11.6, 7.55, 3.0, 1.1, "export/", "files for other tools:\nVTK, STL, networkx, DXF, CSV", FILL["side"], size=10.5)
    box(ax, 11.6, 6.05, 3.0, 1.1, "viz/", "pictures in the paper's\nvisual language: SVG, PNG, GIF", FILL["side"], size=10.5)

    # solver/: pipeline on top, the stages in the paper's order, the foundations below.
    box(ax, 0.4, 0.35, 14.2, 5.15, "", fill=FILL["solver"])
    ax.text(0.7, 5.33, "solver/  (zeromode.solver)", ha="left", va="top", fontsize=12, fontweight="bold", color=INK)
    ax.text(0.7, 4.98, "mathematics only: numpy in and out,\nfrozen dataclasses; no HTTP, JSON, drawing", ha="left", va="top",
            fontsize=8.6, color=INK)
    box(ax, 4.3, 3.95, 6.4, 0.95, "pipeline.py", "design → refine → certify → tolerance, one analysis reused", FILL["stage"], size=10.5)
    w, gap, x0, y0, h = 2.45, 0.36, 0.65, 1.45, 1.75
    centres = []
    for k, (name, body) in enumerate(STAGES):
        x = x0 + k * (w + gap)
        box(ax, x, y0, w, h, f"{k + 1}. {name}/", body, FILL["stage"], size=10.5)
        centres.append(x + w / 2)
        if k:
            arrow(ax, (x, y0 + 0.35), (x - gap, y0 + 0.35))  # imports the stage to its left
    box(ax, 0.65, 0.55, 13.7, 0.6, "errors · budget · progress · tolerances (every threshold, named once with its reason)",
        fill=FILL["base"], size=9.5, weight="normal", title_y=1.0)

    # Imports (grey): downward and leftward only.
    arrow(ax, (6.2, 9.0), (6.2, 8.67))        # CLI → library door
    arrow(ax, (7.7, 9.3), (9.5, 8.67), rad=-0.2)  # CLI → job engine
    arrow(ax, (6.2, 7.55), (5.2, 7.17))       # library door → operations
    arrow(ax, (8.6, 7.55), (6.6, 7.17))       # jobs → operations
    arrow(ax, (7.0, 6.6), (7.3, 6.6))         # operations → wire
    arrow(ax, (11.0, 6.6), (11.6, 6.6))       # wire → viz (and export: responses, examples)
    arrow(ax, (6.8, 6.05), (11.6, 6.2), rad=0.12)  # operations → viz, export (plotting, exporting)
    arrow(ax, (9.2, 6.05), (9.2, 5.52))       # wire → solver
    arrow(ax, (1.0, 6.05), (1.0, 5.52))       # operations → solver
    arrow(ax, (13.1, 7.55), (13.1, 7.17))     # export → viz
    arrow(ax, (13.1, 6.05), (13.1, 5.52))     # viz → solver
    for c in centres:  # the pipeline imports every stage
        start = (min(max(c, 4.5), 10.5), 3.95)
        arrow(ax, start, (c, y0 + h), lw=1.0)

    # Legend.
    arrow(ax, (11.6, 9.6), (12.2, 9.6))
    ax.text(12.35, 9.6, "imports (a box imports only what\nits arrows reach; tests/test_architecture.py)", fontsize=8.6, va="center", color=INK)
    arrow(ax, (11.6, 9.0), (12.2, 9.0), color=PATH, lw=2.6)
    ax.text(12.35, 9.0, "one design request's path", fontsize=8.6, va="center", color=INK)

    # The path of one request (orange, numbered).
    def path(a, b, n, at, label, rad=0.0, ha="left"):
        arrow(ax, a, b, color=PATH, lw=2.6, rad=rad, z=5)
        step(ax, at, n)
        ax.text(at[0] + (0.22 if ha == "left" else -0.22), at[1], label, color=PATH, fontsize=9, ha=ha, va="center")

    path((1.0, 9.0), (1.0, 8.68), 1, (1.35, 8.84), "request")
    path((2.0, 7.55), (2.0, 7.18), 2, (2.35, 7.37), "route calls its operation")
    path((3.0, 6.05), (4.9, 4.92), 3, (3.35, 5.7), "operation runs the pipeline", rad=0.15)
    path((6.6, 3.95), (6.9, y0 + h), 4, (6.45, 3.55), "", ha="right")
    ax.text(7.7, 3.58, "the stages: construct,\nverify, move, certify", color=PATH, fontsize=9, ha="left", va="center")
    path((10.7, 4.45), (9.9, 6.03), 5, (10.95, 4.95), "results (frozen dataclasses) to\nresponses.py: the body the\noperation and the route return")
    path((3.6, 8.65), (3.6, 8.98), 6, (3.95, 8.84), "body")

    fig.tight_layout(pad=0.3)
    return fig


if __name__ == "__main__":
    OUT.parent.mkdir(parents=True, exist_ok=True)
    draw().savefig(OUT, dpi=110)
    print(OUT)
