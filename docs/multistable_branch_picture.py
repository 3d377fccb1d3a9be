"""Regenerate docs/img/multistable_branch.png, the branch point of docs/multistable.md:

    .venv/bin/python docs/multistable_branch_picture.py

The tristable triangle's conformations with a bifurcation asked at the middle one
(zm.multistable(..., bifurcation=1)): the rods in the three conformations, the middle one (the
branch point) with both first-order tangents as arrows: the branch the motion takes (first
colour) and the other branch (second), the branching dyad's node p where they part.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import zeromode as zm
from zeromode.solver.frame import Frame
from zeromode.solver.motion.finite_motion import align_to
from zeromode.viz.layout import layout
from zeromode.viz.picture import Picture
from zeromode.viz.raster import write_raster

OUT = Path(__file__).resolve().parent / "img" / "multistable_branch.png"
APEX = [[0.3, 0.8], [0.45, 1.0], [0.65, 1.15]]


def main() -> None:
    body = zm.multistable([[[0, 0], [1, 0], p] for p in APEX], bifurcation=1).to_dict()
    b = body["bifurcation"]
    confs = np.asarray(body["conformations"], dtype=float)
    k = len(APEX[0]) + 1
    frame = Frame.build(confs[b["index"]], body["frame"]["edges"], specified=range(k))
    picture = Picture.build(
        frame,
        modes=[b["taken_tangent"], b["other_tangent"]],
        configurations=[align_to(c, confs[b["index"]]) for c in np.delete(confs, b["index"], axis=0)],
        frame_panel=b["index"],
        labels=["conformation 0 (minimum)", "1: branch point", "conformation 2 (minimum)"],
        captions=[
            "", f"zero mode 1: the branch taken; 2: the other ({b['angle_degrees']:.0f}° apart); they part most at the dyad's node p", "",
        ],
    )
    write_raster(layout(picture), OUT)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
