"""Regenerate docs/img/multistable_energy.png, the energy landscape of docs/multistable.md:

    .venv/bin/python docs/multistable_picture.py

The named example tristable_triangle_2d designed by zm.multistable, drawn by its plot()
(viz/landscape.py: E(s) − min E along the motion, each minimum with its curvature, the barrier
between neighbours).
"""

from __future__ import annotations

from pathlib import Path

import zeromode as zm
from zeromode.service.wire.examples import example_request

OUT = Path(__file__).resolve().parent / "img" / "multistable_energy.png"


def main() -> None:
    request = example_request("tristable_triangle_2d")
    result = zm.multistable(request["conformations"], seed=request["options"]["seed"])
    result.plot().savefig(OUT, dpi=130)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
