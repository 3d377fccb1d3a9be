"""The paper's visual language: colours, sizes and the rules that pick them.

Colours follow the paper's figures (Figs. 1f, 2, 3, 5): specified nodes V_S red, unspecified
nodes V_U blue, bars grey, requested motions u_S hollow green arrows, designed zero modes solid
green arrows (light to dark green for several), the solution space light blue (light to dark
blue for several motions, Fig. 5), and the allosteric source and target sites purple and orange.
Sizes are SVG pixels (1 px = 1 pt in PNG/PDF output at scale 1).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

SPECIFIED = ("#d7301f", "#8c1d12")  # fill, outline
UNSPECIFIED = ("#2c7fb8", "#1b4f72")
BAR = "#a3a3a3"
GREEN_LIGHT, GREEN_DARK, GREEN = "#74c476", "#1b7837", "#31a354"
BLUE_LIGHT, BLUE_DARK = "#9ecae1", "#3182bd"
SOURCE, TARGET = "#6a3d9a", "#ff7f00"
WHITE = "#ffffff"
TITLE_INK, LABEL_INK, CAPTION_INK, LEGEND_INK = "#222", "#333", "#555", "#333"
# One family for both writers: matplotlib ships DejaVu Sans, so a PNG looks the same everywhere;
# SVG viewers take the first family they have.
FONT_SVG, FONT_RASTER = "Helvetica, Arial, sans-serif", "DejaVu Sans"
TITLE_PX, LABEL_PX, CAPTION_PX, LEGEND_PX = 16.0, 13.0, 12.0, 12.0

# Longest arrow as a fraction of the frame's size, and at most ARROW_GAPS typical gaps between
# the nodes that carry arrows: the median distance to the ARROW_NEIGHBOUR-th nearest of them
# (not the nearest: lattices have close pairs of nodes, whose arrows point apart).
ARROW_FRACTION, ARROW_GAPS, ARROW_NEIGHBOUR = 0.20, 1.2, 3
# Arrows drawn shorter than this many pixels show nothing but a blot: they are left out.
MIN_ARROW_PX = 2.0
# The view of 3D frames: azimuth about z and elevation above the xy-plane, in degrees — the
# isometric view from the (1, −1, 1) octant turned by 15° and lowered by 10°.
VIEW_3D = (-60.0, 25.0)
# How much lighter (mixed with white) and smaller the farthest element is than the nearest.
DEPTH_FADE, DEPTH_SHRINK = 0.45, 0.3
PANEL_PX, PAD_PX, GAP_PX, MIN_WIDTH_PX, ROW_PX = 440.0, 26.0, 18.0, 520.0, 1100.0
# Panels side by side or stacked, whichever picture's width : height is nearer ASPECT.
ASPECT = 4 / 3
# Frames with more nodes carry mode arrows on a spread subsample (ARROW_GRID cells across) and
# get panels up to BIG_PANEL times larger.
MAX_ARROW_NODES, ARROW_GRID, BIG_PANEL = 200, 10, 1.6


def mix_white(colour: str, f: float) -> str:
    """colour mixed with a fraction f ∈ [0, 1] of white (in steps of 1/128: a few distinct strings)."""
    return _mixed(colour, round(128 * min(max(float(f), 0.0), 1.0)))


@lru_cache(maxsize=4096)
def _mixed(colour: str, step: int) -> str:
    rgb = [int(colour[i : i + 2], 16) for i in (1, 3, 5)]
    return "#" + "".join(f"{round(c + (255 - c) * step / 128):02x}" for c in rgb)


def ramp(light: str, dark: str, n: int, single: str) -> list[str]:
    """n colours from light to dark (the paper's light/dark pairs); ``single`` when n = 1."""
    if n == 1:
        return [single]
    a = np.array([int(light[i : i + 2], 16) for i in (1, 3, 5)], dtype=float)
    b = np.array([int(dark[i : i + 2], 16) for i in (1, 3, 5)], dtype=float)
    return ["#" + "".join(f"{round(v):02x}" for v in a + (b - a) * k / (n - 1)) for k in range(n)]

# A finite motion's trajectories are coloured by progress, from blue (start) to yellow (end) as in
# the supplement's figures of nonlinear trajectories (Fig. S1c): a parula-like ramp.
PROGRESS = ("#352a87", "#1283d4", "#33b7a0", "#f9fb0e")


def progress_colour(t: float) -> str:
    """The PROGRESS ramp at t ∈ [0, 1] (piecewise linear between its stops)."""
    stops = np.array([[int(c[i : i + 2], 16) for i in (1, 3, 5)] for c in PROGRESS], dtype=float)
    s = min(max(float(t), 0.0), 1.0) * (len(stops) - 1)
    k = min(int(s), len(stops) - 2)
    rgb = stops[k] + (stops[k + 1] - stops[k]) * (s - k)
    return "#" + "".join(f"{round(v):02x}" for v in rgb)
