"""The energy landscape of a multistable design (POST /v1/design/multistable): E(s) along the
motion, each conformation's minimum marked and labelled with its curvature E″, and the barrier
between neighbours drawn as a bracket from the lower minimum to the top.  Reads the response
body only (``landscape``, ``minima``); matplotlib, imported when used."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from zeromode.viz.style import SPECIFIED, UNSPECIFIED, WHITE

LETTERS = "abc"


def landscape_figure(body: dict, width: float = 6.4, height: float = 3.6) -> Figure:
    """E(s) − min E against the arc length s of the motion, from a multistable body."""
    land = body["landscape"]
    s = np.asarray(land["arclength"], dtype=float)
    e = np.asarray(land["energy"], dtype=float)
    base = float(e.min())
    at = land["conformation_samples"]
    fig = Figure(figsize=(width, height), facecolor=WHITE)
    ax = fig.add_subplot(1, 1, 1)
    ax.plot(s, e - base, color=UNSPECIFIED[0], lw=1.6)
    for j, (k, m) in enumerate(zip(at, body["minima"])):
        ax.plot([s[k]], [e[k] - base], "o", color=SPECIFIED[0], mec=SPECIFIED[1], ms=7, zorder=3)
        ax.annotate(
            f"{LETTERS[j] if j < len(LETTERS) else j}: E″ = {m['curvature']:.3g}",
            (s[k], e[k] - base), textcoords="offset points", xytext=(0, -16), ha="center", fontsize=8,
        )
        if j + 1 < len(at):
            right = at[j + 1]
            top = k + int(np.argmax(e[k : right + 1]))
            low = max(e[k], e[right])
            ax.annotate(
                "", xy=(s[top], e[top] - base), xytext=(s[top], low - base),
                arrowprops={"arrowstyle": "<->", "color": "#555555", "lw": 0.9},
            )
            ax.annotate(
                f"barrier {e[top] - low:.3g}", (s[top], e[top] - base),
                textcoords="offset points", xytext=(0, 6), ha="center", va="bottom", fontsize=8, color="#555555",
            )
    ax.set_xlabel("arc length s along the motion")
    ax.set_ylabel("E(s) − min E")
    ax.set_title(f"Energy along the motion ({len(at)} minima)", fontsize=10)
    span = float((e - base).max())
    ax.set_ylim(-0.12 * span, 1.1 * span)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig
